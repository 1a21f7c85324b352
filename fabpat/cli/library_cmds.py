"""``fabpat library``, ``fabpat show`` and ``fabpat sheet``: list, draw and survey patterns."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import click

from fabpat.cli.library_cache import cache_path as _cache_path
from fabpat.cli.library_cache import read_cache, write_cache
from fabpat.cli.options import (
    depth_option,
    edge_option,
    id_depth_option,
    sample_option,
    seed_option,
    sides_option,
    variation_given,
    variation_option,
    warn_inert_variation,
    weight_option,
)
from fabpat.errors import PatternError
from fabpat.io import atomic_outputs, check_suffix
from fabpat.patterns.count import LibraryCount, count_patterns
from fabpat.patterns.library import Library, enumerate_library, get_pattern, sample_library
from fabpat.patterns.pattern import DEFAULT_EDGE, Pattern
from fabpat.patterns.variation import Variation, variations


def load_library(sides: int, depth: int, sample: int | None = None, seed: int = 0) -> Library:
    """The whole library, or ``sample`` random valid patterns drawn with ``seed`` (needed for depth ≥ 3)."""
    if sample is not None:
        return sample_library(sides, depth, sample, seed)
    return enumerate_library(sides, depth)


def _filleted_row(args: tuple[str, int, int, float, float]) -> dict[str, float]:
    from fabpat.geometry.fillet import fillet_pattern

    pid, sides, depth, edge, weight = args
    fp = fillet_pattern(Pattern.from_id(pid, sides, depth, edge), weight)
    digits = {"filleted_polar_moment": 4, "min_width": 4, "filleted_ratio": 8}
    return {k: round(v, digits.get(k, 6)) for k, v in fp.catalog_columns().items()}


def library_rows(
    lib: Library, edge: float = DEFAULT_EDGE, weight: float | None = 0.2, workers: int | None = None
) -> list[dict[str, object]]:
    """One row per pattern: lattice metrics and, unless ``weight`` is None, filleted metrics.

    Filleting and validating a pattern takes a few milliseconds (min_width by ray casting at
    0.01 mm flattening), so the filleted columns are computed in a process pool with a progress bar
    on stderr, and cached (:mod:`fabpat.cli.library_cache`: checked on reading, never fatal).
    """
    rows: list[dict[str, object]] = []
    for p in lib.patterns(edge):
        m = p.metrics
        rows.append(
            {
                "id": p.id,
                "sides": p.sides,
                "depth": p.depth,
                "edge": p.edge,
                "area": round(m.area, 6),
                "perimeter": round(m.perimeter, 6),
                "ratio": round(m.ratio, 8),
                "polar_moment": round(m.polar_moment, 4),
            }
        )
    if weight is None:
        return rows
    jobs = [(str(r["id"]), lib.sides, lib.depth, edge, weight) for r in rows]
    cache = _cache_path(jobs)
    extras = read_cache(cache, jobs)  # None unless exactly these jobs' columns: a poisoned cache is recomputed
    if extras is None:
        extras = _map_with_progress(_filleted_row, jobs, "filleting", workers)
        write_cache(cache, jobs, extras, lambda line: click.echo(f"fabpat: warning: {line}", err=True))
    for row, extra in zip(rows, extras, strict=True):
        row["weight"] = weight
        row.update(extra)
    return rows


def _map_with_progress(fn, jobs: list, what: str, workers: int | None = None) -> list:  # noqa: ANN001
    import os
    from concurrent.futures import ProcessPoolExecutor

    from rich.console import Console
    from rich.progress import Progress

    workers = workers or min(len(jobs) // 50 + 1, os.cpu_count() or 1)
    console = Console(stderr=True)
    with Progress(console=console, transient=True, disable=not console.is_terminal) as bar:
        task = bar.add_task(what, total=len(jobs))
        if workers <= 1:
            out = []
            for j in jobs:
                out.append(fn(j))
                bar.advance(task)
            return out
        with ProcessPoolExecutor(workers) as pool:
            out = []
            for r in pool.map(fn, jobs, chunksize=16):
                out.append(r)
                bar.advance(task)
            return out


def _print_rows(rows: list[dict[str, object]], fmt: str, title: str, header: list[str] | None = None) -> None:
    """Rows as JSON, CSV or a table; ``header``: the CSV columns when there are no rows (a reader of an
    empty selection still gets the header line, as for any other)."""
    if fmt == "json":
        click.echo(json.dumps(rows, indent=1))
    elif fmt == "csv":
        buf = io.StringIO()
        fieldnames = list(rows[0]) if rows else list(header or [])
        if fieldnames:
            w = csv.DictWriter(buf, fieldnames=fieldnames, lineterminator="\n")
            w.writeheader()
            w.writerows(rows)
        click.echo(buf.getvalue(), nl=False)
    else:
        from rich.console import Console
        from rich.table import Table

        table = Table(title=title)
        # a scenario that did not converge has no value: "–" as in the docs' tables, not Python's None
        cells = [[f"{v:.6g}" if isinstance(v, float) else "–" if v is None else str(v) for v in r.values()]
                 for r in rows]
        keys = list(rows[0]) if rows else []
        for key in keys:
            table.add_column(key, justify="left" if key == "id" else "right", no_wrap=True)
        for c in cells:
            table.add_row(*c)
        # wide enough for every header and cell: a table piped to a file must not truncate column names
        need = sum(max([len(k)] + [len(c[i]) for c in cells]) + 3 for i, k in enumerate(keys)) + 1
        Console(width=max(80, need)).print(table)


@click.command("library")
@sides_option
@depth_option
@edge_option
@click.option("--format", "fmt", type=click.Choice(["table", "json", "csv"]), default="table", show_default=True,
              help="Output format.")
@sample_option
@seed_option
@weight_option
@click.option("--no-fillet", is_flag=True, help="Lattice metrics only (skip the filleted columns; instant).")
@click.option("--count", "count_only", is_flag=True,
              help="Print how many patterns there are instead of listing them: exact up to depth 3 (pruned "
                   "enumeration), beyond an estimate with its 95 % interval (uniform draws, --seed).")
def library_cmd(
    sides: int, depth: int, edge: float, fmt: str, sample: int | None, seed: int, weight: float, no_fillet: bool,
    count_only: bool,
) -> None:
    """List the connected, tileable patterns with their geometric metrics, or count them (--count).

    Columns: lattice metrics of the solid pattern (area mm², perimeter mm, ratio = 4πA/P², polar
    moment mm⁴ about the centre) and the same for the filleted outline, plus its min_width (mm).

    \b
    Examples:
      fabpat library --sides 6 --format json > library.json
      fabpat library --depth 3 --count
    """
    if count_only:
        if sample is not None:
            raise PatternError("--count counts the whole library and takes no --sample (an estimate's draws "
                               "are fixed; --seed chooses them)")
        _print_count(count_patterns(sides, depth, seed), fmt, seed)
        return
    lib = load_library(sides, depth, sample, seed)
    rows = library_rows(lib, edge, None if no_fillet else weight)
    if sample is None:
        source = f"{lib.candidates} candidates"
    else:  # lib.candidates counts the random draws, not the slices the sample stands for
        from fabpat.patterns.lattice import n_faces

        source = f"random sample, seed {seed}, of the 2^{n_faces(depth)} − 1 slices"
    title = f"{len(rows)} patterns, {sides}-gon, depth {depth}, edge {edge:g} mm ({source})"
    _print_rows(rows, fmt, title)


def _print_count(c: LibraryCount, fmt: str, seed: int) -> None:
    """One count: a sentence (table), a JSON object or a CSV row, labelled exact or estimate."""
    if fmt == "json":
        click.echo(json.dumps(c.as_dict(), indent=1))  # one object, the count an exact integer
    elif fmt == "csv":
        _print_rows([c.as_dict()], fmt, "")
    elif c.exact:
        click.echo(f"{c.count} connected, tileable patterns ({c.sides}-gon, depth {c.depth}): exact, by pruned "
                   f"enumeration of the {c.edge_rule_slices} slices that pass the edge rule")
    else:
        click.echo(f"about {c.count:.4g} connected, tileable patterns ({c.sides}-gon, depth {c.depth}): an "
                   f"estimate, 95 % interval {c.low:.4g} … {c.high:.4g}, from {c.draws} uniform draws (seed "
                   f"{seed}) of the {c.edge_rule_slices:.4g} slices that pass the edge rule")


@click.command("show")
@click.argument("pattern_id", metavar="ID")
@sides_option
@id_depth_option
@edge_option
@click.option("--svg", "svg", type=click.Path(dir_okay=False), default=None,
              help="SVG file to write [default: the SVG on stdout].")
@click.option("--filleted", is_flag=True, help="Draw the exact filleted outline (true curves) instead of the lattice.")
@weight_option
@variation_option
def show_cmd(pattern_id: str, sides: int, depth: int | None, edge: float, svg: str | None, filleted: bool,
             weight: float, variation: Variation) -> None:
    """Draw one pattern as an SVG at true size (mm), to --svg FILE or stdout.

    A --variation changes the filleted outline only, so it implies --filleted.

    \b
    Examples:
      fabpat show 0x0488 --sides 6 --filleted --svg pattern.svg
      fabpat show 0x0488 --variation bridge_weight=0.4 --svg wide-necks.svg
      fabpat show 0x0488 > pattern.svg
    """
    from fabpat.views.pictures import pattern_svg

    if svg is not None:
        check_suffix(svg, (".svg",), "--svg")  # an SVG in a .png would open as a broken picture
    p = get_pattern(pattern_id, sides, depth, edge)  # depth None: from the ID's length
    filleted = filleted or not variation.is_paper or bool(variation_given())
    member = p.fillet(weight, variation) if filleted else None
    if member is not None:
        warn_inert_variation(variation, member.variation, p.id)
    title = f"{member.label if member is not None else p.id} ({p.sides}-gon, edge {p.edge:g} mm)"
    text = pattern_svg(p, outline_path=member.outline.to_svg_path() if member is not None else None, title=title)
    if svg is None:
        click.echo(text, nl=False)
        return
    with atomic_outputs(svg) as (tmp,):
        tmp.write_text(text)
    click.echo(f"wrote {svg}")


@click.command("sheet")
@sides_option
@depth_option
@sample_option
@seed_option
@click.option("--out", type=click.Path(dir_okay=False), required=True, help="Contact sheet file: .svg or .png.")
def sheet_cmd(sides: int, depth: int, sample: int | None, seed: int, out: str) -> None:
    """Write a contact sheet: every pattern of the library in a grid with its ID.

    Example: fabpat sheet --sides 6 --out library.png
    """
    from fabpat.views.pictures import contact_sheet_png, contact_sheet_svg

    suffix = Path(out).suffix.lower()
    if suffix not in (".svg", ".png"):
        raise PatternError(f"--out must end in .svg or .png, got {out!r}")
    lib = load_library(sides, depth, sample, seed)
    patterns = lib.patterns()
    with atomic_outputs(out) as (tmp,):
        if suffix == ".svg":
            tmp.write_text(contact_sheet_svg(patterns))
        else:
            contact_sheet_png(patterns, tmp)
    click.echo(f"wrote {out} ({len(patterns)} patterns)")


@click.command("variations")
@click.option("--json", "as_json", is_flag=True, help="A JSON list of {name, min, max, default, unit, meaning}.")
def variations_cmd(as_json: bool) -> None:
    """List the continuous variations every pattern has (its family parameters).

    Each one is given to show, export and simulate as --variation NAME=VALUE, to Python as
    ``fabpat.pattern(ID).fillet(NAME=VALUE)``. The default is the paper's value.

    \b
    Examples:
      fabpat variations
      fabpat variations --json
    """
    rows = variations()
    if as_json:
        click.echo(json.dumps(rows, indent=1))
        return
    for r in rows:
        unit = f" {r['unit']}" if r["unit"] else ""
        click.echo(f"{r['name']}: {r['min']:g} … {r['max']:g}{unit}, default {r['default']:g} (the paper's) — "
                   f"{r['meaning']}")


COMMANDS = [library_cmd, show_cmd, sheet_cmd, variations_cmd]
