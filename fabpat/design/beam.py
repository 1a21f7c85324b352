"""The strip's reduced model: a planar inextensible elastica with one bending stiffness per column.

The strip's columns are segments of one beam of pin-to-pin length L (mm), column c with bending
stiffness EI_c = exp(u_c) (relative to a reference pattern, u = 0), its ends held by rotational springs
of stiffness K = k · EI_end / L, EI_end the stiffness of the end column (the pinned interface segments of
the shell model are slanted, so the pins also hold part of the end rotation, through the end plate
itself: the restraint scales with that plate's stiffness, and the shape depends on stiffness ratios
only; a pure pin is k = 0, a clamp k → ∞). Pushed together to the
chord ``span`` it buckles upwards into the first mode. Equilibrium is the stationary point of

    Π(θ) = Σ_k EI_k / (2 ds) · (θ_{k+1} − θ_k)² + K/2 · (θ_1² + θ_n²)

over the tangent angles θ of n equal segments of length ds, under the two closure constraints
ds Σ sin θ = 0 (both pins at z = 0) and ds Σ cos θ = span (the elastica of Euler; the discrete form
is the standard finite-difference one, e.g. Antman, *Nonlinear Problems of Elasticity*, §4.2). The
stiffness at a joint between two segments is the harmonic mean of theirs (the two half-segments in
series). The KKT system is solved by Newton's method from the pinned first mode z = a sin(π s / L),
and from the clamped one, whose amplitude follows from the end shortening (span / L = J₀(a) for
θ = a cos(π s / L)); the stationary shape of lower energy is the stable arch.

The model serves the design loop twice (:mod:`fabpat.design.api`): it *designs* (the u per column
whose elastica passes through the target, :func:`fit_stiffness`) and it *identifies* (the u per
column whose elastica passes through a shell solve's mid-line, the same call with the solve as the
target). The difference between what a column's pattern was expected to give and what the solve
shows is the model's correction for that column (output space mapping: Bandler et al., *Space
mapping: the state of the art*, IEEE Trans. MTT 52(1), 2004).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SolverError
from fabpat.shell.compiled import one_blas_thread

Arr = NDArray[np.float64]

#: beam segments per strip column (the fits do not change beyond ~8; 12 keeps joints between columns sharp)
SEGMENTS_PER_COLUMN = 12
#: Newton tolerance on the KKT residual, relative to the thrust × length scale
_TOL = 1e-10
_MAX_NEWTON = 60


@dataclass(frozen=True)
class Elastica:
    """A strip as a beam: ``length`` L (mm), column ``edges`` (N + 1,) in arc length from the fixed pin
    (0 … L, mm), ``spring`` k the ends' dimensionless rotational stiffness (K = k · EI_ref / L)."""

    length: float
    edges: tuple[float, ...]
    spring: float = 0.0

    @property
    def columns(self) -> int:
        """Number of strip columns N."""
        return len(self.edges) - 1

    def _segments(self) -> tuple[int, float, NDArray[np.int64]]:
        """Segment count n, segment length ds (mm) and the column of each segment (n,)."""
        n = SEGMENTS_PER_COLUMN * self.columns
        ds = self.length / n
        mid = (np.arange(n) + 0.5) * ds
        col = np.clip(np.searchsorted(np.asarray(self.edges), mid, side="right") - 1, 0, self.columns - 1)
        return n, ds, col.astype(np.int64)

    def solve(self, u: Arr, span: float) -> tuple[Arr, Arr, Arr]:
        """The buckled shape for log-stiffnesses ``u`` (N,) pushed to chord ``span`` (mm): (x, z) (n + 1,)
        mm of the joints from the fixed pin, and θ (n,) rad. Newton starts from the pinned and from the
        clamped first mode (θ = a cos(π s / L), θ = a sin(2π s / L), both with J₀(a) = span / L) and the
        stationary shape of lower energy Π is the stable arch. Raises SolverError if neither converges
        (the message gives the residual reached)."""
        n, ds, col = self._segments()
        ei = np.exp(np.asarray(u, dtype=np.float64))[col]
        c = 2.0 / (1.0 / ei[:-1] + 1.0 / ei[1:]) / ds  # joint stiffnesses, N·mm per rad² (relative)
        k_end = self.spring / self.length * np.array([ei[0], ei[-1]])  # N·mm per rad (relative), each end
        a = _amplitude(span / self.length)
        s = (np.arange(n) + 0.5) / n
        found: list[tuple[float, Arr]] = []
        failure: SolverError | None = None
        for start in (a * np.cos(math.pi * s), a * np.sin(2.0 * math.pi * s)):
            try:
                theta = _newton(start, c, k_end, ds, span, self.length)
            except SolverError as e:
                failure = e
                continue
            d = np.diff(theta)
            found.append((0.5 * float(np.sum(c * d * d) + k_end[0] * theta[0] ** 2 + k_end[1] * theta[-1] ** 2), theta))
        if not found:
            assert failure is not None
            raise failure
        theta = min(found, key=lambda f: f[0])[1]
        x = np.concatenate([[0.0], np.cumsum(ds * np.cos(theta))])
        z = np.concatenate([[0.0], np.cumsum(ds * np.sin(theta))])
        return x, z, theta

    def profile(self, u: Arr, span: float, x: Arr) -> Arr:
        """z (mm) of the elastica at the abscissae ``x`` (mm from the fixed pin)."""
        xb, zb, _ = self.solve(u, span)
        return np.interp(x, np.maximum.accumulate(xb), zb)


