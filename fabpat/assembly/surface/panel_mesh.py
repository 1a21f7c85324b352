"""Flat-mesh panels: ``[tiling] kind = "panel"`` with ``file`` — the faces of a flat polygon mesh (OBJ, PLY or
OFF) made as ONE part, the plates fused at their interfaces (:mod:`fabpat.assembly.place.panel`).

:func:`read_panel_mesh` reads the file with the mesh tilings' reader and checks it with their checks
(:func:`fabpat.assembly.surface.mesh_tiling.mesh_tiling`: faces of 3 … 12 distinct vertices, manifold edges,
consistent orientation, one piece, equal edges, planar regular faces, each within ``tolerance`` mm and
each a one-line :class:`~fabpat.errors.SpecError` naming the face or edge), then the panel's own: every
vertex within ``tolerance`` of one plane (:func:`fabpat.assembly.surface.mesh_tiling.check_flat`: a curved mesh
is ``kind = "mesh"``'s, plates joined by sleeves).

**Plates exactly on the faces** (:func:`regular_tiling`). The fusion matches neighbouring plates'
interfaces to :data:`fabpat.assembly.place.panel.MATCH_TOL` (1e-9 mm), while a mesh file carries 6 to 9
significant digits. So the panel is not laid on the file's vertices themselves but on the tiling of
exact regular polygons of the mesh's edge that its faces make: face 1's regular polygon best superposed
on its corners, then every face across an edge of a placed face built on that edge (breadth first),
each corner reached twice checked to agree within 1e-9 mm (the polygons at an inner vertex fill 360°);
the whole is then superposed on the file's vertices (least-squares rotation and shift), and every vertex
must lie within ``tolerance`` of its file position. The plane's axes are the file's x and y projected
on it (x, y themselves for a mesh in a plane z = const whose faces turn counter-clockwise), the normal
the faces' turning sense, so the part lies where the file has it; z = 0 is the panel's plane.

**End pins** (:func:`end_interfaces`): ``simulate-assembly`` pushes a panel's ends together as the strip's
experiment does (:mod:`fabpat.assembly.solve.strip`). A mesh has no columns, so the ends are taken along
the longer side of its axis-aligned bounding box in the panel's plane (x when the two are equal): a
free edge is pinned when its outward normal points out of that end (within 60° of the axis) and its
face's centre lies within half an edge of the extreme face centres along it. On a honeycomb of rows ×
columns that is the strip's choice exactly (column 0's edges 4 and 5 and the last column's 1 and 2,
:func:`fabpat.assembly.place.placement.end_interfaces`); on a grid of squares the first and last columns'
outer edges. A mesh whose two ends share a face has nothing to push and is refused.

Units: mm.
"""

from __future__ import annotations

import math
import os
from collections import deque
from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.surface.tiling import Tiling
from fabpat.errors import SpecError
from fabpat.geometry.polygons import newell_normal

Arr = NDArray[np.float64]
#: mm: two placements of one corner must agree this closely for the plates' interfaces to fuse
#: (:data:`fabpat.assembly.place.panel.MATCH_TOL`); an exact tiling's agree to ~1e-13 mm
CLOSE = 1e-9
#: a free edge is an end edge when its outward normal is within this angle of the push axis (rad): 60°,
#: which takes a hexagon's two slanted end edges (30° off) and a square's (0°), never a side (90°)
END_CONE = math.pi / 3


def read_panel_mesh(path: str | os.PathLike[str], *, edge: float | None, tolerance: float,
                    source: str) -> Tiling:
    """The checked, exact flat tiling (z = 0, mm) of the mesh file ``path`` scaled to mean edge ``edge``
    (None: the file's own), within ``tolerance`` mm (module docstring); SpecError naming ``source``."""
    from fabpat.assembly.surface.mesh_tiling import mesh_tiling, read_polygon_mesh

    V, faces = read_polygon_mesh(path)
    t = mesh_tiling(V, faces, tolerance=tolerance, edge=edge, source=source, name="panel", flat=True)
    return regular_tiling(t, tolerance, source)


