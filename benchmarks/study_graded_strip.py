"""The graded strip of the paper (§5, Fig. 15 left) compressed between pins, in the shell solver.

Run: ``python benchmarks/study_graded_strip.py [--h 3]`` — prints Markdown tables (≈ 2 min at h = 3 on
2 cores). Strips: the spec ``assemblies/graded-strip.toml`` (2 × 15 hexagons, five patterns from the
catalog's grading rule, stiff → soft), the same grading mirrored, and a uniform strip of its middle
pattern; each at 0.5 and 0.8 of the Rayleigh estimate of its buckling load, with a perturbation of
1 % of the load. Columns: where the strip is highest (fraction of the length from the stiff end),
the deflection area of the first half over the second (< 1: first half flatter), the amplification
of the perturbation and the buckling load it implies (Southwell's reading).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from _strip_load import critical_load, simulate_strip, strip_model  # benchmarks/ is sys.path[0] when a study runs

from fabpat.assembly.choose.choice import face_patterns
from fabpat.assembly.spec.load import load_spec
from fabpat.assembly.surface.tiling import honeycomb_strip

SPEC = Path(__file__).resolve().parents[1] / "assemblies" / "graded-strip.toml"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--h", type=float, default=3.0, help="mesh edge length, mm")
    h = ap.parse_args().h
    spec = load_spec(SPEC)
    t = spec.tiling
    graded = face_patterns(spec)
    groups = list(dict.fromkeys(graded))
    columns = [int(c) for c in honeycomb_strip(t.rows, t.columns, t.edge).grid[:, 1]]
    mirrored = [graded[columns.index(t.columns - 1 - c)] for c in columns]
    strips = {"graded": graded, "mirrored": mirrored, "uniform": [groups[len(groups) // 2]] * len(graded)}
    print(f"Patterns stiff → soft: {', '.join(groups)}; uniform strip: {strips['uniform'][0]}; h = {h} mm\n")
    print("| strip | nodes | P_R estimate (N) | P / P_R | peak (x/L) | first / second half | amplification "
          "| implied P_cr (N) | max w (mm) | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, ids in strips.items():
        model = strip_model(honeycomb_strip(t.rows, t.columns, t.edge), ids, edge=t.edge, h=h,
                            thickness=spec.plates.thickness, weight=spec.plates.weight)
        estimate = critical_load(model)
        for factor in (0.5, 0.8):
            t0 = time.perf_counter()
            r = simulate_strip(model, factor * estimate)
            print(f"| {name} | {len(model.V)} | {estimate:.4g} | {factor} | {r.peak:.3f} | {r.half_ratio:.3f} "
                  f"| {r.amplification:.2f} | {r.implied_critical_load:.4g} | {r.w.max():.2f} "
                  f"| {time.perf_counter() - t0:.0f} |")


if __name__ == "__main__":
    main()
