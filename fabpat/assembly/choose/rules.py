"""Stiffness-based pattern choices (paper §5), as pure functions of ``{pattern ID: strain energy}``.

Every scenario applies the same load to every pattern, so a smaller strain energy (N·mm) means a
stiffer pattern. The catalog supplies the energies, each face's from the rows of its own polygon
(:func:`fabpat.catalog.polygon_energies`: a pentagon plate of a pattern is another plate than its
hexagon, with another energy); these functions only choose, so they are tested on small hand-made
dictionaries.

* :func:`graded` — ``count`` patterns with well-separated energies, ordered stiff → soft (the graded
  strip of Fig. 15 left: five patterns, Cylinder scenario).
* :func:`similar_pair` — a hexagon and a pentagon pattern with similar energies (the sphere of
  Fig. 15 right: two patterns, Dome scenario).
* :func:`similar_set` — the same for a tiling of any polygons (a mesh), one pattern per polygon.
* :func:`similar_pairs` — the ``count`` best such pairs, :func:`similar_pair`'s first, for
  ``rule = "roundest"`` (the closure solver keeps the roundest one under the strain limit). With
  ``bridge_weight = "rule"`` its pools also hold the catalog's swept family members, named ``"ID bW"``
  (:mod:`fabpat.assembly.choose.members`); a pair is always two different patterns, whatever their members.
* :func:`graded_targets` and :func:`nearest_member` — with ``bridge_weight = "rule"`` the rules also
  choose each pattern's family member (:mod:`fabpat.patterns.variation`) that hits its target energy, from the
  pattern's family curve (anything with ``range``, ``energy(w)`` and ``members_for(E)``, such as
  :class:`fabpat.catalog.family.FamilyCurve`), instead of settling for the nearest catalog energy.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Protocol

import numpy as np

from fabpat.assembly.choose.members import pattern_of
from fabpat.errors import SpecError


class MemberCurve(Protocol):
    """What the rules read of a pattern's family curve (:class:`fabpat.catalog.family.FamilyCurve`, or a test's)."""

    @property
    def range(self) -> tuple[float, float]:
        """(lowest, highest) bridge_weight the curve reaches."""

    def energy(self, bridge_weight: float) -> float:
        """The energy (N·mm) of the member ``bridge_weight``."""

    def members_for(self, energy: float) -> list[float]:
        """The members (bridge_weight) whose energy is ``energy`` (N·mm)."""


TRIM = 0.05  # fraction of the catalog ignored at each end: extreme energies are near-mechanisms or outliers
MIN_SEPARATION = 1.25  # smallest energy ratio between consecutive graded patterns called "well separated"


def _clean(energies: Mapping[str, float]) -> tuple[list[str], np.ndarray]:
    """IDs and log-energies of the finite, positive entries, sorted by energy then ID."""
    items = sorted(((float(e), str(k)) for k, e in energies.items() if e is not None and math.isfinite(e) and e > 0))
    return [k for _, k in items], np.log([e for e, _ in items])


def _max_min_gap(logs: np.ndarray, count: int) -> list[int]:
    """Indices of ``count`` sorted values whose smallest consecutive gap is as large as possible.

    Binary search on the gap; greedy from the smallest value decides feasibility (optimal in 1D).
    """
    def greedy(gap: float) -> list[int]:
        picks = [0]
        for i in range(1, len(logs)):
            if logs[i] - logs[picks[-1]] >= gap:
                picks.append(i)
        return picks

    lo, hi = 0.0, float(logs[-1] - logs[0]) / max(count - 1, 1)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if len(greedy(mid)) >= count else (lo, mid)
    return greedy(lo)[:count]


def graded(energies: Mapping[str, float], count: int, trim: float = TRIM,
           min_separation: float = MIN_SEPARATION) -> list[str]:
    """``count`` pattern IDs spread over the catalog's energies, stiff → soft (ascending energy).

    First choice: ``count`` equally spaced log-energies between the extremes (after dropping the
    ``trim`` fraction at each end, when that is at least one pattern), each taking the nearest
    unused pattern. If two consecutive picks then differ by less than ``min_separation`` ×, the
    picks that maximise the smallest ratio are used instead. Raises :class:`SpecError` if there are
    fewer than ``count`` usable patterns or even the best picks are closer than ``min_separation``.
    """
    ids, logs = _clean(energies)
    if count < 2:
        raise SpecError(f"a graded strip needs at least 2 patterns, got count = {count}")
    if len(ids) < count:
        raise SpecError(f"the catalog has {len(ids)} patterns with an energy, fewer than patterns.count = {count}")
    cut = int(trim * len(ids))
    if len(ids) - 2 * cut >= count and cut > 0:
        ids, logs = ids[cut:-cut], logs[cut:-cut]
    used: set[int] = set()
    picks = []
    for target in np.linspace(logs[0], logs[-1], count):
        order = np.argsort(np.abs(logs - target), kind="stable")
        k = next(int(i) for i in order if int(i) not in used)
        used.add(k)
        picks.append(k)
    picks.sort()
    if np.exp(np.diff(logs[picks])).min() < min_separation:
        picks = _max_min_gap(logs, count)
    ratio = float(np.exp(np.diff(logs[picks])).min())
    if ratio < min_separation:
        raise SpecError(f"the catalog's energies are too close for {count} well-separated patterns "
                        f"(best consecutive ratio {ratio:.2f} < {min_separation}); lower patterns.count")
    return [ids[i] for i in picks]


def graded_targets(energies: Mapping[str, float], count: int, trim: float = TRIM) -> list[float]:
    """The ``count`` target energies (N·mm) of :func:`graded`, stiff → soft: equally spaced in log between
    the extremes of the catalog's energies after dropping the ``trim`` fraction at each end (when that
    leaves at least ``count``). Raises :class:`SpecError` as :func:`graded`."""
    ids, logs = _clean(energies)
    if count < 2 or len(ids) < count:
        graded(energies, count, trim)  # raises the same message
    cut = int(trim * len(ids))
    if len(ids) - 2 * cut >= count and cut > 0:
        logs = logs[cut:-cut]
    return [float(np.exp(t)) for t in np.linspace(logs[0], logs[-1], count)]


def nearest_member(curve: MemberCurve, target: float) -> float:
    """The family member (bridge_weight) of ``curve`` whose energy is nearest ``target`` (N·mm): among
    those that hit it exactly, the one closest to the paper's 1 (smallest |ln w|); if the curve does not
    reach it, the end of its range nearer in energy. ``curve``: see the module notes."""
    exact = curve.members_for(target)
    if exact:
        return float(min(exact, key=lambda w: (abs(math.log(w)), w)))
    lo, hi = curve.range
    return float(min((lo, hi), key=lambda w: abs(math.log(curve.energy(w) / target))))


def graded_members(energies: Mapping[str, float], curves: Mapping[str, MemberCurve], count: int,
                   trim: float = TRIM) -> list[tuple[str, float]]:
    """``count`` (pattern ID, bridge_weight) pairs, stiff → soft, whose family energies are the targets of
    :func:`graded_targets` exactly where a family reaches them: for each target in turn, the unused
    pattern whose curve (``curves[ID]``, see the module notes) hits it with the member closest to the
    paper's (smallest |ln w|, then the smaller ID); where none reaches a target, the unused pattern and
    member nearest it in energy. Raises :class:`SpecError` as :func:`graded`."""
    targets = graded_targets(energies, count, trim)
    ids, _ = _clean(energies)
    used: set[str] = set()
    out = []
    for t in targets:
        exact = [(abs(math.log(w)), pid, w) for pid in ids if pid not in used and pid in curves
                 for w in curves[pid].members_for(t)]
        if exact:
            _, pid, w = min(exact)
        else:
            def miss(pid: str, t: float = t) -> tuple[float, str]:
                w = nearest_member(curves[pid], t)
                return abs(math.log(curves[pid].energy(w) / t)), pid

            pid = min((p for p in ids if p not in used and p in curves), key=miss)
            w = nearest_member(curves[pid], t)
        used.add(pid)
        out.append((pid, float(w)))
    return out


def separation(energies: Mapping[str, float], ids: list[str]) -> float:
    """Smallest ratio between consecutive energies of ``ids`` (≥ 1; larger = better separated)."""
    e = sorted(energies[i] for i in ids)
    return min(b / a for a, b in zip(e, e[1:], strict=False))


def _pentagon_pool(pentagon: Mapping[str, float] | None) -> dict[str, float]:
    if not pentagon:  # comparing with hexagon energies instead would pair the wrong plates, silently
        raise SpecError("the catalog has no pentagon energies to compare with the hexagons' (run `fabpat sweep "
                        "--sides 5` for the catalog)")
    return dict(pentagon)


def similar_pair(hexagon: Mapping[str, float], pentagon: Mapping[str, float],
                 quantile: float = 0.5) -> tuple[str, str]:
    """(hexagon ID, pentagon ID): two different patterns with similar energy, each on its own polygon.

    ``hexagon``: {ID: energy (N·mm)} of the hexagon plates, ``pentagon``: of the pentagon plates (the
    same scenario and set-up; a key may be a family member's name ``"ID bW"``,
    :mod:`fabpat.assembly.choose.members`). The
    hexagon pattern is the one nearest the ``quantile`` of the hexagon log-energies (the median: a
    typical stiffness, away from outliers); the pentagon pattern is the other pattern's entry whose
    *pentagon* energy is nearest its hexagon energy (never a member of the hexagon's own pattern). Ties
    go to the smaller ID, so the choice is reproducible. Raises :class:`SpecError` without two hexagon
    energies or without pentagon energies (never falls back to comparing hexagon energies).
    """
    ids, logs = _clean(hexagon)
    if len(ids) < 2:
        raise SpecError("the catalog needs at least two patterns with an energy to pick a similar pair")
    pool = _pentagon_pool(pentagon)
    target = float(np.quantile(logs, quantile))
    h = min(range(len(ids)), key=lambda i: (abs(logs[i] - target), ids[i]))
    hid, e = ids[h], math.exp(logs[h])
    pids, plogs = _clean({k: v for k, v in pool.items() if pattern_of(k) != pattern_of(hid)})
    if not pids:
        raise SpecError("the catalog has no second pattern with a pentagon energy")
    p = min(range(len(pids)), key=lambda i: (abs(plogs[i] - math.log(e)), pids[i]))
    return hid, pids[p]


def similar_set(energies: Mapping[int, Mapping[str, float]], quantile: float = 0.5) -> dict[int, str]:
    """{sides: ID}: one pattern per polygon of a tiling, all of similar energy, each measured on its own
    polygon — :func:`similar_pair` for any set of polygons.

    ``energies``: {sides: {ID: energy (N·mm)}} of each polygon's plates (one scenario and set-up). The
    largest polygon takes the pattern nearest the ``quantile`` of its log-energies; every other
    polygon, largest first, the ID not taken yet whose energy on that polygon is nearest the first
    one's. On {6: hexagons, 5: pentagons} it is :func:`similar_pair`. Ties go to the smaller ID.
    Raises :class:`SpecError` naming the polygon whose energies are missing or too few.
    """
    sides = sorted(energies, reverse=True)
    if sides == [6, 5]:
        return dict(zip(sides, similar_pair(energies[6], energies[5], quantile), strict=True))
    ids, logs = _clean(energies[sides[0]])
    if len(ids) < 2 - (len(sides) == 1):
        raise SpecError(f"the catalog has too few {sides[0]}-sided patterns with an energy to pick from")
    target = float(np.quantile(logs, quantile))
    first = min(range(len(ids)), key=lambda i: (abs(logs[i] - target), ids[i]))
    out, e = {sides[0]: ids[first]}, float(logs[first])
    for n in sides[1:]:
        pids, plogs = _clean({k: v for k, v in energies[n].items() if k not in out.values()})
        if not pids:
            raise SpecError(f"the catalog has no other pattern with a {n}-sided energy (run `fabpat sweep "
                            f"--sides {n}` for the catalog)")
        out[n] = pids[min(range(len(pids)), key=lambda i: (abs(plogs[i] - e), pids[i]))]
    return out


def similar_pairs(hexagon: Mapping[str, float], pentagon: Mapping[str, float], count: int,
                  quantile: float = 0.5) -> list[tuple[str, str]]:
    """Up to ``count`` (hexagon ID, pentagon ID) pairs of similar energy, best first.

    Pair 0 is exactly :func:`similar_pair` (``hexagon``, ``pentagon``, ``quantile``). The others come
    from the ``2 · count`` hexagon patterns whose log-energies are nearest the ``quantile`` of the
    hexagon log-energies (ties to the smaller ID) — typical stiffnesses, as for :func:`similar_pair` —
    each paired with the entry of another pattern (an ID, or a member's name) whose pentagon energy is
    nearest its own hexagon energy, ties to the smaller name. They are ranked by |log E_hex − log E_pent|
    (the energy ratio), then by hexagon ID, then pentagon ID; a pair is listed once. Fewer than
    ``count`` pairs come back only when the catalog has fewer candidates. Raises :class:`SpecError` if
    ``count`` < 1 or :func:`similar_pair` finds no pair.
    """
    if count < 1:
        raise SpecError(f"patterns.candidates must be at least 1, got {count}")
    first = similar_pair(hexagon, pentagon, quantile)
    ids, logs = _clean(hexagon)
    target = float(np.quantile(logs, quantile))
    near = sorted(range(len(ids)), key=lambda i: (abs(logs[i] - target), ids[i]))[:2 * count]
    pids, plogs = _clean(_pentagon_pool(pentagon))
    ranked = []
    for h in near:
        others = [j for j in range(len(pids)) if pattern_of(pids[j]) != pattern_of(ids[h])]
        if not others:
            continue
        p = min(others, key=lambda j: (abs(plogs[j] - logs[h]), pids[j]))
        ranked.append((abs(float(plogs[p] - logs[h])), ids[h], pids[p]))
    rest = [(hid, pid) for _, hid, pid in sorted(ranked) if (hid, pid) != first]
    return [first, *dict.fromkeys(rest)][:count]
