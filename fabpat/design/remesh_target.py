"""A closed-tiling target placed at a size, in millimetres, for mapping a tiling onto it
(:mod:`fabpat.design.remesh`): closest points, outward normals and signed distances.

A :class:`fabpat.design.target.ClosedTarget` has no size and no place (the design fits it afterwards,
:mod:`fabpat.design.surface`). :func:`place_target` gives it both from a base tiling V (n, 3) mm:

* **frame**: the target's own. An ellipsoid ``ellipsoid:A,B,C`` has its semi-axes s·(A, B, C) along x, y, z
  and its centre at the origin (a ``sphere`` is 1 : 1 : 1); a mesh keeps its file's coordinates, scaled by s.
  The base is turned (the shortest turn) so that its design axis (:func:`fabpat.design.closed.design_axis`,
  through the first pentagon) lies along the target's distinct axis (the ratio farthest from the other two,
  :func:`fabpat.design.surface.distinct_axis`; for a mesh, the principal axis of its vertices whose variance
  differs most from the other two), as the design's ellipsoid fit starts it: the latitude bands of a design's
  face groups then follow the target's own axis of symmetry.
* **size**: s such that the base's directions from its centroid, carried along rays onto the target
  (:func:`on_rays`), make a polyhedron of the base's own area (sum of the faces' vector areas): the mean
  edge, the plates' size, stays the base's.

Closest points (:meth:`TargetSurface.closest`): on an ellipsoid by Eberly's root of
Σ (a_i y_i / (t + a_i²))² = 1 in the first octant (D. Eberly, *Distance from a point to an ellipse, an
ellipsoid, or a hyperellipsoid*, Geometric Tools 2020, §3), bracketed and bisected to the last bit; the signed
distance d = N · (x − p), positive outside, has the unit normal N at p as its gradient (exact on a smooth
surface within its reach). On a mesh the closest point is trimesh's (:func:`trimesh.proximity.closest_point`)
and N the vertex normals interpolated at it (Phong's), the mesh read as the smooth surface it samples: the
Euclidean distance to a faceted surface has kinks at the triangles' edges, where its gradient jumps, and a
relaxation onto a 6 240-triangle egg then crept 480 steps where with the interpolated normal it took 28
(measured); d = N · (x − p) differs from |x − p| by the factor cos α, α the angle between N and the
triangle's own normal (a few degrees on such a mesh).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.design.target import ClosedTarget, TargetError

if TYPE_CHECKING:
    import trimesh

Arr = NDArray[np.float64]
Faces = tuple[tuple[int, ...], ...]

#: bisection steps of the ellipsoid's closest-point root: the bracket halves each step, so 200 reach
#: adjacent floating-point numbers from any bracket a float can hold
BISECTIONS = 200


@dataclass(frozen=True, eq=False)
class TargetSurface:
    """A closed target at a size, in its own frame (module doc): ``kind`` "sphere", "ellipsoid" or "mesh";
    ``semi`` (3,) mm the semi-axes along x, y, z (sphere, ellipsoid); ``vertices`` (k, 3) mm and
    ``triangles`` (m, 3) int the scaled mesh; ``centre`` (3,) mm the point the base's rays start from;
    ``scale`` mm per target unit; ``source`` names it in messages."""

    source: str
    kind: str
    centre: Arr
    scale: float
    semi: Arr | None = None
    vertices: Arr | None = None
    triangles: NDArray[np.int64] | None = None

    @cached_property
    def mesh(self) -> trimesh.Trimesh:
        """The scaled mesh as a trimesh (built once; its spatial index too). Raises :class:`TargetError` on a
        target that is not a mesh."""
        import trimesh

        if self.vertices is None or self.triangles is None:
            raise TargetError(f"target {self.source} is an {self.kind}, not a mesh")
        return trimesh.Trimesh(self.vertices, self.triangles, process=False)

    def closest(self, X: Arr) -> tuple[Arr, Arr, Arr]:
        """For points X (n, 3) mm: closest points P (n, 3) mm on the surface, unit normals N (n, 3) there
        (the gradient of the signed distance; on a mesh the interpolated one) and signed distances
        d = N · (X − P) (n,) mm, positive outside (module doc)."""
        X = np.asarray(X, dtype=np.float64)
        if self.semi is not None:
            return _closest_on_ellipsoid(X - self.centre, self.semi, self.centre)
        import trimesh

        P, _, tri = trimesh.proximity.closest_point(self.mesh, X)
        P = np.asarray(P, dtype=np.float64)
        tri = np.asarray(tri, dtype=np.int64)
        corners = self.mesh.vertices[self.mesh.faces[tri]]
        bary = trimesh.triangles.points_to_barycentric(corners, P)
        N = (bary[:, :, None] * np.asarray(self.mesh.vertex_normals)[self.mesh.faces[tri]]).sum(axis=1)
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        return P, N, ((X - P) * N).sum(axis=1)

    @property
    def size(self) -> float:
        """The RMS distance (mm) of the target's points from its centre: for an ellipsoid that of its
        semi-axes' ends (√(mean a_i²)), for a mesh that of its vertices."""
        if self.semi is not None:
            return float(np.sqrt(np.mean(self.semi ** 2)))
        assert self.vertices is not None
        return float(np.sqrt(np.mean(((self.vertices - self.centre) ** 2).sum(axis=1))))


