"""``fabpat sweep``, ``fabpat catalog``, ``fabpat browse`` and ``fabpat plot``: simulate the library into a
catalog, print it, browse it as linked scatter plots, draw its static figures."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import click

import fabpat.catalog.learn  # noqa: F401 - registers the range of --learn (fabpat.validate.RANGES)
from fabpat.catalog.sweep import FAMILY_SAMPLES
from fabpat.cli.options import (
    depth_option,
    edge_option,
    number_option,
    sample_option,
    seed_option,
    sides_option,
    thickness_option,
    variation_option,
    weight_option,
)
from fabpat.patterns.variation import Variation

if TYPE_CHECKING:
    from fabpat.catalog.sweep import SweepReport, SweepSetup

DEFAULT_DB = "catalog.sqlite"
_db_help = "Catalog file (SQLite) [default: the built-in catalog of the default library]."


@click.command("sweep")
@sides_option
@depth_option
@sample_option
@seed_option
@click.option("--db", type=click.Path(dir_okay=False), default=DEFAULT_DB, show_default=True,
              help="Catalog file to create or complete.")
@number_option("--workers", range_name="workers", default=None, help="Local worker processes [default: all cores].")
@click.option("--dask", "dask_address", metavar="ADDRESS", default=None,
              help="Send the tasks to this dask.distributed scheduler (e.g. tcp://host:8786) instead.")
@click.option("--force", is_flag=True, help="Recompute rows already in the catalog.")
@edge_option
@thickness_option
@weight_option
@number_option("--youngs-modulus", "modulus", range_name="youngs_modulus", default=1000.0, show_default=True,
               help="Young's modulus in N/mm² (PLA: 1000).")
@number_option("--poisson", range_name="poisson", default=0.35, show_default=True, help="Poisson's ratio (PLA: 0.35).")
@number_option("--h", "--mesh-size", "h", range_name="h", default=None,
               help="Target mesh edge length in mm (at most twice each pattern's min_width) "
                    "[default: 2.5, an upper bound lowered to 1.1 × min_width for narrower necks, refined to "
                    "half; with --no-extrapolate 1.5].")
@click.option("--extrapolate/--no-extrapolate", default=True, show_default=True,
              help="Mesh each pattern at h, refine that mesh once (h/2, nested) and store the energy "
                   "extrapolated to the mesh-converged value (Richardson, as the built-in catalog and `fabpat "
                   "simulate`); --no-extrapolate: one mesh of h, ≈ 3× faster and 3–5 % low in the median "
                   "(docs/accuracy.md).")
@variation_option
@click.option("--family", is_flag=True,
              help=f"Also sweep the family members {', '.join(f'{w:g}' for w in FAMILY_SAMPLES)} of bridge_weight "
                   "(into the catalog's family table, after the paper's own results), then the midpoints of the "
                   "intervals where a pattern's energy bends or buckles (up to two rounds): what fabpat.catalog.family "
                   "interpolates.")
@number_option("--learn", range_name="learn", default=None,
               help="Depth 3: simulate the N patterns of a --sample pool (default 20000) that most widen the "
                   "catalog's Cylinder-energy range at a printable min width, as the learned response ranks them "
                   "(docs/learned-response.md); the response is refitted afterwards.")
def sweep_cmd(sides: int, depth: int, sample: int | None, seed: int, db: str, workers: int | None,
              dask_address: str | None, force: bool, edge: float, thickness: float, weight: float, modulus: float,
              poisson: float, h: float | None, extrapolate: bool, variation: Variation, family: bool,
              learn: int | None) -> int:
    """Simulate every pattern (fillet → mesh → cantilever, cylinder, dome, nonlinear) into a catalog.

    Each pattern's results are committed as soon as they are computed; re-running resumes (rows whose
    input hash matches are skipped), so an interrupted sweep loses only the patterns in progress.
    Each energy is extrapolated from a mesh of h and its nested refinement h/2 (the rows' h_fine says
    so), or with --no-extrapolate taken from one mesh of h; switching between them recomputes the rows.
    --variation bridge_weight=W sweeps that member of every pattern's family instead of the paper's
    fillets; --family sweeps the paper's and every standard member in turn (`fabpat variations`).

    \b
    Examples:
      fabpat sweep --db catalog.sqlite --workers 2
      fabpat sweep --db catalog.sqlite --family

    The work is :func:`fabpat.catalog.sweep_members.sweep_members`'s.
    """
    from fabpat.catalog.sweep import SweepSetup
    from fabpat.catalog.sweep_members import member_setups, sweep_members
    from fabpat.cli.library_cmds import load_library
    from fabpat.io import check_distinct

    check_distinct([], inputs={"--db": db})  # the library cache, say, may never replace the catalog
    if family and not variation.is_paper:
        raise click.UsageError("--family sweeps every standard member; --variation one member: give one of them")
    setup = SweepSetup(sides, depth, edge, thickness, weight, modulus, poisson, h, extrapolate=extrapolate,
                       bridge_weight=1.0 if family else variation.bridge_weight)
    setups = member_setups(setup, family)
    if dask_address and workers:
        raise click.UsageError("--workers is for local processes; the dask cluster decides with --dask")
    if learn and (family or not variation.is_paper):
        raise click.UsageError("--learn chooses patterns for the learned response, which knows the paper's fillets "
                               "only: give it without --family and --variation")
    ids = _learn_ids(db, sides, depth, sample, seed, learn) if learn else load_library(sides, depth, sample, seed).ids
    with _sweep_progress() as progress:
        try:
            report, sweeps = sweep_members(db, ids, setups, family=family, workers=workers, dask=dask_address,
                                           force=force, progress=progress, tell=lambda line: click.echo(line, err=True))
        except KeyboardInterrupt:
            from fabpat.cli import _TERMINATED  # the CLI's SIGTERM handler records the signal there

            how, code = ("terminated", 128 + _TERMINATED[0]) if _TERMINATED else ("interrupted", 130)
            click.echo(f"fabpat: {how}; every finished pattern is stored in {db}: run the same command "
                       "again to resume", err=True)
            return code
    members_text = f", {sweeps} family members and refinements" if len(setups) > 1 else (
        f", bridge_weight = {setup.bridge_weight:g}" if setup.bridge_weight != 1.0 else "")
    return _finish(db, report, setup, f"{len(ids)} patterns{members_text}", learn=bool(learn))


def _finish(db: str, report: SweepReport, setup: SweepSetup, what: str, learn: bool) -> int:
    """The sweep's summary line, its warnings and the learned response's refit; the exit code (1 if a
    pattern's task raised and was not stored)."""
    click.echo(f"{db}: {report.computed} pattern-scenarios computed ({report.failed_rows} did not converge), "
               f"{report.skipped} already up to date, {what}, {report.seconds:.1f} s")
    mixed = _warn_mixed(db, setup)
    if report.computed and not mixed:  # nothing new, or rows that do not rank together: the model stands
        _refit(db, tell_why=learn)
    if report.crashed:
        click.echo(f"fabpat: warning: {len(report.crashed)} patterns raised and were not stored (re-run to retry): "
                   f"{report.crashed[0]}", err=True)
        return 1
    return 0


@contextlib.contextmanager
def _sweep_progress() -> Iterator[Callable[[int, int], None]]:
    """A progress callback (rows done, rows total) for the sweep: a bar on a terminal, else a plain line every
    few seconds (FABPAT_PROGRESS_INTERVAL, as every command's plain progress lines) on stderr."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from fabpat.progress import progress_interval

    console = Console(stderr=True)
    columns = (TextColumn("simulating"), BarColumn(), MofNCompleteColumn(), TextColumn("pattern-scenarios"),
               TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn())
    interval = progress_interval()
    with Progress(*columns, console=console, transient=True, disable=not console.is_terminal) as bar:
        task = bar.add_task("sweep", total=None)
        last = [time.monotonic()]

        def progress(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)
            # no terminal (a background run, a log file): a plain line every few seconds instead of the bar
            if not console.is_terminal and done and (time.monotonic() - last[0] > interval or done == total):
                last[0] = time.monotonic()
                eta = bar.tasks[0].time_remaining
                click.echo(f"simulated {done}/{total} pattern-scenarios"
                           + (f", ETA {eta / 60:.1f} min" if eta else ""), err=True)

        yield progress


def _learn_ids(db: str, sides: int, depth: int, sample: int | None, seed: int, learn: int) -> tuple[str, ...]:
    """The patterns ``--learn`` simulates (:func:`fabpat.catalog.learn.choose` over a seeded pool)."""
    from fabpat.catalog.learn import choose
    from fabpat.cli.library_cmds import load_library

    if depth != 3:
        raise click.UsageError(f"--learn chooses depth-3 patterns (the learned response reads depths 2 and 3; "
                               f"depth 2 is swept whole): give --depth 3, not {depth}")
    pool = load_library(sides, depth, sample or 20_000, seed).ids
    chosen = choose(db, sides, pool, learn)
    click.echo(f"--learn: {len(chosen)} of {len(pool)} drawn patterns chosen to widen the Cylinder-energy range",
               err=True)
    return tuple(chosen)


def _refit(db: str, tell_why: bool) -> None:
    """Refit the catalog's learned response after a sweep (one stderr line; a failure is a warning: the rows
    are stored whatever the model does)."""
    from fabpat.catalog.response_file import refit_responses
    from fabpat.errors import FabpatError

    try:
        path = refit_responses(db)
    except FabpatError as e:
        click.echo(f"fabpat: warning: the learned response was not refitted: {e}", err=True)
        return
    if path is not None:
        click.echo(f"learned response refitted: {path}", err=True)
    elif tell_why:
        from fabpat.catalog.response_file import MIN_ROWS

        click.echo(f"learned response not fitted: it needs {MIN_ROWS} simulated patterns of a polygon", err=True)


def _warn_mixed(db: str, setup: SweepSetup) -> bool:
    """One stderr line if the catalog now mixes extrapolated and one-mesh energies for this set-up
    (:func:`fabpat.catalog.sweep_members.mixed_energies`). Returns whether it does (the learned response is
    then not refitted)."""
    from fabpat.catalog.sweep_members import mixed_energies

    one, two = mixed_energies(db, setup)
    if one and two:
        click.echo(f"fabpat: warning: {db} now holds {two} extrapolated and {one} one-mesh energies for this "
                   "set-up, which do not rank together (one-mesh energies are 1.5–11 % low); sweep the whole "
                   "library the same way to make them one kind; the learned response was not refitted", err=True)
    return bool(one and two)


_TABLE_COLUMNS = ("id", "area", "perimeter", "polar_moment", "min_width")
_sides_help = "Polygon whose patterns and energies to use (each polygon has its own rows)."


@click.command("catalog")
@click.option("--db", type=click.Path(dir_okay=False), default=None, help=_db_help)
@click.option("--format", "fmt", type=click.Choice(["table", "csv", "json"]), default="table", show_default=True,
              help="Output format.")
@click.option("--long", "long_", is_flag=True, help="One row per pattern × scenario with every stored column.")
@number_option("--sides", range_name="sides", default=6, show_default=True, help=_sides_help)
@click.option("--where", "where", metavar="FILTER", multiple=True,
              help="Keep rows with FIELD OP NUMBER, e.g. \"energy_dome<300\" (OP: < <= > >= = !=; any numeric "
                   "column; repeat for several, all must hold).")
@click.option("--sort", "sort", metavar="FIELD", default=None,
              help="Sort by a numeric column, ascending; -FIELD (e.g. --sort=-specific_stiffness_dome) descending. "
                   "Rows without a value come last.")
@number_option("--top", range_name="sample", default=None, help="Print only the first N rows (after --sort).")
@number_option("--depth", range_name="depth", default=None,
               help="Only the patterns of this subdivision depth (2: the paper's library; 3: the deeper patterns "
                    "the built-in catalog ships or a `sweep --depth 3` stored) [default: 2 where the catalog holds "
                    "depth 2, else every depth].")
def catalog_cmd(db: str | None, fmt: str, long_: bool, sides: int, where: tuple[str, ...], sort: str | None,
                top: int | None, depth: int | None) -> None:
    """Print a catalog: one row per pattern with its metrics and energies (N·mm) per scenario.

    Columns: area (mm²), perimeter (mm), ratio, polar_moment (mm⁴), the filleted ones, min_width (mm),
    energy_<scenario> (N·mm), max_displacement_<scenario> (mm) and specific_stiffness_<scenario> =
    1 / (energy × filleted_area) in 1/(N·mm³): stiffness per mass (under the scenario's fixed load the
    energy is inversely proportional to the stiffness, the mass proportional to the filleted area),
    larger = stiffer per gram; table format shows the main ones and those --sort and --where name.

    \b
    Examples:
      fabpat catalog --format csv > catalog.csv
      fabpat catalog --sort=-specific_stiffness_dome --top 5     # the stiffest per gram (Dome)
      fabpat catalog --where "filleted_area<1200" --sort energy_dome --top 5
    """
    from fabpat.catalog import default_depth, open_catalog, require_depth, require_polygon
    from fabpat.catalog.rows import find_rows, parse_condition, parse_sort
    from fabpat.cli.library_cmds import _print_rows
    from fabpat.io import check_distinct

    check_distinct([], inputs={"--db": db})
    with open_catalog(db) as cat:
        require_polygon(cat, sides)
        if depth is not None:
            require_depth(cat, sides, depth)
        depth = default_depth(cat, sides) if depth is None else depth
        fields = cat.number_columns(long=long_)
        if long_:
            rows = cat.results(sides=sides, **({} if depth is None else {"depth": depth}))
        else:
            rows = cat.pattern_rows(sides=sides, **({} if depth is None else {"depth": depth}))
            for r in rows:
                for k in [k for k in r if k.startswith("converged_")]:
                    del r[k]
        header = list(rows[0]) if rows else []  # the CSV header of an empty selection
        rows = find_rows(rows, fields, where=where, sort=sort, top=top)
        asked = [parse_condition(w, fields).field for w in where] + ([parse_sort(sort, fields)[0]] if sort else [])
        title = f"{cat.path}: {len(rows)} rows"
        if fmt == "table" and not long_:
            keep = [*_TABLE_COLUMNS, *(f"energy_{s}" for s in cat.scenarios())]
            setup = ("depth", "edge", "thickness", "weight")
            if len({tuple(r[k] for k in setup) for r in rows}) > 1:
                keep[1:1] = setup
            keep += [f for f in dict.fromkeys(asked) if f not in keep]
            rows = [{k: r[k] for k in keep} for r in rows]
        elif fmt == "table":
            keep = ["id", "sides", "scenario", "energy", "max_displacement", "converged", "iterations", "seconds",
                    "nodes", "h", "h_fine", "error"]
            keep += [f for f in dict.fromkeys(asked) if f not in keep]
            rows = [{k: "" if r[k] is None else r[k] for k in keep} for r in rows]
    if not rows and fmt == "table":
        click.echo(f"{title} (no rows)" if where or depth is not None else f"{title} (empty catalog)")
        return
    _print_rows(rows, fmt, title, header)


@click.command("browse")
@click.option("--db", type=click.Path(dir_okay=False), default=None, help=_db_help)
@click.option("--out", type=click.Path(dir_okay=False), required=True, help="HTML file to write.")
@click.option("--open", "open_", is_flag=True, help="Open the page in the default web browser.")
@number_option("--sides", range_name="sides", default=6, show_default=True, help=_sides_help)
@number_option("--depth", range_name="depth", default=None,
               help="Show the patterns of this subdivision depth (3: the built-in catalog's depth-3 patterns) "
                    "[default: 2, the paper's library, where the catalog holds it].")
def browse_cmd(db: str | None, out: str, open_: bool, sides: int, depth: int | None) -> None:
    """Write the browsing page: linked scatter plots of the catalog in one offline HTML file.

    Hover a dot for the pattern's picture; box/lasso-select in any plot to highlight the patterns in
    all plots and list them with `fabpat export` lines.

    Examples: fabpat browse --out library.html --open;  fabpat browse --depth 3 --out depth3.html
    """
    from fabpat.catalog import open_catalog
    from fabpat.io import check_distinct, check_suffix
    from fabpat.views.browse import write_page

    check_distinct([out], inputs={"--db": db})  # first: writing over the catalog is the graver mistake
    check_suffix(out, (".html", ".htm"), "--out (the browsing page)")
    with open_catalog(db) as cat:
        n = write_page(cat, out, sides, depth)
    size = os.path.getsize(out) / 1e6
    click.echo(f"wrote {out} ({n} patterns, {size:.1f} MB, works offline)")
    if open_:
        import webbrowser

        webbrowser.open(Path(out).resolve().as_uri())


@click.command("plot")
@click.option("--db", type=click.Path(dir_okay=False), default=None, help=_db_help)
@click.option("--out", type=click.Path(file_okay=False), required=True, help="Folder for the figures.")
@click.option("--highlight", default=None, help="Comma-separated IDs to colour in every figure (a cluster).")
@number_option("--sides", range_name="sides", default=6, show_default=True, help=_sides_help)
def plot_cmd(db: str | None, out: str, highlight: str | None, sides: int) -> None:
    """Write the static scatter plots (paper Figs 13–14) as PNG and SVG.

    Example: fabpat plot --out figures --highlight 0x0488,0x0688
    """
    from fabpat.catalog import open_catalog
    from fabpat.io import check_distinct, check_output_folder
    from fabpat.views.plots import plot_catalog

    check_output_folder(out)
    check_distinct([], inputs={"--db": db})  # no figure may replace the catalog
    ids = [h.strip() for h in (highlight or "").split(",") if h.strip()]
    if highlight is not None and not ids:  # an empty list is an error, not "no highlight"
        raise click.BadParameter(f"{highlight!r} names no pattern: give IDs such as 0x0488,0x0688",
                                 param_hint="--highlight")
    with open_catalog(db) as cat:
        paths = plot_catalog(cat, out, ids, sides)
    click.echo(f"wrote {len(paths)} files to {out}: " + ", ".join(p.name for p in paths))


COMMANDS = [sweep_cmd, catalog_cmd, browse_cmd, plot_cmd]
