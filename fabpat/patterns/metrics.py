"""Geometric metrics of a solid region (paper §4.2): area, perimeter, their ratio, polar moment.

The same four numbers describe a solid pattern (a union of lattice triangles) and, later, its
filleted outline, so both produce a :class:`RegionMetrics`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class RegionMetrics:
    """Area (mm²), perimeter (mm), isoperimetric ratio and polar moment (mm⁴).

    ``ratio`` is the isoperimetric quotient 4πA/P²: 1 for a disc, π√3/6 ≈ 0.907 for a regular
    hexagon, and small for thin, lacy regions. It is dimensionless, so it compares patterns of any
    edge length. ``polar_moment`` is ∫(x² + y²) dA about the polygon centre (the origin).
    """

    area: float
    perimeter: float
    ratio: float
    polar_moment: float

    @classmethod
    def from_values(cls, area: float, perimeter: float, polar_moment: float) -> RegionMetrics:
        """Metrics from area (mm²), perimeter (mm) and polar moment (mm⁴); ratio = 4πA/P²."""
        ratio = 4.0 * math.pi * area / perimeter**2 if perimeter > 0 else 0.0
        return cls(float(area), float(perimeter), float(ratio), float(polar_moment))

    def as_dict(self) -> dict[str, float]:
        """``{area, perimeter, ratio, polar_moment}`` as plain floats."""
        return asdict(self)


def triangle_metrics(V: NDArray[np.float64], F: NDArray[np.int64]) -> tuple[float, float]:
    """Area and polar moment about the origin of a union of disjoint triangles.

    V: (n, 2) float, F: (m, 3) int, counter-clockwise. Uses the exact formula for a triangle,
    J = A/6 (|a|² + |b|² + |c|² + a·b + b·c + c·a).
    """
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    ab, ac = b - a, c - a
    area = 0.5 * (ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0])
    s = (a * a).sum(1) + (b * b).sum(1) + (c * c).sum(1) + (a * b).sum(1) + (b * c).sum(1) + (c * a).sum(1)
    return float(area.sum()), float((area / 6.0 * s).sum())
