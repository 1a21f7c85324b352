"""Family members as candidates: their names, their catalog rows, and a spec whose plates are them.

One code path for every choice that may take a family member (:mod:`fabpat.patterns.variation`) instead of a
catalog pattern: the strip design and the closed-tiling design (:mod:`fabpat.design`) and the sphere's
``rule = "roundest"`` with ``bridge_weight = "rule"`` (:mod:`fabpat.assembly.kit.build`).

* A candidate's **name** is the pattern ID, and for a member other than the paper's `` bW`` with
  ``W = Variation(w).tag()`` (``"0x0488 b0.63"``: pattern 0x0488 at ``bridge_weight`` 0.63, as the kit
  labels its parts): :func:`member_token`, :func:`split_member`.
* The candidates are the **swept members** of the catalog's ``family`` table (``fabpat sweep --family``),
  whose energies are solves, not interpolations: :func:`member_rows` gives one row per member in the
  columns of :func:`fabpat.catalog.catalog` (``energy_<scenario>``, ``converged_<scenario>``,
  ``min_width``, ``filleted_ratio``), so a caller treats a member as one more pattern.
* A polygon whose catalog holds no family rows (the built-in catalog's pentagons until ``fabpat sweep
  --sides 5 --family`` has run) gets no members, and :func:`member_rows` says so in one line.
* :func:`with_candidates` turns a tuple of names, one per face, into the spec that builds them (each
  plate's member in ``[patterns] bridge_weight``) and the plain pattern IDs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fabpat.catalog import DEFAULT_SETUP, Catalog, open_catalog
from fabpat.errors import CatalogError
from fabpat.patterns.variation import Variation

if TYPE_CHECKING:
    from fabpat.assembly.spec.types import AssemblySpec

#: the scenarios a member row carries (the catalog's)
SCENARIOS = ("cantilever", "cylinder", "dome")


def member_token(pattern_id: str, bridge_weight: float) -> str:
    """A candidate's name: the pattern ID, and `` bW`` for a family member other than the paper's."""
    tag = Variation(bridge_weight).tag()
    return f"{pattern_id} {tag}" if tag else pattern_id


def split_member(token: str) -> tuple[str, float]:
    """(pattern ID, bridge_weight) of a candidate name (:func:`member_token`)."""
    pid, _, w = token.partition(" b")
    return pid, float(w) if w else 1.0


def pattern_of(token: str) -> str:
    """The pattern ID of a candidate name (``"0x0488 b0.63"`` → ``"0x0488"``)."""
    return split_member(token)[0]


def _setup(cat: Catalog, sides: int, asked: dict[str, float]) -> dict[str, float]:
    """The set-up whose family rows go with the paper's energies: the one asked for when the catalog holds
    results of ``sides`` there, else the default one (as :func:`fabpat.catalog.polygon_energies`)."""
    held = cat.query("SELECT 1 FROM results WHERE sides = ? AND depth = ? AND edge = ? AND thickness = ? AND "
                     "weight = ? LIMIT 1", (sides, asked["depth"], asked["edge"], asked["thickness"], asked["weight"]))
    return asked if held else {k: float(DEFAULT_SETUP[k]) for k in asked}


def member_rows(db: str | Path | None, sides: int, ids: Iterable[str], *, min_width: float = 0.0,
                depth: int = 2, edge: float = 36.0, thickness: float = 2.0,
                weight: float = 0.2) -> tuple[list[dict[str, Any]], str | None]:
    """The swept family members of the patterns ``ids`` on ``sides``-gons, and a note (None if there is
    nothing to say).

    One row per member (``bridge_weight`` ≠ 1) of the catalog ``db`` (None: the built-in one) at the
    plate set-up asked for (depth, edge mm, thickness mm, weight) when the catalog holds results of that
    polygon there, else at the default one (the paper's energies come from the same set-up): ``id`` the
    member's name (:func:`member_token`), ``pattern``, ``bridge_weight``, per scenario of the member's rows
    ``energy_<scenario>`` (N·mm, a solve) and ``converged_<scenario>`` (0 or 1), ``min_width`` (mm) and
    ``filleted_area`` (mm²) of the member, and ``filleted_ratio`` = 4π·area / perimeter² with the perimeter
    of the paper's member (the family table stores no perimeter; over 0.25 … 2.5 the perimeter of 0x0488
    moves by −4.5 % … +4.1 %, and on 10 random hexagon patterns and 0x0488, 58 members, this ratio is within
    15 % of the member's own, 9 % for 0x0488: it only places the member among the candidates,
    :func:`fabpat.design.closed.pattern_features`). Members narrower than
    ``min_width`` mm are left out. The note names what is missing when the catalog holds no family rows
    for this polygon: its candidates are then the paper's members only. Raises CatalogError for a catalog
    that cannot be read.
    """
    keep = set(ids)
    asked = {"depth": depth, "edge": float(edge), "thickness": float(thickness), "weight": float(weight)}
    with open_catalog(db) as cat:
        setup = _setup(cat, sides, asked)
        rows = cat.family(None, sides=sides, **setup)
        paper = {str(r["id"]): r for r in cat.pattern_rows(pictures=False, sides=sides, **setup)} if rows else {}
        source = "the built-in catalog" if db is None else str(cat.path)
    if not rows:
        return [], (f"{source} has no family rows for {sides}-sided plates (`fabpat sweep --sides {sides} --family` "
                    f"adds them): their candidates are the paper's members only")
    out: dict[tuple[str, float], dict[str, Any]] = {}
    for r in rows:
        pid, bw = str(r["id"]), r["bridge_weight"]
        if isinstance(bw, bool) or not isinstance(bw, int | float):
            raise CatalogError(f"{source}: the family row of {pid} has bridge_weight = {bw!r}, not a number")
        w = float(bw)
        if pid not in keep or w == 1.0:
            continue
        row = out.setdefault((pid, w), {"id": member_token(pid, w), "pattern": pid, "sides": sides,
                                        "bridge_weight": w, "min_width": r["min_width"],
                                        "filleted_area": r["filleted_area"]})
        sc = str(r["scenario"])
        row[f"energy_{sc}"] = r["energy"] if r["converged"] else None
        row[f"converged_{sc}"] = int(bool(r["converged"]) and r["energy"] is not None)
    for (pid, _), row in out.items():
        row["filleted_ratio"] = _ratio(row.get("filleted_area"), paper.get(pid))
    found = [r for r in out.values() if (r["min_width"] or 0.0) >= min_width]
    return sorted(found, key=lambda r: (r["pattern"], r["bridge_weight"])), None


def _ratio(area: float | None, paper: dict[str, object] | None) -> float | None:
    """4π·area / P² with P the paper member's filleted perimeter (mm); None if either is unknown."""
    p = None if paper is None else paper.get("filleted_perimeter")
    if area is None or not isinstance(p, int | float) or not p:
        return None
    return 4.0 * math.pi * float(area) / float(p) ** 2


def member_energies(rows: Sequence[dict[str, Any]], scenario: str) -> dict[str, float]:
    """{member name: energy (N·mm)} of the rows of :func:`member_rows` converged in ``scenario``."""
    return {r["id"]: float(r[f"energy_{scenario}"]) for r in rows
            if r.get(f"converged_{scenario}") and r.get(f"energy_{scenario}")}


def with_candidates(spec: AssemblySpec, candidates: Sequence[str]) -> tuple[AssemblySpec, list[str]]:
    """The spec whose plates are the family members the candidate names say (one per face, in face order;
    :func:`split_member`) and the plain pattern IDs per face; the spec itself when every name is a
    paper's member."""
    from fabpat.assembly.spec.load import PatternSpec

    pairs = [split_member(c) for c in candidates]
    ids, weights = [p for p, _ in pairs], tuple(w for _, w in pairs)
    if all(w == 1.0 for w in weights):
        return spec, ids
    patterns = spec.patterns if spec.patterns is not None else PatternSpec(pattern=ids[0])
    return dataclasses.replace(spec, patterns=dataclasses.replace(patterns, bridge_weights=weights)), ids
