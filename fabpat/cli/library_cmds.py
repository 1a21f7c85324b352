"""``fabpat library``, ``fabpat show`` and ``fabpat sheet``: list, draw and survey patterns."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import click

from fabpat.cli.options import depth_option, edge_option, sides_option
from fabpat.errors import PatternError
from fabpat.io import atomic_outputs
from fabpat.library import Library, enumerate_library, get_pattern, sample_library
from fabpat.pattern import DEFAULT_EDGE, Pattern


def load_library(sides: int, depth: int, sample: int | None = None, seed: int = 0) -> Library:
    if sample is not None:
        return sample_library(sides, depth, sample, seed)
    return enumerate_library(sides, depth)


def library_rows(lib: Library, edge: float = DEFAULT_EDGE) -> list[dict[str, object]]:
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
    return rows


def _print_rows(rows: list[dict[str, object]], fmt: str, title: str) -> None:
    if fmt == "json":
        click.echo(json.dumps(rows, indent=1))
    elif fmt == "csv":
        buf = io.StringIO()
        if rows:
            w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
            w.writeheader()
            w.writerows(rows)
        click.echo(buf.getvalue(), nl=False)
    else:
        from rich.console import Console
        from rich.table import Table

        table = Table(title=title)
        for key in rows[0] if rows else []:
            table.add_column(key, justify="left" if key == "id" else "right")
        for r in rows:
            table.add_row(*(f"{v:.6g}" if isinstance(v, float) else str(v) for v in r.values()))
        Console(width=160).print(table)


@click.command("library")
@sides_option
@depth_option
@edge_option
@click.option("--format", "fmt", type=click.Choice(["table", "json", "csv"]), default="table", show_default=True,
              help="Output format.")
@click.option("--sample", type=int, default=None, help="Draw N random valid patterns instead of listing all.")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed for --sample.")
def library_cmd(sides: int, depth: int, edge: float, fmt: str, sample: int | None, seed: int) -> None:
    """List the connected, tileable patterns with their geometric metrics.

    Example: fabpat library --sides 6 --format json > library.json
    """
    lib = load_library(sides, depth, sample, seed)
    rows = library_rows(lib, edge)
    title = f"{len(rows)} patterns, {sides}-gon, depth {depth}, edge {edge:g} mm ({lib.candidates} candidates)"
    _print_rows(rows, fmt, title)


def _pattern(pattern_id: str, sides: int, depth: int, edge: float) -> Pattern:
    return get_pattern(pattern_id, sides, depth, edge)


@click.command("show")
@click.argument("pattern_id", metavar="ID")
@sides_option
@depth_option
@edge_option
@click.option("--svg", "svg", type=click.Path(dir_okay=False), required=True, help="SVG file to write.")
def show_cmd(pattern_id: str, sides: int, depth: int, edge: float, svg: str) -> None:
    """Draw one pattern as an SVG at true size (mm).

    Example: fabpat show 0x0488 --sides 6 --svg pattern.svg
    """
    from fabpat.pictures import pattern_svg

    p = _pattern(pattern_id, sides, depth, edge)
    text = pattern_svg(p)
    with atomic_outputs(svg) as (tmp,):
        tmp.write_text(text)
    click.echo(f"wrote {svg}")


@click.command("sheet")
@sides_option
@depth_option
@click.option("--sample", type=int, default=None, help="Draw N random valid patterns instead of listing all.")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed for --sample.")
@click.option("--out", type=click.Path(dir_okay=False), required=True, help="Contact sheet file: .svg or .png.")
def sheet_cmd(sides: int, depth: int, sample: int | None, seed: int, out: str) -> None:
    """Write a contact sheet: every pattern of the library in a grid with its ID.

    Example: fabpat sheet --sides 6 --out library.png
    """
    from fabpat.pictures import contact_sheet_png, contact_sheet_svg

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


COMMANDS = [library_cmd, show_cmd, sheet_cmd]
