"""Active learning: which deeper patterns to simulate next (``fabpat sweep --depth 3 --learn N``).

Depth 3 has far too many patterns to simulate (``fabpat library --depth 3 --count``), and a random sample
mostly repeats the middle of the stiffness range that depth 2 already covers. :func:`choose` ranks a seeded
pool of uniformly drawn patterns with the learned response (:mod:`fabpat.catalog.response`) and picks the
ones that may widen the catalog's Cylinder-energy range at a printable width:

* printable: a predicted ``min_width`` at least the depth-2 catalog's smallest (the narrowest neck already
  judged printable);
* not yet in the catalog;
* then alternately the pattern whose interval reaches lowest (may be stiffer than any so far) and the one
  whose interval reaches highest (may be softer): optimism under uncertainty, so a pattern the model knows
  little about is tried before one it confidently places in the middle (the upper-confidence-bound rule of
  Auer, Cesa-Bianchi and Fischer, Machine Learning 47, 2002).

The choice depends only on the pool's seed and the model, so an interrupted ``--learn`` run chooses the
same patterns again and the sweep resumes; the sweep refits the model once all are stored.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fabpat.catalog.response import Response, load_responses, response, response_path
from fabpat.catalog.store import open_catalog
from fabpat.catalog.version import solver_version
from fabpat.errors import CatalogError

#: the scenario whose range the learning widens (the strip designs' stiffness: docs/design.md)
SCENARIO = "energy_cylinder"


def model_for(db: str | Path, sides: int) -> Response:
    """The catalog's own learned response for the polygon if it has a current one, else the built-in one."""
    try:
        own = load_responses(response_path(db)).get(sides)
    except CatalogError:
        own = None
    if own is not None and own.solver_version == solver_version():
        return own
    return response(sides)


def printable_floor(sides: int) -> float:
    """The built-in depth-2 catalog's smallest ``min_width`` of the polygon (mm)."""
    with open_catalog(None) as cat:
        rows = cat.query("SELECT MIN(min_width) AS w FROM patterns WHERE sides = ? AND depth = 2", (sides,))
    w = rows[0]["w"] if rows else None
    if w is None:
        raise CatalogError(f"the built-in catalog has no depth-2 patterns of the {sides}-gon to judge printability by")
    return float(str(w))


def choose(db: str | Path, sides: int, pool: Sequence[str], count: int) -> list[str]:
    """Up to ``count`` IDs of ``pool`` to simulate next (see the module doc), in the order chosen.

    Raises :class:`~fabpat.errors.CatalogError` if no learned response can rank them."""
    model = model_for(db, sides)
    held: set[str] = set()
    if Path(db).exists():
        with open_catalog(db) as cat:
            held = {str(r["id"]) for r in cat.query("SELECT id FROM patterns WHERE sides = ?", (sides,))}
    candidates = [i for i in pool if i not in held]
    if not candidates:
        return []
    pred = model.predict(candidates, extrapolate=True)  # a depth-2 model still orders the first picks
    ok = np.nonzero(pred.values["min_width"] >= printable_floor(sides))[0]
    low = pred.intervals[SCENARIO][ok, 0]
    high = pred.intervals[SCENARIO][ok, 1]
    by_low, by_high = ok[np.argsort(low, kind="stable")], ok[np.argsort(-high, kind="stable")]
    out: list[str] = []
    seen: set[int] = set()
    a = b = 0
    while len(out) < count and (a < len(by_low) or b < len(by_high)):
        for order, k in ((by_low, a), (by_high, b)):
            while k < len(order) and int(order[k]) in seen:
                k += 1
            if k < len(order) and len(out) < count:
                seen.add(int(order[k]))
                out.append(pred.ids[int(order[k])])
                k += 1
            if order is by_low:
                a = k
            else:
                b = k
    return out
