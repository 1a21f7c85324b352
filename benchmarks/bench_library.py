"""Enumerating and filtering the library, and the depth-3 sampler's acceptance rate.

Run: ``python benchmarks/bench_library.py`` — prints a Markdown table. Goal (issue 2): the depth-2
library (65 535 candidates → 430) in ≤ 0.1 s.
"""

from __future__ import annotations

import time

import numpy as np

from fabpat.patterns.lattice import edge_row, n_faces
from fabpat.patterns.library import enumerate_library, is_connected, sample_library
from fabpat.patterns.pattern import pattern_topology


def best_of(fn, repeat: int = 5) -> float:  # noqa: ANN001
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def acceptance(sides: int, depth: int, draws: int = 200_000, seed: int = 0) -> float:
    """Share of uniform edge-rule-passing draws whose pattern is connected."""
    rng = np.random.default_rng(seed)
    row, middle = edge_row(depth)
    ok = 0
    for _ in range(draws // 10_000):
        b = rng.random((10_000, n_faces(depth))) < 0.5
        b[:, row] = False
        b[:, middle] = True
        ok += int(is_connected(b, sides, depth).sum())
    return ok / draws


def main() -> None:
    print("| task | sides | result | seconds (best of 5) |")
    print("|---|---|---|---|")
    for sides in (3, 6, 12):
        pattern_topology(sides, 2)  # topology is cached per (sides, depth): time the filter itself
        t = best_of(lambda s=sides: enumerate_library(s, 2))
        print(f"| enumerate + filter depth 2 | {sides} | {len(enumerate_library(sides, 2))} patterns | {t:.4f} |")
    pattern_topology(6, 3)
    t = best_of(lambda: sample_library(6, 3, 100, seed=1), repeat=3)
    print(f"| sample 100 depth-3 patterns | 6 | 100 distinct | {t:.4f} |")
    for sides in (5, 6):
        print(f"| depth-3 acceptance (200 000 draws) | {sides} | {acceptance(sides, 3):.4f} | – |")
    print(f"| depth-2 acceptance (exact: 430/512) | 6 | {430 / 512:.4f} | – |")


if __name__ == "__main__":
    main()
