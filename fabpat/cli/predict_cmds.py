"""``fabpat predict``: a pattern's scenario energies, min width and area from the learned response, no solve."""

from __future__ import annotations

import sys

import click

from fabpat.cli.options import number_option


@click.command("predict")
@click.argument("ids", nargs=-1, required=True)
@number_option("--sides", range_name="sides", default=6, show_default=True,
               help="Number of polygon sides (the built-in catalog has responses for 5 and 6).")
@click.option("--db", type=click.Path(dir_okay=False), default=None,
              help="Catalog whose learned response to use (its <db>.response.npz) [default: the built-in one].")
@click.option("--json", "as_json", is_flag=True,
              help="Print a JSON list, one object per ID: id, sides and each catalog column with <column>_interval.")
def predict_cmd(ids: tuple[str, ...], sides: int, db: str | None, as_json: bool) -> None:
    """Predict the Cantilever, Cylinder and Dome energies (N·mm) and min width (mm) of connected, tileable
    patterns, each with its 90 % interval, from the learned response fitted to the catalog's simulations, and
    their lattice area (mm², exact). Microseconds per pattern: a prediction, not a solve (`fabpat simulate ID`
    computes the energies). A depth the response was not fitted to is refused (docs/learned-response.md).

    \b
    Examples:
      fabpat predict 0x0488 0xda08
      fabpat library --format csv | cut -d, -f1 | tail -n +2 | fabpat predict - --json   # IDs on stdin
    """
    import json

    from fabpat.catalog.response import TARGETS
    from fabpat.catalog.response_file import predict

    wanted = [i for token in ids for i in (sys.stdin.read().split() if token == "-" else [token])]
    p = predict(wanted, sides, db)
    if as_json:
        click.echo(json.dumps(p.records(), indent=1))
        return
    width = max(len(i) for i in p.ids)
    cells = {t: [f"{p.values[t][k]:.4g} [{p.intervals[t][k, 0]:.4g}, {p.intervals[t][k, 1]:.4g}]"
                 for k in range(len(p.ids))] for t in TARGETS}
    cells["area"] = [f"{a:.2f}" for a in p.values["area"]]  # exact: no interval to show
    header = {t: f"{t} [90 %]" if t != "area" else "area (exact)" for t in TARGETS}
    widths = {t: max(len(header[t]), *(len(c) for c in cells[t])) for t in TARGETS}
    click.echo("  ".join(["id".ljust(width), *(header[t].ljust(widths[t]) for t in TARGETS)]).rstrip())
    for k, i in enumerate(p.ids):
        click.echo("  ".join([i.ljust(width), *(cells[t][k].ljust(widths[t]) for t in TARGETS)]).rstrip())


COMMANDS = [predict_cmd]
