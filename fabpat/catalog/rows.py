"""Catalog rows as Python sees them: checks of stored values, the stiffness-per-mass column, finding rows
(filters, sort, top N) and showing them (a short ``repr``, a notebook table).

Plain functions of the row dicts of :meth:`fabpat.catalog.Catalog.pattern_rows` (and
:meth:`~fabpat.catalog.Catalog.results`); :mod:`fabpat.catalog.store` and :mod:`fabpat.catalog.read`
apply them, nothing here opens a file (only :mod:`fabpat.catalog.schema` is below this module). A
filter is parsed here into a :class:`Condition` and applied in Python: user text never reaches SQL.
"""

from __future__ import annotations

import html
import math
import operator
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeGuard

from fabpat.catalog.schema import CatalogError
from fabpat.validate import as_float

_POLYGONS = {3: "triangles", 4: "squares", 5: "pentagons", 6: "hexagons", 7: "heptagons", 8: "octagons",
             9: "nonagons", 10: "decagons", 12: "dodecagons"}
#: rows shown by a notebook's table of :class:`CatalogRows`
HTML_ROWS = 10


def _error(message: str) -> Exception:
    return CatalogError(message)


def polygon_name(sides: int) -> str:
    """The plural name of a regular polygon: 5 → ``"pentagons"``, 13 → ``"13-gons"``."""
    return _POLYGONS.get(sides, f"{sides}-gons")


# -- stored values are checked as strictly as typed ones ------------------------------------------------

#: result columns that must be finite numbers where not NULL (energy and displacement have stricter rules)
RESULT_NUMBERS = ("E", "nu", "h", "h_fine", "seconds", "iterations", "nodes", "elements")


def _finite(value: object) -> TypeGuard[int | float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


#: N·mm: the largest energy a stored result may hold. The scenarios' loads are fixed (a 1.5 N force,
#: moments of 50 and 100 N·mm per interface) and a solve moves at most twice the plate's diameter
#: (fabpat.simulation.scenarios.check_plausible), so even 64 interfaces turning ten full turns under
#: 100 N·mm store 64 × 100 × 20π ≈ 4e5 N·mm; the built-in catalog's largest is 1 206 N·mm (a family member)
MAX_ENERGY = 1e6
#: a stored displacement may be at most this many times the polygon's diameter (edge / sin(π/n)): the
#: solver's own bound for a nonlinear solve (fabpat.simulation.scenarios.check_plausible)
MAX_DISPLACEMENT_PER_DIAMETER = 2.0


def _diameter(r: Mapping[str, object]) -> float | None:
    """The diameter (mm) of the row's polygon, edge / sin(π/n), or None if its key is not sound."""
    n, edge = r.get("sides"), r.get("edge")
    if not (isinstance(n, int) and not isinstance(n, bool) and n >= 3 and _finite(edge) and edge > 0):
        return None
    return float(edge) / math.sin(math.pi / n)


def result_problem(r: Mapping[str, object]) -> str | None:
    """What is wrong with a stored ``results`` row, or None: ``converged`` must be 0 or 1, ``energy``
    (N·mm) a finite, positive number (present in a converged row) up to :data:`MAX_ENERGY`,
    ``max_displacement`` (mm) finite, ≥ 0 and at most :data:`MAX_DISPLACEMENT_PER_DIAMETER` × the polygon's
    diameter (plausibility: an energy of 1e308 or a displacement of 1e300 mm was listed as a result), the
    numbers of :data:`RESULT_NUMBERS` finite. (SQLite stores a NaN as NULL.)"""
    conv, e, d = r.get("converged"), r.get("energy"), r.get("max_displacement")
    if conv not in (0, 1):
        return f"converged = {conv!r} (must be 0 or 1)"
    if e is None:
        if conv == 1:
            return "energy = NULL in a converged row (must be a finite, positive number of N·mm)"
    elif not (_finite(e) and e > 0):
        return f"energy = {e!r} (must be a finite, positive number of N·mm)"
    elif e > MAX_ENERGY:
        return (f"energy = {e!r} (implausible: the scenarios' fixed loads store at most {MAX_ENERGY:g} N·mm in any "
                "plate)")
    if d is not None and not (_finite(d) and d >= 0):
        return f"max_displacement = {d!r} (must be a finite number ≥ 0 of mm)"
    size = _diameter(r)
    if _finite(d) and size is not None and d > MAX_DISPLACEMENT_PER_DIAMETER * size:  # d: None or finite here
        return (f"max_displacement = {d!r} (implausible: a solve moves a plate at most "
                f"{MAX_DISPLACEMENT_PER_DIAMETER:g} × its diameter, {MAX_DISPLACEMENT_PER_DIAMETER * size:.4g} mm)")
    for c in RESULT_NUMBERS:
        v = r.get(c)
        if v is not None and not _finite(v):
            return f"{c} = {v!r} (must be a finite number)"
    return None


def pattern_problem(r: Mapping[str, object], columns: Iterable[str] = ()) -> str | None:
    """What is wrong with the key of a stored row, or None: ``sides`` an integer ≥ 3, ``depth`` ≥ 1,
    ``edge``, ``thickness``, ``weight`` (and each of ``columns`` present, e.g. the metrics in mm, mm²,
    mm⁴) finite and positive."""
    for c, low in (("sides", 3), ("depth", 1)):
        v = r.get(c, low)
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= low):
            return f"{c} = {v!r} (must be an integer ≥ {low})"
    for c in ("edge", "thickness", "weight", *columns):
        v = r.get(c)
        if v is not None and not (_finite(v) and v > 0):
            return f"{c} = {v!r} (must be a finite, positive number)"
    return None


