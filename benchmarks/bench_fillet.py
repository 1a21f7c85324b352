"""Filleting and validating whole libraries; the area change and min width distributions.

Run: ``python benchmarks/bench_fillet.py`` — prints Markdown tables. Goal (issue 3): filleting and
validating all 430 hexagon patterns in ≤ 5 s on one core. The process pins itself to one CPU (and
one BLAS thread) and does the hexagon first, so its row is the cold, one-core number (imports excluded).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
if hasattr(os, "sched_setaffinity"):
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})

import time  # noqa: E402

import numpy as np  # noqa: E402

from fabpat.geometry.fillet import fillet_pattern  # noqa: E402
from fabpat.patterns.library import enumerate_library  # noqa: E402


def main() -> None:
    print("| sides | patterns | fillet (s) | validate incl. min_width (s) | total (s) | all valid |")
    print("|---|---|---|---|---|---|")
    stats = {}
    for sides in (6, 3, 5, 8, 12):
        patterns = enumerate_library(sides, 2).patterns()
        t0 = time.perf_counter()
        fps = [fillet_pattern(p) for p in patterns]
        t1 = time.perf_counter()
        reports = [fp.validate(1e-2, raise_on_error=False) for fp in fps]
        t2 = time.perf_counter()
        ok = all(r.ok for r in reports)
        print(f"| {sides} | {len(fps)} | {t1 - t0:.2f} | {t2 - t1:.2f} | {t2 - t0:.2f} | {ok} |")
        change = np.array([fp.outline.area / fp.pattern.metrics.area - 1 for fp in fps]) * 100
        width = np.array([r.min_width for r in reports])
        stats[sides] = (change, width, [len(fp.outline.holes) for fp in fps])
    print()
    print("| sides | area change % (min / median / max) | min width mm (min / median / max) | holes (max) |")
    print("|---|---|---|---|")
    for sides, (change, width, holes) in stats.items():
        c = np.percentile(change, [0, 50, 100])
        w = np.percentile(width, [0, 50, 100])
        cs, ws = " / ".join(f"{x:.2f}" for x in c), " / ".join(f"{x:.3f}" for x in w)
        print(f"| {sides} | {cs} | {ws} | {max(holes)} |")


if __name__ == "__main__":
    main()
