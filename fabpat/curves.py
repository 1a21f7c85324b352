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

Everything here is pure numpy (plus scipy's adaptive quadrature for arc length); the only fabpat
import is the error hierarchy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np
from numpy.polynomial import polynomial as npoly
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import quad as _scipy_quad

from fabpat.errors import GeometryError

FloatArray = NDArray[np.float64]
ArcTriple = tuple[tuple[float, float], tuple[float, float], float]
"""One LWPOLYLINE piece: (start (x, y), end (x, y), bulge = tan(sweep / 4), > 0 counter-clockwise)."""

__all__ = [
    "ArcTriple",
    "Conic",
    "EllipseArc",
    "arc_center_radius",
    "arc_length",
    "arc_points",
    "cross2d",
    "biarc",
    "derivative",
    "evaluate",
    "fit_arcs",
    "flatten",
    "flatten_quad",
    "point_arc_distance",
    "quad_area",
    "quad_arc_length",
    "quad_bbox",
    "quad_polar_moment",
    "quad_to_conic",
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
        return flatten_quad(Ps, ws, tol)  # type: ignore[return-value]
    if not tol > 0:
        raise ValueError(f"tolerance must be positive, got {tol}")

    def rec(Pc: FloatArray, Wc: FloatArray, depth: int) -> list[FloatArray]:
        d = _point_segment_distance(Pc, Pc[0], Pc[-1])
        if depth >= 40 or float(d.max()) <= tol:
            return [Pc[0]]
        (PL, WL), (PR, WR) = split(Pc, Wc, 0.5)
        return rec(PL, WL / WL[0], depth + 1) + rec(PR, WR / WR[0], depth + 1)

    return np.array([*rec(P, W, 0), P[-1]])


def _point_segment_distance(X: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
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


# --------------------------------------------------------------------------------------------------
# Conversion to a conic (for DXF ELLIPSE and SVG elliptical arcs)
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class EllipseArc:
    """An elliptical arc in the form of a DXF ELLIPSE entity (ezdxf ``add_ellipse``).

    Points are ``center + major_axis cos ψ + ratio · rot90(major_axis) sin ψ`` for ψ running
    counter-clockwise from ``start_param`` to ``end_param`` (radians, end > start). ``major_axis``
    (2,) has the length of the semi-major axis; ``ratio`` = minor / major ∈ (0, 1]. ``reversed`` is
    True when that counter-clockwise run goes from the Bézier arc's P2 to its P0.
    """

    center: tuple[float, float]
    major_axis: tuple[float, float]
    ratio: float
    start_param: float
    end_param: float
    reversed: bool

    def point(self, psi: ArrayLike) -> FloatArray:
        """Points at ellipse parameters psi (float or (m,)): (2,) or (m, 2) float, mm."""
        psi = np.asarray(psi, dtype=np.float64)
        c, M = np.array(self.center), np.array(self.major_axis)
        m = self.ratio * np.array([-M[1], M[0]])
        return c + np.multiply.outer(np.cos(psi), M) + np.multiply.outer(np.sin(psi), m)

    @property
    def semi_axes(self) -> tuple[float, float]:
        a = math.hypot(*self.major_axis)
        return a, a * self.ratio

    @property
    def rotation(self) -> float:
        """Angle of the major axis from +x, radians."""
        return math.atan2(self.major_axis[1], self.major_axis[0])


@dataclass(frozen=True)
class Conic:
    """The conic carrying a quadratic rational arc.

    ``coefficients`` (A, B, C, D, E, F), unit norm: A x² + B xy + C y² + D x + E y + F = 0.
    ``ellipse`` is set for kind == "ellipse".
    """

    kind: Literal["ellipse", "parabola", "hyperbola"]
    coefficients: tuple[float, float, float, float, float, float]
    ellipse: EllipseArc | None = None


def rot90(v: FloatArray) -> FloatArray:
    """Vectors (2,) or (m, 2) turned a quarter counter-clockwise."""
    return np.array([-v[..., 1], v[..., 0]]).T if v.ndim > 1 else np.array([-v[1], v[0]])


def quad_to_conic(P: ArrayLike, w: float, *, parabola_atol: float = 1e-12) -> Conic:
    """The conic of a standard-form quadratic; for an ellipse also the DXF-ready elliptical arc.

    In barycentric coordinates τ of the control triangle the curve is τ1² = 4 w² τ0 τ2
    (substitute τ = ((1 − t)², 2wt(1 − t), t²) / W); composing with the affine map xy → τ gives the
    implicit coefficients. For w < 1 the centre is the pole of the line at infinity,
    c = (M − w² P1) / (1 − w²) with M the chord midpoint, and the arc is
    c + a cos φ + b sin φ, φ ∈ [−arccos w, arccos w], with conjugate semi-diameters
    a = w (P1 − M) / (1 − w²) and b = (P2 − P0) / (2 √(1 − w²)); an SVD of [a b] gives the axes.

    Raises GeometryError for collinear control points (the arc is a segment, not a conic).
    """
    P = np.asarray(P, dtype=np.float64)
    T = np.vstack([P.T, np.ones(3)])  # columns: homogeneous vertices of the control triangle
    scale = max(float(np.ptp(P, axis=0).max()), 1e-300)
    if abs(np.linalg.det(T)) <= 1e-13 * scale * scale:
        raise GeometryError("collinear control points: the arc is a straight segment, not a conic")
    L = np.linalg.inv(T)  # (x, y, 1) -> barycentric τ
    Qb = np.array([[0.0, 0.0, -2.0 * w * w], [0.0, 1.0, 0.0], [-2.0 * w * w, 0.0, 0.0]])
    Q = L.T @ Qb @ L
    coef = np.array([Q[0, 0], 2 * Q[0, 1], Q[1, 1], 2 * Q[0, 2], 2 * Q[1, 2], Q[2, 2]])
    coef /= np.linalg.norm(coef)
    coefs = tuple(float(c) for c in coef)
    if abs(w - 1.0) <= parabola_atol:
        return Conic("parabola", coefs)  # type: ignore[arg-type]
    if w > 1.0:
        return Conic("hyperbola", coefs)  # type: ignore[arg-type]

    M = 0.5 * (P[0] + P[2])
    c = (M - w * w * P[1]) / (1.0 - w * w)
    a = w * (P[1] - M) / (1.0 - w * w)
    b = (P[2] - P[0]) / (2.0 * math.sqrt(1.0 - w * w))
    U, S, _ = np.linalg.svd(np.column_stack([a, b]))
    e1 = U[:, 0]
    e2 = rot90(e1)

    def param(p: FloatArray) -> float:
        d = p - c
        return math.atan2(float(d @ e2) / S[1], float(d @ e1) / S[0])

    shoulder = (M + w * P[1]) / (1.0 + w)
    psi0, psiS, psi2 = param(P[0]), param(shoulder), param(P[2])
    two_pi = 2.0 * math.pi
    ccw = (psiS - psi0) % two_pi < (psi2 - psi0) % two_pi
    start, end = (psi0, psi2) if ccw else (psi2, psi0)
    end = start + (end - start) % two_pi
    arc = EllipseArc(
        center=(float(c[0]), float(c[1])),
        major_axis=(float(e1[0] * S[0]), float(e1[1] * S[0])),
        ratio=float(S[1] / S[0]),
        start_param=float(start),
        end_param=float(end),
        reversed=not ccw,
    )
    return Conic("ellipse", coefs, arc)  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------------
# Circular arcs with bulges (DXF LWPOLYLINE) and biarc fitting
# --------------------------------------------------------------------------------------------------


def arc_center_radius(start: ArrayLike, end: ArrayLike, bulge: float) -> tuple[FloatArray, float, float]:
    """Centre (2,), radius (mm) and signed sweep θ (rad, > 0 counter-clockwise) of a bulge arc.

    bulge = tan(θ / 4). Radius is inf for bulge 0 (a straight piece; the centre is then the midpoint).
    """
    s, e = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    theta = 4.0 * math.atan(bulge)
    chord = e - s
    L = float(np.hypot(*chord))
    mid = 0.5 * (s + e)
    if abs(theta) < 1e-12 or L == 0.0:
        return mid, math.inf, theta
    n = rot90(chord) / L
    centre = mid + n * (0.5 * L / math.tan(0.5 * theta))
    return centre, 0.5 * L / abs(math.sin(0.5 * theta)), theta


def arc_points(start: ArrayLike, end: ArrayLike, bulge: float, n: int) -> FloatArray:
    """n >= 2 points evenly spaced along a bulge arc, both ends included: (n, 2) float."""
    s, e = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    c, R, theta = arc_center_radius(s, e, bulge)
    u = np.linspace(0.0, 1.0, n)
    if not math.isfinite(R):
        return s + u[:, None] * (e - s)
    phi0 = math.atan2(s[1] - c[1], s[0] - c[0])
    phi = phi0 + theta * u
    out = c + R * np.column_stack([np.cos(phi), np.sin(phi)])
    out[0], out[-1] = s, e
    return out


def point_arc_distance(X: ArrayLike, start: ArrayLike, end: ArrayLike, bulge: float) -> FloatArray:
    """Distances (m,) from points X (m, 2) to a bulge arc (exact: radial if within the sweep)."""
    X = np.atleast_2d(np.asarray(X, dtype=np.float64))
    s, e = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    c, R, theta = arc_center_radius(s, e, bulge)
    if not math.isfinite(R):
        return _point_segment_distance(X, s, e)
    d = X - c
    phi0 = math.atan2(s[1] - c[1], s[0] - c[0])
    rel = np.arctan2(d[:, 1], d[:, 0]) - phi0
    rel = np.mod(rel if theta > 0 else -rel, 2.0 * math.pi)
    inside = rel <= abs(theta)
    radial = np.abs(np.hypot(d[:, 0], d[:, 1]) - R)
    ends = np.minimum(np.linalg.norm(X - s, axis=1), np.linalg.norm(X - e, axis=1))
    return np.where(inside, radial, ends)


def biarc(p1: ArrayLike, t1: ArrayLike, p2: ArrayLike, t2: ArrayLike) -> list[ArcTriple]:
    """Two circular arcs from p1 (unit tangent t1) to p2 (unit tangent t2), G1 at the joint.

    Equal-tangent-length construction: q1 = p1 + d t1, q2 = p2 − d t2 with |q2 − q1| = 2d; the joint
    is their midpoint. d solves 2(1 − t1·t2) d² + 2 v·(t1 + t2) d − |v|² = 0, written in the form that
    stays accurate as t1 → t2.
    """
    p1, t1, p2, t2 = (np.asarray(x, dtype=np.float64) for x in (p1, t1, p2, t2))
    v = p2 - p1
    vt = float(v @ (t1 + t2))
    vv = float(v @ v)
    disc = vt * vt + 2.0 * (1.0 - float(t1 @ t2)) * vv
    d = vv / (vt + math.sqrt(max(disc, 0.0)))
    pm = 0.5 * ((p1 + d * t1) + (p2 - d * t2))
    c1, c2 = pm - p1, p2 - pm
    th1 = 2.0 * math.atan2(float(cross2d(t1, c1)), float(t1 @ c1))
    th2 = 2.0 * math.atan2(float(cross2d(c2, t2)), float(c2 @ t2))
    P1, PM, P2 = (tuple(float(x) for x in p) for p in (p1, pm, p2))
    return [(P1, PM, math.tan(th1 / 4.0)), (PM, P2, math.tan(th2 / 4.0))]  # type: ignore[list-item]


def _arcs_deviation(arcs: list[ArcTriple], curve: FloatArray) -> float:
    """Symmetric sampled deviation between arcs and a dense curve polyline curve (m, 2), mm."""
    d_curve = np.min([point_arc_distance(curve, s, e, b) for s, e, b in arcs], axis=0)
    arc_pts = np.vstack([arc_points(s, e, b, 33) for s, e, b in arcs])
    d_arc = _points_polyline_distance(arc_pts, curve)
    return float(max(d_curve.max(), d_arc.max()))


def _points_polyline_distance(X: FloatArray, V: FloatArray) -> FloatArray:
    """Distances (m,) from points X (m, 2) to the open polyline V (k, 2)."""
    A, B = V[:-1], V[1:]
    AB = B - A
    L2 = np.maximum(np.einsum("ij,ij->i", AB, AB), 1e-300)
    s = np.clip(np.einsum("mkj,kj->mk", X[:, None, :] - A[None], AB) / L2, 0.0, 1.0)
    proj = A[None] + s[..., None] * AB[None]
    return np.sqrt(((X[:, None, :] - proj) ** 2).sum(-1)).min(axis=1)


def fit_arcs(P: ArrayLike, w: float, tol: float, *, samples: int = 65) -> list[ArcTriple]:
    """Circular arcs (a G1 arc spline of biarcs) within ``tol`` mm of a standard-form quadratic.

    Returns the pieces in order from P0 to P2 as (start, end, bulge) triples for a DXF LWPOLYLINE.
    Each parameter interval gets a biarc matching the curve's end points and tangents; the deviation
    is measured both ways on ``samples`` curve points per interval (exact point-to-arc distances)
    and 33 points per arc, and an interval whose deviation exceeds 0.8 tol is bisected. The 20 %
    margin covers what falls between samples: the error of a biarc is a smooth function of the
    parameter with only a few extrema. A circular arc (|P0P1| = |P1P2|, w = cos of the leg-chord
    angle) is returned as one exact arc; collinear control points as one straight piece.
    """
    if not tol > 0:
        raise ValueError(f"tolerance must be positive, got {tol}")
    P = np.asarray(P, dtype=np.float64)
    W = np.array([1.0, w, 1.0])
    l0, l1, chord = (float(np.hypot(*v)) for v in (P[1] - P[0], P[2] - P[1], P[2] - P[0]))
    start, end = tuple(P[0].tolist()), tuple(P[2].tolist())
    if abs(float(cross2d(P[1] - P[0], P[2] - P[0]))) <= 1e-14 * max(l0, l1, chord) ** 2:
        return [(start, end, 0.0)]  # type: ignore[list-item]
    beta = math.acos(max(-1.0, min(1.0, float((P[1] - P[0]) @ (P[2] - P[0])) / (l0 * chord))))
    if abs(l0 - l1) <= 1e-12 * l0 and abs(w - math.cos(beta)) <= 1e-12:
        sign = 1.0 if cross2d(P[1] - P[0], P[2] - P[1]) > 0 else -1.0
        return [(start, end, sign * math.tan(beta / 2.0))]  # type: ignore[list-item]

    def unit_tangent(t: float) -> FloatArray:
        d = derivative(P, W, t)
        return d / np.hypot(*d)

    def fit(a: float, b: float, depth: int) -> list[ArcTriple]:
        ts = np.linspace(a, b, samples)
        curve = evaluate(P, W, ts)
        arcs = biarc(curve[0], unit_tangent(a), curve[-1], unit_tangent(b))
        if depth >= 40 or _arcs_deviation(arcs, curve) <= 0.8 * tol:
            return arcs
        m = 0.5 * (a + b)
        return fit(a, m, depth + 1) + fit(m, b, depth + 1)

    out = fit(0.0, 1.0, 0)
    out[0] = (start, out[0][1], out[0][2])  # type: ignore[assignment]
    out[-1] = (out[-1][0], end, out[-1][2])  # type: ignore[assignment]
    return out
