"""The polygon and mesh formulas against closed forms."""

from __future__ import annotations

import math

import numpy as np

from fabpat.geometry.polygons import boundary_edges, newell_normal, signed_area, triangle_areas


def test_signed_area_of_a_regular_hexagon_and_its_reverse() -> None:
    a = np.arange(6) * math.pi / 3
    P = 36.0 * np.column_stack([np.cos(a), np.sin(a)])
    assert math.isclose(signed_area(P), 1.5 * math.sqrt(3) * 36.0**2, rel_tol=1e-14)
    assert math.isclose(signed_area(P[::-1]), -1.5 * math.sqrt(3) * 36.0**2, rel_tol=1e-14)


def test_newell_normal_of_a_tilted_square_is_twice_its_area_along_its_normal() -> None:
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    u = np.array([2.0, -1.0, 0.0]) / math.sqrt(5)
    v = np.cross(n, u)
    P = np.array([0 * u, 3 * u, 3 * u + 3 * v, 3 * v]) + [5.0, -7.0, 2.0]
    N = newell_normal(P - P.mean(axis=0))
    assert np.allclose(N, 2 * 9.0 * n, atol=1e-12)


def test_triangle_areas_and_the_boundary_of_a_square_of_two_triangles() -> None:
    X = np.array([[0.0, 0, 0], [2, 0, 0], [2, 3, 0], [0, 3, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3]])
    assert np.allclose(triangle_areas(X, F), [3.0, 3.0])
    B = {tuple(e) for e in boundary_edges(F).tolist()}
    assert B == {(0, 1), (1, 2), (2, 3), (3, 0)}  # the diagonal (0, 2) is shared, so not on the boundary
