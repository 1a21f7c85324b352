"""Closed-polyline checks: crossings, containment, and the ray-method minimum width."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.geometry import polyline


def test_polyline_intersections_and_point_in_polygon() -> None:
    square = np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]])
    inner = np.array([[1.0, 1], [1, 3], [3, 3], [3, 1]])
    assert len(polyline.polyline_intersections([square, inner])) == 0
    crossing = inner + [2.5, 0]
    assert len(polyline.polyline_intersections([square, crossing])) == 2
    touching = np.array([[4.0, 1], [5, 1], [5, 2]])  # touches the square's right edge at (4, 1)
    assert len(polyline.polyline_intersections([square, touching])) >= 1
    bowtie = np.array([[0.0, 0], [2, 0], [0, 2], [2, 2]])
    assert len(polyline.polyline_intersections([bowtie])) == 1
    inside = polyline.points_in_polygon([[2, 2], [5, 5], [0.5, 3.9], [-1, 2]], square)
    assert inside.tolist() == [True, False, True, False]


def test_ray_min_width_of_rectangle_and_annulus() -> None:
    rect = np.array([[0.0, 0], [10, 0], [10, 3], [0, 3]])
    width, p, q = polyline.ray_min_width([rect], 0.1)
    assert width == pytest.approx(3.0, abs=1e-12)
    assert abs(p[1] - q[1]) == pytest.approx(3.0)
    phi = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    outer = 5 * np.column_stack([np.cos(phi), np.sin(phi)])
    hole = 4 * np.column_stack([np.cos(phi), np.sin(phi)])[::-1]
    width, _, _ = polyline.ray_min_width([outer, hole], 0.05)
    assert width == pytest.approx(1.0, abs=1e-4)


def test_ray_min_width_from_one_sector_of_a_symmetric_region() -> None:
    # a square plate with a square hole turned 45°: 4-fold symmetric; the narrowest places are where
    # the hole's corners approach the plate's sides (5 - 3·√2 ≈ 0.757 mm)
    outer = np.array([[-5.0, -5], [5, -5], [5, 5], [-5, 5]])
    hole = 3 * np.sqrt(2) * np.array([[1.0, 0], [0, -1], [-1, 0], [0, 1]])  # clockwise
    full = polyline.ray_min_width([outer, hole], 0.01)
    quarter = polyline.ray_min_width([outer, hole], 0.01, symmetry=4)
    assert quarter[0] == pytest.approx(full[0], abs=1e-12)
    assert quarter[0] <= 5 - 3 * np.sqrt(2) + 1e-9
