"""The strip's reduced model and read-outs: which stiffness each column needs, and how far a solve is.

**Reduced model** (an elastica, docs/design.md): a strip pinned at both ends and pushed together carries a
thrust P along the chord, so the bending moment is M = P·w (w the deflection) and the curvature
κ = M / EI. A target mid-line therefore needs, column by column, EI ∝ w̄ / κ̄ (w̄ the column's mean
deflection, κ̄ its turning angle over its arc length); only ratios matter. A pattern's bending stiffness
is ∝ 1 / U_cylinder (two end moments bend the plate: U = M²·L / (2·EI)), so in log space a column's
need and a pattern's stiffness differ by one constant, chosen by least squares (:func:`assign`).

**Read-outs** (:func:`midline`): the width-averaged mid-line of a solved strip, the area-weighted mean
deformed x and uz of the plate nodes in the bins of :func:`fabpat.assembly.solve.strip.profile`; the
error is its vertical distance from the target at the target's x (:func:`errors`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.assembly.solve.strip import StripSetup

Arr = NDArray[np.float64]
Idx = NDArray[np.int64]

#: samples per column of the resampled curves (turning angle and mean deflection per column)
_SAMPLES = 64


def midline(setup: StripSetup, displacement: Arr) -> tuple[Arr, Arr]:
    """The solved strip's width-averaged mid-line from pin to pin: (x, z) mm, x from column 0's pin
    (which is fixed), z the mean uz, one point per profile bin between the pins plus the two pins at
    z = 0. ``setup`` a StripSetup, ``displacement`` (N, 3+) nodal displacements."""
    from fabpat.assembly.solve.strip import profile

    m = setup.model
    n = len(m.X)
    d = np.asarray(displacement)[:n]
    _, xd = profile(setup, m.X[:, 0] + d[:, 0])
    _, zd = profile(setup, d[:, 2])
    left = float(m.X[setup.left, 0].mean())
    right = float((m.X[setup.right, 0] + d[setup.right, 0]).mean()) - left
    xd = xd - left
    # the pins are on the mid-line at z = 0 by construction; the bins next to them are a few mm inside
    inner = (xd > 0) & (xd < right)
    return np.concatenate([[0.0], xd[inner], [right]]), np.concatenate([[0.0], zd[inner], [0.0]])


def pin_length(setup: StripSetup) -> float:
    """Pin-to-pin distance (mm) of the flat strip: mean x of the moving pins minus that of the fixed ones."""
    m = setup.model
    return float(m.X[setup.right, 0].mean() - m.X[setup.left, 0].mean())


def predicted_at(x_mid: Arr, z_mid: Arr, x: Arr) -> Arr:
    """z of the mid-line at the target's x (mm); the mid-line's x made non-decreasing first (a steep arch's
    bins near a pin can overlap by rounding)."""
    return np.interp(x, np.maximum.accumulate(x_mid), z_mid)


def errors(x_mid: Arr, z_mid: Arr, x: Arr, z: Arr) -> tuple[float, float, Arr]:
    """(rms_error, max_error, per-point error) in mm: predicted minus target z at the target's x."""
    e = predicted_at(x_mid, z_mid, x) - z
    return float(np.sqrt(np.mean(e * e))), float(np.abs(e).max()), e


