"""How far a closed assembly's predicted shape is from a closed-tiling target, after the best similarity.

The predicted shape is the plates' deformed mid-surface nodes P (n, 3), mm. The target is a shape
without a size (:class:`fabpat.design.target.ClosedTarget`): the plates' size fixes it, so the target
is moved, turned and scaled onto P (a similarity transform) and the distances are measured in mm:

* ``sphere``: the least-squares sphere (:func:`fabpat.assembly.solve.closure.fit_sphere`); distance
  ||p − c| − r|, so ``rms / radius`` is the closure's ``sphericity_rms``. ``scale`` = r (mm per unit
  radius).
* ``ellipsoid:A,B,C``: semi-axes s·(A, B, C), centre c and rotation R fitted by nonlinear least squares
  (:func:`scipy.optimize.least_squares`) on the first-order (Sampson) distance g/|∇g| with
  g(q) = |q / (sA, sB, sC)| − 1 (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., §4.2.6): exact on
  the surface, within 1 % of the Euclidean distance for deviations below 1 % of the size; Levenberg–Marquardt
  with a Jacobian by central differences of absolute steps (:data:`FIT_STEP`), fitted to a
  seeded subset of :data:`FIT_POINTS` nodes and polished on every node, where the distances are measured. Started
  twice, with the axis that differs most from the other two along ``axis`` (the tiling's design axis)
  and along the points' most distinct principal axis; the better fit is kept.
  ``scale`` = s (mm per unit of the ratios).
* a mesh file (OBJ, STL, PLY, read by trimesh): the nodes are moved onto the mesh, started in each
  of the four proper principal-axis alignments at the mesh's RMS radius and refined by ICP with scale
  (:func:`trimesh.registration.icp`, point to surface). A watertight mesh is then replaced by a smooth
  implicit surface (:func:`implicit_surface`: f = 0 through :data:`IMPLICIT_POINTS` of its vertices, f = ±δ
  at δ along their normals, δ = :data:`IMPLICIT_OFFSET` of its RMS radius; Carr et al., "Reconstruction and
  representation of 3D objects with radial basis functions", SIGGRAPH 2001, with the triharmonic kernel
  r³ and a linear polynomial), whose value is a signed distance to first order (|∇f| = 1 on the surface),
  and the similarity is polished on every node by damped Gauss–Newton on the distances f/σ (σ the scale):
  the distances and their fit are then smooth functions of the nodes, so the summed squared distance has
  the gradient 2 d ∇d exactly (the envelope theorem), which the nearest point of a faceted mesh, jumping
  from facet to facet, and an ICP stopped after its iterations on a subset of the nodes did not give
  (an angle gradient checked to 17.9 relative on a mesh target, against 2.6e-4 on an ellipsoid). A mesh
  that is not watertight keeps the distance of each node to the nearest point of the mesh
  (:func:`trimesh.proximity.closest_point`), unsigned. ``scale`` is the similarity's scale (mm per unit
  of the file).

``radius`` (mm), the size ``relative_rms`` divides by: the sphere's r; otherwise the RMS distance of
P from its centroid (r again on a sphere).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

Arr = NDArray[np.float64]

#: nodes (a seeded random subset) that the ICP of a mesh target moves, and that fit an ellipsoid; the
#: distances use every node
ICP_POINTS = 1000
FIT_POINTS = 2000
#: largest number of residual evaluations of one ellipsoid fit (Levenberg–Marquardt, from each start): a
#: near-round shape leaves the ellipsoid's turn about its axis of symmetry free, which costs evaluations
#: and changes nothing
FIT_EVALUATIONS = 300
#: surface points of a mesh target's implicit surface: farthest-point picks of its vertices (the kernel's cost
#: per node grows with them; 400 points on the mild egg leave its other vertices within IMPLICIT_CHECK)
IMPLICIT_POINTS = 400
#: the implicit surface's off-surface points lie this far along each picked vertex's normal, out (f = δ) and in
#: (f = −δ), as a fraction of the mesh's RMS radius
IMPLICIT_OFFSET = 0.02
#: largest Gauss–Newton iterations of a mesh target's polish (5 to 12 are used)
POLISH_ITERATIONS = 60
#: the polish stops when a step lowers Σ d² by less than this fraction: on the subset, where it only starts the
#: polish on every node, and on every node. An axisymmetric target (the mild egg) turns freely about its axis, where
#: Gauss–Newton converges only linearly (a factor ~4 a step) and J does not move; 1e-10 of J left the distances'
#: gradient within 1e-6 of central differences of the refitted J
POLISH_START = 1e-6
POLISH_TOL = 1e-10
#: the ellipsoid fit's Jacobian: central differences of the distances with this step (relative to the size for
#: the centre and the scale, rad for the rotation): truncation ~ step², round-off ~ 1e-16 / step, both ≲ 1e-10
FIT_STEP = 1e-6


@dataclass(frozen=True, eq=False)
class SurfaceFit:
    """Distances of the nodes from the fitted target: ``signed`` (n,) mm (positive outside the target;
    a mesh target that is not watertight has no inside: its distances are all ≥ 0), ``rms``/``max`` mm,
    ``scale`` (mm per target unit), ``radius`` (mm, the size that ``relative_rms`` divides by); ``gradient``
    (n, 3) the derivative of each node's signed distance with respect to that node's position (a unit vector
    for a sphere or a mesh; dimensionless) with the fitted similarity held, None if not computed: by the
    envelope theorem it is all the derivative of the summed squared distances at the best fit."""

    signed: Arr
    scale: float
    radius: float
    gradient: Arr | None = None
    #: (n, 3) mm: what the summed squared distances' derivative has besides Σ 2 d ∇d, when a parameter of the fit
    #: is not fitted but follows from the nodes (an open target's scale, :mod:`fabpat.design.revolution`); None: none
    extra: Arr | None = None

    @property
    def error_gradient(self) -> Arr:
        """(n, 3) mm: the derivative of Σ d² (mm²) with respect to the nodes: 2 d ∇d, plus :attr:`extra`."""
        assert self.gradient is not None
        g = 2.0 * self.signed[:, None] * self.gradient
        return g if self.extra is None else g + self.extra

    @property
    def distance(self) -> Arr:
        """(n,) unsigned distances (mm)."""
        return np.abs(self.signed)

    @property
    def rms(self) -> float:
        """RMS distance (mm)."""
        return float(np.sqrt(np.mean(self.distance ** 2)))

    @property
    def max(self) -> float:
        """Largest distance (mm)."""
        return float(self.distance.max())

    @property
    def relative_rms(self) -> float:
        """rms over radius."""
        return self.rms / self.radius


def _rms_radius(P: Arr) -> float:
    return float(np.sqrt(np.mean(((P - P.mean(axis=0)) ** 2).sum(axis=1))))


def fit_to_sphere(P: Arr) -> SurfaceFit:
    """The least-squares sphere through P (n, 3) mm."""
    from fabpat.assembly.solve.closure import fit_sphere

    c, r = fit_sphere(P)
    d = np.linalg.norm(P - c, axis=1)
    return SurfaceFit(d - r, r, r, (P - c) / np.maximum(d, 1e-300)[:, None])


def distinct_axis(axes: tuple[float, float, float]) -> int:
    """Index of the ratio farthest from the mean of the other two (the ellipsoid's axis of symmetry)."""
    a = np.asarray(axes, dtype=np.float64)
    return int(np.argmax([abs(a[i] - 0.5 * (a.sum() - a[i])) for i in range(3)]))


def _rotation(w: Arr) -> Arr:
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(w).as_matrix()


def _frame_with(axis: Arr, k: int) -> Arr:
    """A rotation whose column k is the unit vector ``axis``."""
    a = axis / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    u = np.cross(a, helper)
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    cols = [u, v]
    R = np.zeros((3, 3))
    R[:, k] = a
    R[:, [i for i in range(3) if i != k]] = np.column_stack(cols)
    if np.linalg.det(R) < 0:
        R[:, [i for i in range(3) if i != k][0]] *= -1
    return R


def fit_to_ellipsoid(P: Arr, axes: tuple[float, float, float], axis: Arr) -> SurfaceFit:
    """The ellipsoid of ratios ``axes`` fitted to P (n, 3) mm (module doc); ``axis`` (3,) the start
    direction of its distinct axis."""
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    a = np.asarray(axes, dtype=np.float64)
    c0 = P.mean(axis=0)
    s0 = _rms_radius(P) / math.sqrt(float(np.mean(a * a)))
    w0 = Rotation.from_matrix(_frame_with(np.asarray(axis, dtype=np.float64), distinct_axis(axes))).as_rotvec()

    sub = P[np.random.default_rng(0).permutation(len(P))[:FIT_POINTS]] if len(P) > FIT_POINTS else P

    def dist(x: Arr, P: Arr = sub) -> Arr:
        c, w, s = x[:3], x[3:6], x[6]
        q = (P - c) @ _rotation(w)  # coordinates in the ellipsoid's frame
        semi = s * a
        u = q / semi
        n = np.linalg.norm(u, axis=1)
        grad = np.linalg.norm(q / (semi * semi), axis=1) / np.maximum(n, 1e-300)
        return (n - 1.0) / np.maximum(grad, 1e-300)

    val, vec = np.linalg.eigh(np.cov((P - c0).T))
    pca = vec[:, int(np.argmax([abs(val[i] - 0.5 * (val.sum() - val[i])) for i in range(3)]))]
    w1 = Rotation.from_matrix(_frame_with(pca, distinct_axis(axes))).as_rotvec()
    def jac(x: Arr, P: Arr = sub) -> Arr:
        # central differences with absolute steps (1e-6 of the size for c and s, 1e-6 rad for w): MINPACK's own
        # forward differences step each parameter by 1.5e-8 of its value, ~1e-11 rad on the rotation's small
        # components; that Jacobian stalled the fit 1e-5 of J short of its optimum, by a different amount for
        # nodes a 1e-4 rad turn of the angles apart (J's differences then missed its adjoint gradient by up to 64 %)
        steps = np.full(7, FIT_STEP * float(x[6]))
        steps[3:6] = FIT_STEP
        cols = [(dist(x + e, P) - dist(x - e, P)) / (2.0 * e[j]) for j, e in enumerate(np.diag(steps))]
        return np.column_stack(cols)

    sol = min((least_squares(dist, np.concatenate([c0, w, [s0]]), jac=jac, method="lm", xtol=1e-10, ftol=1e-10,
                             max_nfev=FIT_EVALUATIONS)
               for w in (w0, w1)), key=lambda r: float(r.cost))
    if len(sub) < len(P):  # polished on every node: the distances are measured there, and at their own best fit
        # the fit's parameters are stationary (the envelope theorem the angles' gradient rests on)
        sol = least_squares(dist, sol.x, jac=jac, args=(P,), method="lm", xtol=1e-10, ftol=1e-10,
                            max_nfev=FIT_EVALUATIONS)
    s = float(sol.x[6])
    # the Sampson distance is a closed form per node: its gradient by central differences of each coordinate
    # (step 1e-6 of the size: truncation and round-off both ≲ 1e-9 relative)
    step = 1e-6 * s * float(np.max(a))
    grad = np.column_stack([(dist(sol.x, P + step * e) - dist(sol.x, P - step * e)) / (2.0 * step) for e in np.eye(3)])
    return SurfaceFit(dist(sol.x, P), s, _rms_radius(P), grad)


@dataclass(frozen=True, eq=False)
class Implicit:
    """A smooth implicit surface f(x) = Σ_j w_j |y − c_j|³ + a·y + b, y = (x − ``centre``) / ``unit`` (x in the
    mesh file's units): ``centres`` (m, 3) and ``weights`` (m,) in y, ``linear`` (4,) = (a, b); f is returned in
    the file's units, positive outside (module doc, :func:`implicit_surface`)."""

    centre: Arr
    unit: float
    centres: Arr
    weights: Arr
    linear: Arr

    def evaluate(self, X: Arr, chunk: int = 4000) -> tuple[Arr, Arr]:
        """f (n,) in the file's units and ∇f (n, 3), dimensionless, at X (n, 3) in the file's units."""
        Y = (np.asarray(X, dtype=np.float64) - self.centre) / self.unit
        f, g = np.empty(len(Y)), np.empty((len(Y), 3))
        cc = (self.centres * self.centres).sum(axis=1)
        for lo in range(0, len(Y), chunk):  # (chunk, m) at a time: memory, not speed
            y = Y[lo:lo + chunk]
            # |y − c|² by products (BLAS) rather than an (n, m, 3) array of differences
            r = np.sqrt(np.maximum((y * y).sum(axis=1)[:, None] + cc[None, :] - 2.0 * y @ self.centres.T, 0.0))
            wr = r * self.weights[None, :]
            f[lo:lo + chunk] = (r * r * r) @ self.weights
            # ∇ Σ w |y − c|³ = 3 Σ w |y − c| (y − c)
            g[lo:lo + chunk] = 3.0 * (wr.sum(axis=1)[:, None] * y - wr @ self.centres)
        f += Y @ self.linear[:3] + self.linear[3]
        g += self.linear[:3]
        return f * self.unit, g


def implicit_surface(mesh: trimesh.Trimesh) -> Implicit:
    """The :class:`Implicit` surface of a watertight ``mesh`` (module doc): f = 0 at :data:`IMPLICIT_POINTS`
    farthest-point picks of its vertices, f = ±δ at δ along their area-weighted normals (turned outward),
    interpolated by the triharmonic kernel r³ with a linear polynomial (Carr et al. 2001). Raises
    numpy.linalg.LinAlgError only for a degenerate mesh (coincident picks)."""
    V = np.asarray(mesh.vertices, dtype=np.float64)
    N = np.asarray(mesh.vertex_normals, dtype=np.float64)
    if float(mesh.volume) < 0:  # faces wound inward: the normals point in
        N = -N
    centre = V.mean(axis=0)
    unit = _rms_radius(V)
    Y = (V - centre) / unit
    pick = [0]
    near = np.linalg.norm(Y - Y[0], axis=1)
    while len(pick) < min(IMPLICIT_POINTS, len(Y)):
        pick.append(int(np.argmax(near)))
        near = np.minimum(near, np.linalg.norm(Y - Y[pick[-1]], axis=1))
    on, n = Y[pick], N[pick]
    C = np.vstack([on, on + IMPLICIT_OFFSET * n, on - IMPLICIT_OFFSET * n])
    values = np.concatenate([np.zeros(len(on)), np.full(len(on), IMPLICIT_OFFSET), np.full(len(on), -IMPLICIT_OFFSET)])
    m = len(C)
    r = np.linalg.norm(C[:, None, :] - C[None, :, :], axis=2)
    poly = np.hstack([C, np.ones((m, 1))])
    A = np.zeros((m + 4, m + 4))
    A[:m, :m], A[:m, m:], A[m:, :m] = r ** 3, poly, poly.T
    sol = np.linalg.solve(A, np.concatenate([values, np.zeros(4)]))
    return Implicit(centre, unit, C, sol[:m], sol[m:])


def _starts(P: Arr, m: trimesh.Trimesh) -> list[Arr]:
    """The four proper principal-axis alignments as 4 × 4 similarities taking P (n, 3) mm into the file's units, at
    the mesh's RMS radius."""
    pts = np.asarray(m.sample(4000, seed=1), dtype=np.float64)  # for the start: centroid, axes, size

    def axes_of(X: Arr) -> tuple[Arr, Arr]:
        c = X.mean(axis=0)
        _, vec = np.linalg.eigh(np.cov((X - c).T))
        return c, vec

    cm, vm = axes_of(pts)
    cp, vp = axes_of(P)
    s0 = _rms_radius(P) / _rms_radius(pts)
    out = []
    for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)):
        R = vp @ np.diag(signs) @ vm.T
        if np.linalg.det(R) < 0:
            R = vp @ np.diag([-signs[0], signs[1], signs[2]]) @ vm.T
        M = np.eye(4)  # P's frame → the file's: the inverse of scaling by s0, turning by R, moving cm to cp
        M[:3, :3] = R.T / s0
        M[:3, 3] = cm - R.T @ cp / s0
        out.append(M)
    return out


