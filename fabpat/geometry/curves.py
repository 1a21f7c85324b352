"""Rational Bézier curves (paper §3.3): evaluation, splitting, flattening, exact integrals, conics, arcs.

Conventions
-----------
* A rational Bézier curve of degree n is given by control points ``P``, ``(n + 1, d) float``, and
  positive weights ``W``, ``(n + 1,) float``. Coordinates are millimetres.
* A *standard-form quadratic* is the common special case ``P`` ``(3, 2)`` with weights ``(1, w, 1)``;
  functions named ``quad_*`` take ``(P, w)``. Every quadratic with positive weights can be brought to
  standard form (:func:`standardize_quad`) without changing its point set or its end points.
* Parameters ``t`` are floats or ``(m,)`` arrays in [0, 1]; a scalar parameter gives a ``(d,)``
  result, an array gives ``(m, d)``.

Everything here is pure numpy (plus scipy's adaptive quadrature for arc length). The conic and
circular-arc forms the file formats need are in :mod:`fabpat.geometry.conics`, the polyline checks of a
flattened outline in :mod:`fabpat.geometry.polyline`.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Literal, overload

import numpy as np
from numpy.polynomial import polynomial as npoly
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import quad as _scipy_quad

FloatArray = NDArray[np.float64]

__all__ = [
    "arc_length",
    "cross2d",
    "derivative",
    "evaluate",
    "flatten",
    "flatten_quad",
    "point_segment_distance",
    "quad_area",
    "quad_arc_length",
    "quad_bbox",
    "quad_polar_moment",
    "rot90",
    "segment_area_ratio",
    "split",
    "split_quad",
    "standardize_quad",
    "subcurve",
]


# --------------------------------------------------------------------------------------------------
# Evaluation: generalised de Casteljau in homogeneous coordinates
# --------------------------------------------------------------------------------------------------


def _homogeneous(P: ArrayLike, W: ArrayLike) -> FloatArray:
    """(n + 1, d + 1) float: rows (w_i P_i, w_i)."""
    P = np.asarray(P, dtype=np.float64)
    W = np.asarray(W, dtype=np.float64)
    if P.ndim != 2 or W.shape != (P.shape[0],):
        raise ValueError(f"control points (n+1, d) and weights (n+1,) expected, got {P.shape}, {W.shape}")
    if not np.all(W > 0):
        raise ValueError("rational Bézier weights must be positive")
    return np.concatenate([P * W[:, None], W[:, None]], axis=1)


def _casteljau(H: FloatArray, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Run de Casteljau on homogeneous points H (n + 1, d + 1) for t (m,).

    Returns the point ``(m, d + 1)`` and the homogeneous derivative ``(m, d + 1)``: the derivative of
    a Bézier curve is n times the difference of the two points of the penultimate level.
    """
    n = H.shape[0] - 1
    t = t[:, None, None]
    Q = np.broadcast_to(H, (t.shape[0], *H.shape))
    if n == 0:
        return Q[:, 0].copy(), np.zeros_like(Q[:, 0])
    for _ in range(n - 1):
        Q = (1.0 - t) * Q[:, :-1] + t * Q[:, 1:]
    dH = n * (Q[:, 1] - Q[:, 0])
    pt = (1.0 - t[:, 0]) * Q[:, 0] + t[:, 0] * Q[:, 1]
    return pt, dH


def evaluate(P: ArrayLike, W: ArrayLike, t: ArrayLike) -> FloatArray:
    """Points of a rational Bézier curve of any degree.

    P: (n + 1, d) float, W: (n + 1,) float > 0, t: float or (m,) float.
    Returns (d,) or (m, d) float. Working in homogeneous coordinates keeps every de Casteljau step a
    convex combination, which is why it is stable for any positive weights.
    """
    H = _homogeneous(P, W)
    tt = np.atleast_1d(np.asarray(t, dtype=np.float64))
    pt, _ = _casteljau(H, tt)
    out = pt[:, :-1] / pt[:, -1:]
    return out[0] if np.ndim(t) == 0 else out


def derivative(P: ArrayLike, W: ArrayLike, t: ArrayLike) -> FloatArray:
    """First derivative dC/dt (mm per unit parameter), exact.

    Quotient rule on the homogeneous form C = A / h: C' = (A' h − A h') / h².
    P: (n + 1, d), W: (n + 1,), t: float or (m,). Returns (d,) or (m, d).
    """
    H = _homogeneous(P, W)
    tt = np.atleast_1d(np.asarray(t, dtype=np.float64))
    pt, dH = _casteljau(H, tt)
    h = pt[:, -1:]
    out = (dH[:, :-1] * h - pt[:, :-1] * dH[:, -1:]) / (h * h)
    return out[0] if np.ndim(t) == 0 else out


