"""Patterns: a slice replicated by rotation into every fan triangle of a regular n-gon (paper §3.1).

A pattern is the labelled triangulation ``V, F, c`` of the polygon; the *solid pattern* is the
sub-complex of the faces with ``c = True``. Fan triangle ``f`` has its apex at the centre and its base
on polygon edge ``f`` (see :func:`fabpat.patterns.lattice.polygon_vertices`); the slice is mapped linearly into
it, so the same slice fits every n (exchangeability).

Calling the module is :func:`fabpat.patterns.library.pattern`: ``fabpat.pattern("0x0488")`` checks the ID
against the library and infers its depth from its length.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat._callable import make_callable
from fabpat.errors import GeometryError, PatternError
from fabpat.patterns.lattice import Slice, check_depth, check_sides, polygon_vertices, slice_lattice
from fabpat.patterns.metrics import RegionMetrics, triangle_metrics
from fabpat.validate import check

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.geometry.fillet import FilletedPattern
    from fabpat.patterns.variation import Variation

DEFAULT_EDGE = 36.0  # mm: the paper's hexagon edge (§4.1)


@dataclass(frozen=True, eq=False)
class PatternTopology:
    """Combinatorics shared by every pattern with the same ``sides`` and ``depth``.

    ``point_fan``, ``point_ij``: (nv,) fan and (nv, 2) lattice coordinates of one representative of
    each merged vertex; ``F`` (n·4**depth, 3) global faces; ``slice_face`` (n·4**depth,) the slice face
    each pattern face copies; ``E`` (ne, 2) unique edges and ``FE`` (nf, 3) the edge of each face side.
    """

    sides: int
    depth: int
    point_fan: NDArray[np.int64]
    point_ij: NDArray[np.int64]
    F: NDArray[np.int64]
    slice_face: NDArray[np.int64]
    E: NDArray[np.int64]
    FE: NDArray[np.int64]

    @property
    def n_vertices(self) -> int:
        """Number of distinct lattice vertices of the n-gon."""
        return int(self.point_fan.size)

    def vertices(self, edge: float = DEFAULT_EDGE) -> NDArray[np.float64]:
        """(nv, 2) vertex positions in mm for a polygon of the given edge length."""
        corners = polygon_vertices(self.sides, edge)
        N = 2**self.depth
        B = corners[self.point_fan]
        C = corners[(self.point_fan + 1) % self.sides]
        return (self.point_ij[:, :1] * B + self.point_ij[:, 1:] * C) / N


@cache
def pattern_topology(sides: int, depth: int) -> PatternTopology:
    n, d = check_sides(sides), check_depth(depth)
    IJ, Fs = slice_lattice(d)
    on_ab = IJ[:, 0] >= 1  # points owned by this fan; the AC side belongs to the next fan's AB side
    K = int(on_ab.sum())
    rank = np.full(len(IJ), -1, dtype=np.int64)
    rank[on_ab] = np.arange(K)
    local_of = {(int(i), int(j)): k for k, (i, j) in enumerate(IJ)}
    glob = np.empty((n, len(IJ)), dtype=np.int64)
    for f in range(n):
        for k, (i, j) in enumerate(IJ):
            if i == 0 and j == 0:
                glob[f, k] = 0
            elif i >= 1:
                glob[f, k] = 1 + f * K + rank[k]
            else:
                glob[f, k] = 1 + ((f + 1) % n) * K + rank[local_of[int(j), 0]]
    point_fan = np.zeros(1 + n * K, dtype=np.int64)
    point_ij = np.zeros((1 + n * K, 2), dtype=np.int64)
    for f in range(n):
        point_fan[1 + f * K : 1 + (f + 1) * K] = f
        point_ij[1 + f * K : 1 + (f + 1) * K] = IJ[on_ab]
    F = np.concatenate([glob[f][Fs] for f in range(n)])
    slice_face = np.tile(np.arange(len(Fs)), n)
    sides_ = np.sort(np.stack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1), axis=2)
    E, inv = np.unique(sides_.reshape(-1, 2), axis=0, return_inverse=True)
    FE = inv.reshape(-1, 3)
    for a in (point_fan, point_ij, F, slice_face, E, FE):
        a.setflags(write=False)
    return PatternTopology(n, d, point_fan, point_ij, F, slice_face, E, FE)


@dataclass(frozen=True, eq=False)
class Pattern:
    """A slice in a regular polygon: ``V`` (nv, 2) mm, ``F`` (nf, 3), ``c`` (nf,) solid labels."""

    slice: Slice
    sides: int = 6
    edge: float = DEFAULT_EDGE

    @classmethod
    def from_id(cls, pattern_id: str, sides: int = 6, depth: int = 2, edge: float = DEFAULT_EDGE) -> Pattern:
        """The pattern of a hex ID in the regular ``sides``-gon of edge ``edge`` mm; raises :class:`PatternError`."""
        return cls(Slice.from_id(pattern_id, depth), check_sides(sides), check("edge", edge, error=PatternError))

    @property
    def id(self) -> str:
        """The slice's hex ID."""
        return self.slice.id

    @property
    def depth(self) -> int:
        """Subdivision depth of the slice."""
        return self.slice.depth

    @property
    def topology(self) -> PatternTopology:
        """The shared lattice topology of (sides, depth), cached across patterns."""
        return pattern_topology(self.sides, self.depth)

    @cached_property
    def V(self) -> NDArray[np.float64]:
        """(n_vertices, 2) float: lattice vertices in mm, polygon centre at the origin, read-only."""
        V = self.topology.vertices(self.edge)
        V.setflags(write=False)
        return V

    @property
    def F(self) -> NDArray[np.int64]:
        """(sides · 4**depth, 3) int: the lattice triangles (counter-clockwise vertex indices)."""
        return self.topology.F

    @cached_property
    def c(self) -> NDArray[np.bool_]:
        """(sides · 4**depth,) bool: True where the triangle of ``F`` is solid, read-only."""
        c = self.slice.solid[self.topology.slice_face]
        c.setflags(write=False)
        return c

    @property
    def solid_faces(self) -> NDArray[np.int64]:
        """F̃: (k, 3) the faces of the solid pattern."""
        return self.F[self.c]

    @cached_property
    def boundary_edges(self) -> NDArray[np.int64]:
        """(b, 2) vertex pairs of edges with solid on exactly one side (incl. the polygon border)."""
        topo = self.topology
        count = np.bincount(topo.FE[self.c].ravel(), minlength=len(topo.E))
        return topo.E[count == 1]

    @cached_property
    def metrics(self) -> RegionMetrics:
        """Area (mm²), perimeter (mm), ratio 4πA/P² and polar moment (mm⁴) of the solid pattern (the
        union of its solid lattice triangles); the filleted outline has the same four numbers as
        :attr:`fabpat.geometry.fillet.FilletedPattern.metrics`."""
        area, J = triangle_metrics(self.V, self.solid_faces)
        e = self.boundary_edges
        perimeter = float(np.linalg.norm(self.V[e[:, 0]] - self.V[e[:, 1]], axis=1).sum())
        return RegionMetrics.from_values(area, perimeter, J)

    def fillet(self, weight: float = 0.2, variation: Variation | None = None, **values: float) -> FilletedPattern:
        """The exact filleted outline (paper §3.3) with interface-arc middle weight ``weight`` (the
        paper's 0.2) and a family member (:mod:`fabpat.patterns.variation`, ``fabpat variations``): either a
        :class:`~fabpat.patterns.variation.Variation` or its values by name (``bridge_weight=0.5``), not both.
        Raises :class:`~fabpat.errors.GeometryError` for a weight or variation outside its range, an
        unknown variation name, a ``variation`` that is not a Variation, or both spellings at once."""
        # A convenience over the next stage, imported when called: the pattern stage stays self-contained.
        from fabpat.geometry.fillet import fillet_pattern
        from fabpat.patterns.variation import Variation

        if variation is not None and values:
            raise GeometryError(f"give the variation once: fillet(variation=Variation(...)) or fillet("
                                f"{', '.join(f'{k}=…' for k in values)}), not both")
        if variation is not None and not isinstance(variation, Variation):
            raise GeometryError(f"variation must be a fabpat.Variation such as Variation(bridge_weight=0.5), got "
                                f"{type(variation).__name__} {variation!r:.40}")
        return fillet_pattern(self, weight, variation if variation is not None else Variation.from_values(values))

    def __repr__(self) -> str:
        return (f"Pattern('{self.id}', sides={self.sides}, depth={self.depth}, edge={self.edge:g} mm, "
                f"area={self.metrics.area:.1f} mm²)")

    def _repr_svg_(self) -> str:
        """Notebook picture: the solid lattice triangles in the polygon, true size (mm)."""
        from fabpat.views.pictures import pattern_svg

        return pattern_svg(self)


make_callable(__name__, "fabpat.patterns.library:pattern")
