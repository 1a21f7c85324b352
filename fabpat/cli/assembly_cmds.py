"""``fabpat assemble SPEC --out DIR``: the complete kit of an assembly spec (see fabpat.assembly.build);
``fabpat simulate-assembly SPEC``: the assembly as one shell model (see fabpat.assembly.simulate), and
its deprecated alias ``simulate-strip``.

The command only parses its options, shows a progress bar on stderr and prints the files written
(one per line, on stdout, relative to the current folder). Errors are one line on stderr, exit 2.
"""

from __future__ import annotations

import os
from pathlib import Path

import click

from fabpat.cli.options import h_option, modulus_option, number_option, poisson_option


@click.command("assemble")
@click.argument("spec", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False),
              help="Output folder (created; an earlier `fabpat assemble` output there is replaced).")
@click.option("--progress/--no-progress", default=True, show_default=True, help="Progress bar on stderr.")
@click.option("--timestamp", default=None, metavar="ISO8601",
              help="Fixed STEP header time (ISO 8601, e.g. 2025-01-31T12:00:00Z), for byte-reproducible files.")
@click.option("--force", is_flag=True,
              help="Build even if a plate is too narrow for its process (the export check); warn instead.")
def assemble_cmd(spec: str, out: str, progress: bool, timestamp: str | None, force: bool) -> None:
    """Build, check and write everything to fabricate and assemble the SPEC (a TOML file).

    Writes a STEP assembly, one STL per distinct part, a GLB preview, laser sheets (DXF), the net
    (SVG), a bill of materials (CSV, Markdown), an assembly picture (PNG) and manifest.json.

    Example: fabpat assemble assemblies/truncated-icosahedron.toml --out sphere-kit
    """
    from fabpat.assembly.build import assemble, steps
    from fabpat.assembly.spec import load_spec
    from fabpat.exchange.step import check_timestamp
    from fabpat.io import check_distinct

    timestamp = check_timestamp(timestamp)
    check_distinct([out], inputs={"SPEC": spec})  # the kit (its folder, any file) may not replace the spec …
    parsed = load_spec(spec)
    check_distinct([out], inputs={"patterns.catalog": parsed.patterns.catalog})  # … or the catalog it reads
    names = steps(parsed)
    bar = None
    if progress:
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        console = Console(stderr=True)
        # no bar when stderr is not a terminal: a piped stderr gets only the error or warning lines
        bar = Progress(TextColumn("{task.description:<10}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                       TimeElapsedColumn(), console=console, transient=True, disable=not console.is_terminal)
        bar.start()
        task = bar.add_task("assemble", total=len(names))
    done = 0

    def tell(step: str) -> None:
        nonlocal done
        if bar is not None:
            bar.update(task, description=step, completed=done)
        done += 1

    try:
        result = assemble(parsed, out, tell, timestamp, force=force)
    finally:
        if bar is not None:
            bar.stop()
    for line in result.report.lines():
        click.echo(f"check: {line}", err=True)
    for line in result.warnings:
        click.echo(f"fabpat: warning: {line}", err=True)
    for name in result.files:
        click.echo(os.path.join(out, name) if not Path(out).is_absolute() else str(Path(out) / name))


@click.command("simulate-assembly")
@click.argument("spec", type=click.Path(dir_okay=False))
@number_option("--end-shortening", range_name="end_shortening", default=0.1, show_default=True,
               help="The end pins move towards each other by this fraction of the strip length.")
@h_option(3.0)
@number_option("--steps", range_name="steps", default=10, show_default=True,
               help="Equal end-shortening increments reported in the JSON path.")
@number_option("--imperfection", range_name="imperfection_force", default=None,
               help="Upward out-of-plane force (N, in total) that selects the buckle [default: 0.01].")
@modulus_option
@poisson_option
@click.option("--vtu", type=click.Path(dir_okay=False), help="Every plate, deformed, with fields for ParaView (.vtu).")
@click.option("--png", type=click.Path(dir_okay=False),
              help="Deflection profile and reaction–end-shortening curve (.png).")
@click.option("--json", "as_json", is_flag=True, help="Print the results as one JSON object.")
def simulate_assembly_cmd(spec: str, end_shortening: float, h: float, steps: int, imperfection: float | None,
                          E: float, nu: float, vtu: str | None, png: str | None, as_json: bool) -> None:
    """Solve an assembly SPEC as one shell model: plates joined by rigid sleeves, pins driven together.

    For a honeycomb-strip spec the end pins (as in the kit) are pushed towards each other by
    --end-shortening × the strip length under displacement control, through buckling, until the strip
    bows into an arch. Prints key=value lines (or --json): converged, plates, sleeves, nodes, dofs,
    iterations, seconds, energy, plate_energies, sleeve_moments, reaction, max_deflection, peak,
    half_ratio, path. A graded strip's arch peaks towards its soft end.

    Example: fabpat simulate-assembly assemblies/graded-strip.toml --png strip.png --vtu strip.vtu
    """
    _simulate_assembly(spec, end_shortening, h, steps, imperfection, E, nu, vtu, png, as_json)


def _simulate_assembly(spec: str, end_shortening: float, h: float, steps: int, imperfection: float | None,
                       E: float, nu: float, vtu: str | None, png: str | None, as_json: bool) -> None:
    import json
    import time

    import numpy as np

    from fabpat.assembly.build import face_patterns
    from fabpat.assembly.simulate import IMPERFECTION, final_shell_result, run_strip, strip_setup, write_profiles_png
    from fabpat.assembly.spec import load_spec
    from fabpat.errors import SpecError
    from fabpat.exchange.vtu import write_vtu
    from fabpat.io import atomic_outputs, check_distinct, check_suffix
    from fabpat.scenarios import PNG_SUFFIXES, VTU_SUFFIXES

    outputs = [p for p in (vtu, png) if p is not None]
    check_distinct(outputs, inputs={"SPEC": spec})
    for option, path, valid in (("--vtu", vtu, VTU_SUFFIXES), ("--png", png, PNG_SUFFIXES)):
        if path is not None:
            check_suffix(path, valid, option)
    parsed = load_spec(spec)
    if parsed.tiling.kind != "honeycomb-strip":
        raise SpecError(f"{spec}: simulate-assembly can simulate tiling.kind = \"honeycomb-strip\" "
                        f"(end shortening), got {parsed.tiling.kind!r}")
    t0 = time.perf_counter()
    setup = strip_setup(parsed, face_patterns(parsed), h=h, E=E, nu=nu)
    with atomic_outputs(*outputs) as temps:
        run = run_strip(setup, end_shortening, steps=steps,
                        imperfection=IMPERFECTION if imperfection is None else imperfection)
        tmp = dict(zip(outputs, temps, strict=True))
        m = setup.model
        if vtu is not None:
            write_vtu(tmp[vtu], m.X, m.F, final_shell_result(run),
                      point_data={"plate": m.plate_of_node[: len(m.X)].astype(np.int64)})
        if png is not None:
            write_profiles_png(tmp[png], [(parsed.name, run)])
    row = {
        "converged": True, "plates": len(m.plates), "sleeves": len(m.sleeves), "nodes": m.n_nodes,
        "dofs": run.result.dofs, "iterations": run.result.iterations, "seconds": time.perf_counter() - t0,
        "energy": run.energy, "plate_energies": run.plate_energies, "sleeve_moments": run.sleeve_moments,
        "reaction": run.reaction, "max_deflection": run.max_deflection, "peak": run.peak,
        "half_ratio": run.half_ratio, "path": run.path,
    }
    if as_json:
        click.echo(json.dumps(row, indent=1))
    else:
        def text(v: object) -> str:
            if isinstance(v, float):
                return f"{v:.6g}"
            if isinstance(v, bool):
                return str(v).lower()
            if isinstance(v, (dict, list)):
                return json.dumps(v, separators=(",", ":"))
            return str(v)

        for k, v in row.items():
            click.echo(f"{k}={text(v)}")
    for path in outputs:
        click.echo(f"wrote {path}", err=True)  # stdout is data (key=value lines or JSON)


@click.command("simulate-strip")
@click.argument("spec", type=click.Path(dir_okay=False))
@number_option("--end-shortening", range_name="end_shortening", default=0.1, show_default=True,
               help="See simulate-assembly.")
@h_option(3.0)
@number_option("--steps", range_name="steps", default=10, show_default=True, help="See simulate-assembly.")
@number_option("--imperfection", range_name="imperfection_force", default=None, help="See simulate-assembly.")
@modulus_option
@poisson_option
@click.option("--vtu", type=click.Path(dir_okay=False), help="See simulate-assembly.")
@click.option("--png", type=click.Path(dir_okay=False), help="See simulate-assembly.")
@click.option("--json", "as_json", is_flag=True, help="See simulate-assembly.")
def simulate_strip_cmd(spec: str, end_shortening: float, h: float, steps: int, imperfection: float | None,
                       E: float, nu: float, vtu: str | None, png: str | None, as_json: bool) -> None:
    """Deprecated alias of `fabpat simulate-assembly` (same options and output); removed in the next release."""
    click.echo("fabpat: simulate-strip is deprecated and will be removed in the next release: use "
               "simulate-assembly (same options and output)", err=True)
    _simulate_assembly(spec, end_shortening, h, steps, imperfection, E, nu, vtu, png, as_json)


COMMANDS = [assemble_cmd, simulate_assembly_cmd, simulate_strip_cmd]
