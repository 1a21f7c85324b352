"""How many connected, tileable patterns a polygon has at a depth: exact where the pruned enumeration
reaches (depth ≤ 3, :mod:`fabpat.patterns.enumeration`), an estimate with its 95 % interval beyond.

The estimate draws slices that pass the edge rule uniformly (the free faces as fair coin flips, as the
rejection sampler does), counts the connected ones on the n-gon (:func:`fabpat.patterns.library.is_connected`)
and scales the share, with its Wilson score interval, by the 2**free_faces slices that pass the edge
rule. ``fabpat library --count`` prints either, labelled as such.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fabpat.errors import PatternError
from fabpat.patterns.enumeration import MAX_ENUMERATED_DEPTH, count_library, free_faces
from fabpat.patterns.lattice import check_depth, check_sides, edge_row, n_faces
from fabpat.patterns.library import is_connected
from fabpat.validate import check

#: Pattern faces (draws × sides × 4**depth) one estimate examines: ≈ 10 s of connectivity graphs
#: (about 1e6 faces per second measured), e.g. 6 510 draws of depth-4 hexagons.
ESTIMATE_FACES = 10_000_000

#: Fewest and most draws of an estimate, whatever the budget above allows.
ESTIMATE_DRAWS = (200, 20_000)

Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile: a two-sided 95 % interval


@dataclass(frozen=True)
class LibraryCount:
    """The size of one library: ``count`` patterns, ``exact`` or estimated from ``draws`` uniform draws
    with the 95 % interval ``[low, high]`` (equal to ``count`` when exact); ``edge_rule_slices`` =
    2**free_faces, the slices that pass the edge rule; ``method`` says how it was obtained."""

    sides: int
    depth: int
    count: int
    exact: bool
    low: int
    high: int
    edge_rule_slices: int
    draws: int
    method: str

    def as_dict(self) -> dict[str, object]:
        """The fields as a JSON-ready dict (ints stay exact)."""
        return {"sides": self.sides, "depth": self.depth, "count": self.count, "exact": self.exact,
                "low": self.low, "high": self.high, "edge_rule_slices": self.edge_rule_slices,
                "draws": self.draws, "method": self.method}


def count_patterns(sides: int = 6, depth: int = 3, seed: int = 0, draws: int | None = None) -> LibraryCount:
    """The number of connected, tileable patterns of the ``sides``-gon at ``depth``: exact (pruned
    enumeration) up to depth :data:`~fabpat.patterns.enumeration.MAX_ENUMERATED_DEPTH`, estimated beyond
    from ``draws`` uniform draws (default: as many as :data:`ESTIMATE_FACES` allows, within
    :data:`ESTIMATE_DRAWS`) with ``seed``. Raises :class:`PatternError` for a bad polygon, depth, seed or
    number of draws.
    """
    n, d = check_sides(sides), check_depth(depth)
    seed = int(check("seed", seed, error=PatternError))
    total = 2 ** free_faces(d)
    if d <= MAX_ENUMERATED_DEPTH and draws is None:
        c = count_library(n, d)
        return LibraryCount(n, d, c, True, c, c, total, 0, "pruned enumeration")
    faces = n * n_faces(d)
    if draws is None:
        draws = min(max(ESTIMATE_FACES // faces, ESTIMATE_DRAWS[0]), ESTIMATE_DRAWS[1])
    draws = int(check("sample", draws, "number of draws", error=PatternError))
    connected = _connected_draws(n, d, draws, seed)
    low, high = wilson_interval(connected, draws)
    # integers throughout: 2**free_faces overflows a float from depth 6 (2**3969)
    estimate = round(Fraction(total * connected, draws))
    return LibraryCount(n, d, estimate, False, math.floor(total * Fraction(low)), math.ceil(total * Fraction(high)),
                        total, draws, "estimate: uniform draws, Wilson 95 % interval")


def _connected_draws(sides: int, depth: int, draws: int, seed: int) -> int:
    """How many of ``draws`` uniform edge-rule slices (drawn in batches of ≤ 1e6 faces) are connected."""
    rng = np.random.default_rng(seed)
    row, middle = edge_row(depth)
    M = n_faces(depth)
    batch = max(1, 1_000_000 // (sides * M))
    hits = done = 0
    while done < draws:
        b = rng.random((min(batch, draws - done), M)) < 0.5
        b[:, row] = False
        b[:, middle] = True
        hits += int(is_connected(b, sides, depth).sum())
        done += len(b)
    return hits


def wilson_interval(successes: int, trials: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval (low, high) of a binomial proportion: a 95 % interval for the default
    ``z``, inside [0, 1] and sensible at 0 or ``trials`` successes."""
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / (1 + z * z / trials)
    return max(0.0, centre - half), min(1.0, centre + half)
