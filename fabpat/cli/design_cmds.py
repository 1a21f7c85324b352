"""``fabpat design TARGET --spec BASE.toml --out DIR``: one pattern per tile for a target shape (see
fabpat.design). The command only parses its options, shows progress on stderr and prints the files
written; an unreachable target is one warning line on stderr (the best design is still written).
"""

from __future__ import annotations

import click

import fabpat.design.ranges  # noqa: F401 - registers --max-solves' and --tolerance's ranges
from fabpat.cli.options import h_option, number_option


@click.command("design")
@click.argument("target")
@click.option("--spec", "spec", required=True, type=click.Path(dir_okay=False),
              help="Base assembly spec (TOML); [patterns] may narrow the candidates: allowed, min_width, max_distinct.")
@click.option("--out", required=True, type=click.Path(file_okay=False),
              help="Output folder (created; an earlier `fabpat design` output there is replaced).")
@h_option(3.0, "assembly")
@number_option("--max-solves", range_name="max_solves", default=None,
               help="Budget of full assembly solves for the search (the baselines' one or two come on top) "
                    "[default: 12 for a strip, 60 for a closed tiling].")
@number_option("--tolerance", range_name="design_tolerance", default=0.01, show_default=True,
               help="Reachable when the rms error is at most this fraction of the span (closed: of the radius).")
@click.option("--scale-target", is_flag=True,
              help="Scale a target whose arc length differs from the strip's by more than 2 % to its length.")
@number_option("--workers", range_name="workers", default=None, help="Local worker processes [default: 1].")
@click.option("--dask", "dask_address", metavar="ADDRESS", default=None,
              help="Send the solves to this dask.distributed scheduler (e.g. tcp://host:8786) instead.")
@number_option("--max-minutes", range_name="max_minutes", default=None,
               help="Time budget in minutes: when it runs out the solves stop and the best design so far is written "
                    "(design.json: \"interrupted\": true), as on Ctrl-C or SIGTERM [default: none].")
@click.option("--kit", is_flag=True, help="Also run `fabpat assemble` on design.toml into DIR/kit.")
@click.option("--dry-run", is_flag=True,
              help="Check the inputs and print the plan as JSON (strip: pin length, end shortening, scale, the "
                   "elastica's peak strain; closed: the target's fitted scale, with shapes the mapped faces' "
                   "irregularity) in seconds: no solve, no file.")
@click.option("--per", type=click.Choice(["face", "group"]), default="face", show_default=True,
              help="Closed tilings: a pattern per face (refined from the best group design), or per face group "
                   "(polygon and latitude band).")
@click.option("--vary", metavar="WORDS", default=None,
              help="Design variables, comma-separated: shapes, patterns, angles, thickness [default: shapes,patterns "
                   "for a closed target (shapes: the base tiling mapped onto the target, plates shaped to its faces, "
                   "its mesh written as DIR/mapped.obj; a sphere keeps its faces: patterns), patterns,angles for a cap "
                   "or a tube, patterns for a strip (it must include patterns: a strip keeps its flat angle and "
                   "thickness)]. Without patterns a closed design keeps the base spec's own [patterns].")
@click.option("--progress/--no-progress", default=True, show_default=True,
              help="Progress on stderr (solves done; in a solve its increment, λ and factorizations).")
def design_cmd(target: str, spec: str, out: str, h: float, max_solves: int | None, tolerance: float, scale_target: bool,
               workers: int | None, dask_address: str | None, max_minutes: float | None, kit: bool,
               dry_run: bool, per: str, vary: str | None, progress: bool) -> None:
    """Choose one pattern per tile so that the assembled strip or closed tiling matches TARGET.

    For a honeycomb-strip spec, TARGET is a CSV of the arch's mid-line (header x,z, mm; x from column 0's
    pin, z up, both pins at z = 0). For a closed tiling (truncated-icosahedron or goldberg; other kinds are
    refused) it is `sphere`, `ellipsoid:A,B,C` (axis ratios 0.1 to 10) or a surface mesh file (.obj, .stl,
    .ply); the plates fix its size. An open tiling takes a surface of revolution: a hex-cap `cap:H` (a
    spherical cap of rim radius 1 and height H in (0, 1]), a hex-tube `revolution:R0,R1,…,Rk` (radii at equal
    steps along an axis of length 1). A TARGET that names an existing file is that file.
    Writes DIR/design.toml (a spec for `fabpat assemble` and `fabpat simulate-assembly`, with every
    tile's pattern and, for a strip, [load] end_shortening), DIR/design.json and DIR/design.png.

    Ctrl-C, SIGTERM or --max-minutes stop the solves and write the best design so far ("interrupted": true in
    design.json; a signal still exits 130 or 143). --dry-run checks the inputs and prints the plan, no solve.

    Examples: fabpat design arch.csv --spec assemblies/graded-strip.toml --out arch-design;
    fabpat design sphere --spec assemblies/truncated-icosahedron.toml --out sphere-design
    """
    from fabpat.design import design
    from fabpat.design.target import target_file
    from fabpat.io import check_distinct
    from fabpat.progress import Progress

    if dask_address and workers:
        raise click.UsageError("--workers is for local processes; the dask cluster decides with --dask")
    check_distinct([out], inputs={"TARGET": target_file(target), "--spec": spec})
    if dry_run:
        import json

        from fabpat.design.dry_run import dry_run as plan

        click.echo(json.dumps(plan(target, spec, out=out, h=h, scale_target=scale_target, per=per, vary=vary),
                              indent=1))
        return
    with Progress("design", enabled=progress) as bar:
        bar.update("reading the target, the spec and the catalog")
        done = [0]

        def solves(n: int, seconds: float) -> None:
            done[0] = n
            bar.update(f"{n} solves done")

        res = design(target, spec, out=out, h=h, max_solves=max_solves, tolerance=tolerance,
                     scale_target=scale_target, workers=workers or 1, dask=dask_address, kit=kit, progress=solves,
                     max_minutes=max_minutes, status=lambda text: bar.update(f"{done[0]} solves done; {text}"),
                     per=per, vary=vary)
    rec = res.record
    click.echo(f"rms_error={rec['rms_error']:.4g} mm relative_rms={rec['relative_rms']:.4g} solves={rec['solves']} "
               f"reachable={str(rec['reachable']).lower()}", err=True)
    if res.warning:
        click.echo(f"fabpat: warning: {res.warning}", err=True)
    for note in rec.get("notes", []):  # e.g. a --vary word this search does not vary: said, not only in design.json
        click.echo(f"fabpat: note: {note}", err=True)
    for f in ("design.toml", "design.json", "design.png", *sorted(res.files), *(["kit/"] if kit else [])):
        click.echo(f"{out.rstrip('/')}/{f}")
    if rec.get("stopped_by") in ("SIGINT", "SIGTERM"):  # the files are written; the exit still says why it ended
        raise KeyboardInterrupt


COMMANDS = [design_cmd]