def stored_error(path: object, r: Mapping[str, object], problem: str) -> Exception:
    """The :class:`~fabpat.catalog.CatalogError` for a bad stored row: one line naming the catalog, the
    pattern, the scenario and the value (``problem``: :func:`result_problem`, :func:`pattern_problem`)."""
    where = f"pattern {' '.join(str(r.get('id')).split())[:40]}"
    if r.get("scenario") is not None:
        where += f", scenario {' '.join(str(r['scenario']).split())[:40]}"
    return _error(f"catalog {path} holds a bad value at {where}: {problem}; the file was edited or damaged: "
                        "re-run the sweep that made it (`fabpat sweep --db FILE` with its options recomputes "
                        "such rows) or give another --db")


def check_row(path: object, r: Mapping[str, object], columns: Iterable[str] = ()) -> None:
    """Raise :func:`stored_error` for a bad stored row of catalog ``path``: a results row (one with a
    ``scenario``) by :func:`result_problem`, every row's key and ``columns`` by :func:`pattern_problem`."""
    problem = (result_problem(r) if "scenario" in r else None) or pattern_problem(r, columns)
    if problem:
        raise stored_error(path, r, problem)


def stored_float(value: object) -> float | None:
    """A stored number (a row checked by :func:`check_row`) as a float
    (:func:`fabpat.validate.as_float`); NULL stays None."""
    return None if value is None else as_float(value)


def specific_stiffness(energy: float | None, filleted_area: float | None) -> float | None:
    """Stiffness per mass of a plate in one scenario, in 1/(N·mm³): ``1 / (energy × filleted_area)``
    (energy N·mm, filleted area mm²); None if either is missing. The column ``specific_stiffness_<s>``.

    Why this is stiffness per mass: every scenario puts one fixed load P on every pattern, and by
    Clapeyron's theorem a linear plate under it stores U = P²/(2k) (k its stiffness), so k ∝ 1/U; the
    plate's mass is ρ·t·A (density ρ, thickness t, filleted area A), with the same ρ and t for every row
    of a set-up. So 1/(U·A) = (k/m) · 2ρt/P²: larger = stiffer per gram. Exact for a linear response, a
    ranking by the secant stiffness for the nonlinear solves; compare rows of one scenario and one
    set-up only (P, t and ρ differ between them).
    """
    if energy is None or filleted_area is None:
        return None
    return 1.0 / (float(energy) * float(filleted_area))


# -- finding rows ---------------------------------------------------------------------------------------

#: the comparison operators of a filter
OPERATORS: dict[str, Callable[[float, float], bool]] = {
    "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "=": operator.eq, "!=": operator.ne}
_CONDITION = re.compile(r"\s*([A-Za-z_]\w*)\s*([<>=!~]+)\s*(.*?)\s*", re.DOTALL)


@dataclass(frozen=True)
class Condition:
    """One filter ``field op value`` on a numeric column (:func:`parse_condition`)."""

    field: str
    op: str
    value: float

    def holds(self, row: Mapping[str, object]) -> bool:
        """Whether ``row`` meets it; a row without a value in ``field`` never does."""
        v = row.get(self.field)
        return v is not None and OPERATORS[self.op](as_float(v), self.value)


_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)


