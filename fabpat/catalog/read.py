"""Reading a catalog: energies for the assembly rules (:func:`energies`, :func:`polygon_energies`: one
polygon's own rows) and the rows of ``fabpat.catalog()`` (:func:`catalog`, filtered, sorted, cut).

Built on :mod:`fabpat.catalog.store` (the database file) and :mod:`fabpat.catalog.rows` (row checks,
finding, :class:`~fabpat.catalog.rows.CatalogRows`); the top of the catalog modules but for the package
:mod:`fabpat.catalog` itself, where every public name here is also ``fabpat.catalog.<name>``.
"""

from __future__ import annotations

import contextlib
import math
import os
import shlex
from collections.abc import Iterator, Mapping, Sequence
from functools import cache
from pathlib import Path

from fabpat.catalog.rows import CatalogRows, check_row, find_rows, parse_condition, polygon_name
from fabpat.catalog.schema import DEFAULT_SETUP, KEY, METRICS, CatalogError, builtin_path
from fabpat.catalog.store import Catalog, open_catalog
from fabpat.validate import as_float, check


@cache
def _builtin_energies(scenario: str, sides: int, depth: int, edge: float, thickness: float,
                      weight: float) -> tuple[tuple[str, float], ...]:
    with open_catalog(None) as cat:
        return tuple(_energy_items(cat, scenario, sides, depth, edge, thickness, weight))


def _energy_items(cat: Catalog, scenario: str, sides: int, depth: int, edge: float, thickness: float,
                  weight: float) -> Iterator[tuple[str, float]]:
    for r in cat.query("SELECT * FROM results WHERE scenario = ? AND sides = ? AND depth = ? AND edge = ? AND "
                       "thickness = ? AND weight = ? ORDER BY id", (scenario, sides, depth, edge, thickness, weight)):
        check_row(cat.path, r, METRICS)  # a bad stored energy is an error, never a silently used (or dropped) number
        if r["converged"]:
            yield str(r["id"]), as_float(r["energy"])


@contextlib.contextmanager
def _reading(catalog: Catalog | str | Path | None) -> Iterator[Catalog]:
    """An open catalog: ``catalog`` itself, or the file it names (None: the built-in one), closed after."""
    if isinstance(catalog, Catalog):
        yield catalog
        return
    if catalog is not None and not isinstance(catalog, str | os.PathLike):
        raise CatalogError(f"catalog must be a catalog file name, an open Catalog or None (the built-in one), "
                           f"got {catalog!r}")
    with open_catalog(catalog) as cat:
        yield cat


def energies(catalog: Catalog | str | Path | None, scenario: str, sides: int = 6, *, depth: int = 2,
             edge: float = 36.0, thickness: float = 2.0, weight: float = 0.2) -> dict[str, float]:
    """Total strain energy (N·mm) of every converged pattern in one scenario: {pattern ID: energy}.

    ``catalog``: an open :class:`Catalog`, a path, or None for the built-in catalog (cached).
    Lower energy = stiffer pattern (constant loads, paper §5). Empty if the scenario was not simulated
    for this polygon and set-up (:func:`polygon_energies` refuses that instead). Raises
    :class:`CatalogError` for an unknown scenario or a bad stored value.
    """
    from fabpat.simulation.scenarios import SCENARIOS

    if scenario not in SCENARIOS:
        raise CatalogError(f"unknown scenario {scenario!r}; expected one of {', '.join(SCENARIOS)}")
    args = (scenario, sides, depth, float(edge), float(thickness), float(weight))
    if catalog is None:
        return dict(_builtin_energies(*args))
    with _reading(catalog) as cat:
        return dict(_energy_items(cat, *args))


def polygon_energies(catalog: Catalog | str | Path | None, scenario: str, sides: int, *, depth: int = 2,
                     edge: float = 36.0, thickness: float = 2.0, weight: float = 0.2) -> dict[str, float]:
    """{pattern ID: energy (N·mm)} from the rows of the polygon ``sides`` itself, for the assembly rules:
    a pentagon face is ranked by pentagon energies, never by another polygon's.

    The set-up (depth, edge mm, thickness mm, weight) is the one asked for if the catalog holds any
    ``scenario`` energies there, else the default one (:data:`DEFAULT_SETUP`): energies rank patterns, and
    a catalog simulated at the default plate set-up ranks them just as well. The choice does not depend
    on ``sides``, so the polygons of one tiling are compared at one set-up. Raises :class:`CatalogError`
    naming the ``fabpat sweep`` command to run if the polygon has no energies there.
    """
    asked = {"depth": depth, "edge": float(edge), "thickness": float(thickness), "weight": float(weight)}
    with _reading(catalog) as cat:
        held = cat.query("SELECT 1 FROM results WHERE scenario = ? AND depth = ? AND edge = ? AND thickness = ? "
                         "AND weight = ? AND converged = 1 LIMIT 1", (scenario, *asked.values()))
        setup = asked if held else {k: DEFAULT_SETUP[k] for k in asked}
        found = energies(cat if catalog is not None else None, scenario, sides,
                         depth=depth if held else int(DEFAULT_SETUP["depth"]), edge=setup["edge"],
                         thickness=setup["thickness"], weight=setup["weight"])
        if not found:
            raise CatalogError(missing_polygon_message(cat, sides, setup))
        return found


