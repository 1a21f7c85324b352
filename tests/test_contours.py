"""The 2-D cutting contours: outlines fitted by lines and circular arcs, and their kerf offsets."""

from __future__ import annotations

import math

import pytest

from fabpat.exchange import contours
from tests.test_cad import bowtie, bowtie_area, rounded_square


def test_bulge_loops_and_kerf_offset() -> None:
    tol = 0.01
    loops = contours.bulge_loops(bowtie(), tol)
    P = bowtie().perimeter
    assert abs(sum(lp.area() for lp in loops) - bowtie_area()) <= P * tol
    d = 0.1
    grown = contours.offset_bulge_loops(loops, d)
    assert len(grown) == 1 and grown[0].area() > 0
    # Growth = perimeter × d + O(d²) at corners (convex corners add ≤ π d² in all).
    assert sum(lp.area() for lp in grown) - bowtie_area() == pytest.approx(P * d, abs=P * tol + math.pi * d * d)
    square = contours.bulge_loops(rounded_square(), tol)
    assert square[0].bulges.tolist().count(0.0) == 4  # circular corners stay single exact arcs
    offset_area = sum(lp.area() for lp in contours.offset_bulge_loops(square, d))
    exact = (20 + 2 * d) ** 2 - (4 - math.pi) * (3 + d) ** 2  # a rounded square again
    assert offset_area == pytest.approx(exact, abs=1e-9)