def parse_condition(text: str, fields: Sequence[str]) -> Condition:
    """``"energy_dome<300"`` → :class:`Condition`: ``FIELD OP NUMBER``, spaces allowed, with FIELD one of
    ``fields``, OP one of ``< <= > >= = !=`` and NUMBER a finite number in the column's unit.
    Raises :class:`~fabpat.catalog.CatalogError` (one line listing the valid fields or operators)."""
    ops = " ".join(OPERATORS)
    m = _CONDITION.fullmatch(text) if isinstance(text, str) else None
    if m is None:
        raise _error(f"filter {text!r} is not FIELD OP NUMBER (such as 'energy_dome<300'), OP one of {ops}")
    field, op, number = m.groups()
    if field not in fields:
        raise _error(f"filter {text!r}: unknown field {field!r}; the numeric fields are {describe_fields(fields)}")
    if op not in OPERATORS:
        raise _error(f"filter {text!r}: unknown operator {op!r}; use one of {ops}")
    try:  # float() also takes "1_000" and non-ASCII digits; a filter is plain ASCII decimal notation
        value = float(number) if _NUMBER.fullmatch(number.strip()) else math.nan
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise _error(f"filter {text!r}: {number!r} is not a finite number in plain decimal notation (such as 300, "
                     "2.5 or 1e3)")
    return Condition(field, op, value)


#: per-scenario columns, ``PREFIX_SCENARIO``: listed once per prefix in a message (:func:`describe_fields`)
SCENARIO_PREFIXES = ("energy", "max_displacement", "specific_stiffness")
#: the text column rows can be sorted by (pattern IDs, as text): every row has one
TEXT_SORT = "id"


def describe_fields(fields: Sequence[str]) -> str:
    """``fields`` for a one-line message, short: the per-scenario columns (``energy_dome``, …) as
    ``energy_S, max_displacement_S, specific_stiffness_S (S: cantilever, cylinder, dome)``, the others
    by name (23 names of ~400 characters made a message that wrapped over several lines)."""
    scenarios: dict[str, None] = {}
    plain = []
    for f in fields:
        prefix = next((p for p in SCENARIO_PREFIXES if f.startswith(p + "_")), None)
        if prefix is None:
            plain.append(f)
        else:
            scenarios[f.removeprefix(prefix + "_")] = None
    if scenarios:
        plain.append(", ".join(f"{p}_S" for p in SCENARIO_PREFIXES) + f" (S: {', '.join(scenarios)})")
    return ", ".join(plain)


def parse_sort(text: str, fields: Sequence[str]) -> tuple[str, bool]:
    """``"FIELD"`` → (FIELD, False) ascending, ``"-FIELD"`` → (FIELD, True) descending; FIELD one of
    ``fields`` or ``"id"`` (pattern IDs as text), spelt exactly (no spaces), else
    :class:`~fabpat.catalog.CatalogError` listing them (:func:`describe_fields`)."""
    if not isinstance(text, str):
        raise _error(f"sort field must be a column name such as 'energy_dome' or '-energy_dome', got {text!r}")
    descending = text.startswith("-")
    name = text.removeprefix("-")
    if name not in (TEXT_SORT, *fields):
        shown = text if len(text) <= 40 else text[:40] + "…"
        bare = text.strip().removeprefix("-").strip()
        hint = "; no spaces around the name" if bare in (TEXT_SORT, *fields) else ""
        raise _error(f"cannot sort by {shown!r}{hint}: FIELD sorts ascending, -FIELD descending, FIELD one of "
                     f"{describe_fields([TEXT_SORT, *fields])}")
    return name, descending


