"""Active learning: which deeper patterns to simulate next (``fabpat sweep --depth 3 --learn N``).

Depth 3 has far too many patterns to simulate (``fabpat library --depth 3 --count``), and a random sample
mostly repeats the middle of the stiffness range that depth 2 already covers. :func:`choose` ranks a seeded
pool of uniformly drawn patterns with the learned response (:mod:`fabpat.catalog.response`) and picks the
ones that may widen the catalog's Cylinder-energy range at a printable width:

* not among the patterns the model was fitted to;
* alternately the pattern whose interval reaches lowest (may be stiffer than any so far) and the one
  whose interval reaches highest (may be softer): optimism under uncertainty, so a pattern the model knows
  little about is tried before one it confidently places in the middle (the upper-confidence-bound rule of
  Auer, Cesa-Bianchi and Fischer, Machine Learning 47, 2002);
* printable: its exact ``min_width`` (a fillet, no solve) at least the print limit, 0.8 mm.

The choice depends only on the pool's seed and the model, so an interrupted ``--learn`` run chooses the
same patterns again and the sweep resumes; the sweep refits the model once all are stored.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fabpat.catalog.response import Response
from fabpat.catalog.response_file import load_responses, response, response_path
from fabpat.catalog.version import solver_version
from fabpat.validate import RANGES, Range

#: the scenario whose range the learning widens (the strip designs' stiffness: docs/design.md)
SCENARIO = "energy_cylinder"

#: ``fabpat sweep --learn N``: 1 … 100 000 patterns (a depth-3 pattern's three scenarios take 5–15 s on 2 cores:
#: 100 000 is a fortnight; beyond that the count is a typo), checked by :func:`fabpat.validate.check`
RANGES.setdefault("learn", Range("learn", 1, 100_000, integer=True,
                                 why="depth-3 patterns a --learn sweep simulates; each takes 5–15 s on 2 cores"))


def model_for(db: str | Path, sides: int) -> Response:
    """The catalog's own learned response for the polygon if it has a current one, else the built-in one.
    A damaged response file beside the catalog is a CatalogError (not silently passed over)."""
    path = response_path(db)
    own = load_responses(path).get(sides) if path.exists() else None
    if own is not None and own.solver_version == solver_version():
        return own
    return response(sides)


def printable_floor() -> float:
    """The narrowest feature counted as printable (mm): the exporters' print limit, two perimeters of a 0.4 mm
    nozzle (:data:`fabpat.exchange.registry.PRINT_MIN_WIDTH`). Not the depth-2 catalog's narrowest neck
    (1.95 mm for hexagons of 36 mm): every depth-3 pattern with a bridged joint has necks of half that (0.98 mm),
    as its sub-triangles are half the size (docs/learned-response.md)."""
    from fabpat.exchange.registry import PRINT_MIN_WIDTH

    return float(PRINT_MIN_WIDTH)


def exact_min_width(pattern_id: str, sides: int) -> float:
    """The filleted outline's narrowest feature (mm) at the catalog's default set-up: a fillet, no solve
    (about 0.05 s for a depth-3 pattern)."""
    from fabpat.catalog.schema import DEFAULT_SETUP
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.lattice import depth_of_id
    from fabpat.patterns.library import get_pattern

    p = get_pattern(pattern_id, sides, depth_of_id(pattern_id), float(str(DEFAULT_SETUP["edge"])))
    return float(str(fillet_pattern(p, float(str(DEFAULT_SETUP["weight"]))).catalog_columns()["min_width"]))


#: how many candidates per pattern chosen :func:`choose` may fillet to find printable ones
FILLETS_PER_CHOICE = 20


def choose(db: str | Path, sides: int, pool: Sequence[str], count: int) -> list[str]:
    """Up to ``count`` IDs of ``pool`` to simulate next (see the module doc), in the order chosen.

    The candidates are the pool's patterns the model was not fitted to, ranked by the model; each in turn is
    filleted and kept if its exact ``min_width`` is at least :func:`printable_floor` (at most
    :data:`FILLETS_PER_CHOICE` × ``count`` fillets). The catalog's rows are not consulted, so a run that was
    interrupted chooses the same patterns again and the sweep skips those already stored. Raises
    :class:`~fabpat.errors.CatalogError` if no learned response can rank them."""
    model = model_for(db, sides)
    candidates = [i for i in dict.fromkeys(pool) if i not in model.ids]
    if not candidates or count < 1:
        return []
    pred = model.predict(candidates, extrapolate=True)  # a depth-2 model still orders the first picks
    by_low = np.argsort(pred.intervals[SCENARIO][:, 0], kind="stable")
    by_high = np.argsort(-pred.intervals[SCENARIO][:, 1], kind="stable")
    order = list(dict.fromkeys(int(k) for pair in zip(by_low, by_high, strict=True) for k in pair))
    floor = printable_floor()
    out: list[str] = []
    for k in order[: FILLETS_PER_CHOICE * count]:
        if exact_min_width(pred.ids[k], sides) >= floor:
            out.append(pred.ids[k])
            if len(out) == count:
                break
    return out
