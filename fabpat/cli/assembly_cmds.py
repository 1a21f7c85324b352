"""``fabpat assemble SPEC --out DIR``: the complete kit of an assembly spec (see fabpat.assembly.kit.build);
``fabpat simulate-assembly SPEC``: the assembly as one shell model (see fabpat.assembly.solve.strip), and
its deprecated alias ``simulate-strip``.

The command only parses its options, shows progress on stderr (:mod:`fabpat.progress`: a bar on a
terminal, a line every few seconds otherwise) and prints the files written (one per line, on stdout,
relative to the current folder). Errors are one line on stderr, exit 2; a spec with several problems
gets one line for each, after a line counting them.
"""

from __future__ import annotations

import os
from pathlib import Path

import click

from fabpat.cli.options import h_option, max_elements_option, number_option
from fabpat.simulation.mesh import ASSEMBLY_MAX_ELEMENTS

#: more plates over the strain limit than this get one warning line between them, not one each
MAX_STRAIN_LINES = 3
PROGRESS_HELP = ("Progress on stderr: a bar on a terminal, else a line every few seconds "
                 "(FABPAT_PROGRESS_INTERVAL seconds, default 5).")


def _load(spec: str, need_sheet: bool = False):  # type: ignore[no-untyped-def]  # -> AssemblySpec
    """The parsed spec; a spec with several problems is told one line each (``fabpat: error: …``), exit 2."""
    from fabpat.assembly.spec.load import SpecProblems, load_spec

    try:
        return load_spec(spec, need_sheet=need_sheet)
    except SpecProblems as e:
        if len(e.problems) < 2:
            raise
        for line in str(e).splitlines():
            click.echo(f"fabpat: error: {line}", err=True)
        raise click.exceptions.Exit(2) from e


@click.command("assemble")
@click.argument("spec", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False),
              help="Output folder (created; an earlier `fabpat assemble` output there is replaced).")
@click.option("--progress/--no-progress", default=True, show_default=True, help=PROGRESS_HELP)
@click.option("--timestamp", default=None, metavar="ISO8601",
              help="Fixed time (ISO 8601, e.g. 2025-01-31T12:00:00Z) for every file's dates and ids: two runs "
                   "of one spec then write byte-identical files.")
@click.option("--force", is_flag=True,
              help="Build even if a plate is too narrow for its process (the export check) or would exceed "
                   "material.strain_limit when bent sleeves close the object; warn instead.")
@click.option("--predict/--no-predict", default=True, show_default=True,
              help="With sleeves not at the dihedral angles: predict the bent shape (shell solver) for the "
                   "preview, prediction.json and the strain check.")
@number_option("--predict-h", "predict_h", range_name="h", default=None,
               help="Target mesh edge (mm) of the prediction [default: 3, or the largest the plates' interfaces "
                    "allow when smaller].")
def assemble_cmd(spec: str, out: str, progress: bool, timestamp: str | None, force: bool, predict: bool,
                 predict_h: float | None) -> None:
    """Build, check and write everything to fabricate and assemble the SPEC (a TOML file).

    Writes a STEP assembly, one STL per distinct part, a GLB preview, laser sheets (DXF), the net
    (SVG), a bill of materials (CSV, Markdown), an assembly picture (PNG) and manifest.json. With
    sleeves printed at other angles than the joints' dihedrals (sleeve.angle = "flat": the paper's
    bent sphere) it first predicts the bent shape: prediction.json, predicted.stl, the GLB and PNG
    of that shape, and the flat parts side by side in parts.step and parts.3dm.

    Example: fabpat assemble assemblies/truncated-icosahedron.toml --out sphere-kit
    """
    from fabpat.assembly.kit.build import assemble, steps
    from fabpat.exchange.step import check_timestamp
    from fabpat.io import check_distinct
    from fabpat.progress import Progress
    from fabpat.shell.news import listening

    timestamp = check_timestamp(timestamp)
    check_distinct([out], inputs={"SPEC": spec})  # the kit (its folder, any file) may not replace the spec …
    parsed = _load(spec, need_sheet=True)
    check_distinct([out], inputs={"patterns.catalog": parsed.patterns.catalog})  # … or the catalog it reads
    names = steps(parsed, predict)
    done = 0
    what = _path_words(parsed)
    head = ""  # the line's words before the solver's news
    with Progress("assemble", total=len(names), enabled=progress) as bar:
        def tell(step: str) -> None:
            nonlocal done, head
            done += 1
            head = f"step {done} of {len(names)}: {step}"
            bar.update(head, done - 1)

        def solving(f: float) -> None:  # within the "prediction" step: the fraction of its path
            nonlocal head
            head = f"step {done} of {len(names)}: prediction, {100 * f:.0f} % of {what}"
            bar.update(head, done - 1 + f)

        # the solver's own news (each increment; the kernels' first compilation, ~40 s once after an install)
        with listening(lambda text: bar.update(f"{head}; {text}")):
            result = assemble(parsed, out, tell, timestamp, force=force, predict=predict, predict_h=predict_h,
                              predict_progress=solving)
    for line in (*result.report.lines(), *result.notes):
        click.echo(f"check: {line}", err=True)
    for line in result.warnings:
        click.echo(f"fabpat: warning: {line}", err=True)
    for name in result.files:
        click.echo(os.path.join(out, name) if not Path(out).is_absolute() else str(Path(out) / name))