def _closest_on_ellipsoid(Y: Arr, semi: Arr, centre: Arr) -> tuple[Arr, Arr, Arr]:
    """Closest points, normals and signed distances of points Y (n, 3) mm given about the centre of the
    ellipsoid of semi-axes ``semi`` (3,) along x, y, z (Eberly's root, module doc)."""
    a2 = semi * semi
    sign = np.where(Y < 0.0, -1.0, 1.0)
    # a coordinate of exactly 0 would put the bracket's end on a pole of the root's function: nudge it by
    # 1e-13 of the size, far below any distance measured
    y = np.maximum(np.abs(Y), 1e-13 * float(semi.max()))
    k = int(np.argmin(semi))
    lo = -a2[k] + semi[k] * y[:, k]  # the term of the smallest axis is 1 here: F(lo) ≥ 0
    hi = -a2[k] + np.linalg.norm(semi * y, axis=1)  # every term ≤ (a_i y_i)² / |a ∘ y|²: F(hi) ≤ 0
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        F = (((semi * y) / (mid[:, None] + a2)) ** 2).sum(axis=1) - 1.0
        above = F > 0.0
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    t = 0.5 * (lo + hi)
    p = a2 * y / (t[:, None] + a2)
    g = p / a2  # half the gradient of Σ (x_i / a_i)², outward
    N = g / np.linalg.norm(g, axis=1, keepdims=True)
    P = sign * p
    N = sign * N
    d = ((Y - P) * N).sum(axis=1)
    return P + centre, N, d


def closed_target(target: ClosedTarget | str) -> ClosedTarget:
    """The closed target ``target`` names (:func:`fabpat.design.target.read_target`); TargetError for a strip
    target or anything else."""
    if isinstance(target, ClosedTarget):
        return target
    from fabpat.design.target import read_target

    read = read_target(target)
    if not isinstance(read, ClosedTarget):
        raise TargetError(f"target {read.source} is a strip mid-line: a tiling is mapped onto a closed target "
                          "(sphere, ellipsoid:A,B,C or a surface mesh file)")
    return read


def _turn(a: Arr, b: Arr) -> Arr:
    """The rotation matrix of the shortest turn taking unit vector a to unit vector b."""
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:  # opposite: half a turn about any axis normal to a
        helper = np.eye(3)[int(np.argmin(np.abs(a)))]
        u = np.cross(a, helper)
        u /= np.linalg.norm(u)
        return 2.0 * np.outer(u, u) - np.eye(3)
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


