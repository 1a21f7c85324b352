"""Skeleton tilings: the polyhedral surfaces whose faces carry the plates (paper §5).

A :class:`Tiling` is a surface of regular polygons sharing edges: vertices ``V`` (nv, 3) mm and
faces as vertex loops, counter-clockwise seen from the outside (the side the face normal points
to). Two tilings are built here:

* :func:`truncated_icosahedron` — 20 hexagons + 12 pentagons, 60 vertices, 90 edges; interior
  dihedral angles arccos(−√5/3) ≈ 138.19° (hexagon–hexagon) and arccos(−√((5 + 2√5)/15)) ≈ 142.62°
  (hexagon–pentagon). Built by cutting every edge of the icosahedron into thirds.
* :func:`honeycomb_strip` — ``rows`` × ``columns`` flat-topped hexagons in the plane z = 0 (columns
  along x, odd columns shifted up by half a hexagon), every interior edge shared by two tiles.

Face loop ``(v0, v1, …)`` matches :func:`fabpat.patterns.lattice.polygon_vertices`: corner i of the plate is
v_i, so polygon edge i of the plate lies on skeleton edge (v_i, v_{i+1}).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from fabpat.geometry.polygons import newell_normal
from fabpat.patterns.lattice import polygon_vertices
from fabpat.validate import SAME_POINT

PHI = (1.0 + math.sqrt(5.0)) / 2.0
HEX_HEX_DIHEDRAL = math.acos(-math.sqrt(5.0) / 3.0)  # rad, ≈ 138.19°
HEX_PENT_DIHEDRAL = math.acos(-math.sqrt((5.0 + 2.0 * math.sqrt(5.0)) / 15.0))  # rad, ≈ 142.62°
#: a polyhedron's plate label prefix by polygon sides ("F" for any other polygon)
FACE_LETTERS = {3: "T", 4: "Q", 5: "P", 6: "H"}


def edge_key(a: int, b: int) -> tuple[int, int]:
    """The undirected edge between vertices ``a`` and ``b`` as (low, high) vertex indices."""
    return (a, b) if a <= b else (b, a)


@dataclass(frozen=True, eq=False)
class Tiling:
    """A surface of regular polygons: ``V`` (nv, 3) float mm, ``faces`` vertex loops (CCW from outside).

    ``name`` is the tiling kind; ``grid`` (nf, 2) int gives (row, column) of each tile of a strip
    (−1 for polyhedra). ``best_fit``: the faces are only nearly regular (and planar), and each plate
    sits at its face's best fit (:meth:`frames`). Derived data (edges, normals, dihedral angles) are
    cached properties.
    """

    name: str
    V: NDArray[np.float64]
    faces: tuple[tuple[int, ...], ...]
    grid: NDArray[np.int64] | None = None
    best_fit: bool = False

    @property
    def sides(self) -> NDArray[np.int64]:
        """(nf,) number of sides of each face."""
        return np.array([len(f) for f in self.faces], dtype=np.int64)

    @cached_property
    def labels(self) -> tuple[str, ...]:
        """The kit's plate label of each face: "T" and the face number on a strip; on a polyhedron the
        polygon's letter (:data:`FACE_LETTERS`: "H" hexagon, "P" pentagon, "Q" square, "T" triangle, "F"
        any other) and the count within that prefix, zero-padded to the width of the largest ("H01" …
        "H20", "P01" … "P12" on the truncated icosahedron)."""
        prefixes = [FACE_LETTERS.get(len(loop), "F") if self.grid is None else "T" for loop in self.faces]
        counts = {p: prefixes.count(p) for p in prefixes}
        seen: dict[str, int] = {}
        out = []
        for p in prefixes:
            seen[p] = seen.get(p, 0) + 1
            out.append(f"{p}{seen[p]:0{len(str(counts[p]))}d}")
        return tuple(out)

    @cached_property
    def edges(self) -> NDArray[np.int64]:
        """(ne, 2) int vertex pairs (low, high), in order of first appearance along the faces."""
        seen: dict[tuple[int, int], int] = {}
        for loop in self.faces:
            for i, a in enumerate(loop):
                seen.setdefault(edge_key(a, loop[(i + 1) % len(loop)]), len(seen))
        return np.array(list(seen), dtype=np.int64).reshape(-1, 2)

    @cached_property
    def edge_faces(self) -> NDArray[np.int64]:
        """(ne, 2, 2) int: for each edge, (face, local edge index) of its two faces; (−1, −1) if none.

        The first face is the lower face index, so the table is reproducible.
        """
        index = {(int(a), int(b)): k for k, (a, b) in enumerate(self.edges)}
        out = np.full((len(self.edges), 2, 2), -1, dtype=np.int64)
        for f, loop in enumerate(self.faces):
            for i, a in enumerate(loop):
                k = index[edge_key(a, loop[(i + 1) % len(loop)])]
                slot = 0 if out[k, 0, 0] < 0 else 1
                if slot == 1 and out[k, 1, 0] >= 0:
                    raise ValueError(f"edge {k} is shared by more than two faces")
                out[k, slot] = (f, i)
        return out

    @cached_property
    def face_edges(self) -> tuple[tuple[int, ...], ...]:
        """For each face, the edge index of its polygon edge i (edge i runs from v_i to v_{i+1})."""
        out = [[-1] * len(loop) for loop in self.faces]
        for k, pair in enumerate(self.edge_faces):
            for f, i in pair:
                if f >= 0:
                    out[f][i] = k
        return tuple(tuple(r) for r in out)

    @cached_property
    def centroids(self) -> NDArray[np.float64]:
        """(nf, 3) mm: centre of each (regular) face."""
        return np.array([self.V[list(loop)].mean(axis=0) for loop in self.faces])

    @cached_property
    def normals(self) -> NDArray[np.float64]:
        """(nf, 3) outward unit normals (right-hand rule on the loop)."""
        out = []
        for loop, c in zip(self.faces, self.centroids, strict=True):
            P = self.V[list(loop)] - c
            n = newell_normal(P)
            out.append(n / np.linalg.norm(n))
        return np.array(out)

    @cached_property
    def dihedral(self) -> NDArray[np.float64]:
        """(ne,) interior dihedral angle of each edge in rad (π on flat joints and boundary edges).

        Interior = measured through the inside of a convex polyhedron: π − angle between normals.
        """
        out = np.full(len(self.edges), math.pi)
        for k, ((fa, _), (fb, _)) in enumerate(self.edge_faces):
            if fb >= 0:
                c = float(np.clip(self.normals[fa] @ self.normals[fb], -1.0, 1.0))
                out[k] = math.pi - math.acos(c)
        return out

    @property
    def interior_edges(self) -> NDArray[np.int64]:
        """Indices of the edges shared by two faces (each gets a sleeve)."""
        return np.flatnonzero(self.edge_faces[:, 1, 0] >= 0)

    @property
    def boundary_edges(self) -> NDArray[np.int64]:
        """Indices of the edges with one face only (free plate interfaces)."""
        return np.flatnonzero(self.edge_faces[:, 1, 0] < 0)

    def edge_length(self) -> float:
        """Common edge length in mm (the tiling is built from regular polygons of one edge)."""
        a, b = self.edges[0]
        return float(np.linalg.norm(self.V[b] - self.V[a]))

    def plate_radius(self, plate_edge: float, axis: NDArray[np.float64] | None = None) -> float:
        """Mean distance (mm) of the plates' mid-surfaces from the centre of this tiling (the mean of its
        vertices) or, with ``axis`` (3,), from the line through it along ``axis`` (:func:`mean_distance`):
        each plate the face's polygon shrunk about its centroid to edge ``plate_edge`` (mm), as
        :mod:`fabpat.assembly.place.placement` sets it on the face plane (up to the slots' shared setback)."""
        shrink = plate_edge / self.edge_length()
        loops = []
        for loop in self.faces:
            P = self.V[list(loop)]
            c = P.mean(axis=0)
            loops.append(c + (P - c) * shrink)
        return mean_distance(loops, self.V.mean(axis=0), axis)

    def scaled(self, edge: float) -> Tiling:
        """The same tiling with edge length ``edge`` mm (scaled about the origin)."""
        return Tiling(self.name, self.V * (edge / self.edge_length()), self.faces, self.grid, self.best_fit)

    def frames(self) -> NDArray[np.float64]:
        """(nf, 4, 4) rigid transforms from a plate's polygon frame to the world.

        In the polygon frame the face is :func:`polygon_vertices` (centre at the origin, edge 0 along
        +x) with normal +z; the transform sends it onto the skeleton face, +z onto the outward normal.
        On a ``best_fit`` tiling the turn about the normal is the one that puts the polygon's corners
        nearest the face's projected corners (least squares: θ = arg Σ z_i / p_i over the corners as
        complex numbers, Procrustes), the centre at the corners' mean.
        """
        out = np.zeros((len(self.faces), 4, 4))
        for f, loop in enumerate(self.faces):
            X = self.V[loop[1]] - self.V[loop[0]]
            X /= np.linalg.norm(X)
            Z = self.normals[f]
            if self.best_fit:
                X -= (X @ Z) * Z
                X /= np.linalg.norm(X)
                Y = np.cross(Z, X)
                Q = self.V[list(loop)] - self.centroids[f]
                p = polygon_vertices(len(loop), 1.0) @ np.array([1.0, 1j])
                turn = np.angle(np.sum((Q @ X + 1j * (Q @ Y)) / p))
                X = math.cos(turn) * X + math.sin(turn) * Y
            out[f, :3, :3] = np.stack([X, np.cross(Z, X), Z], axis=1)
            out[f, :3, 3] = self.centroids[f]
            out[f, 3, 3] = 1.0
        return out


_K = 16  # a fan triangle cut into _K² equal triangles (upward and downward ones): their centroids
_SUB_CENTROIDS = np.array([((i + 1 / 3) / _K, (j + 1 / 3) / _K) for i in range(_K) for j in range(_K - i)]
                          + [((i + 2 / 3) / _K, (j + 2 / 3) / _K) for i in range(_K - 1) for j in range(_K - 1 - i)])


def edge_for_radius(unit: Tiling, radius: float, allowance: float, lo: float, hi: float,
                    axis: NDArray[np.float64] | None = None) -> float:
    """The plate edge e (mm, in [lo, hi]) at which the plates of ``unit`` (a unit-edge skeleton), on its
    faces scaled to the skeleton edge e + ``allowance`` (mm), lie ``radius`` mm from its centre (or its
    ``axis``) on average (:meth:`Tiling.plate_radius`). The distance grows with e: its root by Brent's
    method (:func:`scipy.optimize.brentq`). Raises ValueError naming the radii [lo, hi] reach."""
    from scipy.optimize import brentq

    def off(e: float) -> float:
        return unit.scaled(e + allowance).plate_radius(e, axis) - radius

    if off(lo) > 0 or off(hi) < 0:
        raise ValueError(f"plate edges of {lo:.4g} … {hi:.4g} mm make this tiling {off(lo) + radius:.4g} … "
                         f"{off(hi) + radius:.4g} mm in radius with these sleeves: give a radius in that range")
    return float(brentq(off, lo, hi, xtol=1e-9, rtol=1e-12))


def mean_distance(polygons: list[NDArray[np.float64]], centre: NDArray[np.float64],
                  axis: NDArray[np.float64] | None = None) -> float:
    """Mean distance (mm) from ``centre`` (3,), or with ``axis`` (3,) from the line through it, of the
    planar polygons ``polygons`` ((n, 3) loops, mm), averaged over their area: each fan triangle from a
    polygon's centroid cut into 256 equal triangles, whose centroids weigh its area alike (the centroid
    rule's error is 6e-5 of the distance for a 60 mm square 100 mm away, against a million random points)."""
    bary = _SUB_CENTROIDS
    u = None if axis is None else np.asarray(axis, dtype=float) / float(np.linalg.norm(axis))
    total = weight = 0.0
    for P in polygons:
        c = P.mean(axis=0)
        for a, b in zip(P, np.roll(P, -1, axis=0), strict=True):
            q = c + np.outer(bary[:, 0], a - c) + np.outer(bary[:, 1], b - c) - centre
            if u is not None:
                q = q - np.outer(q @ u, u)
            area = 0.5 * float(np.linalg.norm(np.cross(a - c, b - c)))
            total += area * float(np.linalg.norm(q, axis=1).mean())
            weight += area
    return total / weight


def weld(points: list[NDArray[np.float64]] | NDArray[np.float64], tol: float = SAME_POINT
         ) -> tuple[NDArray[np.float64], list[int]]:
    """Merge points closer than about ``tol`` (mm; rounded to a grid of that step): the unique points (n, 3)
    in order of first appearance, and the index of each input point among them."""
    key = np.round(np.array(points) / tol).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # keep the order of first appearance: vertex numbering is reproducible
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return np.array(points)[first[order]], rank[inverse.ravel()].tolist()


def _ccw_loop(points: NDArray[np.float64], normal: NDArray[np.float64]) -> list[int]:
    """Indices of coplanar points sorted counter-clockwise about ``normal`` (around their centre)."""
    c = points.mean(axis=0)
    u = points[0] - c
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    ang = np.arctan2((points - c) @ v, (points - c) @ u)
    return np.argsort(ang).tolist()


def icosahedron() -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Regular icosahedron of edge 2: ``V`` (12, 3) (cyclic permutations of (0, ±1, ±φ)), ``F`` (20, 3)."""
    V = []
    for s1 in (-1.0, 1.0):
        for s2 in (-1.0, 1.0):
            V += [(0.0, s1, s2 * PHI), (s1, s2 * PHI, 0.0), (s2 * PHI, 0.0, s1)]
    Va = np.array(V)
    D = np.linalg.norm(Va[:, None] - Va[None], axis=2)
    F = [
        (i, j, k)
        for i in range(12)
        for j in range(i + 1, 12)
        for k in range(j + 1, 12)
        if np.allclose([D[i, j], D[j, k], D[i, k]], 2.0)
    ]
    Fa = np.array(F, dtype=np.int64)
    for r, tri in enumerate(Fa):  # orient outward
        a, b, c = Va[tri]
        if np.cross(b - a, c - a) @ (a + b + c) < 0:
            Fa[r] = tri[[0, 2, 1]]
    return Va, Fa


def truncated_icosahedron(edge: float = 36.0) -> Tiling:
    """20 hexagons + 12 pentagons of edge ``edge`` mm, centred at the origin.

    Each icosahedron edge is cut at its thirds; a pentagon replaces every icosahedron vertex and a
    hexagon every icosahedron face. Faces: hexagons first (icosahedron face order), then pentagons.
    """
    Vi, Fi = icosahedron()
    third = {}  # (a, b) -> point a + (b - a)/3, the new vertex next to a on edge ab
    pts: list[NDArray[np.float64]] = []
    for a in range(12):
        for b in range(12):
            if a != b and math.isclose(float(np.linalg.norm(Vi[a] - Vi[b])), 2.0):
                third[a, b] = len(pts)
                pts.append(Vi[a] + (Vi[b] - Vi[a]) / 3.0)
    V, idx = weld(pts)
    faces: list[tuple[int, ...]] = []
    for a, b, c in Fi:
        ring = [third[a, b], third[b, a], third[b, c], third[c, b], third[c, a], third[a, c]]
        faces.append(tuple(idx[r] for r in ring))  # already CCW: the triangle is outward-oriented
    for a in range(12):
        ring = [idx[third[a, b]] for b in range(12) if (a, b) in third]
        order = _ccw_loop(V[ring], Vi[a] / np.linalg.norm(Vi[a]))
        faces.append(tuple(ring[o] for o in order))
    t = Tiling("truncated-icosahedron", V, tuple(faces))
    return t.scaled(edge)


def honeycomb_strip(rows: int, columns: int, edge: float = 36.0) -> Tiling:
    """A band of ``rows`` × ``columns`` flat-topped hexagons of edge ``edge`` mm in the plane z = 0.

    Tile (r, c) has its centre at (1.5 e c, √3 e (r + ½ (c mod 2))): columns run along x (the strip's
    length), odd columns are shifted up by half a hexagon, so neighbouring tiles share whole edges.
    Faces are numbered column by column (c major, r minor), which makes "group of columns" contiguous.
    """
    if rows < 1 or columns < 1:
        raise ValueError(f"a strip needs rows ≥ 1 and columns ≥ 1, got {rows} × {columns}")
    corners = polygon_vertices(6, edge)
    pts: list[NDArray[np.float64]] = []
    grid = []
    for c in range(columns):
        for r in range(rows):
            centre = np.array([1.5 * edge * c, math.sqrt(3.0) * edge * (r + 0.5 * (c % 2))])
            pts += [np.array([*(centre + p), 0.0]) for p in corners]
            grid.append((r, c))
    V, idx = weld(pts)
    faces = tuple(tuple(idx[6 * f + i] for i in range(6)) for f in range(len(grid)))
    return Tiling("honeycomb-strip", V, faces, np.array(grid, dtype=np.int64))
