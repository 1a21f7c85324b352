"""``fabpat assemble SPEC --out DIR``: the complete kit of an assembly spec (see fabpat.assembly.build).

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

        bar = Progress(TextColumn("{task.description:<10}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                       TimeElapsedColumn(), console=Console(stderr=True), transient=True)
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


@click.command("simulate-strip")
@click.argument("spec", type=click.Path(dir_okay=False))
@h_option(3.0)
@number_option("--load-factor", range_name="load_factor", default=0.8, show_default=True,
               help="Compression as a fraction of the Rayleigh estimate of the strip's buckling load.")
@number_option("--compression", range_name="compression", default=None,
               help="Compression in N (instead of --load-factor).")
@number_option("--imperfection", range_name="imperfection", default=0.01, show_default=True,
               help="Out-of-plane perturbation force as a fraction of the compression.")
@modulus_option
@poisson_option
@click.option("--vtu", type=click.Path(dir_okay=False), help="Deformed strip with fields for ParaView (.vtu).")
@click.option("--png", type=click.Path(dir_okay=False), help="Side view of the deflection profile (.png).")
@click.option("--json", "as_json", is_flag=True, help="Print the results (with the profile) as JSON.")
def simulate_strip_cmd(spec: str, h: float, load_factor: float, compression: float | None, imperfection: float,
                       E: float, nu: float, vtu: str | None, png: str | None, as_json: bool) -> None:
    """Compress a whole flat strip (a honeycomb-strip SPEC) between pins and report how it bends.

    Tiles are welded on their interface segments; the first column's end interfaces are pinned, the
    last column's slide along x and carry the compression. Prints the buckling-load estimate, the
    load, where the strip is highest (fraction of its length) and the deflection area of the first
    (stiff) half over the second: a graded strip bends asymmetrically, stiff end flatter.

    Prints one line of plain key=value fields, named as in --json: nodes, elements, length (mm),
    critical_load_estimate and compression (N), imperfection (fraction), max_deflection (mm), peak
    (fraction of the length), half_ratio, amplification, implied_critical_load (N), converged,
    iterations, seconds (s), patterns (comma-separated IDs).

    Example: fabpat simulate-strip assemblies/graded-strip.toml --png strip.png --vtu strip.vtu
    """
    import json
    import time

    from fabpat.assembly.build import face_patterns
    from fabpat.assembly.spec import load_spec
    from fabpat.assembly.strip_sim import critical_load, simulate_strip, strip_model, write_profile_png
    from fabpat.assembly.tiling import honeycomb_strip
    from fabpat.errors import SolverError, SpecError
    from fabpat.exchange.vtu import write_vtu
    from fabpat.io import atomic_outputs, check_distinct, check_suffix
    from fabpat.scenarios import PNG_SUFFIXES, VTU_SUFFIXES

    outputs = [p for p in (vtu, png) if p is not None]
    check_distinct(outputs, inputs={"SPEC": spec})
    for option, path, valid in (("--vtu", vtu, VTU_SUFFIXES), ("--png", png, PNG_SUFFIXES)):
        if path is not None:
            check_suffix(path, valid, option)
    parsed = load_spec(spec)
    t = parsed.tiling
    if t.kind != "honeycomb-strip":
        raise SpecError(f"{spec}: simulate-strip needs tiling.kind = \"honeycomb-strip\", got {t.kind!r}")
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    t0 = time.perf_counter()
    console = Console(stderr=True)
    with Progress(TextColumn("{task.description:<22}"), BarColumn(), TimeElapsedColumn(), console=console,
                  transient=True, disable=not console.is_terminal) as bar:
        task = bar.add_task("meshing the tiles", total=4)
        ids = face_patterns(parsed)
        model = strip_model(honeycomb_strip(t.rows, t.columns, t.edge), ids, edge=t.edge, h=h,
                            thickness=parsed.plates.thickness, weight=parsed.plates.weight, E=E, nu=nu)
        bar.update(task, advance=1, description="buckling-load estimate")
        estimate = critical_load(model)
        P = compression if compression is not None else load_factor * estimate
        bar.update(task, advance=1, description=f"nonlinear solve ({len(model.V)} nodes)")
        with atomic_outputs(*outputs) as temps:
            r = simulate_strip(model, P, imperfection)
            if not r.amplification > 0:  # past the buckling load: the reported response would be meaningless
                raise SolverError(f"the compression {P:.4g} N is beyond the strip's buckling load (amplification "
                                  f"{r.amplification:.3g} ≤ 0; estimate {estimate:.4g} N): use a smaller load")
            bar.update(task, advance=1, description="writing files")
            tmp = dict(zip(outputs, temps, strict=True))
            if vtu is not None:
                write_vtu(tmp[vtu], model.V, model.F, r.result)
            if png is not None:
                write_profile_png(tmp[png], r)
        bar.update(task, advance=1)
    row = {
        "spec": parsed.name, "patterns": list(dict.fromkeys(ids)), "nodes": len(model.V), "elements": len(model.F),
        "length": model.length, "critical_load_estimate": estimate, "compression": P, "imperfection": imperfection,
        "max_deflection": float(r.w.max()), "peak": r.peak, "half_ratio": r.half_ratio,
        "amplification": r.amplification, "implied_critical_load": r.implied_critical_load,
        "converged": r.result.converged, "iterations": r.result.iterations,
        "seconds": time.perf_counter() - t0,
    }
    if as_json:
        click.echo(json.dumps({**row, "profile": {"x": r.x.tolist(), "w": r.w.tolist()}}, indent=1))
    else:
        def text(v: object) -> str:
            return f"{v:.4g}" if isinstance(v, float) else str(v).lower() if isinstance(v, bool) else str(v)

        click.echo(" ".join(f"{k}={text(v)}" for k, v in row.items() if k != "patterns")
                   + " patterns=" + ",".join(row["patterns"]))
    for path in outputs:
        click.echo(f"wrote {path}", err=True)  # stdout is data (key=value lines or JSON)


COMMANDS = [assemble_cmd, simulate_strip_cmd]