def _amplitude(ratio: float) -> float:
    """a with J₀(a) = span / L: the amplitude of θ = a cos(π s / L) (or a sin(2π s / L)) whose chord is
    that fraction of the length (the mean of cos(a cos φ) over a half period is J₀(a))."""
    from scipy.optimize import brentq
    from scipy.special import j0

    if not 0.0 < ratio < 1.0:
        raise SolverError(f"strip elastica: the chord must be shorter than the strip, span / L = {ratio:.6g}")
    return float(brentq(lambda a: float(j0(a)) - ratio, 0.0, 2.404825557695773))  # first zero of J₀


def _newton(theta: Arr, c: Arr, k_end: Arr, ds: float, span: float, length: float) -> Arr:
    """Newton's method on the KKT system of Π with the two closure constraints, from ``theta`` (rad)."""
    n = len(theta)
    theta = np.array(theta, dtype=np.float64)
    scale = max(float(c.max()), float(k_end.max()), 1e-300)
    lam = np.zeros(2)
    r_theta, g = np.zeros(n), np.zeros(2)
    for it in range(_MAX_NEWTON):
        grad_e = _energy_gradient(theta, c, k_end)
        s, co = np.sin(theta), np.cos(theta)
        J = np.vstack([ds * co, -ds * s])  # ∂(g1, g2)/∂θ
        if it == 0:  # the multipliers (reactions) that best balance the first guess
            lam = np.linalg.lstsq(J.T, -grad_e, rcond=None)[0]
        r_theta = grad_e + J.T @ lam
        g = np.array([ds * s.sum(), ds * co.sum() - span])
        if np.abs(r_theta).max() <= _TOL * scale * length and np.abs(g).max() <= _TOL * length:
            return theta
        H = _energy_hessian(c, k_end) + np.diag(-lam[0] * ds * s - lam[1] * ds * co)
        K = np.block([[H, J.T], [J, np.zeros((2, 2))]])
        try:
            step = np.linalg.solve(K, -np.concatenate([r_theta, g]))
        except np.linalg.LinAlgError as e:
            raise SolverError(f"strip elastica: singular Newton system at iteration {it}") from e
        # a tangent angle moves by at most 0.2 rad per iteration: Newton stays on the branch it starts on
        f = min(1.0, 0.2 / max(float(np.abs(step[:n]).max()), 1e-300))
        theta = theta + f * step[:n]
        lam = lam + f * step[n:]
    raise SolverError(f"strip elastica: Newton did not converge in {_MAX_NEWTON} iterations (closure residual "
                      f"{float(np.abs(g).max()):.3g} mm, equilibrium residual {float(np.abs(r_theta).max()):.3g})")


def _energy_gradient(theta: Arr, c: Arr, k_end: Arr) -> Arr:
    d = np.diff(theta)
    g = np.zeros_like(theta)
    g[:-1] -= c * d
    g[1:] += c * d
    g[0] += k_end[0] * theta[0]
    g[-1] += k_end[1] * theta[-1]
    return g


def _energy_hessian(c: Arr, k_end: Arr) -> Arr:
    n = len(c) + 1
    H = np.zeros((n, n))
    i = np.arange(n - 1)
    H[i, i] += c
    H[i + 1, i + 1] += c
    H[i, i + 1] -= c
    H[i + 1, i] -= c
    H[0, 0] += k_end[0]
    H[-1, -1] += k_end[1]
    return H


def fit_spring(beam: Elastica, u: Arr, span: float, x: Arr, z: Arr) -> Elastica:
    """``beam`` with the end spring k that best reproduces the mid-line (x, z) mm of a strip of
    log-stiffnesses ``u`` (least squares over log k in [−5, 12]: from a pin to a clamp)."""
    from scipy.optimize import minimize_scalar

    def cost(logk: float) -> float:
        b = Elastica(beam.length, beam.edges, math.exp(logk))
        try:
            return float(np.sum((b.profile(u, span, x) - z) ** 2))
        except SolverError:
            return math.inf

    # the fits solve hundreds of small systems (the 2 × 15 strip's KKT system is 182 × 182), which several BLAS
    # threads only slow down: on the loaded 2-core machine (load average 9) a fit to the 2 × 15 strip took 79 s
    # with the default threads (65 ms per solve) and under 2 s with one
    with one_blas_thread():
        best = minimize_scalar(cost, bounds=(-5.0, 12.0), method="bounded", options={"xatol": 1e-3})
    return Elastica(beam.length, beam.edges, math.exp(float(best.x)))


def fit_stiffness(beam: Elastica, span: float, x: Arr, z: Arr, prior: Arr, lower: Arr, upper: Arr,
                  regularization: float = 0.01) -> Arr:
    """The log-stiffnesses u (N,) whose elastica best passes through (x, z) mm: least squares of the
    height error at x plus ``regularization`` × max |z| × (u − ``prior``) (columns whose moment is near
    zero hardly change the shape; they stay near the prior), within ``lower`` ≤ u ≤ ``upper``."""
    from scipy.optimize import least_squares

    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    p0 = np.clip(np.asarray(prior, dtype=np.float64), lo, hi)
    w = regularization * max(float(np.abs(z).max()), 1e-9)

    def residual(u: Arr) -> Arr:
        return np.concatenate([beam.profile(u, span, x) - z, w * (u - p0)])

    if np.all(hi - lo <= 1e-12):
        return p0
    free = hi - lo > 1e-12
    fixed = p0.copy()

    def sub(v: Arr) -> Arr:
        u = fixed.copy()
        u[free] = v
        return residual(u)

    with one_blas_thread():
        sol = least_squares(sub, p0[free], bounds=(lo[free], hi[free]), diff_step=1e-4, xtol=1e-8, ftol=1e-10)
    out = fixed.copy()
    out[free] = sol.x
    return out
