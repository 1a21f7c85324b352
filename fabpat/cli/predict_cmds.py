"""``fabpat predict``: a pattern's scenario energies, min width and area from the learned response, no solve."""

from __future__ import annotations

import click

from fabpat.cli.options import sides_option


@click.command("predict")
@click.argument("ids", nargs=-1, required=True)
@sides_option
@click.option("--db", type=click.Path(dir_okay=False), default=None,
              help="Catalog whose learned response to use (its <db>.response.npz) [default: the built-in one].")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object per ID (a list): id, sides and each catalog column with <column>_interval.")
def predict_cmd(ids: tuple[str, ...], sides: int, db: str | None, as_json: bool) -> None:
    """Predict the Cantilever, Cylinder and Dome energies (N·mm), min width (mm) and area (mm²) of
    connected, tileable patterns of depth 2 or 3 in microseconds, each with its 90 % interval, from the
    learned response fitted to the catalog's simulations (docs/learned-response.md). A prediction, not a
    solve: `fabpat simulate ID` computes the energies."""
    import json

    from fabpat.catalog.response import TARGETS, predict

    p = predict(list(ids), sides, db)
    if as_json:
        click.echo(json.dumps(p.records(), indent=1))
        return
    click.echo("id  " + "  ".join(f"{t} [90 %]" for t in TARGETS))
    for k, i in enumerate(p.ids):
        cells = [f"{p.values[t][k]:.4g} [{p.intervals[t][k, 0]:.4g}, {p.intervals[t][k, 1]:.4g}]" for t in TARGETS]
        click.echo(f"{i}  " + "  ".join(cells))


COMMANDS = [predict_cmd]