@click.command("simulate-assembly")
@click.argument("spec", type=click.Path(dir_okay=False))
@number_option("--end-shortening", range_name="end_shortening", default=None,
               help="Strips: the end pins move towards each other by this fraction of the strip length "
                    "[default: 0.1].")
@h_option(3.0, "assembly")
@number_option("--steps", range_name="steps", default=None,
               help="Report steps of the path [default: 10 for a strip, 4 for a closed assembly].")
@number_option("--imperfection", range_name="imperfection_force", default=None,
               help="Strips: upward out-of-plane force (N, in total) that selects the buckle [default: 0.01].")
@number_option("--youngs-modulus", "E", range_name="youngs_modulus", default=None,
               help="Young's modulus in N/mm² [default: the spec's material.youngs_modulus, 1000].")
@number_option("--poisson", "nu", range_name="poisson", default=None,
               help="Poisson's ratio [default: the spec's material.poisson, 0.35].")
@click.option("--vtu", type=click.Path(dir_okay=False),
              help="Every plate, deformed, with fields for ParaView (.vtu), curvatures and surface strain included.")
@click.option("--png", type=click.Path(dir_okay=False),
              help="Strips: deflection profile and reaction curve; closed assemblies: the bent shape (.png).")
@click.option("--png-field", type=click.Choice(["energy", "mean_curvature", "gaussian_curvature", "strain"]),
              default=None, help="Closed assemblies: what colours the --png picture [default: energy].")
@max_elements_option(ASSEMBLY_MAX_ELEMENTS, "mesh elements of the whole assembly")
@click.option("--json", "as_json", is_flag=True, help="Print the results as one JSON object.")
@click.option("--progress/--no-progress", default=True, show_default=True, help=PROGRESS_HELP)
def simulate_assembly_cmd(spec: str, end_shortening: float | None, h: float, steps: int | None,
                          imperfection: float | None, E: float | None, nu: float | None, vtu: str | None,
                          png: str | None, png_field: str | None, max_elements: int, as_json: bool,
                          progress: bool) -> None:
    """Solve an assembly SPEC as one shell model: plates joined by rigid sleeves.

    A honeycomb-strip's end pins (as in the kit) are pushed towards each other by --end-shortening ×
    the strip length under displacement control, through buckling, until the strip bows into an arch
    (a graded strip's arch peaks towards its soft end). A truncated icosahedron starts as flat plates
    on the polyhedron and its sleeves turn to the spec's [sleeve] angle: straight sleeves ("flat")
    bend the plates into the paper's sphere.

    Prints key=value lines (or --json): converged, plates, sleeves, nodes, dofs, iterations,
    factorizations, seconds, h, energy, plate_energies, sleeve_moments, reaction, max_deflection,
    peak, half_ratio (strips), radius, sphericity_rms, sphericity_max (closed), peak_strain,
    peak_strain_plate, strain_limit, over_limit, path. Every plate over the spec's
    material.strain_limit is named on stderr.

    Example: fabpat simulate-assembly assemblies/truncated-icosahedron.toml --png sphere.png --vtu sphere.vtu
    """
    _simulate_assembly(spec, end_shortening, h, steps, imperfection, E, nu, vtu, png, as_json, png_field,
                       max_elements, progress)


def _path_words(spec) -> str:  # type: ignore[no-untyped-def]
    """What the fraction of a spec's solver path is a fraction of, for the progress lines."""
    if spec.tiling.pushed:  # a strip or a panel
        return "the end shortening"
    return "the candidate pairs" if spec.patterns.rule == "roundest" else "the sleeves' turn"


