"""Open targets: surfaces of revolution for the open tilings (a dome on a ``hex-cap``, a profile on a ``hex-tube``).

Both targets are a meridian curve (radius ρ from the axis, height a along it) turned about the axis:

* ``cap:H`` — a spherical cap of rim radius 1 and height H (0 < H ≤ 1; 1 is a hemisphere): the arc of the
  sphere of radius (1 + H²) / (2H) from the apex (ρ, a) = (0, H) to the rim (1, 0).
* ``revolution:R0,R1,…,Rk`` — the radii (k ≥ 1) at k + 1 equally spaced stations along an axis of length 1
  (so the radii are in units of the length), joined by the interpolating cubic spline (a straight line for two
  radii): ``revolution:0.5,0.5`` is a cylinder whose length is twice its radius.

A target is bounded: the curve has ends, and a node beyond them is measured to the nearest end (the rim or a
tube's end circle), so the target's extent counts as well as its shape. The curve is sampled at
:data:`SAMPLES` points; the distance of a node is that to the nearest point of the sampled polyline in its
meridian plane (the polyline's chords are within (π / (2·SAMPLES))² / 2 ≈ 3e-7 of the curve's size).

**The size.** A free scale would let a bounded target grow until the nodes sit on a small part of it (measured:
the two-ring dome fitted cap:0.5, cap:0.7 and cap:1 equally, 3.9 %, as parts of larger spheres). So the
target's scale s (mm per target unit) is not fitted but makes it as large as the nodes: the RMS distance of
the nodes from their centroid equals s times the target surface's own (:func:`profile_size`, weighted by area;
the plates' nodes cover their surface nearly evenly). The error's derivative then has a term through s
(:attr:`fabpat.design.surface.SurfaceFit.extra`).

**The fit** (:func:`fit_to_profile`): the target moved and turned onto the nodes P (n, 3) mm — five
parameters: the origin c (3,) and the axis' direction (two small turns about the start frame's first two axes:
the turn about the axis itself changes nothing) — by Levenberg–Marquardt (:func:`scipy.optimize.least_squares`)
on the signed distances with a Jacobian by central differences of absolute steps, as the ellipsoid's
(:mod:`fabpat.design.surface`): on a seeded subset of :data:`fabpat.design.surface.FIT_POINTS` nodes, then
polished on every node, where the distances are measured. Start: the axis given (the tiling's design axis), the
origin at the nodes' lowest point along it (a cap: the apex at their highest).
``radius`` (the size ``relative_rms`` divides by): the RMS distance of P from its centroid, as for the
ellipsoid and mesh targets. The signed distance is positive outside (away from the axis on a tube, away from
the sphere's centre on a cap); its gradient with respect to each node, with the similarity held, is the
polyline's unit normal (or the unit vector from an end) turned back into space.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.design.surface import FIT_EVALUATIONS, FIT_POINTS, FIT_STEP, SurfaceFit, _frame_with, _rms_radius

if TYPE_CHECKING:  # pragma: no cover
    from scipy.spatial import cKDTree

Arr = NDArray[np.float64]

__all__ = ["SAMPLES", "cap_profile", "revolution_profile", "profile_size", "fit_to_profile"]

#: points of the sampled meridian curve
SAMPLES = 2001


def cap_profile(height: float) -> Arr:
    """(SAMPLES, 2) points (ρ, a) of the spherical cap of rim radius 1 and ``height`` H (0 < H ≤ 1), from the
    apex to the rim, so that the outward normal is the tangent turned by +90°."""
    R = (1.0 + height * height) / (2.0 * height)
    top = math.asin(min(1.0, 1.0 / R)) if height < 1.0 else 0.5 * math.pi
    phi = np.linspace(0.0, top, SAMPLES)
    return np.column_stack([R * np.sin(phi), height - R + R * np.cos(phi)])


def revolution_profile(radii: tuple[float, ...]) -> Arr:
    """(SAMPLES, 2) points (ρ, a) of the meridian through ``radii`` (k + 1 ≥ 2, at a = 0, 1/k, …, 1; a cubic
    spline through them, a line for two), from a = 1 down to a = 0 so that the outward normal is the tangent
    turned by +90°."""
    from scipy.interpolate import make_interp_spline

    r = np.asarray(radii, dtype=np.float64)
    t = np.linspace(0.0, 1.0, len(r))
    a = np.linspace(1.0, 0.0, SAMPLES)
    spline = make_interp_spline(t, r, k=min(3, len(r) - 1))
    return np.column_stack([spline(a), a])


def _nearest(S: Arr, tree: cKDTree, Q: Arr) -> tuple[Arr, Arr]:
    """Signed distances (m,) of the meridian points Q (m, 2) from the polyline S (k, 2) and their unit gradients
    (m, 2): the nearer of the two segments at the nearest sample (``tree`` its cKDTree)."""
    _, i = tree.query(Q)
    best_d = np.full(len(Q), np.inf)
    best_g = np.zeros((len(Q), 2))
    sign = np.ones(len(Q))
    for lo in (np.maximum(i - 1, 0), np.minimum(i, len(S) - 2)):
        A, B = S[lo], S[lo + 1]
        t = B - A
        u = np.clip(np.einsum("ij,ij->i", Q - A, t) / np.einsum("ij,ij->i", t, t), 0.0, 1.0)
        v = Q - (A + u[:, None] * t)
        d = np.linalg.norm(v, axis=1)
        normal = np.column_stack([-t[:, 1], t[:, 0]])  # the tangent turned by +90°: outward (module doc)
        s = np.where(np.einsum("ij,ij->i", v, normal) < 0.0, -1.0, 1.0)
        better = d < best_d
        best_d = np.where(better, d, best_d)
        sign = np.where(better, s, sign)
        unit = np.where((d > 1e-300)[:, None], v / np.maximum(d, 1e-300)[:, None],
                        normal / np.linalg.norm(normal, axis=1)[:, None])
        best_g = np.where(better[:, None], unit, best_g)
    return sign * best_d, sign[:, None] * best_g


def profile_size(S: Arr) -> float:
    """The RMS distance of the surface of revolution of meridian ``S`` (k, 2) from its centroid, weighted by area
    (each chord's ring: area ∝ ρ × length), in the profile's units."""
    mid = 0.5 * (S[1:] + S[:-1])
    w = mid[:, 0] * np.linalg.norm(np.diff(S, axis=0), axis=1)
    a = float(w @ mid[:, 1]) / float(w.sum())
    return math.sqrt(float(w @ (mid[:, 0] ** 2 + (mid[:, 1] - a) ** 2)) / float(w.sum()))


def fit_to_profile(P: Arr, S: Arr, axis: Arr, cap: bool) -> SurfaceFit:
    """The surface of revolution of meridian ``S`` (k, 2) points (ρ, a) (:func:`cap_profile`,
    :func:`revolution_profile`) fitted to the nodes P (n, 3) mm (module doc); ``axis`` (3,) the start direction
    of its axis, ``cap`` True for a cap (the origin starts below the nodes' highest point by the cap's height)."""
    from scipy.optimize import least_squares
    from scipy.spatial import cKDTree
    from scipy.spatial.transform import Rotation

    tree = cKDTree(S)
    size = _rms_radius(P)
    s = size / profile_size(S)  # the target as large as the nodes (module doc)
    R0 = _frame_with(np.asarray(axis, dtype=np.float64), 2)
    c = P.mean(axis=0)
    along = (P - c) @ R0[:, 2]
    c0 = c + (float(along.max()) - s * float(S[:, 1].max()) if cap else float(along.min())) * R0[:, 2]

    def meridian(x: Arr, P: Arr, scale: float = s) -> tuple[Arr, Arr, Arr]:
        R = R0 @ Rotation.from_rotvec([x[3], x[4], 0.0]).as_matrix()
        q = (P - x[:3]) @ R / scale
        return np.column_stack([np.linalg.norm(q[:, :2], axis=1), q[:, 2]]), q, R

    def dist(x: Arr, P: Arr, scale: float = s) -> Arr:
        return scale * _nearest(S, tree, meridian(x, P, scale)[0])[0]

    def jac(x: Arr, P: Arr) -> Arr:  # central differences of absolute steps (the ellipsoid's reason)
        steps = np.full(5, FIT_STEP * s)
        steps[3:] = FIT_STEP
        return np.column_stack([(dist(x + e, P) - dist(x - e, P)) / (2.0 * e[j])
                                for j, e in enumerate(np.diag(steps))])

    sub = P[np.random.default_rng(0).permutation(len(P))[:FIT_POINTS]] if len(P) > FIT_POINTS else P
    x0 = np.concatenate([c0, [0.0, 0.0]])
    sol = least_squares(dist, x0, jac=jac, args=(sub,), method="lm", xtol=1e-10, ftol=1e-10, max_nfev=FIT_EVALUATIONS)
    if len(sub) < len(P):  # polished on every node (the envelope theorem the angles' gradient rests on)
        sol = least_squares(dist, sol.x, jac=jac, args=(P,), method="lm", xtol=1e-10, ftol=1e-10,
                            max_nfev=FIT_EVALUATIONS)
    M, q, R = meridian(sol.x, P)
    d, g = _nearest(S, tree, M)
    rho = np.maximum(M[:, 0], 1e-300)[:, None]
    # ∂d/∂p with the fit held: the meridian gradient (g_ρ along the node's radial direction, g_a along the axis)
    # turned into space; the scale cancels (d in mm = s·d(q), q = Rᵀ(p − c)/s)
    local = np.column_stack([g[:, :1] * q[:, :2] / rho, g[:, 1]])
    # the scale follows the nodes (s = size / profile size): Σ d² moves with it by ∂J/∂s · ∂s/∂p, ∂s/∂p_i =
    # (p_i − p̄) / (n · size · profile size); ∂J/∂s by central differences (step 1e-6 relative)
    ds = 1e-6 * s
    dJ = float(np.sum(dist(sol.x, P, s + ds) ** 2) - np.sum(dist(sol.x, P, s - ds) ** 2)) / (2.0 * ds)
    extra = dJ * (P - P.mean(axis=0)) / (len(P) * size * profile_size(S))
    return SurfaceFit(s * d, s, size, local @ R.T, extra)
