"""Built-in surfaces of (nearly) regular polygons beyond the truncated icosahedron: Goldberg polyhedra,
hexagon tubes and hexagon caps (paper §3, §6: "a target surface approximated as a polygon mesh with
(almost) regular faces").

None of them can be built exactly from flat regular polygons of one edge (only the truncated
icosahedron, GP(1, 1), can among the Goldberg polyhedra), so each is a *realization*: vertices on a
sphere or a cylinder whose faces are only nearly regular and nearly planar. The plates sit at their
faces' best fit and the closure solver ramps every sleeve's mismatch to zero
(:func:`fabpat.assembly.solve.closure.slot_motions`): the closed shape comes from the combinatorics and the
plates' stiffness, not from the realization.

* :func:`geodesic` — the geodesic sphere {3,5+}_(m,n): each icosahedron face covered by the triangular
  lattice whose big triangle has corners 0, m e1 + n e2 and its 60° turn (T = m² + mn + n² small
  triangles per face), projected to the unit sphere and triangulated by its convex hull (on a sphere
  the hull is the Delaunay triangulation). 10 T + 2 vertices.
* :func:`goldberg` — GP(m, n), its dual: 10 T + 2 faces, 12 pentagons and 10 (T − 1) hexagons (Hart,
  *Goldberg polyhedra*, in *Shaping Space*, Springer 2013). Realization ``"dual"``: a vertex at each
  geodesic triangle's centroid projected to the sphere (faces not planar); ``"planar"``: the polar
  reciprocal (every face in the plane tangent to the sphere at its geodesic vertex).
* :func:`hex_tube` — ``rows`` hexagons around a cylinder × ``columns`` along it: the honeycomb strip of
  :func:`fabpat.assembly.surface.tiling.honeycomb_strip` rolled up so that row ``rows`` is row 0.
* :func:`hex_cap` — ``rings`` rings of faces around a central hexagon (a flat disc) or pentagon (a dome:
  the faces of GP(rings + 1, 0) within ``rings`` edge-steps of one pentagon, which holds no other).

Each returns vertices (n, 3) and faces (vertex loops) at unit mean edge;
:func:`fabpat.assembly.surface.mesh_tiling.mesh_tiling`
with ``fit="best"`` orients, checks and scales them like a mesh file.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.surface.tiling import edge_key, icosahedron, weld
from fabpat.errors import SpecError

Arr = NDArray[np.float64]
Faces = tuple[tuple[int, ...], ...]
REALIZATIONS = ("dual", "planar")


def _integers(what: str, **values: object) -> None:
    """SpecError naming ``what`` unless every value is an integer (not a bool, a float such as 1.5, None or
    a string): a count of faces is whole, and ``range(1.5)`` or ``None < 1`` raised bare TypeErrors."""
    for name, v in values.items():
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            raise SpecError(f"{what}: {name} must be an integer, got {v!r}")


def geodesic(m: int, n: int) -> tuple[Arr, NDArray[np.int64]]:
    """The geodesic sphere {3,5+}_(m,n): unit vertices (10 T + 2, 3), outward triangles (20 T, 3).
    Raises :class:`SpecError` unless m ≥ 1 and n ≥ 0 are integers."""
    from scipy.spatial import ConvexHull

    _integers("a Goldberg polyhedron GP(m, n)", m=m, n=n)
    if m < 1 or n < 0:
        raise SpecError(f"a Goldberg polyhedron GP(m, n) needs m ≥ 1 and n ≥ 0, got ({m}, {n})")
    V, F = icosahedron()
    s3 = math.sqrt(3.0)
    p1 = np.array([m + 0.5 * n, 0.5 * s3 * n])  # m e1 + n e2
    p2 = np.array([0.5 * p1[0] - 0.5 * s3 * p1[1], 0.5 * s3 * p1[0] + 0.5 * p1[1]])  # p1 turned by 60°
    M = np.linalg.inv(np.column_stack([p1, p2]))
    pts = []
    for i in range(-n - 1, m + 2):
        for j in range(0, m + n + 2):
            w1, w2 = M @ np.array([i + 0.5 * j, 0.5 * s3 * j])
            w0 = 1.0 - w1 - w2
            if min(w0, w1, w2) >= -1e-9:
                pts.append((w0, w1, w2))
    W = np.array(pts)
    P = np.vstack([W @ V[f] for f in F])
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    P = weld(P, 1e-9)[0]
    T = m * m + m * n + n * n
    if len(P) != 10 * T + 2:
        raise AssertionError(f"GP({m}, {n}): {len(P)} geodesic vertices, expected {10 * T + 2}")
    tri = ConvexHull(P).simplices.astype(np.int64)
    for r, (a, b, c) in enumerate(tri):  # outward: the hull of points on a sphere contains the centre
        if np.cross(P[b] - P[a], P[c] - P[a]) @ (P[a] + P[b] + P[c]) < 0:
            tri[r] = (a, c, b)
    return P, tri


def goldberg(m: int, n: int, realization: str = "dual") -> tuple[Arr, Faces]:
    """GP(m, n) as vertices (20 T, 3) and faces (12 pentagons, 10 (T − 1) hexagons, CCW from outside),
    pentagons first; ``realization`` "dual" or "planar" (module docstring). Unit mean edge. Raises
    :class:`SpecError` for another realization or m, n that are not integers m ≥ 1, n ≥ 0."""
    _integers("a Goldberg polyhedron GP(m, n)", m=m, n=n)
    if not isinstance(realization, str) or realization not in REALIZATIONS:
        raise SpecError(f"realization = {realization!r}: choose one of {', '.join(REALIZATIONS)}")
    P, tri = geodesic(m, n)
    if realization == "dual":
        C = P[tri].mean(axis=1)
        C /= np.linalg.norm(C, axis=1, keepdims=True)
    else:
        C = np.linalg.solve(P[tri], np.ones((len(tri), 3, 1)))[..., 0]  # x · a = x · b = x · c = 1
    around: list[list[int]] = [[] for _ in range(len(P))]
    for t, corners in enumerate(tri):
        for v in corners:
            around[v].append(t)
    faces = []
    for v, ts in enumerate(around):
        u = np.cross(P[v], [0.0, 0.0, 1.0] if abs(P[v][2]) < 0.9 else [1.0, 0.0, 0.0])
        u /= np.linalg.norm(u)
        w = np.cross(P[v], u)
        ang = [math.atan2((C[t] - P[v]) @ w, (C[t] - P[v]) @ u) for t in ts]
        faces.append(tuple(ts[k] for k in np.argsort(ang)))
    faces.sort(key=len)  # pentagons first, each group in geodesic vertex order (reproducible)
    return _unit(C, tuple(faces))


def _unit(V: Arr, faces: Faces) -> tuple[Arr, Faces]:
    """The mesh scaled to unit mean edge."""
    ends = {tuple(sorted((f[i], f[(i + 1) % len(f)]))) for f in faces for i in range(len(f))}
    e = np.array(sorted(ends))
    return V / float(np.linalg.norm(V[e[:, 1]] - V[e[:, 0]], axis=1).mean()), faces


def hex_tube(rows: int, columns: int) -> tuple[Arr, Faces]:
    """``rows`` hexagons around × ``columns`` along a cylinder (axis x), unit edge before rolling. Raises
    :class:`SpecError` unless they are integers, rows ≥ 3 and columns ≥ 1."""
    from fabpat.assembly.surface.tiling import honeycomb_strip

    _integers("a hexagon tube", rows=rows, columns=columns)
    if rows < 3 or columns < 1:
        raise SpecError(f"a hexagon tube needs rows ≥ 3 (around) and columns ≥ 1, got {rows} × {columns}")
    flat = honeycomb_strip(rows, columns, 1.0)
    period = math.sqrt(3.0) * rows
    radius = period / (2.0 * math.pi)
    y = flat.V[:, 1] - flat.V[:, 1].min() + 0.5 * math.sqrt(3.0)  # row 0's bottom edge at y = 0 (even columns)
    theta = -2.0 * math.pi * y / period  # clockwise: the strip's counter-clockwise loops face outwards
    P = np.column_stack([flat.V[:, 0], radius * np.cos(theta), radius * np.sin(theta)])
    P, idx = weld(P, 1e-6)
    faces = tuple(tuple(int(idx[i]) for i in loop) for loop in flat.faces)
    return _unit(P, faces)


def hex_cap(rings: int, centre: int = 5) -> tuple[Arr, Faces]:
    """A central hexagon (``centre`` 6, flat) or pentagon (5, a dome) and ``rings`` rings of hexagons, the
    centre face's outward normal along +z: the dome's apex is up (the GLB turns +z to glTF's up, +y).
    Raises :class:`SpecError` unless ``rings`` ≥ 1 is an integer and ``centre`` 5 or 6."""
    _integers("a hexagon cap", rings=rings, centre=centre)
    if rings < 1 or centre not in (5, 6):
        raise SpecError(f"a hexagon cap needs rings ≥ 1 and centre 5 or 6, got rings = {rings}, centre = {centre}")
    if centre == 6:
        from fabpat.assembly.surface.tiling import honeycomb_strip

        size = 2 * rings + 1
        flat = honeycomb_strip(size, size, 1.0)
        grid = flat.grid
        assert grid is not None
        mid = np.flatnonzero((grid[:, 0] == rings) & (grid[:, 1] == rings))[0]
        V, faces = flat.V, flat.faces
        start = int(mid)
    else:
        V, faces = goldberg(rings + 1, 0, "dual")
        start = 0  # a pentagon (pentagons come first)
        V = V @ _turn_to_z(V[list(faces[start])].mean(axis=0)).T
    keep = _rings(faces, start, rings)
    used = sorted({v for f in keep for v in faces[f]})
    new = {v: i for i, v in enumerate(used)}
    return _unit(V[used], tuple(tuple(new[v] for v in faces[f]) for f in keep))


def _turn_to_z(d: Arr) -> Arr:
    """(3, 3) rotation taking the direction ``d`` (3,) to +z (Rodrigues' formula about d × z)."""
    d = d / np.linalg.norm(d)
    z = np.array([0.0, 0.0, 1.0])
    k = np.cross(d, z)
    s, c = float(np.linalg.norm(k)), float(d @ z)
    if s < 1e-15:  # already along ±z: the identity, or half a turn about x
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]]) / s
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _rings(faces: Faces, start: int, rings: int) -> list[int]:
    """Faces within ``rings`` edge-steps of face ``start``, nearest first (ties by face index)."""
    by_edge: dict[tuple[int, int], list[int]] = {}
    for f, loop in enumerate(faces):
        for i, a in enumerate(loop):
            by_edge.setdefault(edge_key(a, loop[(i + 1) % len(loop)]), []).append(f)
    dist = {start: 0}
    frontier = [start]
    for d in range(1, rings + 1):
        nxt = []
        for f in frontier:
            loop = faces[f]
            for i, a in enumerate(loop):
                for g in by_edge[edge_key(a, loop[(i + 1) % len(loop)])]:
                    if g not in dist:
                        dist[g] = d
                        nxt.append(g)
        frontier = sorted(nxt)
    return sorted(dist, key=lambda f: (dist[f], f))