def _distinct(values: Arr) -> int:
    """Index of the value farthest from the mean of the other two."""
    return int(np.argmax([abs(values[i] - 0.5 * (values.sum() - values[i])) for i in range(3)]))


def on_rays(surface: TargetSurface, D: Arr) -> Arr:
    """Where the rays from ``surface.centre`` along directions D (n, 3) first leave the surface: points
    (n, 3) mm. On an ellipsoid in closed form; on a mesh the farthest crossing of each ray (trimesh's ray
    test), so that a surface that is not star-shaped from the centre still gets one point per ray; a ray
    that crosses nothing (a mesh with holes) goes to the point of the mesh closest to where the ray meets
    the sphere of the target's size."""
    U = D / np.linalg.norm(D, axis=1, keepdims=True)
    if surface.semi is not None:
        return surface.centre + U / np.sqrt(((U / surface.semi) ** 2).sum(axis=1))[:, None]
    m = surface.mesh
    origins = np.repeat(surface.centre[None, :], len(U), axis=0)
    hits, ray, _ = m.ray.intersects_location(origins, U, multiple_hits=True)
    hits = np.asarray(hits, dtype=np.float64)
    ray = np.asarray(ray, dtype=np.int64)
    reach = np.full(len(U), -1.0)
    np.maximum.at(reach, ray, ((hits - surface.centre) * U[ray]).sum(axis=1))
    out = surface.centre + U * reach[:, None]
    missed = reach <= 0.0
    if missed.any():
        out[missed] = surface.closest(surface.centre + U[missed] * surface.size)[0]
    return out


def face_area(V: Arr, faces: Faces) -> float:
    """Sum (mm²) of the faces' vector areas (half the norm of Newell's sum; the area of a planar face)."""
    total = 0.0
    for loop in faces:
        P = V[list(loop)]
        total += 0.5 * float(np.linalg.norm(np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)))
    return total


def place_target(V: Arr, faces: Faces, target: ClosedTarget | str | TargetSurface) -> tuple[TargetSurface, Arr]:
    """The target at the base's size, and the base's rotation (3, 3) into the target's frame (module doc).
    V (n, 3) mm the base tiling, faces its loops. A :class:`TargetSurface` is returned as it is (with the
    rotation that keeps the base's frame). Raises :class:`TargetError` for a strip target or a name that is
    no target."""
    if isinstance(target, TargetSurface):
        return target, np.eye(3)
    from fabpat.design.closed import design_axis
    from fabpat.design.surface import distinct_axis

    t = closed_target(target)
    axis = design_axis(V, faces)
    if t.kind == "mesh" and t.mesh is not None:  # a mesh target always carries its mesh (read_target)
        Vm = np.asarray(t.mesh.vertices, dtype=np.float64)
        Fm = np.asarray(t.mesh.faces, dtype=np.int64)
        tri = Vm[Fm]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        centre = (area[:, None] * tri.mean(axis=1)).sum(axis=0) / area.sum()  # the surface's area centroid
        val, vec = np.linalg.eigh(np.cov((Vm - centre).T))
        unit = TargetSurface(t.source, "mesh", centre, 1.0, vertices=Vm, triangles=Fm)
        goal = vec[:, _distinct(val)]
    else:
        axes = np.ones(3) if t.axes is None else np.asarray(t.axes, dtype=np.float64)
        unit = TargetSurface(t.source, t.kind, np.zeros(3), 1.0, semi=axes)
        goal = np.eye(3)[distinct_axis((float(axes[0]), float(axes[1]), float(axes[2])))]
    R = _turn(axis, goal)
    D = (V - V.mean(axis=0)) @ R.T
    s = math.sqrt(face_area(V, faces) / face_area(on_rays(unit, D), faces))
    if unit.semi is not None:
        return TargetSurface(t.source, t.kind, np.zeros(3), s, semi=unit.semi * s), R
    assert unit.vertices is not None
    return TargetSurface(t.source, "mesh", unit.centre * s, s, vertices=unit.vertices * s,
                         triangles=unit.triangles), R
