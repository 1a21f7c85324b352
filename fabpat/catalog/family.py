"""The catalog over each pattern's family: energies between the swept members, without a solve.

``fabpat sweep --family`` stores every pattern's three energies at the standard members
:data:`fabpat.catalog.sweep.FAMILY_SAMPLES` of ``bridge_weight`` (:mod:`fabpat.patterns.variation`) next to the
paper's (``bridge_weight = 1``, the catalog's own results). Between them the energy is interpolated
by a monotone piecewise-cubic Hermite interpolant (PCHIP: Fritsch & Carlson, *SIAM J. Numer. Anal.* 17,
1980; :class:`scipy.interpolate.PchipInterpolator`) in log w and log energy: the energies are monotone
in w (wider necks, stiffer plate) and close to power laws, and PCHIP keeps each interval monotone, so
"which member gives energy E" has at most one answer per interval and no overshoot. The measured error
against direct solves is in docs/variations.md.

A member whose solve did not converge (a soft member buckling under the Dome load) ends the curve:
the interpolant covers the contiguous run of converged members around the paper's, and asking
outside it raises :class:`~fabpat.errors.CatalogError` naming the range that is covered.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fabpat.catalog import CatalogError, open_catalog
from fabpat.simulation.scenarios import scenario_name
from fabpat.validate import check


@dataclass(frozen=True)
class FamilyCurve:
    """One pattern's energy over its family in one scenario, from the catalog.

    ``weights`` (k,) the converged members' bridge_weight, increasing, the paper's 1 among them;
    ``energies`` (k,) their strain energies (N·mm); ``min_widths`` (k,) their narrowest features (mm).
    """

    pattern_id: str
    sides: int
    scenario: str
    weights: NDArray[np.float64]
    energies: NDArray[np.float64]
    min_widths: NDArray[np.float64]

    @property
    def range(self) -> tuple[float, float]:
        """(lowest, highest) bridge_weight the curve covers."""
        return float(self.weights[0]), float(self.weights[-1])

    def _pchip(self):  # noqa: ANN202 - scipy object
        from scipy.interpolate import PchipInterpolator

        return PchipInterpolator(np.log(self.weights), np.log(self.energies))

    def energy(self, bridge_weight: float) -> float:
        """The interpolated energy (N·mm) of the member ``bridge_weight``; :class:`CatalogError` outside
        :attr:`range` (the members swept and converged), :class:`~fabpat.errors.RangeError` for a value
        that is not a number in the parameter's range (``fabpat variations``)."""
        w = check("bridge_weight", bridge_weight)
        lo, hi = self.range
        if not (lo <= w <= hi) or not math.isfinite(w):
            raise CatalogError(f"pattern {self.pattern_id} ({self.sides}-gon) {self.scenario}: the catalog's family "
                               f"covers bridge_weight {lo:g} … {hi:g}, not {w:g}")
        if len(self.weights) == 1:
            return float(self.energies[0])
        return float(np.exp(self._pchip()(math.log(w))))

    def members_for(self, energy: float) -> list[float]:
        """Every bridge_weight whose interpolated energy is ``energy`` (N·mm): one per interval that
        brackets it (the interpolant is monotone on each), increasing; [] if none."""
        from scipy.optimize import brentq

        target = math.log(float(energy))
        x, y = np.log(self.weights), np.log(self.energies)
        if len(x) == 1:
            return [float(self.weights[0])] if y[0] == target else []
        f = self._pchip()
        out: list[float] = []
        for a, b, ya, yb in zip(x[:-1], x[1:], y[:-1], y[1:], strict=True):
            if ya == target:
                out.append(math.exp(a))
            elif (ya - target) * (yb - target) < 0:
                out.append(math.exp(brentq(lambda t: float(f(t)) - target, a, b, xtol=1e-12)))
        if y[-1] == target:
            out.append(math.exp(x[-1]))
        return sorted(set(out))


@dataclass(frozen=True)
class FamilyMatch:
    """A pattern and family member whose interpolated energy is the one asked for.

    ``energy`` N·mm (interpolated), ``min_width`` mm (interpolated linearly in log w between members).
    """

    pattern_id: str
    bridge_weight: float
    energy: float
    min_width: float