def fit_to_mesh(P: Arr, mesh: trimesh.Trimesh, implicit: Implicit | None = None) -> SurfaceFit:
    """The surface ``mesh`` (a trimesh.Trimesh) moved onto P (n, 3) mm by the best similarity (module doc);
    ``implicit`` its :func:`implicit_surface` (None: the nearest points of the mesh by ICP, unsigned unless
    watertight)."""
    import trimesh

    m = mesh
    sub = P[np.random.default_rng(0).permutation(len(P))[:ICP_POINTS]] if len(P) > ICP_POINTS else P
    if implicit is not None:  # each start polished on the subset, the best polished on every node
        _, T = min((_polish(sub, implicit, M, POLISH_START) for M in _starts(P, m)), key=lambda ct: ct[0])
        return _fit_of(P, implicit, T)
    best: tuple[float, Arr] | None = None
    for M in _starts(P, m):
        # the nodes onto the surface (point-to-surface, trimesh's closest points), not samples onto nodes
        T, _, cost = trimesh.registration.icp(sub, m, initial=M, max_iterations=20, reflection=False, scale=True)
        if best is None or cost < best[0]:
            best = (float(cost), T)
    assert best is not None
    T, _, _ = trimesh.registration.icp(sub, m, initial=best[1], max_iterations=200, threshold=1e-9,
                                       reflection=False, scale=True)
    scale = float(np.cbrt(abs(np.linalg.det(T[:3, :3]))))  # file units per mm
    Q = P @ T[:3, :3].T + T[:3, 3]
    C, d, _ = trimesh.proximity.closest_point(m, Q)
    d = np.asarray(d, dtype=np.float64) / scale
    sign = np.where(m.contains(Q), -1.0, 1.0) if m.is_watertight else np.ones(len(Q))
    # trimesh's sign is positive inside; ours outside, as the sphere's
    away = (Q - np.asarray(C, dtype=np.float64)) / np.maximum(d * scale, 1e-300)[:, None]
    return SurfaceFit(d * sign, 1.0 / scale, _rms_radius(P), sign[:, None] * away @ T[:3, :3] / scale)


