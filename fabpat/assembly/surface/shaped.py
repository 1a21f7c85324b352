"""Meshes whose faces carry shaped plates (``[tiling] kind = "mesh"``, ``plates = "shaped"``): each plate is
its own face's polygon (:mod:`fabpat.geometry.shaped`), not the regular polygon of the mean edge.

A shaped face need not be regular, nor its edges equal: it must be **planar** (every corner within
``tiling.tolerance`` mm of the face's best-fit plane: a plate is flat) and **almost regular** (within
:data:`~fabpat.geometry.shaped.MAX_IRREGULARITY`, 20 % of the mean edge and 20° from the regular angle,
with the centroid's foot inside every edge: what :func:`~fabpat.geometry.shaped.shape_pattern` takes).
:func:`check_shaped_faces` refuses any other face when the spec is read, naming it by its plate label
("H07", :attr:`~fabpat.assembly.surface.tiling.Tiling.labels`). :class:`ShapedTiling` is the skeleton of
such a mesh: its edge (the one the sleeves' allowance is added to) is the mean edge, and each face has
its polygon in its plate's frame (:meth:`ShapedTiling.face_polygons`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.surface.tiling import Tiling
from fabpat.errors import GeometryError, SpecError
from fabpat.geometry.polygons import newell_normal
from fabpat.geometry.shaped import MAX_IRREGULARITY, irregularity

#: ``[tiling] plates``: "regular" (every plate the regular polygon of the mesh's edge) or "shaped"
PLATE_KINDS = ("regular", "shaped")


def face_plane(P: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The best-fit plane of a face's corners P (n, 3) mm: (its centre (3,) — the corners' mean — and the
    rows (u, v, normal) (3, 3) of an orthonormal frame whose normal has the loop's turning sense (Newell),
    so that the loop runs counter-clockwise in (u, v)). The normal is the corners' smallest principal
    axis (least squares). Raises :class:`GeometryError` for a face of no area."""
    c = P.mean(axis=0)
    turn = newell_normal(P - c)
    if not float(np.linalg.norm(turn)) > 0.0:
        raise GeometryError("has no area")
    normal = np.linalg.svd(P - c, full_matrices=False)[2][-1]
    normal = normal if normal @ turn >= 0.0 else -normal
    u = P[0] - c - ((P[0] - c) @ normal) * normal
    u /= np.linalg.norm(u)
    return c, np.stack([u, np.cross(normal, u), normal])