def split(P: ArrayLike, W: ArrayLike, t: float) -> tuple[tuple[FloatArray, FloatArray], ...]:
    """Exact subdivision at parameter t: ``((P_left, W_left), (P_right, W_right))``.

    The left piece covers [0, t], the right [t, 1], each reparametrised to [0, 1]. Weights are the
    homogeneous coordinates of the de Casteljau triangle's edges, so they are not normalised; use
    :func:`standardize_quad` for a quadratic.
    """
    H = _homogeneous(P, W)
    left, right = [H[0]], [H[-1]]
    Q = H
    while Q.shape[0] > 1:
        Q = (1.0 - t) * Q[:-1] + t * Q[1:]
        left.append(Q[0])
        right.append(Q[-1])
    L, R = np.array(left), np.array(right[::-1])
    return (L[:, :-1] / L[:, -1:], L[:, -1].copy()), (R[:, :-1] / R[:, -1:], R[:, -1].copy())


def subcurve(P: ArrayLike, W: ArrayLike, a: float, b: float) -> tuple[FloatArray, FloatArray]:
    """The piece of the curve on [a, b] (0 <= a < b <= 1) as its own rational Bézier curve."""
    if not 0.0 <= a < b <= 1.0:
        raise ValueError(f"need 0 <= a < b <= 1, got {a}, {b}")
    (PL, WL), _ = split(P, W, b)
    _, (PR, WR) = split(PL, WL, a / b)
    return PR, WR


def standardize_quad(P: ArrayLike, W: ArrayLike) -> tuple[FloatArray, float]:
    """Bring a quadratic rational with weights (w0, w1, w2) to standard form (1, w1 / sqrt(w0 w2), 1).

    Two operations leave the curve's point set and end points unchanged: scaling all weights by c
    (homogeneous coordinates), and the Möbius reparametrisation t -> ρt / ((1 − t) + ρt), which
    multiplies w_i by ρ^i. Choosing c = 1/w0 and ρ = sqrt(w0 / w2) makes both end weights 1.
    Returns (P (3, 2), w).
    """
    W = np.asarray(W, dtype=np.float64)
    if W.shape != (3,) or not np.all(W > 0):
        raise ValueError("a quadratic needs three positive weights")
    return np.array(P, dtype=np.float64), float(W[1] / math.sqrt(W[0] * W[2]))


def split_quad(P: ArrayLike, w: float, t: float = 0.5) -> tuple[tuple[FloatArray, float], ...]:
    """Split a standard-form quadratic at t into two standard-form quadratics ((P, w), (P, w)).

    At t = 1/2 both pieces have weight sqrt((1 + w) / 2).
    """
    (PL, WL), (PR, WR) = split(P, [1.0, w, 1.0], t)
    return standardize_quad(PL, WL), standardize_quad(PR, WR)


# --------------------------------------------------------------------------------------------------
# Flattening
# --------------------------------------------------------------------------------------------------


@overload
def flatten_quad(P: ArrayLike, w: float, tol: float, *, return_params: Literal[False] = False) -> FloatArray: ...


@overload
def flatten_quad(P: ArrayLike, w: float, tol: float, *, return_params: Literal[True]) -> tuple[FloatArray, FloatArray]:
    ...


@overload
def flatten_quad(
    P: ArrayLike, w: float, tol: float, *, return_params: bool = False
) -> FloatArray | tuple[FloatArray, FloatArray]: ...


