"""Areas, normals and boundaries of polygons and triangle meshes: the few formulas every stage uses, in one
place (pure functions over arrays, as libigl's over ``V, F``).

* :func:`signed_area`: the shoelace formula (Gauss's area formula), positive counter-clockwise.
* :func:`newell_normal`: Newell's method (Sutherland, Sproull & Schumacker, "A characterization of ten
  hidden-surface algorithms", ACM Computing Surveys 6(1), 1974): twice the vector area of a closed loop
  in 3-D, exact for a planar loop and the best-fit plane's normal of a near-planar one.
* :func:`triangle_areas`: half the norm of the edges' cross product.
* :func:`boundary_edges`: the directed edges used by exactly one triangle.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Arr = NDArray[np.float64]


def signed_area(P: Arr) -> float:
    """Signed area (mm²) of the closed polygon ``P`` (n, 2) mm: positive when it turns counter-clockwise."""
    return 0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - P[:, 1] * np.roll(P[:, 0], -1)))


def newell_normal(P: Arr) -> Arr:
    """(3,) Newell vector of the closed loop ``P`` (n, 3) mm: Σ P_i × P_(i+1), twice the loop's vector area
    (mm²) when ``P`` is taken about a point of its plane (its mean, say), along its right-hand normal. Not
    normalised: its length says whether the loop has an area at all."""
    return np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)


def triangle_areas(X: Arr, F: NDArray[np.int64]) -> Arr:
    """(m,) areas (mm²) of the triangles ``F`` (m, 3) over the points ``X`` (n, 3) mm."""
    P = X[F]
    return 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)


def boundary_edges(F: NDArray[np.int64]) -> NDArray[np.int64]:
    """(k, 2) directed edges of the triangles ``F`` (m, 3) used by exactly one of them, each in its
    triangle's orientation."""
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = np.sort(E, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return E[counts[inv.reshape(-1)] == 1]
