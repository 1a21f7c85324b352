"""Options shared by several commands, so each is spelled and checked the same way everywhere.

Every numeric option is a :class:`NumberType` over a named range of :mod:`fabpat.validate`: the value
is checked while parsing (before any work, before any file is opened) and ``--help`` shows the range.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import fields
from typing import Any

import click

from fabpat.errors import GeometryError, RangeError
from fabpat.patterns.pattern import DEFAULT_EDGE
from fabpat.patterns.variation import Variation
from fabpat.validate import RANGES, check


class NumberType(click.ParamType):
    """A float or integer option checked against ``fabpat.validate.RANGES[range_name]``."""

    def __init__(self, range_name: str) -> None:
        self.range = RANGES[range_name]
        self.name = "integer" if self.range.integer else "float"

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        """``INTEGER`` or ``FLOAT`` in ``--help``."""
        return "INTEGER" if self.range.integer else "FLOAT"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        """The checked number, or click's one-line usage error naming the option and its range."""
        if isinstance(value, int | float) and not isinstance(value, bool):
            number: Any = value
        else:
            text = str(value).strip()
            try:
                number = int(text) if self.range.integer else float(text)
            except ValueError:
                kind = "an integer" if self.range.integer else "a number"
                valid = self.range.describe().removeprefix("an integer in ")
                self.fail(f"{value!r} is not {kind}: must be {kind} in {valid}", param, ctx)
        try:
            return check(self.range.name, number, label="value")
        except RangeError as e:
            self.fail(str(e).removeprefix("value ").removeprefix("= "), param, ctx)


def number_option(*decls: str, range_name: str, help: str, **kwargs: Any) -> Any:  # noqa: A002 - click's name
    """A ``click.option`` of :class:`NumberType` whose help ends with the valid range."""
    r = RANGES[range_name]
    return click.option(*decls, type=NumberType(range_name), help=f"{help} Range: {r.describe()}.", **kwargs)


def max_elements_option(default: int, what: str) -> Any:
    """``--max-elements``: the size limit of the heavy work (see docs/reliability.md)."""
    return number_option("--max-elements", range_name="max_elements", default=default, show_default=True,
                         help=f"Refuse to start when the estimated number of {what} is above this.")


sides_option = number_option("--sides", range_name="sides", default=6, show_default=True,
                             help="Number of polygon sides.")
depth_option = number_option("--depth", range_name="depth", default=2, show_default=True,
                             help="Subdivision depth of the slice; depth ≥ 3 needs --sample.")
id_depth_option = number_option(
    "--depth", range_name="depth", default=None,
    help="Subdivision depth of the ID [default: from its length: 4 hex digits → 2, 16 → 3].",
)
edge_option = number_option("--edge", range_name="edge", default=DEFAULT_EDGE, show_default=True,
                            help="Polygon edge length in mm.")
weight_option = number_option("--weight", range_name="weight", default=0.2, show_default=True,
                              help="Middle weight w of the interface fillet arcs (the paper's 0.2).")
thickness_option = number_option("--thickness", range_name="thickness", default=2.0, show_default=True,
                                 help="Plate thickness in mm.")
sample_option = number_option("--sample", range_name="sample", default=None,
                              help="Draw N random valid patterns instead of listing all (needed for depth ≥ 3).")
seed_option = number_option("--seed", range_name="seed", default=0, show_default=True,
                            help="Random seed for --sample.")
poisson_option = number_option("--poisson", "nu", range_name="poisson", default=0.35, show_default=True,
                               help="Poisson's ratio (PLA: 0.35).")
modulus_option = number_option("--youngs-modulus", "E", range_name="youngs_modulus", default=1000.0,
                               show_default=True, help="Young's modulus in N/mm² (PLA: 1000).")


#: what bounds ``--h`` for one pattern (fabpat.simulation.mesh_size.MAX_H_PER_MIN_WIDTH) and for an assembly
#: (fabpat.assembly.solve.model.MAX_H_PER_INTERFACE × the interface segment)
H_LIMITS = {"pattern": "at most twice the pattern's min_width",
            "assembly": "at most twice the interface segment, 7.5 mm for 36 mm plates at weight 0.2"}