def missing_polygon_message(cat: Catalog, sides: int, setup: Mapping[str, object] | None = None) -> str:
    """The one line for a polygon without catalog energies: the ``fabpat sweep`` command that adds them
    (with the options of ``setup`` that differ from :data:`~fabpat.catalog.DEFAULT_SETUP`) and the
    set-ups the catalog holds (:func:`held_setups`)."""
    options = [f"--sides {sides}"] + [f"--{k} {v:g}" for k, v in (setup or {}).items()
                                      if k in DEFAULT_SETUP and k != "sides" and v != DEFAULT_SETUP[k]]
    builtin = cat.path == builtin_path()
    db = "catalog.sqlite" if builtin else shlex.quote(str(cat.path))
    then = " and read that catalog (--db catalog.sqlite; in a spec, patterns.catalog)" if builtin else ""
    return (f"no catalog energies for {polygon_name(sides)} (sides = {sides}) in "
            f"{'the built-in catalog' if builtin else cat.path}: run `fabpat sweep {' '.join(options)} "
            f"--db {db}`{then}; it holds {held_setups(cat)}")


def held_setups(cat: Catalog) -> str:
    """The set-ups a catalog holds, as ``sides=6 depth=2 edge=36 thickness=2 weight=0.2 (430 patterns)``
    (edge and thickness in mm), joined by ``; `` (``nothing`` for an empty catalog)."""
    return "; ".join(f"sides={s['sides']} depth={s['depth']} edge={s['edge']:g} thickness={s['thickness']:g} "
                     f"weight={s['weight']:g} ({s['patterns']} patterns)" for s in cat.setups()) or "nothing"


def default_depth(cat: Catalog, sides: int | None) -> int | None:
    """The depth a reading shows when none is asked for: the paper's library (depth 2, :data:`DEFAULT_SETUP`) if
    the catalog holds depth-2 patterns of the polygon (``sides``; None: of any polygon), else None (every depth:
    a catalog a ``fabpat sweep --depth 3`` filled alone). The built-in catalog holds depth-3 patterns beside the
    430 per polygon (docs/learned-response.md); they are read with ``depth=3``, so that a default reading stays
    the paper's library."""
    depth = int(DEFAULT_SETUP["depth"])
    held = any(s["depth"] == depth and (sides is None or s["sides"] == sides) for s in cat.setups())
    return depth if held else None


def require_depth(cat: Catalog, sides: int, depth: int) -> None:
    """:class:`CatalogError` naming the depths the catalog holds of the polygon unless it holds ``depth`` (rather
    than an empty answer: ``fabpat catalog --depth 4``)."""
    held = sorted({int(as_float(s["depth"])) for s in cat.setups() if s["sides"] == sides})
    if depth not in held:
        raise CatalogError(f"catalog {cat.path.name} has no depth-{depth} patterns of {polygon_name(sides)}: it holds "
                           f"depth {', '.join(map(str, held))} (`fabpat sweep --depth {depth} --sample N` adds some)")


