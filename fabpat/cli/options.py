"""Options shared by several commands, so each is spelled and checked the same way everywhere."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from fabpat.pattern import DEFAULT_EDGE


def _at_least(minimum: float, what: str, strict: bool = False) -> Callable[..., Any]:
    def check(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
        if value is None:
            return value
        bad = value <= minimum if strict else value < minimum
        if bad:
            op = ">" if strict else "≥"
            raise click.BadParameter(f"{what} must be {op} {minimum:g}, got {value:g}", ctx, param)
        return value

    return check


sides_option = click.option(
    "--sides", type=int, default=6, show_default=True, callback=_at_least(3, "sides"),
    help="Number of polygon sides (≥ 3).",
)
depth_option = click.option(
    "--depth", type=int, default=2, show_default=True, callback=_at_least(1, "depth"),
    help="Subdivision depth of the slice (≥ 1); depth ≥ 3 needs --sample.",
)
id_depth_option = click.option(
    "--depth", type=int, default=None, callback=_at_least(1, "depth"),
    help="Subdivision depth of the ID [default: from its length: 4 hex digits → 2, 16 → 3].",
)
edge_option = click.option(
    "--edge", type=float, default=DEFAULT_EDGE, show_default=True, callback=_at_least(0, "edge", True),
    help="Polygon edge length in mm.",
)
weight_option = click.option(
    "--weight", type=float, default=0.2, show_default=True, callback=_at_least(0, "weight", True),
    help="Middle weight w of the interface fillet arcs (the paper's 0.2).",
)