def _resampled(x: Arr, z: Arr, columns: int) -> tuple[Arr, Arr, Arr, float]:
    """The curve at ``_SAMPLES`` equal arc steps per column: arc s, x, z (mm) and a column's arc length."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))])
    ss = np.linspace(0.0, s[-1], columns * _SAMPLES + 1)
    return ss, np.interp(ss, s, x), np.interp(ss, s, z), float(s[-1] / columns)


def column_turning(x: Arr, z: Arr, columns: int) -> Arr:
    """How far the curve through (x, z) mm turns downwards over each column (rad, (columns,)): minus the
    change of its tangent angle, positive where an arch is concave; the columns are equal lengths of arc
    from x[0] (the inextensible strip's columns)."""
    ss, xs, zs, _ = _resampled(x, z, columns)
    theta = np.unwrap(np.arctan2(np.gradient(zs, ss), np.gradient(xs, ss)))
    edges = theta[::_SAMPLES]
    return -(edges[1:] - edges[:-1])


def column_needs(x: Arr, z: Arr, columns: int) -> Arr:
    """The elastica's need log(w̄ / κ̄) of each column (columns,) for a curve through (x, z) mm (w̄ the
    column's mean height, κ̄ its turning over its arc length, :func:`column_turning`). +inf where the
    column turns the wrong way or not at all (it would need to be rigid), −inf where it turns but does
    not rise above the pins (it would need no stiffness)."""
    ss, _, zs, ds = _resampled(x, z, columns)
    kappa = column_turning(x, z, columns) / ds
    out = np.empty(columns)
    for c in range(columns):
        a, b = c * _SAMPLES, (c + 1) * _SAMPLES
        w = float(np.trapezoid(zs[a:b + 1], ss[a:b + 1]) / ds)
        if kappa[c] <= 1e-9 / ds:
            out[c] = math.inf
        elif w <= 0.0:
            out[c] = -math.inf
        else:
            out[c] = math.log(w / kappa[c])
    return out


def curvature_update(turn_obs: Arr, turn_target: Arr, limit: float = 1.0, floor: float = 0.05) -> Arr:
    """Change of log-stiffness per column that would turn each column as the target does if its bending
    moment stayed the same (κ = M / EI, so EI_new = EI · κ_obs / κ_target): log(turn_obs / turn_target),
    clipped to ±``limit``; 0 where the target hardly turns (below ``floor`` × its largest turning: the
    moment there is near zero and the stiffness hardly matters) or the two turn opposite ways, then
    ±``limit`` towards the target's sign (stiffer where the solve turns the wrong way)."""
    t, o = np.asarray(turn_target), np.asarray(turn_obs)
    small = np.abs(t) < floor * max(float(np.abs(t).max()), 1e-300)
    same = (t * o) > 0
    r = np.zeros(len(t))
    r[same] = np.log(o[same] / t[same])
    r[~same & ~small] = limit  # the column bends the wrong way: its moment has the other sign; stiffen it
    r[small] = 0.0
    return np.clip(r, -limit, limit)


def column_errors(x_t: Arr, e: Arr, columns: int) -> Arr:
    """RMS of the per-point error ``e`` (mm) over each column's share of the span (columns,)."""
    k = np.minimum((x_t / max(x_t[-1], 1e-300) * columns).astype(np.int64), columns - 1)
    s = np.bincount(k, e * e, minlength=columns)
    n = np.maximum(np.bincount(k, minlength=columns), 1)
    return np.sqrt(s / n)


def _levels(v: Arr, k: int) -> list[Idx]:
    """Optimal split of values ``v`` into at most ``k`` groups of consecutive sorted values (least squares,
    dynamic programming): the index arrays of the groups."""
    order = np.argsort(v, kind="stable")
    a = v[order]
    n = len(a)
    k = min(k, n)
    c1 = np.concatenate([[0.0], np.cumsum(a)])
    c2 = np.concatenate([[0.0], np.cumsum(a * a)])

    def cost(i: int, j: int) -> float:  # squared deviation of a[i:j] from its mean
        m = j - i
        return float(c2[j] - c2[i] - (c1[j] - c1[i]) ** 2 / m)

    best = np.full((k + 1, n + 1), np.inf)
    cut = np.zeros((k + 1, n + 1), dtype=np.int64)
    best[0, 0] = 0.0
    for g in range(1, k + 1):
        for j in range(1, n + 1):
            for i in range(g - 1, j):
                c = best[g - 1, i] + cost(i, j)
                if c < best[g, j]:
                    best[g, j], cut[g, j] = c, i
    groups = []
    j, g = n, k
    while g > 0:
        i = int(cut[g, j])
        groups.append(order[i:j])
        j, g = i, g - 1
    return [grp for grp in reversed(groups) if len(grp)]


def assign(needs: Arr, log_stiffness: Arr, max_distinct: int | None = None) -> tuple[Idx, float]:
    """Candidate index per column and the log-scale b chosen: the candidates (``log_stiffness`` (M,),
    sorted ascending) nearest needs + b, b minimising the sum of squared log differences over a grid
    spanning the candidates' range; ±inf needs take the stiffest/softest candidate. With
    ``max_distinct`` K the columns' values are first grouped into ≤ K levels (:func:`_levels`), each
    level one pattern."""
    ls = np.asarray(log_stiffness, dtype=np.float64)
    lo, hi = float(ls[0]), float(ls[-1])
    fin = np.isfinite(needs)
    if not fin.any():
        b = 0.0
        offsets = np.array([0.0])
    else:
        nf = needs[fin]
        spread = np.ptp(nf) > 0
        offsets = np.linspace(lo - nf.max(), hi - nf.min(), 201) if spread else np.array([0.5 * (lo + hi) - nf[0]])
    best: tuple[float, Idx, float] | None = None
    for b in offsets:
        v = np.where(fin, needs + b, np.where(needs > 0, hi, lo))
        idx = _pick(np.clip(v, lo, hi), ls, max_distinct)
        cost = float(np.sum((ls[idx] - v)[fin] ** 2))
        if best is None or cost < best[0] - 1e-12:
            best = (cost, idx, float(b))
    assert best is not None
    return best[1], best[2]


def _pick(v: Arr, ls: Arr, k: int | None) -> Idx:
    """Nearest candidate of each value, or of each of ≤ k levels."""
    def nearest(t: Arr) -> Idx:
        j = np.clip(np.searchsorted(ls, t), 1, len(ls) - 1)
        left = np.abs(t - ls[j - 1]) <= np.abs(ls[j] - t)
        return np.where(left, j - 1, j).astype(np.int64) if len(ls) > 1 else np.zeros(len(t), dtype=np.int64)

    idx = nearest(v)
    if k is None or len(np.unique(idx)) <= k:
        return idx
    out = np.empty(len(v), dtype=np.int64)
    for grp in _levels(v, k):
        out[grp] = nearest(np.array([v[grp].mean()]))[0]
    return out