def _simulate_assembly(spec: str, end_shortening: float | None, h: float, steps: int | None,
                       imperfection: float | None, E: float | None, nu: float | None, vtu: str | None,
                       png: str | None, as_json: bool, png_field: str | None = None,
                       max_elements: int = ASSEMBLY_MAX_ELEMENTS, progress: bool = True) -> None:
    import json

    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.io import atomic_outputs, check_distinct, check_suffix
    from fabpat.progress import Progress
    from fabpat.shell.news import listening
    from fabpat.simulation.scenarios import PNG_SUFFIXES, VTU_SUFFIXES

    outputs = [p for p in (vtu, png) if p is not None]
    check_distinct(outputs, inputs={"SPEC": spec})
    for option, path, valid in (("--vtu", vtu, VTU_SUFFIXES), ("--png", png, PNG_SUFFIXES)):
        if path is not None:
            check_suffix(path, valid, option)
    parsed = _load(spec)
    if png_field is not None and (png is None or parsed.tiling.pushed):
        from fabpat.errors import SpecError

        raise SpecError("--png-field colours the --png picture of a closed assembly (a strip's PNG is its "
                        "deflection profile): give --png with a closed assembly's spec, or leave --png-field out")
    what = _path_words(parsed)
    if parsed.tiling.radius is not None:  # the edge it chose is a fact of the run, not of the output fields
        click.echo(f"fabpat: tiling.radius = {parsed.tiling.radius:g} mm: plate edge {parsed.tiling.edge:.4f} mm",
                   err=True)
    with atomic_outputs(*outputs) as temps, Progress("simulate-assembly", total=1.0, enabled=progress) as bar:
        head = ["meshing and joining the plates"]  # the line's words before the solver's news
        bar.update(head[0], 0.0)

        def reached(f: float) -> None:
            head[0] = f"{100 * f:.0f} % of {what}"
            bar.update(head[0], f)

        # each increment; the kernels' first compilation (~40 s once after an install)
        with listening(lambda text: bar.update(f"{head[0]}; {text}")):
            sim = simulate_assembly(parsed, h=h, steps=steps, end_shortening=end_shortening,
                                    imperfection=imperfection, youngs_modulus=E, poisson=nu,
                                    max_elements=max_elements, progress=reached)
        bar.update("writing the files")
        tmp = dict(zip(outputs, temps, strict=True))
        if vtu is not None:
            sim.to_vtu(tmp[vtu])
        if png is not None:
            sim.to_png(tmp[png], png_field)  # None: the default (a strip takes none)
    row = sim.fields()
    if as_json:
        click.echo(json.dumps(row, indent=1))
    else:
        def text(v: object) -> str:
            if v is None:
                return "null"
            if isinstance(v, float):
                return f"{v:.6g}"
            if isinstance(v, bool):
                return str(v).lower()
            if isinstance(v, (dict, list)):
                return json.dumps(v, separators=(",", ":"))
            return str(v)

        for k, v in row.items():
            click.echo(f"{k}={text(v)}")
    peaks = sim.plate_peak_strain()
    over = row["over_limit"]
    if len(over) > MAX_STRAIN_LINES:  # a line per plate would bury the rest: the count and the worst
        worst = max(over, key=lambda label: peaks[label])
        click.echo(f"fabpat: warning: {len(over)} plates exceed the strain limit {sim.strain_limit:g} "
                   f"(material.strain_limit), the most {worst} at peak strain {peaks[worst]:.4g}; over_limit lists "
                   "them all", err=True)
    for label in over if len(over) <= MAX_STRAIN_LINES else ():
        click.echo(f"fabpat: warning: plate {label}: peak strain {peaks[label]:.4g} exceeds the strain limit "
                   f"{sim.strain_limit:g} (material.strain_limit)", err=True)
    for path in outputs:
        click.echo(f"wrote {path}", err=True)  # stdout is data (key=value lines or JSON)


@click.command("simulate-strip")
@click.argument("spec", type=click.Path(dir_okay=False))
@number_option("--end-shortening", range_name="end_shortening", default=None, help="See simulate-assembly.")
@h_option(3.0, "assembly")
@number_option("--steps", range_name="steps", default=None, help="See simulate-assembly.")
@number_option("--imperfection", range_name="imperfection_force", default=None, help="See simulate-assembly.")
@number_option("--youngs-modulus", "E", range_name="youngs_modulus", default=None, help="See simulate-assembly.")
@number_option("--poisson", "nu", range_name="poisson", default=None, help="See simulate-assembly.")
@click.option("--vtu", type=click.Path(dir_okay=False), help="See simulate-assembly.")
@click.option("--png", type=click.Path(dir_okay=False), help="See simulate-assembly.")
@click.option("--json", "as_json", is_flag=True, help="See simulate-assembly.")
def simulate_strip_cmd(spec: str, end_shortening: float | None, h: float, steps: int | None, imperfection: float | None,
                       E: float | None, nu: float | None, vtu: str | None, png: str | None, as_json: bool) -> None:
    """Deprecated alias of `fabpat simulate-assembly` (same options and output); removed in the next release."""
    from fabpat.cli import deprecated

    deprecated("simulate-strip", "simulate-assembly")  # said after the output, or inside the one error line
    _simulate_assembly(spec, end_shortening, h, steps, imperfection, E, nu, vtu, png, as_json)


COMMANDS = [assemble_cmd, simulate_assembly_cmd, simulate_strip_cmd]
