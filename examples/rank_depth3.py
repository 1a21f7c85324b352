"""Rank a sample of the depth-3 library (too large to list: 2**49 slices pass the edge rule).

Draw 40 valid depth-3 hexagon patterns (reproducibly, seed 1), then rank them by polar moment about
the centre — the lattice metric the paper plots the energies against (§4.2; a larger polar moment
goes with a stiffer pattern in Figs 13–14). Run: ``python examples/rank_depth3.py``.
"""

import fabpat

lib = fabpat.library(sides=6, depth=3, edge=36.0, sample=40, seed=1)
ranked = sorted(lib, key=lambda p: p.metrics.polar_moment, reverse=True)
print(f"sampled={len(lib)} depth={lib.depth}")
for rank, p in enumerate(ranked[:5], 1):
    m = p.metrics
    print(f"rank={rank} id={p.id} area={m.area:.4f} perimeter={m.perimeter:.4f} polar_moment={m.polar_moment:.2f}")
