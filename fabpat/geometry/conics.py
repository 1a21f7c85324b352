"""Other exact or toleranced forms of the outline's arcs, for the file formats that need them.

* :func:`quad_to_conic`: the conic carrying a standard-form quadratic (ellipse parameters for DXF
  ``ELLIPSE`` and SVG ``A`` commands; implicit coefficients for the parabola and hyperbola).
* Circular arcs given by (start, end, bulge) as in a DXF ``LWPOLYLINE``, and :func:`fit_arcs`, a G1
  biarc fit of a quadratic within a tolerance in mm (laser cutters want arcs and lines).

Conventions as in :mod:`fabpat.geometry.curves` (millimetres, ``(3, 2)`` control points, weights (1, w, 1)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from fabpat.errors import GeometryError
from fabpat.geometry.curves import FloatArray, cross2d, derivative, evaluate, point_segment_distance, rot90

ArcTriple = tuple[tuple[float, float], tuple[float, float], float]
"""One LWPOLYLINE piece: (start (x, y), end (x, y), bulge = tan(sweep / 4), > 0 counter-clockwise)."""

__all__ = [
    "ArcTriple",
    "Conic",
    "EllipseArc",
    "arc_center_radius",
    "arc_points",
    "biarc",
    "fit_arcs",
    "point_arc_distance",
    "quad_to_conic",
]

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
        """(a, b) in mm: semi-major and semi-minor axis lengths."""
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
    k0, k1, k2, k3, k4, k5 = (float(c) for c in coef)
    coefs = (k0, k1, k2, k3, k4, k5)
    if abs(w - 1.0) <= parabola_atol:
        return Conic("parabola", coefs)
    if w > 1.0:
        return Conic("hyperbola", coefs)

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
    return Conic("ellipse", coefs, arc)


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
        return point_segment_distance(X, s, e)
    d = X - c
    phi0 = math.atan2(s[1] - c[1], s[0] - c[0])
    rel = np.arctan2(d[:, 1], d[:, 0]) - phi0
    rel = np.mod(rel if theta > 0 else -rel, 2.0 * math.pi)
    inside = rel <= abs(theta)
    radial = np.abs(np.hypot(d[:, 0], d[:, 1]) - R)
    ends = np.minimum(np.linalg.norm(X - s, axis=1), np.linalg.norm(X - e, axis=1))
    return np.where(inside, radial, ends)


def _xy(p: FloatArray) -> tuple[float, float]:
    """A point (2,) as Python floats (x, y), mm."""
    return float(p[0]), float(p[1])


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
    P1, PM, P2 = (_xy(p) for p in (p1, pm, p2))
    return [(P1, PM, math.tan(th1 / 4.0)), (PM, P2, math.tan(th2 / 4.0))]


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
    start, end = _xy(P[0]), _xy(P[2])
    if abs(float(cross2d(P[1] - P[0], P[2] - P[0]))) <= 1e-14 * max(l0, l1, chord) ** 2:
        return [(start, end, 0.0)]
    beta = math.acos(max(-1.0, min(1.0, float((P[1] - P[0]) @ (P[2] - P[0])) / (l0 * chord))))
    if abs(l0 - l1) <= 1e-12 * l0 and abs(w - math.cos(beta)) <= 1e-12:
        sign = 1.0 if cross2d(P[1] - P[0], P[2] - P[1]) > 0 else -1.0
        return [(start, end, sign * math.tan(beta / 2.0))]

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
    out[0] = (start, out[0][1], out[0][2])
    out[-1] = (out[-1][0], end, out[-1][2])
    return out
