"""Meshes graded to the local width of an outline: a second, independent mesh family for the reference
energies of ``study_convergence.py`` (not part of fabpat).

Element size s(x) = h · min(1, (w/k + g·d) / H0) with w the local width at the nearest boundary samples
(distance to the nearest boundary point that is far along the boundary: arc separation > 2 × distance,
or another loop), d the distance to those samples, k = 3 elements across a width, growth g = 0.3 and
H0 = 1.5 mm: necks get k elements across at h = H0 and proportionally more on finer meshes, so the
whole family refines uniformly with h (as a reference extrapolated in h needs). Curves are flattened
as fabpat does (:func:`fabpat.simulation.mesh.flatten_outline`, 0.02·h mm); Triangle refines towards s by per-triangle
area bounds.
"""

from __future__ import annotations

import math

import numpy as np
import triangle
from fabpat.simulate import mesh as M
from scipy.spatial import cKDTree

K_ACROSS, GROWTH, H0 = 3.0, 0.3, 1.5


def boundary_width(loops: list[np.ndarray], ds: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Boundary samples (k, 2) every ≤ ds mm and the local width there (k,) in mm (inf: wider than 12 mm)."""
    pts, lid, arc, per = [], [], [], []
    for i, P in enumerate(loops):
        Q = M._subdivide(M._clean_loop(P), ds)
        seg = np.linalg.norm(np.roll(Q, -1, 0) - Q, axis=1)
        pts.append(Q)
        lid.append(np.full(len(Q), i))
        arc.append(np.concatenate([[0.0], np.cumsum(seg)[:-1]]))
        per.append(np.full(len(Q), seg.sum()))
    X, L, S, Pm = np.concatenate(pts), np.concatenate(lid), np.concatenate(arc), np.concatenate(per)
    w = np.full(len(X), np.inf)
    pairs = cKDTree(X).query_pairs(12.0, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.linalg.norm(X[i] - X[j], axis=1)
    along = np.abs(S[i] - S[j])
    along = np.minimum(along, Pm[i] - along)
    far = (L[i] != L[j]) | (along > 2.0 * d)
    np.minimum.at(w, i[far], d[far])
    np.minimum.at(w, j[far], d[far])
    return X, w


def size_factor(C: np.ndarray, X: np.ndarray, w: np.ndarray) -> np.ndarray:
    """min(1, (w/k + g·d)/H0) at points C (m, 2): the element size per mm of h."""
    narrow = w / K_ACROSS < H0
    Xn, wn = X[narrow], w[narrow]
    out = np.ones(len(C))
    if len(Xn) == 0:
        return out
    D = cKDTree(C).sparse_distance_matrix(cKDTree(Xn), H0 / GROWTH, output_type="coo_matrix")
    val = wn[D.col] / K_ACROSS + GROWTH * D.data
    np.minimum.at(out, D.row, val / H0)
    return np.minimum(out, 1.0)


def graded_mesh(outline: object, h: float, min_angle: float = 25.0) -> M.ShellMesh:
    """A Triangle mesh of a filleted outline graded to its local width (module docstring), interfaces tagged."""
    segs = [(a, b) for a, b in outline.polygon.interfaces]  # type: ignore[attr-defined]
    loops = [M._clean_loop(L) for L in M.flatten_outline(outline, M.FLATTEN_TOL_PER_H * h)]
    X, w = boundary_width(loops)
    verts, sg, holes, off = [], [], [], 0
    for k, P in enumerate(loops):
        a = M._signed_area(P)
        if k == 0 and a < 0 or k > 0 and a > 0:
            P = P[::-1]
        if k > 0:
            holes.append(M._point_inside(P))
        s = h * size_factor(P, X, w)
        cut = []
        for p, q, sp, sq in zip(P, np.roll(P, -1, 0), s, np.roll(s, -1), strict=True):
            n = max(1, math.ceil(float(np.linalg.norm(q - p)) / min(sp, sq) - 1e-9))
            cut.append(p + (np.arange(n)[:, None] / n) * (q - p))
        Q = np.concatenate(cut)
        verts.append(Q)
        sg.append(off + np.stack([np.arange(len(Q)), (np.arange(len(Q)) + 1) % len(Q)], 1))
        off += len(Q)
    data = {"vertices": np.concatenate(verts), "segments": np.concatenate(sg)}
    if holes:  # Triangle reads an empty hole list out of bounds
        data["holes"] = np.array(holes)
    a0 = M.AREA_FACTOR * math.sqrt(3.0) / 4.0
    T = triangle.triangulate(data, f"pq{min_angle:g}a{a0 * h * h:.10g}")
    for _ in range(10):
        V, F = T["vertices"], T["triangles"]
        target = a0 * (h * size_factor(V[F].mean(axis=1), X, w)) ** 2
        e = V[F]
        u, v = e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]
        if (0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) <= 1.05 * target).all():
            break
        T = dict(T, triangle_max_area=target)
        T = triangle.triangulate(T, f"rpq{min_angle:g}")
    V, F = np.asarray(T["vertices"], float), np.asarray(T["triangles"], np.int64)
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    if not used.all():
        V, F = V[used], (np.cumsum(used) - 1)[F]
    a, b = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    cw = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    F[cw] = F[cw][:, [0, 2, 1]]
    return M.ShellMesh(V, F, M.tag_segments(V, segs))