def flatten_quad(
    P: ArrayLike, w: float, tol: float, *, return_params: bool = False
) -> FloatArray | tuple[FloatArray, FloatArray]:
    """Polyline through points of a standard-form quadratic, within ``tol`` mm of the curve.

    Returns (k, 2) float including both end points (and the (k,) parameters if asked).

    Adaptive bisection in the parameter. For the piece on [a, b] the control points are the
    homogeneous blossoms B(a, a), B(a, b), B(b, b); in standard form with weight w' its largest
    distance from the chord *line* is exactly h w' / (1 + w') (h: distance of the middle control point
    from that line, attained at the piece's own midpoint). When the middle control point projects
    inside the chord, the whole control triangle - and so the curve - does too, and that number is
    also the distance to the chord *segment*, in both directions (Hausdorff). A piece is accepted only
    then, so the guarantee is exact, not estimated.
    """
    if not tol > 0:
        raise ValueError(f"tolerance must be positive, got {tol}")
    H = _homogeneous(P, [1.0, w, 1.0])

    def blossom(u: FloatArray, v: FloatArray) -> FloatArray:
        c0 = (1.0 - u) * (1.0 - v)
        c1 = (1.0 - u) * v + u * (1.0 - v)
        c2 = u * v
        return c0[:, None] * H[0] + c1[:, None] * H[1] + c2[:, None] * H[2]

    # The sagitta of a piece shrinks about like 1/n² when it is cut into n equal parameter pieces, so
    # a piece failing with sagitta s is cut into ≈ sqrt(s / tol) pieces (at least 2) rather than
    # bisected: that lands close to the fewest segments instead of up to twice as many.
    def pieces(sag: FloatArray) -> NDArray[np.int64]:
        with np.errstate(invalid="ignore"):
            k = np.ceil(1.1 * np.sqrt(np.nan_to_num(sag, nan=0.0) / tol))
        return np.clip(k, 2, 64).astype(np.int64)

    a, b, k = np.array([0.0]), np.array([1.0]), np.array([1])
    done: list[FloatArray] = []
    for depth in range(64):
        if depth > 0:
            j = np.repeat(np.arange(len(a)), k)
            i = np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
            span = (b - a)[j] / k[j]
            a, b = a[j] + i * span, a[j] + (i + 1) * span
        Ha, Hm, Hb = blossom(a, a), blossom(a, b), blossom(b, b)
        pa, pm, pb = (X[:, :2] / X[:, 2:] for X in (Ha, Hm, Hb))
        ws = Hm[:, 2] / np.sqrt(Ha[:, 2] * Hb[:, 2])
        chord = pb - pa
        L2 = np.einsum("ij,ij->i", chord, chord)
        rel = pm - pa
        with np.errstate(invalid="ignore", divide="ignore"):
            sag = np.abs(chord[:, 0] * rel[:, 1] - chord[:, 1] * rel[:, 0]) / np.sqrt(L2) * ws / (1.0 + ws)
            proj = np.einsum("ij,ij->i", rel, chord) / L2
        # A zero chord (the piece returns to its start) cannot be judged by a chord: split it.
        ok = (L2 > 0) & (sag <= tol) & (proj >= 0.0) & (proj <= 1.0)
        if depth == 63:
            ok[:] = True
        done.append(a[ok])
        a, b, k = a[~ok], b[~ok], pieces(sag[~ok])
        if a.size == 0:
            break
    ts = np.concatenate([np.sort(np.concatenate(done)), [1.0]])
    pts = evaluate(P, [1.0, w, 1.0], ts)
    pts[0], pts[-1] = np.asarray(P, dtype=np.float64)[0], np.asarray(P, dtype=np.float64)[-1]
    return (pts, ts) if return_params else pts


def flatten(P: ArrayLike, W: ArrayLike, tol: float) -> FloatArray:
    """Polyline within ``tol`` mm of a rational Bézier curve of any degree: (k, d) float, both ends.

    A piece is accepted when every control point lies within tol of the chord segment: the curve is in
    the convex hull of its control points (positive weights) and the distance to a segment is convex,
    so that bounds the whole piece. Quadratics use the sharper exact test of :func:`flatten_quad`.
    """
    P = np.asarray(P, dtype=np.float64)
    W = np.asarray(W, dtype=np.float64)
    if P.shape[0] == 3 and P.shape[1] == 2:
        Ps, ws = standardize_quad(P, W)
        return flatten_quad(Ps, ws, tol)
    if not tol > 0:
        raise ValueError(f"tolerance must be positive, got {tol}")

    def rec(Pc: FloatArray, Wc: FloatArray, depth: int) -> list[FloatArray]:
        d = point_segment_distance(Pc, Pc[0], Pc[-1])
        if depth >= 40 or float(d.max()) <= tol:
            return [Pc[0]]
        (PL, WL), (PR, WR) = split(Pc, Wc, 0.5)
        return rec(PL, WL / WL[0], depth + 1) + rec(PR, WR / WR[0], depth + 1)

    return np.array([*rec(P, W, 0), P[-1]])


