"""A base tiling mapped onto a closed target and relaxed into flat, nearly regular faces on it.

Equal regular plates close into a sphere's shape whatever the sleeves (docs/design.md, "Mapped tilings"):
a target of another shape needs plates shaped to its own faces. Here are the faces. Pure functions over
vertices V (n, 3) float mm and faces as vertex loops (counter-clockwise seen from outside):

* :func:`map_tiling` — the base's vertices carried onto the target (:mod:`fabpat.design.remesh_target`
  places it: the base's size, the target's frame) along the rays from the base's centroid. A ray keeps the
  base's even spread of directions, and every target here is star-shaped from its centre (a sphere, an
  ellipsoid, an egg); the closest point would pile a round base's vertices onto the sides of an elongated
  target and leave its ends bare. A ray that misses a mesh goes to the closest point.
* :func:`relax` — the vertices moved so that every face is planar and as regular as the target allows, close
  to the target: a sparse nonlinear least-squares problem (:func:`residuals`), after Tang et al.,
  *Form-finding with polyhedral meshes made simple*, ACM TOG 33(4) 2014: every condition is made a low-degree
  polynomial by auxiliary unknowns (a unit normal per face, an edge length per face and one for the tiling),
  solved by Levenberg–Marquardt with the sparse normal equations factorised directly (SuperLU), since the
  planarity weight makes the system too ill-conditioned for an iterative trust-region solve
  (docs/design.md, "Mapped tilings", measures both).
* :func:`measure` — per-face planarity (mm), edge and angle deviation, distance from the target.
* :func:`approximation_error` — the planar faces' points (or their corners) against the target after the
  design's own best similarity (:meth:`fabpat.design.target.ClosedTarget.fit`).
* :func:`write_obj` — polygon faces kept (:func:`fabpat.assembly.surface.mesh_tiling.write_obj`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from fabpat.design.remesh_target import Faces, TargetSurface, on_rays, place_target
from fabpat.design.target import ClosedTarget
from fabpat.errors import FabpatError, SolverError

Arr = NDArray[np.float64]
Target = ClosedTarget | str | TargetSurface

#: the weights of :func:`relax`'s residual groups (all residuals in mm; the weights are pure numbers)
PLANAR_WEIGHT = 1000.0
EDGE_WEIGHT = 1.0
ANGLE_WEIGHT = 1.0
ACROSS_WEIGHT = 1.0
TARGET_WEIGHT = 10.0
#: the weight of the three residuals that hold the vertices' net turn about their centroid at zero: a turn of
#: the whole tiling on a sphere costs nothing, and on a near-round ellipsoid so little that the steps crept
#: hundreds of times, turning the design axis off the target's (measured: 0.016 rad per 100 steps)
SPIN_WEIGHT = 1.0
#: relax's stop: a step below this fraction of the size in every coordinate, and the planarity goal
STEP_TOLERANCE = 1e-10
#: planarity :func:`relax` must reach, as a fraction of the size (the largest distance of a corner from its
#: face's best-fit plane); otherwise it raises :class:`RelaxError`
PLANARITY_GOAL = 1e-6
#: relax's other stop: the cost fell by at most this fraction of itself over the last STALL_STEPS accepted steps
#: (on a mesh target the distance has kinks at the triangles' edges and the steps never shrink to nothing)
STALL = 1e-6
STALL_STEPS = 10
MAX_ITERATIONS = 200
#: :func:`approximation_error` measures at most this many points of the faces, a seeded subset (the rms to about
#: 1 %): a mesh target's closest points for GP(4, 0)'s 27 000 took 7.8 GB in trimesh
FIT_SAMPLE = 4000


class RemeshError(FabpatError, ValueError):
    """Faces that are not loops of at least 3 distinct vertex indices of V, or V that is not (n, 3) finite."""


class RelaxError(SolverError):
    """:func:`relax` did not reach its goal within its iterations; the message says what it reached."""


@dataclass(frozen=True)
class Weights:
    """The weights of :func:`relax`'s residual groups (pure numbers; every residual is in mm): ``planar`` the
    faces' edges against their normals (and the normals' unit length), ``edge`` each edge against its face's
    length, ``angle`` each short diagonal (corners i − 1, i + 1) against its face's regular one, ``across``
    each face's length against the tiling's, ``target`` each vertex's signed distance from the target, ``spin``
    the vertices' net turn about their start's centroid (:data:`SPIN_WEIGHT`)."""

    planar: float = PLANAR_WEIGHT
    edge: float = EDGE_WEIGHT
    angle: float = ANGLE_WEIGHT
    across: float = ACROSS_WEIGHT
    target: float = TARGET_WEIGHT
    spin: float = SPIN_WEIGHT


@dataclass(frozen=True, eq=False)
class Measures:
    """How flat, regular and close a tiling is: per face (nf,) ``planarity`` (mm, the largest distance of a
    corner from the face's best-fit plane), ``edge_deviation`` (largest |edge − mean| over the tiling's mean
    edge: within and across faces), ``angle_deviation`` (rad, largest |corner angle − (n − 2)π/n|); ``size`` mm
    (RMS distance of the vertices from their centroid); ``distance_rms``, ``distance_max`` of the vertices from
    the target (Euclidean, to the closest point) as fractions of the size."""

    planarity: Arr
    edge_deviation: Arr
    angle_deviation: Arr
    size: float
    distance_rms: float
    distance_max: float


@dataclass(frozen=True, eq=False)
class Relaxed:
    """:func:`relax`'s result: ``V`` (n, 3) mm, ``faces``, its :class:`Measures` ``measures``, the
    ``surface`` it was relaxed against, ``iterations`` (accepted and refused steps) and ``seconds``."""

    V: Arr
    faces: Faces
    measures: Measures
    surface: TargetSurface
    iterations: int
    seconds: float


def _check(V: Arr, faces: Faces) -> tuple[Arr, Faces]:
    """V as (n, 3) float and faces as tuples of ints, or :class:`RemeshError`."""
    try:
        A = np.asarray(V, dtype=np.float64)
    except (TypeError, ValueError):
        raise RemeshError("V must be an (n, 3) array of vertex coordinates (mm)") from None
    if A.ndim != 2 or A.shape[1] != 3 or not np.isfinite(A).all():
        raise RemeshError(f"V must be an (n, 3) array of finite coordinates (mm), got shape {A.shape}")
    try:
        loops = tuple(tuple(int(i) for i in loop) for loop in faces)
    except (TypeError, ValueError):
        raise RemeshError("faces must be a sequence of vertex-index loops") from None
    for k, loop in enumerate(loops):
        if len(loop) < 3 or len(set(loop)) != len(loop) or min(loop) < 0 or max(loop) >= len(A):
            raise RemeshError(f"face {k + 1} {loop} is not a loop of at least 3 distinct vertices of V "
                              f"(0 … {len(A) - 1})")
    if not loops:
        raise RemeshError("no faces")
    return A, loops


def map_tiling(V: Arr, faces: Faces, target: Target) -> Arr:
    """The base tiling's vertices V (n, 3) mm on the target: (n, 3) mm in the target's frame, at the size
    where the mapped faces' area is the base's (:func:`fabpat.design.remesh_target.place_target`), each vertex
    where the ray from the base's centroid through it meets the target (module doc). ``target``: "sphere",
    "ellipsoid:A,B,C", a mesh file, a :class:`ClosedTarget`, or a placed :class:`TargetSurface` (then the base
    is taken as turned into its frame already: only its centroid moves, onto the surface's centre). Raises
    :class:`fabpat.design.target.TargetError` (a bad target) or :class:`RemeshError` (bad V or faces)."""
    A, loops = _check(V, faces)
    surface, R = place_target(A, loops, target)
    return on_rays(surface, (A - A.mean(axis=0)) @ R.T)


@dataclass(frozen=True)
class _Layout:
    """Index arrays of the residuals: per face corner k (all faces' corners in order) its face ``f``, vertex
    ``i``, next ``j`` and previous ``p``, and the regular short diagonal over the edge ``ratio``
    (2 cos(π/n))."""

    f: NDArray[np.int64]
    i: NDArray[np.int64]
    j: NDArray[np.int64]
    p: NDArray[np.int64]
    ratio: Arr
    nv: int
    nf: int


def _layout(nv: int, faces: Faces) -> _Layout:
    f, i, j, p, ratio = [], [], [], [], []
    for k, loop in enumerate(faces):
        n = len(loop)
        for c in range(n):
            f.append(k)
            i.append(loop[c])
            j.append(loop[(c + 1) % n])
            p.append(loop[c - 1])
            ratio.append(2.0 * math.cos(math.pi / n))

    def ints(a: list[int]) -> NDArray[np.int64]:
        return np.array(a, dtype=np.int64)

    return _Layout(ints(f), ints(i), ints(j), ints(p), np.array(ratio), nv, len(faces))


def _unit_rows(d: Arr) -> tuple[Arr, Arr]:
    """Lengths (m,) and unit vectors (m, 3) of vectors d (m, 3)."""
    length = np.linalg.norm(d, axis=1)
    return length, d / np.maximum(length, 1e-300)[:, None]


def residuals(x: Arr, lay: _Layout, surface: TargetSurface, w: Weights, scale: float, start: Arr
              ) -> tuple[Arr, sp.csr_matrix]:
    """Residuals r (m,) mm and their sparse Jacobian (m, len(x)) of :func:`relax`'s problem at unknowns
    x = (V (nv, 3), face normals (nf, 3), face edge lengths (nf,), the tiling's edge length) flattened, mm;
    ``scale`` mm turns the normals' unit length into mm. Groups, each times its weight: n_f · (v_j − v_i) per
    face edge; scale (n_f · n_f − 1) / 2 per face; |v_j − v_i| − L_f per face edge; |v_j − v_p| −
    2 cos(π/n) L_f per corner (the short diagonal of a regular n-gon of edge L_f); L_f − L per face; the signed
    distance of every vertex from ``surface`` (its gradient the surface normal); the net turn
    Σ_k r_k × (v_k − s_k) / Σ_k |r_k| of the vertices from their ``start`` s (nv, 3) mm, r_k = s_k − the
    start's centroid (a rigid turn by a small angle ω gives about ω times the size)."""
    nv, nf = lay.nv, lay.nf
    V = x[:3 * nv].reshape(nv, 3)
    Nrm = x[3 * nv:3 * nv + 3 * nf].reshape(nf, 3)
    Lf = x[3 * nv + 3 * nf:3 * nv + 4 * nf]
    iL = 3 * nv + 4 * nf
    m = len(lay.f)
    rows: list[NDArray[np.int64]] = []
    cols: list[NDArray[np.int64]] = []
    vals: list[Arr] = []
    out: list[Arr] = []
    top = 0

    def add(r: Arr, entries: list[tuple[NDArray[np.int64], Arr]]) -> None:
        nonlocal top
        idx = top + np.arange(len(r))
        for c, v in entries:
            rows.append(np.broadcast_to(idx, c.shape) if c.ndim == 1 else np.repeat(idx, c.shape[1]))
            cols.append(c.ravel())
            vals.append(v.ravel())
        out.append(r)
        top += len(r)

    def xyz(v: NDArray[np.int64]) -> NDArray[np.int64]:
        return 3 * v[:, None] + np.arange(3)

    E = V[lay.j] - V[lay.i]
    n = Nrm[lay.f]
    add(w.planar * (n * E).sum(axis=1), [(xyz(lay.j), w.planar * n), (xyz(lay.i), -w.planar * n),
                                          (3 * nv + xyz(lay.f), w.planar * E)])
    add(w.planar * scale * 0.5 * ((Nrm * Nrm).sum(axis=1) - 1.0),
        [(3 * nv + xyz(np.arange(nf)), w.planar * scale * Nrm)])
    length, u = _unit_rows(E)
    lf = 3 * nv + 3 * nf + lay.f
    add(w.edge * (length - Lf[lay.f]), [(xyz(lay.j), w.edge * u), (xyz(lay.i), -w.edge * u),
                                         (lf, np.full(m, -w.edge))])
    diag, ud = _unit_rows(V[lay.j] - V[lay.p])
    add(w.angle * (diag - lay.ratio * Lf[lay.f]), [(xyz(lay.j), w.angle * ud), (xyz(lay.p), -w.angle * ud),
                                                   (lf, -w.angle * lay.ratio)])
    faces_ = np.arange(nf)
    add(w.across * (Lf - x[iL]), [(3 * nv + 3 * nf + faces_, np.full(nf, w.across)),
                                  (np.full(nf, iL), np.full(nf, -w.across))])
    _, N, d = surface.closest(V)
    add(w.target * d, [(xyz(np.arange(nv)), w.target * N)])
    arm = start - start.mean(axis=0)
    norm = float(np.linalg.norm(arm, axis=1).sum())
    cross = np.zeros((3, nv, 3))  # row a: the coefficients of (v_k)_b in (Σ r_k × v_k)_a
    for a in range(3):
        cross[a] = np.cross(arm, np.eye(3)[a])  # (r × v)_a = v · (e_a × r) = −v · (r × e_a)
    cross = -cross * (w.spin / norm)
    add(w.spin * np.cross(arm, V - start).sum(axis=0) / norm,
        [(np.tile(np.arange(3 * nv), (3, 1)), cross.reshape(3, -1))])
    J = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(top, len(x)))
    return np.concatenate(out), J


def _levenberg_marquardt(x: Arr, fun: Callable[[Arr], tuple[Arr, sp.csr_matrix]], step_tol: float,
                         done: Callable[[Arr], bool], max_iter: int, dense: int = 0) -> tuple[Arr, int, bool]:
    """Minimise ½|r(x)|² from x: Levenberg–Marquardt with Marquardt's diagonal scaling and Nielsen's update
    of the damping (K. Madsen, H. B. Nielsen, O. Tingleff, *Methods for non-linear least squares problems*,
    DTU 2004, §3.2), each step a direct sparse solve of (JᵀJ + μ diag(JᵀJ)) dx = −Jᵀr. The last ``dense``
    rows of J may be full: their part GᵀG of JᵀJ is added by the Sherman–Morrison–Woodbury identity, one
    sparse LU (SuperLU) and ``dense`` + 1 solves, since GᵀG would fill the matrix. Stops when an accepted step
    is below ``step_tol`` in every coordinate, or the last :data:`STALL_STEPS` accepted steps lowered the cost
    by at most :data:`STALL` of it, and ``done(x)``. Returns (x, iterations, converged)."""
    from scipy.sparse.linalg import splu

    def normal(J: sp.csr_matrix) -> tuple[sp.csc_matrix, Arr, Arr]:
        S = J[:J.shape[0] - dense]
        G = J[J.shape[0] - dense:].toarray()
        A = (S.T @ S).tocsc()
        return A, G, A.diagonal() + (G * G).sum(axis=0)

    r, J = fun(x)
    cost = 0.5 * float(r @ r)
    A, G, diag = normal(J)
    mu, nu = 1e-6, 2.0
    costs = [cost]
    for it in range(1, max_iter + 1):
        g = J.T @ r
        D = np.maximum(diag, 1e-12 * max(float(diag.max()), 1e-300))
        lu = splu((A + sp.diags(mu * D)).tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})  # SPD: symmetric ordering, pivots on the diagonal
        dx = lu.solve(-g)
        if dense:  # (M + GᵀG)⁻¹ b = M⁻¹b − M⁻¹Gᵀ (I + G M⁻¹ Gᵀ)⁻¹ G M⁻¹b
            MG = lu.solve(np.ascontiguousarray(G.T))
            dx -= MG @ np.linalg.solve(np.eye(dense) + G @ MG, G @ dx)
        x_new = x + dx
        r_new, J_new = fun(x_new)
        cost_new = 0.5 * float(r_new @ r_new)
        predicted = 0.5 * float(dx @ (mu * D * dx - g))
        if cost_new < cost and predicted > 0.0:
            rho = (cost - cost_new) / predicted
            x, r, J, cost = x_new, r_new, J_new, cost_new
            A, G, diag = normal(J)
            mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            costs.append(cost)
            # a faceted target (a mesh) has kinks in its distance: the steps then never shrink, the cost stalls
            stalled = len(costs) > STALL_STEPS and costs[-STALL_STEPS - 1] - cost <= STALL * cost
            if (float(np.abs(dx).max()) <= step_tol or stalled) and done(x):
                return x, it, True
        else:
            mu *= nu
            nu *= 2.0
            if mu > 1e16:  # no step lowers the cost: a minimum to the last bit
                return x, it, done(x)
    return x, max_iter, False


def relax(V: Arr, faces: Faces, target: Target, *, weights: Weights | None = None,
          max_iterations: int = MAX_ITERATIONS) -> Relaxed:
    """Vertices V (n, 3) mm (a tiling mapped onto the target, :func:`map_tiling`) moved so that every face is
    planar and as regular as the target allows, near the target: the least squares of :func:`residuals` with
    ``weights`` (default :class:`Weights`: planarity 1000, every other group 1), solved by Levenberg–Marquardt
    (module doc) from V, the faces' Newell normals and the mean edge. ``target`` as for :func:`map_tiling`,
    placed from V itself unless a :class:`TargetSurface`: give the surface that mapped V
    (:func:`fabpat.design.remesh_target.place_target` of the base) to relax against exactly it (placed anew
    from a mapped V, a mesh target that is not centrally symmetric lands a little off: V's centroid is not the
    mesh's). Returns :class:`Relaxed`; raises
    :class:`RelaxError` (what was reached) unless every face is planar to :data:`PLANARITY_GOAL` of the size
    within ``max_iterations`` steps, :class:`TargetError` or :class:`RemeshError` for bad input."""
    start = time.perf_counter()
    A, loops = _check(V, faces)
    surface, _ = place_target(A, loops, target)
    w = weights or Weights()
    lay = _layout(len(A), loops)
    normals = np.zeros((len(loops), 3))
    for k, loop in enumerate(loops):
        P = A[list(loop)]
        normals[k] = np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    edge = np.linalg.norm(A[lay.j] - A[lay.i], axis=1)
    Lf = np.bincount(lay.f, edge) / np.bincount(lay.f)
    x0 = np.concatenate([A.ravel(), normals.ravel(), Lf, [float(edge.mean())]])
    size = _size(A)

    def fun(x: Arr) -> tuple[Arr, sp.csr_matrix]:
        return residuals(x, lay, surface, w, float(edge.mean()), A)

    def flat(x: Arr) -> bool:
        return float(planarity(x[:3 * len(A)].reshape(-1, 3), loops).max()) <= PLANARITY_GOAL * size

    x, its, ok = _levenberg_marquardt(x0, fun, STEP_TOLERANCE * size, flat, max_iterations, dense=3)
    Vr = x[:3 * len(A)].reshape(-1, 3)
    m = measure(Vr, loops, surface)
    if not ok:
        raise RelaxError(f"relaxing {len(loops)} faces onto {surface.source} did not converge in {its} steps: "
                         f"planarity reached {m.planarity.max():.3g} mm ({m.planarity.max() / m.size:.2g} of the "
                         f"size, goal {PLANARITY_GOAL:g}), edges within {m.edge_deviation.max():.2%}, angles within "
                         f"{math.degrees(float(m.angle_deviation.max())):.2f}°, target distance rms "
                         f"{m.distance_rms:.3%} of the size")
    return Relaxed(Vr, loops, m, surface, its, time.perf_counter() - start)


def _size(V: Arr) -> float:
    return float(np.sqrt(np.mean(((V - V.mean(axis=0)) ** 2).sum(axis=1))))


def planarity(V: Arr, faces: Faces) -> Arr:
    """(nf,) mm: for each face the largest distance of a corner from its best-fit plane (least squares, the
    smallest singular vector of the corners about their mean)."""
    out = np.zeros(len(faces))
    for k, loop in enumerate(faces):
        P = V[list(loop)]
        P = P - P.mean(axis=0)
        normal = np.linalg.svd(P)[2][-1]
        out[k] = float(np.abs(P @ normal).max())
    return out


def measure(V: Arr, faces: Faces, surface: TargetSurface | None = None) -> Measures:
    """The :class:`Measures` of vertices V (n, 3) mm with ``faces``; the distances are 0 without a
    ``surface``. Raises :class:`RemeshError` for bad V or faces."""
    A, loops = _check(V, faces)
    lay = _layout(len(A), loops)
    edge = np.linalg.norm(A[lay.j] - A[lay.i], axis=1)
    mean = float(edge.mean())
    edge_dev = np.zeros(len(loops))
    np.maximum.at(edge_dev, lay.f, np.abs(edge - mean) / mean)
    a = A[lay.p] - A[lay.i]
    b = A[lay.j] - A[lay.i]
    cos = (a * b).sum(axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    sides = np.array([len(loops[f]) for f in lay.f], dtype=np.float64)
    angle_dev = np.zeros(len(loops))
    np.maximum.at(angle_dev, lay.f, np.abs(np.arccos(np.clip(cos, -1.0, 1.0)) - math.pi * (sides - 2.0) / sides))
    size = _size(A)
    d = np.zeros(1) if surface is None else np.linalg.norm(A - surface.closest(A)[0], axis=1)
    return Measures(planarity(A, loops), edge_dev, angle_dev, size, float(np.sqrt(np.mean(d * d))) / size,
                    float(d.max()) / size)


def face_points(V: Arr, faces: Faces, k: int = 6) -> Arr:
    """Points (m, 3) mm spread over the faces: each face cut into the triangles from its corners' mean to its
    edges, each triangle sampled at the barycentric points (a, b) / k, a + b ≤ k (corners and edges
    included, so shared points repeat). Raises :class:`RemeshError` for bad V or faces."""
    A, loops = _check(V, faces)
    ab = np.array([(a, b) for a in range(k + 1) for b in range(k + 1 - a)], dtype=np.float64) / k
    out = []
    for loop in loops:
        P = A[list(loop)]
        c = P.mean(axis=0)
        Q = np.roll(P, -1, axis=0)
        out.append((c + ab[:, :1, None] * (P - c)[None] + ab[:, 1:, None] * (Q - c)[None]).reshape(-1, 3))
    return np.vstack(out)


def approximation_error(V: Arr, faces: Faces, target: ClosedTarget | str, *, corners: bool = False) -> float:
    """The distance of a polyhedron's planar faces' points (:func:`face_points`), or with ``corners`` its
    vertices only, from the target after the design's best similarity
    (:meth:`fabpat.design.target.ClosedTarget.fit`): the relative rms (rms over the points' RMS radius), as
    ``relative_rms`` of a design; of more than :data:`FIT_SAMPLE` points a seeded subset of that many. Raises
    :class:`fabpat.design.target.TargetError` for a bad target."""
    from fabpat.design.closed import design_axis
    from fabpat.design.remesh_target import closed_target

    A, loops = _check(V, faces)
    t = closed_target(target)
    P = A if corners else face_points(A, loops)
    if len(P) > FIT_SAMPLE:
        P = P[np.random.default_rng(0).choice(len(P), FIT_SAMPLE, replace=False)]
    return float(t.fit(P, design_axis(A, loops)).relative_rms)


def write_obj(V: Arr, faces: Faces) -> bytes:
    """The polygon mesh as OBJ bytes, polygon faces kept (:func:`fabpat.assembly.surface.mesh_tiling.write_obj`,
    through meshio). Raises :class:`RemeshError` for bad V or faces."""
    from fabpat.assembly.surface.mesh_tiling import write_obj as write_tiling
    from fabpat.assembly.surface.tiling import Tiling

    A, loops = _check(V, faces)
    return write_tiling(Tiling("mapped", A, loops, best_fit=True))