def _fit_of(P: Arr, surface: Implicit, T: Arr) -> SurfaceFit:
    """The implicit surface's fit to every node of P, polished from the similarity ``T`` (:func:`_polish`)."""
    _, T = _polish(P, surface, T, POLISH_TOL)
    A = T[:3, :3]
    sigma = float(np.cbrt(np.linalg.det(A)))
    f, g = surface.evaluate(P @ A.T + T[:3, 3])
    return SurfaceFit(f / sigma, 1.0 / sigma, _rms_radius(P), g @ (A / sigma))


def _polish(P: Arr, surface: Implicit, T: Arr, tol: float) -> tuple[float, Arr]:
    """(Σ d² mm², the 4 × 4 similarity) of q = σ R (p − p̄) + t (σ file units per mm, R a rotation) minimising
    Σ d², d = f(q) / σ mm over the nodes P (n, 3), from ``T`` by Levenberg–Marquardt steps (Gauss–Newton with
    Marquardt's damping) in (t, a turn ω applied as R ← exp([ω]×) R, σ), until a step lowers Σ d² by less than
    ``tol`` of it (:data:`POLISH_START`, :data:`POLISH_TOL`)."""
    from scipy.spatial.transform import Rotation

    U, S, Vt = np.linalg.svd(T[:3, :3])
    R, sigma = U @ Vt, float(S.mean())
    pbar = P.mean(axis=0)
    t = T[:3, :3] @ pbar + T[:3, 3]

    def state(R: Arr, t: Arr, sigma: float) -> tuple[Arr, Arr, Arr, Arr]:
        r = (P - pbar) @ R.T
        f, g = surface.evaluate(sigma * r + t)
        return f / sigma, g, f, r

    d, g, f, r = state(R, t, sigma)
    cost, mu = float(d @ d), 1e-3
    for _ in range(POLISH_ITERATIONS):
        Jm = np.hstack([g / sigma, np.cross(r, g), ((g * r).sum(axis=1) / sigma - f / sigma ** 2)[:, None]])
        H, b = Jm.T @ Jm, Jm.T @ d
        # converged when even the undamped step promises less than the stopping fraction: a step then only
        # trades round-off, and trying it would cost evaluations for nothing
        full = np.linalg.lstsq(H, -b, rcond=None)[0]
        if -float(b @ full) <= tol * cost:
            break
        c1 = math.inf
        for _ in range(12):  # Marquardt: damp the diagonal until the step lowers the cost
            step = -np.linalg.solve(H + mu * np.diag(np.diag(H)), b)
            R1 = Rotation.from_rotvec(step[3:6]).as_matrix() @ R
            t1, s1 = t + step[:3], sigma + float(step[6])
            d1, g1, f1, r1 = state(R1, t1, s1)
            c1 = float(d1 @ d1)
            if c1 <= cost:
                break
            mu *= 10.0
        if c1 > cost:
            break
        done = cost - c1 <= tol * cost
        R, t, sigma, d, g, f, r, cost, mu = R1, t1, s1, d1, g1, f1, r1, c1, max(mu / 10.0, 1e-12)
        if done:
            break
    out = np.eye(4)
    out[:3, :3] = sigma * R
    out[:3, 3] = t - sigma * R @ pbar
    return cost, out