def family_curves(scenario: str, *, sides: int = 6, depth: int = 2, edge: float = 36.0, thickness: float = 2.0,
                  weight: float = 0.2, db: str | Path | None = None) -> dict[str, FamilyCurve]:
    """Every pattern's :class:`FamilyCurve` in ``scenario`` for one set-up (``db`` None: the built-in
    catalog). A pattern without family rows has a one-member curve (the paper's). Raises
    :class:`CatalogError` if the catalog holds no result of this set-up."""
    sc = scenario_name(scenario)
    setup = {"sides": sides, "depth": depth, "edge": float(edge), "thickness": float(thickness),
             "weight": float(weight)}
    with open_catalog(db) as cat:
        paper = cat.results(sc, **setup)
        members = cat.family(sc, **setup)
        widths = {str(r["id"]): r["min_width"] for r in cat.pattern_rows(**setup)}
    if not paper:
        raise CatalogError(f"the catalog holds no {sc} results for sides={sides} depth={depth} edge={edge:g} mm "
                           f"thickness={thickness:g} mm weight={weight:g}")
    rows: dict[str, list[tuple[float, bool, float, float]]] = {}
    for r in paper:
        rows.setdefault(str(r["id"]), []).append((1.0, bool(r["converged"]), r["energy"] or math.nan,  # type: ignore[arg-type]
                                                  float(widths.get(str(r["id"])) or math.nan)))
    for r in members:
        pid = str(r["id"])
        if pid in rows:
            rows[pid].append((float(r["bridge_weight"]), bool(r["converged"]),  # type: ignore[arg-type]
                              r["energy"] or math.nan, float(r["min_width"] or math.nan)))  # type: ignore[arg-type]
    return {pid: curve for pid, pts in rows.items() if (curve := _curve(pid, sides, sc, pts)) is not None}


def _curve(pid: str, sides: int, scenario: str, pts: Iterable[tuple[float, bool, float, float]]) -> FamilyCurve | None:
    """The contiguous run of converged members around the paper's; None if the paper's did not converge."""
    ordered = sorted(pts)
    k = next((i for i, p in enumerate(ordered) if p[0] == 1.0), None)
    if k is None or not ordered[k][1]:
        return None
    lo = k
    while lo > 0 and ordered[lo - 1][1]:
        lo -= 1
    hi = k
    while hi + 1 < len(ordered) and ordered[hi + 1][1]:
        hi += 1
    run = ordered[lo:hi + 1]
    return FamilyCurve(pid, sides, scenario, np.array([p[0] for p in run]), np.array([p[2] for p in run]),
                       np.array([p[3] for p in run]))


def family_energy(pattern_id: str, scenario: str, bridge_weight: float, *, sides: int = 6,
                  db: str | Path | None = None) -> float:
    """The interpolated energy (N·mm) of one pattern's member ``bridge_weight`` in ``scenario`` (the
    default set-up of ``sides``; ``db`` None: the built-in catalog). Raises :class:`CatalogError` for a
    pattern not in the catalog or a member outside its swept, converged range, :class:`RangeError` for a
    ``bridge_weight`` that is not a number in its range (0.25 … 2.5)."""
    check("bridge_weight", bridge_weight)  # before reading the catalog: a bad value is the caller's
    curves = family_curves(scenario, sides=sides, db=db)
    curve = curves.get(pattern_id)
    if curve is None:
        raise CatalogError(f"pattern {pattern_id} has no converged {scenario_name(scenario)} result in the catalog "
                           f"for {sides}-gons")
    return curve.energy(bridge_weight)


def _number(value: object) -> float:
    """``value`` as a float if it is a real number (not a bool), else NaN: a string is no energy."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    return float(value) if ok else math.nan  # type: ignore[arg-type]


def match_energy(scenario: str, energy: float, *, sides: int = 6, db: str | Path | None = None,
                 min_width: float = 0.0, curves: dict[str, FamilyCurve] | None = None) -> list[FamilyMatch]:
    """Every (pattern, member) whose interpolated energy in ``scenario`` is ``energy`` (N·mm), with a
    narrowest feature of at least ``min_width`` mm, closest to the paper's member first (by |log w|).

    ``curves``: from :func:`family_curves` (to ask many energies without re-reading the catalog).
    Raises :class:`CatalogError` for an energy that is not a positive finite number (a string, None,
    NaN) or a ``min_width`` that is not a finite number ≥ 0.
    """
    e = _number(energy)
    if not (math.isfinite(e) and e > 0):
        raise CatalogError(f"energy must be a positive number of N·mm, got {energy!r}")
    if not (math.isfinite(_number(min_width)) and _number(min_width) >= 0):
        raise CatalogError(f"min_width must be a finite number ≥ 0 of mm, got {min_width!r}")
    curves = family_curves(scenario, sides=sides, db=db) if curves is None else curves
    out: list[FamilyMatch] = []
    for pid, c in curves.items():
        for w in c.members_for(e):
            width = float(np.interp(math.log(w), np.log(c.weights), c.min_widths))
            if width >= min_width:
                out.append(FamilyMatch(pid, w, e, width))
    return sorted(out, key=lambda m: (abs(math.log(m.bridge_weight)), m.pattern_id))
