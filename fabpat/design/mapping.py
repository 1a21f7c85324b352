"""The design loop's first stage: the elastica designs, the assembly solver checks, the elastica learns.

One round (output space mapping, :mod:`fabpat.design.beam`):

1. **Design on the model**: the log-stiffness u* per column whose elastica (with the corrections δ
   learnt so far) passes through the target (:func:`fabpat.design.beam.fit_stiffness`).
2. **Choose patterns**: per column the candidate whose catalog log-stiffness log(1 / U_cylinder) is
   nearest u* − δ (within ``max_distinct``: :func:`fabpat.design.strip.assign`'s grouping).
3. **Solve** that strip with the shell solver (one full assembly solve).
4. **Identify**: the u per column whose elastica passes through the solve's mid-line; δ = that u minus
   the chosen patterns' catalog values (what the catalog's Cylinder energy misses about a pattern in
   that column of this strip: its neighbours, the sleeves, the pins).

Before the first round the ends' rotational spring is fitted to the single-pattern baseline's solve
(a uniform strip: only the spring shapes it). The loop stops when a round proposes a strip already
solved, or the budget is spent, or the elastica cannot follow the target or a solve's mid-line (its
Newton iteration fails, as for an arch whose first columns turn against the thrust's moment): the
pattern search (:mod:`fabpat.design.search`) then goes on from the solves made.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fabpat.design.beam import Elastica, fit_spring, fit_stiffness
from fabpat.design.search import Evaluated, Search
from fabpat.design.strip import _pick
from fabpat.errors import SolverError

Arr = NDArray[np.float64]

#: how far (log-stiffness) the identified u of a column may leave the catalog's range: a pattern in a
#: strip may act a little stiffer or softer than any Cylinder energy says
IDENTIFY_MARGIN = 2.0


def _midline(ev: Evaluated, span: float) -> tuple[Arr, Arr]:
    x, z = np.asarray(ev.data["x"]), np.asarray(ev.data["z"])
    keep = (x >= 0.0) & (x <= span)
    return x[keep], z[keep]


def space_mapping(search: Search, beam: Elastica, single: Evaluated, span: float, budget: int) -> Elastica:
    """Rounds of the module doc from the single-pattern solve ``single`` until a round repeats a strip
    or ``budget`` solves are spent; the solves go into ``search`` (its ``best`` is the result). Returns
    the calibrated elastica."""
    u_cat = search.log_s - search.log_s[single.key[0]]  # ascending; the single pattern is u = 0
    xs, zs = _midline(single, span)
    beam = fit_spring(beam, np.zeros(search.columns), span, xs, zs)
    try:
        _rounds(search, beam, span, budget, u_cat)
    except SolverError:  # the reduced model lost the target (module doc): the search takes over
        pass
    return beam


def _rounds(search: Search, beam: Elastica, span: float, budget: int, u_cat: Arr) -> None:
    """The rounds of :func:`space_mapping` with the calibrated ``beam``; raises SolverError when the
    elastica cannot be solved for a stiffness it is asked about."""
    lo, hi = float(u_cat[0]), float(u_cat[-1])
    n = search.columns
    delta = np.zeros(n)
    prior = np.zeros(n)
    while search.runner.solves < budget:
        u_star = fit_stiffness(beam, span, search.target_x, search.target_z, prior + delta, lo + delta, hi + delta)
        key = tuple(int(i) for i in _pick(np.clip(u_star - delta, lo, hi), u_cat, search.max_distinct))
        if key in search.seen:
            return
        ev = search.evaluate([key])[0]
        if ev is None:
            return
        xs, zs = _midline(ev, span)
        chosen = u_cat[list(key)]
        a = fit_stiffness(beam, span, xs, zs, chosen + delta, lo + delta - IDENTIFY_MARGIN,
                          hi + delta + IDENTIFY_MARGIN)
        delta = a - chosen
        prior = u_star - delta
