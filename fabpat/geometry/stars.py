"""Vertex stars: which boundary vertices of a solid pattern are problematic, and what filleting does at
each (paper §3.3, Fig. 8a; the rule is in :mod:`fabpat.geometry.fillet`'s module doc).

Around a boundary vertex the lattice triangles form solid and void *runs*; one solid run that is not a
straight angle makes a **sharp** vertex, two or more a **non-manifold** one, and the polygon-edge
midpoints are **interface** vertices. :data:`HEXAGON_STAR_TABLE` lists every star of the hexagon lattice
with its class and actions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import groupby

import numpy as np
from numpy.typing import NDArray

from fabpat.patterns.lattice import polygon_vertices
from fabpat.patterns.pattern import Pattern

_ANGLE_EPS = 1e-9  # rad: runs this close to 180° are straight
@dataclass(frozen=True)
class StarRun:
    """A maximal run of solid or void triangles around a vertex, with its total angle (rad)."""

    solid: bool
    triangles: int
    angle: float


@dataclass(frozen=True)
class VertexStar:
    """Classification of one boundary vertex of the solid pattern."""

    vertex: int
    kind: str  # "non-manifold", "sharp", "straight" or "interface"
    runs: tuple[StarRun, ...]  # counter-clockwise, starting with a solid run


def _angle(d: NDArray[np.float64]) -> float:
    return math.atan2(float(d[1]), float(d[0]))


def _ccw(a: float, b: float) -> float:
    """Counter-clockwise angle from direction a to direction b, in (0, 2π]."""
    t = (b - a) % (2 * math.pi)
    return t if t > 1e-12 else 2 * math.pi


def _boundary_half_edges(F: NDArray[np.int64], nv: int) -> NDArray[np.int64]:
    """(b, 2) directed edges of the solid faces with no twin: the boundary, solid on the left."""
    H = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = H[:, 0] * nv + H[:, 1]
    twin = H[:, 1] * nv + H[:, 0]
    return H[~np.isin(key, twin)]


def _interface_vertices(pattern: Pattern) -> dict[int, int]:
    """Vertex index of each polygon-edge midpoint → polygon edge index."""
    corners = polygon_vertices(pattern.sides, pattern.edge)
    mids = (corners + np.roll(corners, -1, axis=0)) / 2
    out = {}
    for i, m in enumerate(mids):
        d = np.linalg.norm(pattern.V - m, axis=1)
        k = int(np.argmin(d))
        if d[k] < 1e-9 * pattern.edge:
            out[k] = i
    return out


def star_runs(pattern: Pattern, v: int) -> tuple[StarRun, ...]:
    """Runs of the star of vertex v, counter-clockwise, starting with a solid run.

    Outside the polygon counts as one void run of zero triangles (it matters only at polygon-boundary
    vertices).
    """
    V, F, c = pattern.V, pattern.F, pattern.c
    items = []  # (start direction, angle, solid)
    for f in np.flatnonzero((F == v).any(axis=1)):
        k = int(np.flatnonzero(F[f] == v)[0])
        a, b = F[f][(k + 1) % 3], F[f][(k + 2) % 3]  # counter-clockwise: v → a → b
        start = _angle(V[a] - V[v])
        items.append((start % (2 * math.pi), _ccw(start, _angle(V[b] - V[v])), bool(c[f])))
    items.sort()
    labels, angles, counts = [], [], []
    for i, (start, ang, solid) in enumerate(items):
        labels.append(solid)
        angles.append(ang)
        counts.append(1)
        gap = (items[(i + 1) % len(items)][0] - (start + ang)) % (2 * math.pi)
        if 1e-9 < gap < 2 * math.pi - 1e-9:  # outside the polygon
            labels.append(False)
            angles.append(gap)
            counts.append(0)
    return runs_of_labels(tuple(labels), tuple(angles), tuple(counts))


def classify(runs: tuple[StarRun, ...], interface: bool = False) -> str:
    """Kind of a boundary vertex from its runs (see the module docstring)."""
    if interface:
        return "interface"
    solid = [r for r in runs if r.solid]
    if len(solid) >= 2:
        return "non-manifold"
    if abs(solid[0].angle - math.pi) < _ANGLE_EPS:
        return "straight"
    return "sharp"


def star_actions(runs: tuple[StarRun, ...], interface: bool = False) -> tuple[str, ...]:
    """What the filleting rule does to each run of a star (the lookup table's row).

    ``"round"`` a convex solid corner (material removed), ``"fill"`` a concave corner (material
    added), ``"bridge"`` a void run between two solid runs (material added), ``"straight"`` a 180° run
    the boundary crosses without an arc, ``"round-across"`` a void run wider than 180° at a
    non-manifold vertex (the arc rounds the convex corner made by the other runs), ``"interface"``
    the solid run at a polygon-edge midpoint, ``"keep"`` a run left as it is.
    """
    if interface:
        return tuple("interface" if r.solid else "keep" for r in runs)
    n_solid = sum(r.solid for r in runs)
    acts = []
    for r in runs:
        straight = abs(r.angle - math.pi) < _ANGLE_EPS
        if n_solid == 1:
            if straight:
                acts.append("straight")
            elif r.solid:
                acts.append("round" if r.angle < math.pi else "keep")
            else:
                acts.append("fill" if r.angle < math.pi else "keep")
        elif r.solid:
            acts.append("keep")
        else:
            acts.append("straight" if straight else "bridge" if r.angle < math.pi else "round-across")
    return tuple(acts)


def _necklaces(k: int) -> list[tuple[bool, ...]]:
    """Solid/void labelings of a k-star up to rotation, one representative each."""
    seen, out = set(), []
    for m in range(2**k):
        lab = tuple(bool((m >> (k - 1 - i)) & 1) for i in range(k))
        canon = max(lab[i:] + lab[:i] for i in range(k))
        if canon not in seen:
            seen.add(canon)
            out.append(canon)
    return out


def runs_of_labels(
    labels: tuple[bool, ...], angles: tuple[float, ...] | None = None, counts: tuple[int, ...] | None = None
) -> tuple[StarRun, ...]:
    """Runs of a cyclic labeling (angles default to equal shares of 360°), starting with a solid run.

    ``counts``: triangles per item (default 1 each; 0 for the outside of the polygon).
    """
    k = len(labels)
    angles = angles or (2 * math.pi / k,) * k
    counts = counts or (1,) * k
    first = next((i for i in range(k) if labels[i] and not labels[i - 1]), 0)
    order = [(first + i) % k for i in range(k)]
    runs = []
    for solid, group in groupby(order, key=lambda i: labels[i]):
        g = list(group)
        runs.append(StarRun(solid, sum(counts[i] for i in g), math.fsum(angles[i] for i in g)))
    return tuple(runs)


def star_table(k: int = 6) -> list[tuple[str, str, tuple[str, ...]]]:
    """The lookup table of a regular k-star: (labels as S/V string, kind, action per run).

    For the hexagon lattice (k = 6) this lists the 14 labelings up to rotation: 2 trivial (all solid,
    all void), 1 straight, the 4 sharp and the 7 non-manifold configurations of the paper's Figs 9–10.
    """
    rows: list[tuple[str, str, tuple[str, ...]]] = []
    for labels in _necklaces(k):
        if all(labels) or not any(labels):
            rows.append(("".join("S" if x else "V" for x in labels), "interior" if all(labels) else "empty", ()))
            continue
        runs = runs_of_labels(labels)
        rows.append(("".join("S" if x else "V" for x in labels), classify(runs), star_actions(runs)))
    return rows


HEXAGON_STAR_TABLE = star_table(6)


def vertex_stars(pattern: Pattern) -> tuple[VertexStar, ...]:
    """Classification of every boundary vertex of the solid pattern (paper Fig. 8a)."""
    H = _boundary_half_edges(pattern.solid_faces, len(pattern.V))
    iface = _interface_vertices(pattern)
    return tuple(
        VertexStar(v, classify(runs := star_runs(pattern, v), v in iface), runs)
        for v in sorted({int(x) for x in H.ravel()})
    )