def point_segment_distance(X: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Distances (m,) from points X (m, d) to the segment [a, b]."""
    ab = b - a
    L2 = float(ab @ ab)
    s = np.zeros(len(X)) if L2 == 0 else np.clip((X - a) @ ab / L2, 0.0, 1.0)
    return np.linalg.norm(X - (a + s[:, None] * ab), axis=1)


# --------------------------------------------------------------------------------------------------
# Green's-theorem integrals, arc length, bounding box
# --------------------------------------------------------------------------------------------------


def cross2d(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """z-component of the cross product of 2D vectors (..., 2): (...)."""
    a, b = np.asarray(a), np.asarray(b)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def segment_area_ratio(w: float) -> float:
    """Area between a standard-form conic arc and its chord, as a fraction of its control triangle.

    Affine maps keep area ratios, and every w < 1 arc is the affine image of a circular arc of
    half-angle α = arccos w; the circular segment R²(α − sin α cos α) over the triangle
    R² sin³α / cos α gives f = w (arccos w − w √(1 − w²)) / (1 − w²)^{3/2}. The hyperbolic case
    (w > 1) is the same function continued (α = iβ): f = w (w √(w² − 1) − arcosh w) / (w² − 1)^{3/2},
    and w = 1 is Archimedes' parabolic segment, 2/3. Near w = 1 both forms cancel badly, so there the
    series f = 2w Σ_k C(2k, k)/4^k x^k / (2k + 3) with x = 1 − w² is summed instead (it follows from
    d/ds [arcsin s − s √(1 − s²)] = 2 s² / √(1 − s²)).
    """
    if not w > 0:
        raise ValueError(f"weight must be positive, got {w}")
    x = 1.0 - w * w
    if abs(x) < 0.3:
        total, c, xk = 0.0, 1.0, 1.0
        for k in range(60):
            term = c * xk / (2 * k + 3)
            total += term
            if abs(term) < 1e-18 * abs(total):
                break
            c *= (2 * k + 1) / (2 * k + 2)
            xk *= x
        return 2.0 * w * total
    if x > 0:
        s = math.sqrt(x)
        return w * (math.asin(s) - s * w) / (s * s * s)
    s = math.sqrt(-x)
    return w * (s * w - math.asinh(s)) / (s * s * s)


def quad_area(P: ArrayLike, w: float) -> float:
    """Exact ∫ (x dy − y dx) / 2 along a standard-form quadratic from P0 to P2 (mm²).

    Summed around a closed loop this is the loop's signed area. It is the chord's term P0 × P2 / 2
    plus the signed area between the arc and its chord, f(w) times the signed control-triangle area
    (:func:`segment_area_ratio`, closed form).
    """
    # plain floats: the same IEEE operations as the array form, without its per-call overhead
    (x0, y0), (x1, y1), (x2, y2) = np.asarray(P, dtype=np.float64).tolist()
    tri = 0.5 * ((x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0))
    return 0.5 * (x0 * y2 - y0 * x2) + segment_area_ratio(w) * tri


@lru_cache(maxsize=4)
def _gauss_legendre(n: int) -> tuple[FloatArray, FloatArray]:
    x, wt = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * wt


def _quad_pieces(P: FloatArray, w: float) -> list[tuple[FloatArray, float]]:
    """Split a standard-form quadratic until every piece's weight lies in [0.5, 2]."""
    if 0.5 <= w <= 2.0:
        return [(P, w)]
    (PL, wL), (PR, wR) = split_quad(P, w, 0.5)
    return _quad_pieces(PL, wL) + _quad_pieces(PR, wR)


def quad_polar_moment(P: ArrayLike, w: float) -> float:
    """∫ (x² + y²)(x dy − y dx) / 4 along a standard-form quadratic (mm⁴), to machine precision.

    Summed around a closed loop this is the polar moment ∫∫ (x² + y²) dA of the enclosed region.

    Gauss–Legendre quadrature, documented rather than closed form: the integrand is the rational
    function |A|² (A × A') / W⁴ of degree ≤ 6 over 8 (A, W the homogeneous numerator and weight).
    The poles of 1/W are at t = 1/2 ± i/2 √((1 + w)/(1 − w)) (w < 1) or 1/2 ± ½√((w + 1)/(w − 1))
    (w > 1). After exact splitting until w ∈ [0.5, 2] they lie outside the Bernstein ellipse with
    ρ ≥ 3.1, so 24 points converge like ρ^{-48} < 1e-23: the result is exact to rounding.
    """
    P = np.asarray(P, dtype=np.float64)
    x, wt = _gauss_legendre(24)
    total = 0.0
    for Pi, wi in _quad_pieces(P, float(w)):
        C = evaluate(Pi, [1.0, wi, 1.0], x)
        D = derivative(Pi, [1.0, wi, 1.0], x)
        total += float(np.sum(wt * np.einsum("ij,ij->i", C, C) * cross2d(C, D))) / 4.0
    return total


def quad_arc_length(P: ArrayLike, w: float, a: float = 0.0, b: float = 1.0) -> float:
    """Arc length (mm) of a standard-form quadratic between parameters a and b.

    Adaptive Gauss–Kronrod (QUADPACK via scipy.integrate.quad) on the exact speed |C'(t)|, written
    with plain floats so each of the few dozen evaluations costs a microsecond; relative accuracy
    1e-12 is requested (the brief asks 1e-10).
    """
    (x0, y0), (x1, y1), (x2, y2) = np.asarray(P, dtype=np.float64).tolist()
    w = float(w)

    def speed(t: float) -> float:
        s = 1.0 - t
        b0, b1, b2 = s * s, 2.0 * w * t * s, t * t
        d0, d1, d2 = -2.0 * s, 2.0 * w * (1.0 - 2.0 * t), 2.0 * t
        Wt = b0 + b1 + b2
        dW = d0 + d1 + d2
        ax, ay = b0 * x0 + b1 * x1 + b2 * x2, b0 * y0 + b1 * y1 + b2 * y2
        dax, day = d0 * x0 + d1 * x1 + d2 * x2, d0 * y0 + d1 * y1 + d2 * y2
        return math.hypot(dax * Wt - ax * dW, day * Wt - ay * dW) / (Wt * Wt)

    value, _ = _scipy_quad(speed, a, b, epsabs=0.0, epsrel=1e-12, limit=200)
    return float(value)


def arc_length(P: ArrayLike, W: ArrayLike, a: float = 0.0, b: float = 1.0) -> float:
    """Arc length (mm) of a rational Bézier curve of any degree, adaptive Gauss–Kronrod, rel 1e-12."""
    P = np.asarray(P, dtype=np.float64)
    W = np.asarray(W, dtype=np.float64)
    if P.shape == (3, 2):
        Ps, ws = standardize_quad(P, W)
        # The Möbius map to standard form changes parameters; only the full curve maps to itself.
        if a == 0.0 and b == 1.0:
            return quad_arc_length(Ps, ws)

    def speed(t: float) -> float:
        return float(np.linalg.norm(derivative(P, W, t)))

    value, _ = _scipy_quad(speed, a, b, epsabs=0.0, epsrel=1e-12, limit=200)
    return float(value)


def _power_coefficients(P: FloatArray, W: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Power-basis coefficients (ascending) of the homogeneous numerator (n+1, d) and weight (n+1,)."""
    n = len(W) - 1
    # Bernstein B_{i,n}(t) = C(n, i) t^i (1 − t)^(n − i) in the power basis, rows = i.
    B = np.zeros((n + 1, n + 1))
    for i in range(n + 1):
        B[i, i:] = math.comb(n, i) * np.atleast_1d(npoly.polypow([1.0, -1.0], n - i))
    return B.T @ (P * W[:, None]), B.T @ W


def extrema_params(P: ArrayLike, W: ArrayLike) -> FloatArray:
    """Parameters in (0, 1) where some coordinate of the curve has a stationary point, sorted (m,).

    Each coordinate's derivative numerator A_k' h − A_k h' is a polynomial; its real roots are exact
    candidates for the bounding box.
    """
    P = np.asarray(P, dtype=np.float64)
    W = np.asarray(W, dtype=np.float64)
    A, h = _power_coefficients(P, W)
    roots: list[float] = []
    for k in range(P.shape[1]):
        num = npoly.polysub(npoly.polymul(npoly.polyder(A[:, k]), h), npoly.polymul(A[:, k], npoly.polyder(h)))
        num = npoly.polytrim(num, tol=1e-14 * (np.abs(num).max() + 1e-300))
        if len(num) < 2:
            continue
        for r in npoly.polyroots(num):
            if abs(r.imag) < 1e-12 and 0.0 < r.real < 1.0:
                roots.append(float(r.real))
    return np.array(sorted(roots))


def quad_bbox(P: ArrayLike, w: float) -> FloatArray:
    """Exact bounding box of a standard-form quadratic: (2, 2) float [[xmin, ymin], [xmax, ymax]]."""
    P = np.asarray(P, dtype=np.float64)
    t = np.concatenate([[0.0, 1.0], extrema_params(P, [1.0, w, 1.0])])
    X = evaluate(P, [1.0, w, 1.0], t)
    return np.stack([X.min(axis=0), X.max(axis=0)])

def rot90(v: FloatArray) -> FloatArray:
    """Vectors (2,) or (m, 2) turned a quarter counter-clockwise."""
    return np.array([-v[..., 1], v[..., 0]]).T if v.ndim > 1 else np.array([-v[1], v[0]])
