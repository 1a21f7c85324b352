"""Cubic Bézier approximation of rational quadratic arcs and circular (bulge) arcs, within a tolerance.

For cutter software that reads only lines and cubic Béziers (no rotated elliptical arcs). A
standard-form rational quadratic (P0, P1, P2; weights 1, w, 1) is replaced by the cubic with the
same end points and end tangents whose inner control points lie λ = 4w / (3(1 + w)) along the legs
(P1 − P0 and P1 − P2): it also passes through the arc's midpoint (P0 + 2w P1 + P2) / (2(1 + w)),
since the cubic's midpoint is (P0 + 3 C1 + 3 C2 + P2) / 8. For w = 1 it is the exact degree
elevation of the parabola; for a quarter circle (w = cos 45°) λ = 0.5523, the usual circle constant.
An arc whose cubic misses by more than the tolerance is split at its middle (exactly, by de
Casteljau) and each half approximated again; the error of this cubic falls like the sixth power
of the arc's turning angle, so one or two splits are typical at 0.01 mm.

Error check: the larger of the two one-sided distances between 65 points on the cubic and a
flattening of the exact arc within tol / 20 (:func:`fabpat.geometry.curves.flatten_quad`) and the reverse;
an arc is accepted when that is ≤ 0.8 × tol, the 20 % kept for what lies between the samples.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError

_SAMPLES = 65
_MAX_DEPTH = 16  # 2**16 pieces per arc: far beyond any tolerance a cutter can hold


def _cubic(P: NDArray[np.float64], w: float) -> NDArray[np.float64]:
    lam = 4.0 * w / (3.0 * (1.0 + w))
    return np.array([P[0], P[0] + lam * (P[1] - P[0]), P[2] + lam * (P[1] - P[2]), P[2]])


def cubic_points(C: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.float64]:
    """(m, 2) points of the cubic Bézier C (4, 2) at parameters t (m,)."""
    s = 1.0 - t
    B = np.stack([s**3, 3 * s * s * t, 3 * s * t * t, t**3], axis=1)
    return B @ C


def _segment_distance(X: NDArray[np.float64], P: NDArray[np.float64]) -> NDArray[np.float64]:
    """(m,) distances from points X (m, 2) to the open polyline P (k, 2)."""
    A, D = P[:-1], np.diff(P, axis=0)
    L2 = np.maximum(np.einsum("ij,ij->i", D, D), 1e-300)
    s = np.clip(np.einsum("mkj,kj->mk", X[:, None, :] - A[None], D) / L2, 0.0, 1.0)
    return np.hypot(*(X[:, None, :] - A[None] - s[..., None] * D[None]).transpose(2, 0, 1)).min(axis=1)


def cubic_error(C: NDArray[np.float64], P: NDArray[np.float64], w: float, tol: float) -> float:
    """Sampled two-sided distance (mm) between the cubic C (4, 2) and the rational arc (P, w)."""
    from fabpat.geometry.curves import flatten_quad

    exact = np.asarray(flatten_quad(P, w, tol / 20.0))
    approx = cubic_points(C, np.linspace(0.0, 1.0, _SAMPLES))
    return max(float(_segment_distance(approx, exact).max()), float(_segment_distance(exact, approx).max()))


def _fit(P: NDArray[np.float64], w: float, tol: float, depth: int = 0) -> list[NDArray[np.float64]]:
    from fabpat.geometry.curves import split_quad

    C = _cubic(P, w)
    if cubic_error(C, P, w, tol) <= 0.8 * tol:
        return [C]
    if depth >= _MAX_DEPTH:
        raise GeometryError(f"cannot approximate an arc by cubic Béziers within {tol:g} mm")
    (PL, wL), (PR, wR) = split_quad(P, w, 0.5)
    return _fit(PL, wL, tol, depth + 1) + _fit(PR, wR, tol, depth + 1)


_CACHE: dict[tuple[float, ...], NDArray[np.float64]] = {}
_CACHE_SIZE = 8192


def quad_to_cubics(P: NDArray[np.float64], w: float, tol: float) -> list[NDArray[np.float64]]:
    """Cubic Béziers (each (4, 2), in order, head to tail) within ``tol`` mm of the rational arc.

    ``P`` (3, 2) mm control points of a standard-form arc with middle weight ``w`` > 0. Raises
    :class:`GeometryError` if ``_MAX_DEPTH`` halvings do not reach ``tol``. The fit is done with
    the arc moved to P0 = origin, chord along +x, and cached (a fit is invariant under rigid
    motions, and a pattern repeats its arcs by symmetry), as :func:`fabpat.exchange.contours.fitted_arcs` does.
    """
    P = np.asarray(P, dtype=np.float64)
    chord = P[2] - P[0]
    length = float(np.hypot(*chord))
    if length == 0.0:
        return _fit(P, w, tol)
    c, s = chord / length
    R = np.array([[c, s], [-s, c]])  # rotates the chord onto +x
    q = R @ (P[1] - P[0])
    key = (round(float(q[0]), 10), round(float(q[1]), 10), round(length, 10), w, tol)
    fits = _CACHE.get(key)
    if fits is None:
        fits = np.array(_fit(np.array([[0.0, 0.0], q, [length, 0.0]]), w, tol))
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.clear()
        _CACHE[key] = fits
    out = fits @ R + P[0]
    out[0, 0], out[-1, -1] = P[0], P[2]  # the ends exactly where the neighbours start and end
    return list(out)


def bulge_to_quads(
    s: NDArray[np.float64], e: NDArray[np.float64], bulge: float
) -> list[tuple[NDArray[np.float64], float]]:
    """A circular bulge arc (sweep θ = 4 atan(bulge)) as rational quadratics of ≤ 90° each.

    A circular arc of sweep φ < π from A to B is the standard-form arc with P1 at the tangents'
    intersection and w = cos(φ / 2) (Piegl & Tiller, *The NURBS Book*, §7.3).
    """
    from fabpat.geometry.conics import arc_center_radius, arc_points

    c, R, theta = arc_center_radius(s, e, bulge)
    n = max(1, math.ceil(abs(theta) / (0.5 * math.pi) - 1e-12))
    pts = arc_points(s, e, bulge, n + 1)
    phi = abs(theta) / n
    out = []
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        mid = 0.5 * (a + b)
        d = mid - c
        P1 = c + d * (R / (math.cos(0.5 * phi) * float(np.hypot(*d))))
        out.append((np.array([a, P1, b]), math.cos(0.5 * phi)))
    return out
