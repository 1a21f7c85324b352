"""Closed polylines (flattened outlines): crossings, containment and the narrowest neck.

A loop is a ``(k, 2) float`` array of vertices in mm, closed implicitly (no repeated last point);
edge e joins vertex e to e + 1. These are the checks :meth:`fabpat.geometry.outline.Outline.validate` runs on
an outline flattened within a tolerance; they are pure numpy plus scipy's k-d tree.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fabpat.geometry.curves import FloatArray, cross2d, rot90

__all__ = ["points_in_polygon", "polyline_intersections", "ray_min_width"]


def _segment_distances(a0: FloatArray, a1: FloatArray, b0: FloatArray, b1: FloatArray) -> FloatArray:
    """Distances (m,) between segments [a0, a1] and [b0, b1], all (m, 2); 0 when they cross."""

    def pt_seg(p: FloatArray, s0: FloatArray, s1: FloatArray) -> FloatArray:
        d = s1 - s0
        L2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
        u = np.clip(np.einsum("ij,ij->i", p - s0, d) / L2, 0.0, 1.0)
        return np.hypot(*(p - s0 - u[:, None] * d).T)

    o1 = cross2d(a1 - a0, b0 - a0)
    o2 = cross2d(a1 - a0, b1 - a0)
    o3 = cross2d(b1 - b0, a0 - b0)
    o4 = cross2d(b1 - b0, a1 - b0)
    proper = (o1 * o2 < 0) & (o3 * o4 < 0)
    d = np.minimum.reduce([pt_seg(a0, b0, b1), pt_seg(a1, b0, b1), pt_seg(b0, a0, a1), pt_seg(b1, a0, a1)])
    return np.where(proper, 0.0, d)


def _closed_edges(loops: list[FloatArray]) -> tuple[FloatArray, FloatArray, NDArray[np.int64], NDArray[np.int64]]:
    """Edge starts (M, 2), ends (M, 2), loop index (M,) and index within the loop (M,)."""
    A = np.vstack(loops)
    B = np.vstack([np.roll(V, -1, axis=0) for V in loops])
    lid = np.concatenate([np.full(len(V), i) for i, V in enumerate(loops)])
    eid = np.concatenate([np.arange(len(V)) for V in loops])
    return A, B, lid, eid


def polyline_intersections(loops: Sequence[ArrayLike], eps: float = 1e-9) -> NDArray[np.int64]:
    """Pairs of edges of closed polylines that touch or cross: (p, 4) int (loop_i, edge_i, loop_j, edge_j).

    loops: closed polylines (k_l, 2) without a repeated last point; edge e joins vertex e to e + 1.
    Consecutive edges of a loop share a vertex and are only reported when they fold back onto each
    other. Candidates come from a sort-and-sweep on x-extents (no all-pairs loop), then an exact
    vectorised segment-distance test; "touch" means closer than eps (mm).
    """
    Ls = [np.asarray(V, dtype=np.float64) for V in loops]
    A, B, lid, eid = _closed_edges(Ls)
    n = len(A)
    sizes = np.array([len(V) for V in Ls])
    xmin, xmax = np.minimum(A[:, 0], B[:, 0]), np.maximum(A[:, 0], B[:, 0])
    ymin, ymax = np.minimum(A[:, 1], B[:, 1]), np.maximum(A[:, 1], B[:, 1])
    order = np.argsort(xmin, kind="stable")
    hi = np.searchsorted(xmin[order], xmax[order] + eps, side="right")
    counts = np.maximum(hi - np.arange(n) - 1, 0)
    found: list[NDArray[np.int64]] = []
    block = 4096
    for lo in range(0, n, block):
        idx = np.arange(lo, min(lo + block, n))
        c = counts[idx]
        if c.sum() == 0:
            continue
        i_sorted = np.repeat(idx, c)
        offsets = np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c)
        j_sorted = i_sorted + 1 + offsets
        i, j = order[i_sorted], order[j_sorted]
        keep = (ymin[i] <= ymax[j] + eps) & (ymin[j] <= ymax[i] + eps)
        i, j = i[keep], j[keep]
        same = lid[i] == lid[j]
        k = sizes[lid[i]]
        gap = np.abs(eid[i] - eid[j])
        adjacent = same & ((gap == 1) | (gap == k - 1))
        d = _segment_distances(A[i], B[i], A[j], B[j])
        hit = (d <= eps) & ~adjacent
        # Adjacent edges only intersect by folding back along each other (a zero-width spike).
        ui, uj = B[i] - A[i], B[j] - A[j]
        fold = adjacent & (np.abs(cross2d(ui, uj)) <= eps * np.hypot(*ui.T) * np.hypot(*uj.T)) & (
            np.einsum("ij,ij->i", ui, uj) < 0
        )
        sel = hit | fold
        found.append(np.column_stack([lid[i[sel]], eid[i[sel]], lid[j[sel]], eid[j[sel]]]))
    return np.vstack(found) if found else np.zeros((0, 4), dtype=np.int64)


def points_in_polygon(X: ArrayLike, V: ArrayLike) -> NDArray[np.bool_]:
    """Crossing-number test: which points X (m, 2) lie inside the closed polygon V (k, 2); (m,) bool."""
    X = np.atleast_2d(np.asarray(X, dtype=np.float64))
    V = np.asarray(V, dtype=np.float64)
    A, B = V, np.roll(V, -1, axis=0)
    y = X[:, 1:2]
    straddle = (A[None, :, 1] > y) != (B[None, :, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = A[None, :, 0] + (y - A[None, :, 1]) * (B[None, :, 0] - A[None, :, 0]) / (
            B[None, :, 1] - A[None, :, 1]
        )
    crossings = straddle & (X[:, 0:1] < xc)
    return (crossings.sum(axis=1) % 2) == 1


def _subdivide(A: FloatArray, B: FloatArray, max_len: float) -> tuple[FloatArray, FloatArray]:
    """Edges A -> B ((M, 2) each) cut into pieces no longer than max_len: (M', 2), (M', 2)."""
    D = B - A
    m = np.maximum(1, np.ceil(np.hypot(*D.T) / max_len)).astype(np.int64)
    e = np.repeat(np.arange(len(A)), m)
    k = np.arange(m.sum()) - np.repeat(np.cumsum(m) - m, m)
    return A[e] + (k / m[e])[:, None] * D[e], A[e] + ((k + 1) / m[e])[:, None] * D[e]


REFINE_CANDIDATES = 16  # local minima of the sampled thickness refined (with symmetry: per sector)
REFINE_SAMPLES = 65  # rays across ±1 spacing around each: a step of spacing/32


def _ray_hits(
    origin: FloatArray,
    direction: FloatArray,
    A: FloatArray,
    B: FloatArray,
    ri: NDArray[np.int64],
    ej: NDArray[np.int64],
) -> FloatArray:
    """Distance to the first hit of rays origin + t direction ((m, 2) each) among candidate edges.

    A, B (M, 2): edges; ri, ej (p,): candidate (ray, edge) pairs. Returns t (m,), inf if no hit.
    """
    Ae, D = A[ej], B[ej] - A[ej]
    o, nrm = origin[ri], direction[ri]
    W0 = Ae - o
    den = cross2d(nrm, D)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = cross2d(W0, D) / den
        u = cross2d(W0, nrm) / den
    # t > 1e-9 skips the ray's own edge; a ray parallel to an edge (den = 0) cannot leave through it.
    ok = (np.abs(den) > 1e-14) & (u >= -1e-12) & (u <= 1.0 + 1e-12) & (t > 1e-9)
    t_best = np.full(len(origin), np.inf)
    np.minimum.at(t_best, ri[ok], t[ok])
    return t_best


def _in_sector(P: FloatArray, symmetry: int) -> NDArray[np.bool_]:
    """Points (m, 2) whose polar angle lies in [0, 2π/symmetry], with 1e-9 rad of overlap."""
    angle = np.mod(np.arctan2(P[:, 1], P[:, 0]) + 1e-9, 2.0 * math.pi)
    return angle <= 2.0 * math.pi / symmetry + 2e-9


def ray_min_width(
    loops: Sequence[ArrayLike], spacing: float, *, symmetry: int = 1
) -> tuple[float, FloatArray, FloatArray]:
    """Narrowest bar or neck of a region bounded by closed polylines, mm.

    loops: closed polylines (k, 2), oriented with the solid on their left (outer counter-clockwise,
    holes clockwise). Definition: from each boundary point cast a ray along the inward normal; its
    length to the first boundary point it meets is the local thickness there (the "ray method" of
    wall-thickness analysis), and min_width is the smallest such thickness. At a neck or bar the
    minimising ray is the double normal, so the neck width is found exactly; a rounded or right-angled
    convex corner does not shrink it (its normals cross the whole part), but a convex corner sharper
    than 90° does, towards 0 at the tip - a sharp tip is thin. A straight cut across a neck (an
    interface edge) counts as boundary, so the neck width measured along it is found.

    Rays start on the edges spaced at most ``spacing`` mm and at every vertex (along the bisector
    of the two edge normals, which is the curve normal at a flattening vertex); around the best local
    minima (``REFINE_CANDIDATES``) the edge rays are re-sampled 32 times finer (``REFINE_SAMPLES`` over
    ±1 spacing). To avoid an all-pairs test, 8 rays against every edge first give an upper bound U;
    then each ray is only tested against the edge pieces near its first U mm (k-d tree on piece
    midpoints), which cannot miss a hit shorter than U.

    ``symmetry`` = n > 1 declares that the region is invariant under rotation by 2π/n about the
    origin (the caller checks it): every boundary point then has an image in the sector of polar
    angles [0, 2π/n], so rays start there only - n times fewer - and still hit every edge.

    Returns (width, p (2,), q (2,)) with p, q the ends of the narrowest ray.

    One function: the vectorised ray casting, its candidate filtering and the neck's location share the same
    arrays; its steps are commented in order.
    """
    from scipy.spatial import cKDTree

    if symmetry < 1:
        raise ValueError(f"symmetry must be a positive integer, got {symmetry}")
    Ls = [np.asarray(V, dtype=np.float64) for V in loops]
    A, B, lid, eid = _closed_edges(Ls)
    D = B - A
    length = np.hypot(*D.T)
    nz = length > 0
    normal = np.zeros_like(D)
    normal[nz] = rot90(D[nz] / length[nz, None])
    # vertex i of a loop starts edge i; its incoming edge is the loop's previous edge
    sizes = np.array([len(V) for V in Ls])
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    prev = np.where(eid == 0, first[lid] + sizes[lid] - 1, np.arange(len(A)) - 1)
    bis = normal + normal[prev]
    bl = np.hypot(*bis.T)
    vok = bl > 1e-9
    if symmetry > 1:
        vok &= _in_sector(A, symmetry)
    v_orig, v_dir = A[vok], bis[vok] / bl[vok, None]

    m = np.where(nz, np.maximum(1, np.ceil(length / spacing)), 0).astype(np.int64)
    e = np.repeat(np.arange(len(A)), m)
    k = np.arange(m.sum()) - np.repeat(np.cumsum(m) - m, m)
    f = (k + 0.5) / m[e]
    e_orig, e_dir = A[e] + f[:, None] * D[e], normal[e]
    # One sample of overlap past the sector's ends keeps a minimum there a local minimum below.
    cast_from = np.ones(len(e), dtype=bool) if symmetry == 1 else _in_sector(e_orig, symmetry)
    cast_from |= np.roll(cast_from, 1) | np.roll(cast_from, -1)
    ce = np.flatnonzero(cast_from)

    # Upper bound from a subset of rays against all edges.
    sub = ce[:: max(1, len(ce) // 8)]
    ri = np.repeat(np.arange(len(sub)), len(A))
    ej = np.tile(np.arange(len(A)), len(sub))
    U = float(_ray_hits(e_orig[sub], e_dir[sub], A, B, ri, ej).min())
    if not math.isfinite(U):
        return math.inf, np.full(2, np.nan), np.full(2, np.nan)
    PA, PB = _subdivide(A, B, max(U / 4.0, spacing))
    piece_len = float(np.hypot(*(PB - PA).T).max())
    tree = cKDTree(0.5 * (PA + PB))

    def cast(o: FloatArray, n: FloatArray) -> FloatArray:
        pairs = cKDTree(o + 0.5 * U * n).sparse_distance_matrix(tree, 0.5 * (U + piece_len), output_type="ndarray")
        return _ray_hits(o, n, PA, PB, pairs["i"].astype(np.int64), pairs["j"].astype(np.int64))

    t_first = cast(np.vstack([e_orig[ce], v_orig]), np.vstack([e_dir[ce], v_dir]))
    t = np.full(len(e), np.inf)
    t[ce] = t_first[: len(ce)]
    t_vertex = t_first[len(ce) :]
    tmin = float(t_first.min())
    # Refine around local minima of the thickness along the boundary that could beat the best one
    # (the sampled minimum overestimates a smooth one by O(curvature · spacing²) < spacing).
    local = (t <= np.roll(t, 1)) & (t <= np.roll(t, -1)) & (t <= tmin + spacing) & np.isfinite(t)
    cand = np.flatnonzero(local)
    cand = cand[np.argsort(t[cand])][:REFINE_CANDIDATES]
    sub_f = np.linspace(-1.0, 1.0, REFINE_SAMPLES)
    e2 = np.repeat(e[cand], len(sub_f))
    f2 = np.clip((f[cand][:, None] + sub_f[None] / m[e[cand]][:, None]).ravel(), 0.0, 1.0)
    o2, n2 = A[e2] + f2[:, None] * D[e2], normal[e2]
    origin = np.vstack([e_orig, v_orig, o2])
    direction = np.vstack([e_dir, v_dir, n2])
    t_all = np.concatenate([t, t_vertex, cast(o2, n2)])
    i = int(np.argmin(t_all))
    if not math.isfinite(t_all[i]):
        return math.inf, np.full(2, np.nan), np.full(2, np.nan)
    return float(t_all[i]), origin[i], origin[i] + t_all[i] * direction[i]