def plane_axes(t: Tiling) -> tuple[Arr, Arr, Arr]:
    """(origin, u, v) mm of the panel's plane: the vertices' mean, the file's x axis projected on the plane
    (its y when x is within 25° of the normal) and normal × u; the normal is the faces' summed turning
    sense (Newell), so every face turns counter-clockwise in (u, v)."""
    c = t.V.mean(axis=0)
    normal = np.zeros(3)
    for loop in t.faces:
        P = t.V[list(loop)] - c
        normal += newell_normal(P)
    normal /= np.linalg.norm(normal)
    axis = np.eye(3)[0] if abs(normal[0]) < 0.9 else np.eye(3)[1]
    u = axis - (axis @ normal) * normal
    u /= np.linalg.norm(u)
    return c, u, np.cross(normal, u)


def _regular_on(first: Arr, second: Arr, n: int, edge: float) -> Arr:
    """(n, 2) corners of the counter-clockwise regular n-gon of ``edge`` whose corners 0 and 1 lie at
    ``first`` and on the ray to ``second``."""
    d = second - first
    theta = math.atan2(float(d[1]), float(d[0]))
    turns = theta + 2.0 * math.pi * np.arange(n) / n  # the direction of each side in turn
    steps = edge * np.stack([np.cos(turns), np.sin(turns)], axis=1)
    return first + np.vstack([np.zeros(2), np.cumsum(steps[:-1], axis=0)])


def regular_tiling(t: Tiling, tolerance: float, source: str) -> Tiling:
    """``t`` (a checked flat mesh, mm) laid on the exact tiling of regular polygons its faces make, in the
    panel's plane z = 0 (module docstring); SpecError (one line naming the face or vertex) if the polygons
    do not close up around a vertex or a vertex lies farther than ``tolerance`` from its file position."""
    ends = t.edges
    e = float(np.linalg.norm(t.V[ends[:, 1]] - t.V[ends[:, 0]], axis=1).mean())
    _, u, v = plane_axes(t)
    Q = np.stack([t.V @ u, t.V @ v], axis=1)  # the file's vertices in the plane (the world origin's foot at 0)
    pos: dict[int, Arr] = {}

    def put(f: int, corners: Arr) -> None:
        for vertex, p in zip(t.faces[f], corners, strict=True):
            if vertex in pos and float(np.linalg.norm(pos[vertex] - p)) > CLOSE:
                raise SpecError(f"{source}: face {f + 1}'s regular {len(t.faces[f])}-gon puts vertex {vertex + 1} "
                                f"{float(np.linalg.norm(pos[vertex] - p)):.3g} mm from where its neighbours put it: "
                                "the polygons around it do not fill 360° (not a flat tiling of regular polygons)")
            pos.setdefault(vertex, p)

    first = t.faces[0]
    z = Q[list(first)] @ np.array([1.0, 1j])
    n0 = len(first)
    turn = np.exp(2j * math.pi * np.arange(n0) / n0)
    phase = np.sum((z - z.mean()) / turn)  # the regular polygon's best rotation onto the corners (Procrustes)
    ideal = z.mean() + e / (2.0 * math.sin(math.pi / n0)) * turn * phase / abs(phase)
    put(0, np.stack([ideal.real, ideal.imag], axis=1))
    neighbour = {}
    for (fa, ia), (fb, ib) in t.edge_faces[t.interior_edges]:
        neighbour[int(fa), int(ia)], neighbour[int(fb), int(ib)] = (int(fb), int(ib)), (int(fa), int(ia))
    placed, queue = {0}, deque([0])
    while queue:
        f = queue.popleft()
        loop = t.faces[f]
        for i in range(len(loop)):
            if (f, i) not in neighbour or neighbour[f, i][0] in placed:
                continue
            g, j = neighbour[f, i]
            gl = t.faces[g]
            # g runs the shared edge the other way: its corner j is f's corner i + 1
            corners = _regular_on(pos[loop[(i + 1) % len(loop)]], pos[loop[i]], len(gl), e)
            put(g, np.roll(corners, j, axis=0))
            placed.add(g)
            queue.append(g)
    used = sorted(pos)  # a vertex no face names is left out (the faces renumbered, in the file's order)
    new = {k: m for m, k in enumerate(used)}
    V = _superposed(np.array([pos[k] for k in used]), Q[used], used, tolerance, source)
    return Tiling("panel", V, tuple(tuple(new[k] for k in loop) for loop in t.faces))