def h_option(default: float, limit: str = "pattern") -> Any:
    """``--h``: the target mesh edge in mm, with a command's own default; ``limit`` names what bounds it
    (a key of :data:`H_LIMITS`)."""
    return number_option("--h", "h", range_name="h", default=default, show_default=True,
                         help=f"Target mesh edge length in mm ({H_LIMITS[limit]}).")


def parse_variation(texts: Iterable[str]) -> Variation:
    """A :class:`~fabpat.patterns.variation.Variation` from ``NAME=VALUE`` strings (the repeatable ``--variation``).

    Raises :class:`~fabpat.errors.GeometryError` for a string without ``=``, spaces around the name or
    value, a value that is not a finite number, a parameter given twice, an unknown name or a value outside its range.
    """
    names = ", ".join(f.name for f in fields(Variation))
    values: dict[str, float] = {}
    for text in texts:
        name, sep, raw = str(text).partition("=")
        if not sep:
            raise GeometryError(f"{text!r} is not NAME=VALUE; valid names: {names}")
        if name != name.strip() or raw != raw.strip():  # as the other options' names: spelt exactly
            raise GeometryError(f"{text!r}: no spaces around the name or the value (NAME=VALUE, such as "
                                f"bridge_weight=0.5); valid names: {names}")
        if name in values:
            raise GeometryError(f"{name} given twice")
        if name not in {f.name for f in fields(Variation)}:
            raise GeometryError(f"unknown variation {name!r}; valid: {names}")
        valid = f"a number in {RANGES[name].describe()}"
        # a plain decimal number: Python's float() would also take "1_0" (10) and non-ASCII digits
        if not _DECIMAL.fullmatch(raw):
            raise GeometryError(f"{name}={raw!r} is not a number; {name} is {valid}")
        value = float(raw)
        if not math.isfinite(value):
            raise GeometryError(f"{name}={raw!r} is not a finite number; {name} is {valid}")
        values[name] = value
    return Variation.from_values(values)


#: what ``--variation NAME=VALUE`` reads as a number: ASCII decimal notation, optional exponent (inf and nan
#: too, to be refused as not finite)
_DECIMAL = re.compile(r"[+-]?((\d+(\.\d*)?|\.\d+)(e[+-]?\d+)?|inf(inity)?|nan)", re.ASCII | re.IGNORECASE)


def _variation(ctx: click.Context, param: click.Parameter, value: tuple[str, ...]) -> Variation:
    try:
        v = parse_variation(value)
    except GeometryError as e:
        raise click.BadParameter(str(e), ctx, param) from None
    ctx.meta[VARIATION_GIVEN] = tuple(str(t).partition("=")[0].strip() for t in value)
    return v


#: ``click.Context.meta`` key of the parameter names the command line gave with ``--variation`` (a
#: value equal to the paper's default is still a choice the user made: ``show`` then draws the
#: filleted outline and ``simulate`` echoes it)
VARIATION_GIVEN = "fabpat.variation_given"


def warn_inert_variation(asked: Variation, made: Variation, pattern_id: str) -> None:
    """One warning line on stderr when ``--variation`` asked for a member (``asked``) and the filleted
    pattern came out the paper's (``made``): a pattern without non-manifold vertices has no bridging
    arc for ``bridge_weight`` to act on (:func:`fabpat.geometry.fillet.fillet_pattern`)."""
    if not asked.is_paper and made.is_paper:
        click.echo(f"fabpat: warning: pattern {pattern_id} has no non-manifold vertex, so {asked.label()} does not "
                   "change it: its outline is the paper's", err=True)


def variation_given() -> tuple[str, ...]:
    """The names the running command's ``--variation`` options gave (empty when none or outside click)."""
    ctx = click.get_current_context(silent=True)
    return tuple(ctx.meta.get(VARIATION_GIVEN, ())) if ctx is not None else ()


#: ``--variation NAME=VALUE`` (repeatable): the pattern's family member (``fabpat variations``), parsed
#: into a :class:`fabpat.patterns.variation.Variation` (the paper's fillets when not given)
variation_option = click.option(
    "--variation", "variation", multiple=True, metavar="NAME=VALUE", callback=_variation,
    help="A continuous variation of the pattern (repeatable; `fabpat variations` lists them), e.g. "
         "--variation bridge_weight=0.5 [default: the paper's fillets].")