def centroid_feet(Q: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n,) where the vertex centroid's foot falls on each edge of polygon Q (n, 2), as a fraction of the
    edge from its start (in (0, 1): inside the edge)."""
    E = np.roll(Q, -1, axis=0) - Q
    L2 = np.einsum("ij,ij->i", E, E)
    return np.einsum("ij,ij->i", Q.mean(axis=0) - Q, E) / L2


def check_shaped_faces(V: NDArray[np.float64], loops: tuple[tuple[int, ...], ...], tolerance: float,
                       source: str) -> None:
    """Refuse (:class:`SpecError`, one line naming ``source``, the face's plate label and its number in the
    file, the value found and the limit) the first face of mesh ``V`` (n, 3) mm, ``loops`` that is farther
    than ``tolerance`` mm from its best-fit plane, more irregular than
    :data:`~fabpat.geometry.shaped.MAX_IRREGULARITY`, or whose centroid's foot falls outside an edge
    (module docstring)."""
    labels = Tiling("mesh", V, loops).labels
    edge_limit, angle_limit = MAX_IRREGULARITY
    for f, loop in enumerate(loops):
        where = f"{source}: face {labels[f]} (face {f + 1} of the file)"
        P = V[list(loop)]
        try:
            c, axes = face_plane(P)
            Q = (P - c) @ axes.T
            dev = irregularity(Q[:, :2])
        except GeometryError as err:
            raise SpecError(f"{where} {err}") from None
        off = np.abs(Q[:, 2])
        if off.max() > tolerance:
            raise SpecError(f"{where} is not planar: its corner {int(off.argmax()) + 1} is {off.max():.3g} mm off the "
                            f"face's best-fit plane (tiling.tolerance = {tolerance:g} mm): a shaped plate is flat")
        if dev[0] > edge_limit or dev[1] > angle_limit:
            raise SpecError(f"{where} is too irregular for a shaped plate: its edges deviate up to "
                            f"{100 * dev[0]:.1f} % from their mean and its corners {math.degrees(dev[1]):.1f}° from "
                            f"the regular {len(loop)}-gon's angle (limit {100 * edge_limit:.0f} % / "
                            f"{math.degrees(angle_limit):.0f}°)")
        sigma = centroid_feet(Q[:, :2])
        if not ((sigma > 0.0) & (sigma < 1.0)).all():
            e = int(np.argmax(np.abs(sigma - 0.5)))
            raise SpecError(f"{where} is too irregular for a shaped plate: its centre's foot on its edge {e + 1} lies "
                            f"outside the edge (at {sigma[e]:.3f} of it; limit 0 to 1)")


@dataclass(frozen=True, eq=False)
class ShapedTiling(Tiling):
    """The skeleton of a mesh whose faces carry shaped plates: a :class:`Tiling` whose edge is its mean edge
    (its edges differ by up to 20 %), so that scaling it by the sleeves' allowance
    (:func:`~fabpat.assembly.surface.joints.skeleton_edge`) scales the mean edge."""

    def edge_length(self) -> float:
        """The mean edge length (mm)."""
        d = self.V[self.edges[:, 1]] - self.V[self.edges[:, 0]]
        return float(np.linalg.norm(d, axis=1).mean())

    def scaled(self, edge: float) -> ShapedTiling:
        """The same tiling with mean edge ``edge`` mm (scaled about the origin)."""
        return ShapedTiling(self.name, self.V * (edge / self.edge_length()), self.faces, self.grid, self.best_fit)

    def face_polygons(self) -> list[NDArray[np.float64]]:
        """Each face's corners (n_f, 2) mm in its plate frame (:meth:`Tiling.frames`: x, y of the frame;
        counter-clockwise), corner i the skeleton vertex ``faces[f][i]``."""
        out = []
        for loop, T in zip(self.faces, self.frames(), strict=True):
            out.append((self.V[list(loop)] - T[:3, 3]) @ T[:3, :2])
        return out


def inset(P: NDArray[np.float64], distance: float) -> NDArray[np.float64]:
    """Convex polygon P (n, 2) mm, counter-clockwise, with every edge moved ``distance`` mm inward (outward
    when negative), each corner where its two edges' moved lines meet. Raises :class:`GeometryError` when
    two adjacent edges are parallel (no corner) or the result turns clockwise (the inset ate the polygon)."""
    E = np.roll(P, -1, axis=0) - P
    T = E / np.linalg.norm(E, axis=1)[:, None]
    N = np.column_stack([-T[:, 1], T[:, 0]])  # left of a counter-clockwise edge: inward
    out = np.empty_like(P)
    for i in range(len(P)):
        j = i - 1  # edges j (ending at corner i) and i (starting there), each moved along its inward normal
        A = np.array([N[j], N[i]])
        b = np.array([N[j] @ P[i] + distance, N[i] @ P[i] + distance])
        if abs(float(np.linalg.det(A))) < 1e-12:
            raise GeometryError(f"the polygon's edges {j % len(P)} and {i} are parallel: no corner to move")
        out[i] = np.linalg.solve(A, b)
    area = 0.5 * float(np.sum(out[:, 0] * np.roll(out[:, 1], -1) - np.roll(out[:, 0], -1) * out[:, 1]))
    if not area > 0.0:
        raise GeometryError(f"moving the polygon's edges {distance:g} mm inward leaves no polygon")
    return out