def _superposed(P: Arr, Q: Arr, names: list[int], tolerance: float, source: str) -> Arr:
    """``P`` (n, 2) moved rigidly onto ``Q`` (least squares, Kabsch without reflection) as (n, 3) points at
    z = 0; SpecError if a point then lies farther than ``tolerance`` mm from its ``Q`` (named by ``names``,
    its vertex in the file from 0)."""
    p0, q0 = P.mean(axis=0), Q.mean(axis=0)
    a = (P - p0) @ np.array([1.0, 1j])
    b = (Q - q0) @ np.array([1.0, 1j])
    rot = np.sum(np.conj(a) * b)
    moved = q0 @ np.array([1.0, 1j]) + a * (rot / abs(rot) if abs(rot) > 0 else 1.0)
    dev = np.abs(moved - b - q0 @ np.array([1.0, 1j]))
    k = int(dev.argmax())
    if dev[k] > tolerance:
        raise SpecError(f"{source}: vertex {names[k] + 1} is {dev[k]:.3g} mm from the tiling of regular polygons the "
                        f"faces make (tiling.tolerance = {tolerance:g} mm): the panel's plates are exact regular "
                        "polygons")
    return np.stack([moved.real, moved.imag, np.zeros(len(moved))], axis=1)


def push_axis(t: Tiling) -> int:
    """0 (x) or 1 (y): the longer side of the tiling's bounding box in its plane (x when they are equal)."""
    size = np.ptp(t.V[:, :2], axis=0)
    return 1 if size[1] > size[0] * (1.0 + 1e-9) else 0


def end_interfaces(t: Tiling) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """(face, polygon edge) of the free edges at the low and at the high end of ``t`` along :func:`push_axis`
    (module docstring), each in boundary-edge order; SpecError if an end has none or one face is at both."""
    axis = push_axis(t)
    e = t.edge_length()
    centres = t.centroids[:, axis]
    low, high = [], []
    for k in t.boundary_edges:
        f, i = (int(x) for x in t.edge_faces[k, 0])
        loop = t.faces[f]
        a, b = t.V[loop[i], :2], t.V[loop[(i + 1) % len(loop)], :2]
        outward = np.array([b[1] - a[1], a[0] - b[0]]) / float(np.linalg.norm(b - a))  # right of a CCW edge
        if outward[axis] <= -math.cos(END_CONE) + 1e-12 and centres[f] <= centres.min() + 0.5 * e + 1e-9:
            low.append((f, i))
        elif outward[axis] >= math.cos(END_CONE) - 1e-12 and centres[f] >= centres.max() - 0.5 * e - 1e-9:
            high.append((f, i))
    both = {f for f, _ in low} & {f for f, _ in high}
    if not low or not high or both:
        raise SpecError("simulate-assembly pushes a panel's two ends together along the longer side of its bounding "
                        f"box ({'xy'[axis]}); this mesh's ends " + (f"share face {min(both) + 1}" if both else
                                                                     "have no free edge facing out")
                        + ": nothing to push")
    return low, high


class _PanelTable(Protocol):
    """What :func:`panel_tiling` reads of a panel's ``[tiling]`` (a :class:`~fabpat.assembly.spec.types.TilingSpec`,
    a later room's type)."""

    @property
    def file(self) -> str | None: ...
    @property
    def rows(self) -> int: ...
    @property
    def columns(self) -> int: ...
    @property
    def edge(self) -> float: ...
    @property
    def vertices(self) -> Sequence[Sequence[float]]: ...
    @property
    def faces(self) -> tuple[tuple[int, ...], ...]: ...


def panel_tiling(t: _PanelTable) -> Tiling:
    """The panel's :class:`~fabpat.assembly.surface.tiling.Tiling` at its plate edge (mm, z = 0) from its ``[tiling]``
    (a :class:`~fabpat.assembly.spec.types.TilingSpec`): rows × columns hexagons
    (:func:`fabpat.assembly.surface.tiling.honeycomb_strip`), or the exact flat tiling of a mesh file kept in the spec
    (:func:`fabpat.assembly.surface.panel_mesh.regular_tiling`)."""
    from fabpat.assembly.surface.tiling import honeycomb_strip

    if t.file is None:
        return honeycomb_strip(t.rows, t.columns, t.edge)
    return Tiling("panel", np.array(t.vertices, dtype=np.float64).reshape(-1, 3), t.faces)