def find_rows(rows: Iterable[dict[str, object]], fields: Sequence[str], *, where: Iterable[str] | str = (),
              sort: str | None = None, top: int | None = None) -> list[dict[str, object]]:
    """The rows meeting every ``where`` filter (all of them), sorted by ``sort``, the first ``top``.

    ``fields``: the numeric columns filters and the sort may name
    (:meth:`fabpat.catalog.Catalog.number_columns`); ``where``: ``"FIELD OP NUMBER"`` strings
    (:func:`parse_condition`); ``sort``: ``"FIELD"`` ascending or ``"-FIELD"`` descending, rows without
    a value last, ties in the rows' order (by ID); ``top``: a positive integer. Raises
    :class:`~fabpat.catalog.CatalogError` for a bad filter, sort field or ``top``.
    """
    if not isinstance(where, str | Iterable):
        raise _error(f"where must be a filter 'FIELD OP NUMBER' or a list of them, got {where!r}")
    conditions = [parse_condition(w, fields) for w in ([where] if isinstance(where, str) else where)]
    order = parse_sort(sort, fields) if sort is not None else None
    if top is not None and (isinstance(top, bool) or not isinstance(top, int) or top < 1):
        raise _error(f"top must be a positive integer (how many rows to keep), got {top!r}")
    out = [r for r in rows if all(c.holds(r) for c in conditions)]
    if order is not None:
        name, descending = order
        valued = [(v, r) for r in out if (v := r.get(name)) is not None]
        # stable: ties keep the rows' order either way
        if name == TEXT_SORT:
            valued.sort(key=lambda vr: str(vr[0]), reverse=descending)
        else:
            valued.sort(key=lambda vr: as_float(vr[0]), reverse=descending)
        out = [r for _, r in valued] + [r for r in out if r.get(name) is None]
    return out if top is None else out[:top]


# -- showing rows ---------------------------------------------------------------------------------------


def _cell(v: object) -> str:
    return "" if v is None else f"{v:.6g}" if isinstance(v, float) else str(v)


class CatalogRows(list[dict[str, object]]):
    """The rows of :func:`fabpat.catalog.catalog`: a list of dicts (one per pattern), plus
    :meth:`to_dataframe`, a short ``repr`` (count, set-ups, columns) and a notebook table of the first
    :data:`HTML_ROWS` rows. ``source``: the catalog file the rows come from."""

    def __init__(self, rows: Iterable[dict[str, object]] = (), source: str | None = None) -> None:
        super().__init__(rows)
        self.source = source

    def columns(self) -> list[str]:
        """Column names, in the rows' order (the first row's, then any only later rows have)."""
        return list(dict.fromkeys(k for r in self for k in r))

    def setups(self) -> list[str]:
        """The distinct set-ups of the rows, as ``"sides=6 depth=2 edge=36 mm thickness=2 mm weight=0.2"``."""
        keys = dict.fromkeys(tuple(r.get(k) for k in ("sides", "depth", "edge", "thickness", "weight")) for r in self)
        return [f"sides={s!s} depth={d!s} edge={_cell(e)} mm thickness={_cell(t)} mm weight={_cell(w)}"
                for s, d, e, t, w in keys]

    def __repr__(self) -> str:
        setups = self.setups()
        shown = "; ".join(setups[:3]) + (f"; and {len(setups) - 3} more set-ups" if len(setups) > 3 else "")
        cols = self.columns()
        source = f" from {self.source}" if self.source else ""
        return (f"<CatalogRows: {len(self)} patterns{source}" + (f"; {shown}" if shown else "")
                + f"; {len(cols)} columns: {', '.join(cols)}>")

    def _table_columns(self) -> list[str]:
        cols = self.columns()
        keep = ["id", *(["sides", "depth", "edge", "thickness", "weight"] if len(self.setups()) > 1 else []),
                "filleted_area", "min_width"]
        keep += [c for c in cols if c.startswith(("energy_", "specific_stiffness_"))]
        return [c for c in keep if c in cols]

    def _repr_html_(self) -> str:
        """A table of the first :data:`HTML_ROWS` rows (Jupyter shows it instead of the list)."""
        cols = self._table_columns()
        head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(_cell(r.get(c)))}</td>" for c in cols) + "</tr>"
                       for r in self[:HTML_ROWS])
        more = f"first {min(len(self), HTML_ROWS)} of " if len(self) > HTML_ROWS else ""
        caption = (f"{more}{len(self)} patterns" + (f" from {self.source}" if self.source else "")
                   + f"; {len(self.columns())} columns in all (rows.to_dataframe() has every one)")
        return (f"<table><caption>{html.escape(caption)}</caption><thead><tr>{head}</tr></thead>"
                f"<tbody>{body}</tbody></table>")

    def to_dataframe(self) -> Any:
        """A pandas ``DataFrame`` of the rows, indexed by pattern ID. Needs pandas
        (``pip install 'fabpat[pandas]'``); raises :class:`~fabpat.catalog.CatalogError` without it."""
        try:
            import pandas as pd
        except ImportError:
            raise _error("to_dataframe needs pandas: pip install 'fabpat[pandas]'") from None
        frame = pd.DataFrame(list(self), columns=self.columns() or None)
        return frame.set_index("id", drop=False) if "id" in frame.columns else frame