def catalog(path: str | Path | None = None, *, sides: int | float | None = 6, where: Sequence[str] | str = (),
            sort: str | None = None, top: int | None = None, **setup: object) -> CatalogRows:
    """The rows of a catalog (``None``: the built-in one) — ``fabpat.catalog()``.

    One dict per pattern (see :meth:`Catalog.pattern_rows`): ``id``, the set-up (``sides``, ``depth``,
    ``edge`` mm, ``thickness`` mm, ``weight``), lattice and filleted metrics (mm², mm, mm⁴),
    ``min_width`` (mm) and per scenario ``energy_<scenario>`` (N·mm), ``max_displacement_<scenario>``
    (mm) and ``specific_stiffness_<scenario>`` (1/(N·mm³), stiffness per mass:
    :func:`~fabpat.catalog.rows.specific_stiffness`).

    ``sides``: the polygon (default 6, the hexagon; None: every polygon, whose energies do not compare), a
    whole number in [3, 64]; other set-up keys filter too (finite numbers). Without ``depth`` the rows are the
    paper's depth-2 library where the catalog holds it (:func:`default_depth`); ``depth=3`` gives the built-in
    catalog's depth-3 patterns. ``where``: filters
    ``"FIELD OP NUMBER"`` that all hold (``OP`` one of ``< <= > >= = !=``), ``sort``: ``"FIELD"``
    ascending or ``"-FIELD"`` descending, ``top``: keep the first N (:func:`~fabpat.catalog.rows.find_rows`;
    ``sort="id"`` orders by pattern ID). The stiffest patterns per gram in the Dome scenario:
    ``fabpat.catalog(sort="-specific_stiffness_dome", top=5)``.
    Raises :class:`CatalogError` for a bad argument, and rather than return no rows: a polygon the catalog
    lacks names the ``fabpat sweep`` command that adds it, a set-up it lacks the set-ups it holds, filters
    that keep no row the filter and its field's range (:func:`no_filter_match_message`).
    """
    bad = sorted(set(setup) - set(KEY[1:]))
    if bad:
        raise CatalogError(f"unknown catalog filter {bad[0]!r}: choose from {', '.join(KEY[1:])}, where, sort, top")
    if path is not None and not isinstance(path, str | os.PathLike):
        raise CatalogError(f"path must be a catalog file name or None (the built-in one), got {path!r}")
    for key, value in (("sides", sides), *setup.items()):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int | float)
                                  or not math.isfinite(value)):
            raise CatalogError(f"catalog filter {key} must be a finite number, got {value!r}")
    if sides is not None:  # a polygon is a whole number of sides (6.0 is 6; 6.5 and NaN are no polygon)
        if isinstance(sides, float) and sides.is_integer():
            sides = int(sides)
        sides = int(check("sides", sides, "catalog filter sides", error=CatalogError))
    with open_catalog(path) as cat:
        if sides is not None:
            require_polygon(cat, sides)
            setup["sides"] = sides
        if "depth" not in setup and (depth := default_depth(cat, sides)) is not None:
            setup["depth"] = depth
        rows = cat.pattern_rows(pictures=False, **setup)  # setup: checked keys of KEY above
        if not rows and setup:
            raise CatalogError(no_match_message(cat, setup))
        fields = cat.number_columns()
        found = find_rows(rows, fields, where=where, sort=sort, top=top)
        if rows and not found:  # as for a polygon or set-up above: no empty answer taken for an empty catalog
            raise CatalogError(no_filter_match_message(rows, fields, where))
        return CatalogRows(found, source=cat.path.name)


def no_filter_match_message(rows: Sequence[Mapping[str, object]], fields: Sequence[str],
                            where: Sequence[str] | str) -> str:
    """Why the filters ``where`` (on the numeric ``fields``) kept none of ``rows``: the first filter that
    keeps none on its own, with its field's range over the rows, or that they hold together for none."""
    filters = [where] if isinstance(where, str) else list(where)
    for text in filters:
        cond = parse_condition(text, fields)
        values = [as_float(v) for r in rows if (v := r.get(cond.field)) is not None]
        if not any(cond.holds(r) for r in rows):
            span = f"{min(values):.6g} … {max(values):.6g}" if values else "no values"
            return (f"no pattern meets the filter {text!r}: {cond.field} spans {span} over the {len(rows)} "
                    f"patterns of this polygon and set-up")
    return (f"no pattern meets all the filters {' and '.join(repr(t) for t in filters)} together (each alone "
            f"keeps some of the {len(rows)} patterns of this polygon and set-up)")


def require_polygon(cat: Catalog, sides: int) -> None:
    """:class:`CatalogError` (:func:`missing_polygon_message`) if ``cat`` holds no pattern of ``sides``."""
    if not cat.query("SELECT 1 FROM patterns WHERE sides = ? LIMIT 1", (sides,)):
        raise CatalogError(missing_polygon_message(cat, sides))


def no_match_message(cat: Catalog, setup: dict[str, object]) -> str:
    """Why a filter found no rows: the filter, and the set-ups the catalog does hold (:func:`held_setups`),
    so an empty answer is never mistaken for an empty catalog."""
    asked = " ".join(f"{k}={v}" for k, v in setup.items())
    return f"no patterns with {asked} in {cat.path}; it holds {held_setups(cat)}"
