"""The library: the pruned enumeration against the filter it replaces, the exact depth-3 count against
the rejection sampler's acceptance rate, and the two depth-3 samplers.

Run: ``python benchmarks/bench_library.py [draws]`` — prints Markdown tables (``draws``: uniform
edge-rule slices per polygon for the acceptance rate, default 300 000; about a minute each). Goal
(issue 2): the depth-2 library (65 535 candidates → 430) in ≤ 0.1 s; the pruned enumeration must be
faster than the filter.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from fabpat.patterns import enumeration as en
from fabpat.patterns.count import wilson_interval
from fabpat.patterns.lattice import edge_row, n_faces
from fabpat.patterns.library import enumerate_library, is_connected, is_tileable, sample_library
from fabpat.patterns.pattern import pattern_topology


def best_of(fn, repeat: int = 5) -> float:  # noqa: ANN001
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def cold(fn):  # noqa: ANN001, ANN201
    """``fn`` with the enumeration's caches emptied first: what a fresh process pays."""
    def run():  # noqa: ANN202
        en._table.cache_clear()
        en._faces.cache_clear()
        en.enumeration.cache_clear()
        return fn()
    return run


def filtered_depth2(sides: int) -> int:
    """Today's route before the enumeration: every slice through the edge rule and the n-gon filter."""
    M = n_faces(2)
    values = np.arange(1, 2**M, dtype=np.int64)
    bits = ((values[:, None] >> np.arange(M - 1, -1, -1)) & 1).astype(bool)
    bits = bits[is_tileable(bits, 2)]
    return int(is_connected(bits, sides, 2).sum())


def acceptance(sides: int, depth: int, draws: int = 300_000, seed: int = 0) -> int:
    """How many of ``draws`` uniform edge-rule-passing slices have a connected pattern."""
    rng = np.random.default_rng(seed)
    row, middle = edge_row(depth)
    ok = 0
    for _ in range(draws // 10_000):
        b = rng.random((10_000, n_faces(depth))) < 0.5
        b[:, row] = False
        b[:, middle] = True
        ok += int(is_connected(b, sides, depth).sum())
    return ok


def main(draws: int = 300_000) -> None:
    print("| task | sides | result | seconds (best of 5) |")
    print("|---|---|---|---|")
    for sides in (3, 6, 12):
        pattern_topology(sides, 2)  # topology is cached per (sides, depth): time the filter itself
        t = best_of(lambda s=sides: filtered_depth2(s))
        print(f"| depth 2: all 65 535 slices through the two filters | {sides} | {filtered_depth2(sides)} | {t:.4f} |")
        t = best_of(cold(lambda s=sides: en.enumeration(s, 2).all_bits()))
        print(f"| depth 2: pruned enumeration, cold | {sides} | {len(en.enumeration(sides, 2).all_bits())} | {t:.4f} |")
        t = best_of(lambda s=sides: enumerate_library(s, 2))
        print(f"| depth 2: `enumerate_library` (enumeration cached) | {sides} | {len(enumerate_library(sides, 2))} "
              f"| {t:.4f} |")
    t = best_of(cold(lambda: en._table(3)), repeat=3)
    print(f"| depth 3: build the programme's states (cold) | – | {en._table(3).n_states} states | {t:.3f} |")
    for sides in (5, 6):
        t = best_of(lambda s=sides: en.enumeration.__wrapped__(s, 3), repeat=3)
        print(f"| depth 3: count completions (states built) | {sides} | {en.count_library(sides, 3)} | {t:.4f} |")
    pattern_topology(6, 3)
    for count in (1, 100, 1000, 10_000):
        r = best_of(lambda c=count: sample_library(6, 3, c, seed=1, method="rejection"), repeat=3)
        e = best_of(lambda c=count: sample_library(6, 3, c, seed=1, method="exact"), repeat=3)
        c = best_of(cold(lambda c=count: sample_library(6, 3, c, seed=1, method="exact")), repeat=3)
        print(f"| depth 3: sample {count}: rejection / exact (built) / exact (cold) | 6 | – | "
              f"{r:.4f} / {e:.4f} / {c:.4f} |")
    print()
    print(f"| depth 3 | sides | exact count | count / 2^49 | acceptance ({draws} draws) | 95 % interval |")
    print("|---|---|---|---|---|---|")
    for sides in (5, 6):
        exact = en.count_library(sides, 3)
        ok = acceptance(sides, 3, draws, seed=sides)  # independent draws per polygon
        low, high = wilson_interval(ok, draws)
        print(f"| | {sides} | {exact} | {exact / 2**49:.5f} | {ok / draws:.5f} | [{low:.5f}, {high:.5f}] |")
    print(f"| depth 2 | 6 | {en.count_library(6, 2)} | {430 / 512:.5f} (of 2^9) | – | – |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 300_000)
