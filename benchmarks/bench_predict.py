"""The learned response: its accuracy on patterns it never saw, and how many patterns it ranks per second.

Run: ``python benchmarks/bench_predict.py [--heldout DB] [--count N]`` — prints Markdown tables:

* **cross-validation** on the built-in catalog, per polygon (depth 2): every pattern predicted by a model fitted
  without it (5 folds); Spearman rank correlation and median relative error per scenario energy, and the share
  of 90 % intervals (calibrated on the even-numbered patterns' out-of-fold residuals) that hold the odd-numbered
  ones' truths;
* **held out** (``--heldout DB``: a catalog swept from seeded depth-3 samples that the model never saw, e.g.
  ``fabpat sweep --depth 3 --sample 200 --seed 20261207 --db heldout.sqlite``): the same numbers, with the
  shipped model's own intervals;
* **speed**: ``fabpat.predict`` on N sampled depth-3 IDs plus the 430 depth-2 ones (IDs checked, features,
  trees), best of 3, after a first call that loads the compiled loops.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.stats import spearmanr

import fabpat
from fabpat.catalog import response as R
from fabpat.catalog import response_file as RF
from fabpat.patterns.library import sample_library

ENERGIES = ("energy_cantilever", "energy_cylinder", "energy_dome")


def _row(label: str, truth: np.ndarray, pred: np.ndarray, low: np.ndarray, high: np.ndarray) -> str:
    rho = spearmanr(pred, truth).statistic
    median = float(np.median(np.abs(pred / truth - 1)))
    cover = float(np.mean((low <= truth) & (truth <= high)))
    return f"| {label} | {len(truth)} | {rho:.3f} | {100 * median:.1f} % | {100 * cover:.0f} % |"


def cross_validation() -> None:
    print("| polygon, scenario (5-fold, depth 2) | patterns | Spearman | median error | 90 % interval covers |")
    print("|---|---:|---:|---:|---:|")
    for sides in (6, 5):
        ids, Y = R.training_arrays(fabpat.catalog(sides=sides))
        oof = R.out_of_fold(R.cell_features(ids, sides), Y[:, :3])
        resid = oof - np.log(Y[:, :3])
        for j, name in enumerate(ENERGIES):
            q = R.conformal_quantile(resid[0::2, j])
            odd = slice(1, None, 2)
            pred = np.exp(oof[odd, j])
            print(_row(f"{sides}-gon, {name}", Y[odd, j], pred, pred * np.exp(-q), pred * np.exp(q)))


def held_out(db: str) -> None:
    trained = RF.response(6).ids  # a held-out pattern the model was fitted to would not be held out
    rows = [r for r in fabpat.catalog(db, sides=6) if r["depth"] == 3 and r["id"] not in trained]
    ids, Y = R.training_arrays(rows)
    p = fabpat.predict(ids, 6)
    print(f"\n| held-out depth-3 hexagons ({db}), scenario | patterns | Spearman | median error "
          "| 90 % interval covers |")
    print("|---|---:|---:|---:|---:|")
    for j, name in enumerate(ENERGIES):
        iv = p.intervals[name]
        print(_row(name, Y[:, j], p.values[name], iv[:, 0], iv[:, 1]))


def speed(count: int) -> None:
    ids = list(sample_library(6, 3, count, seed=1).ids) + [r["id"] for r in fabpat.catalog(sides=6)]
    model = RF.response(6)  # the stored trees, read once
    model.predict(ids[:10], extrapolate=True)  # loads the compiled loops (numba cache)
    best, cpu = float("inf"), float("inf")
    for _ in range(3):
        t, c = time.perf_counter(), time.process_time()
        model.predict(ids, extrapolate=True)  # the IDs checked, featurised and predicted, as fabpat.predict
        best, cpu = min(best, time.perf_counter() - t), min(cpu, time.process_time() - c)
    # CPU seconds too: on a shared machine the wall clock measures the neighbours
    # CPU per pattern: the compiled loops run on every core, so 2 cores rank about 2 / (CPU s per pattern)
    print(f"\n| patterns ranked | wall s | CPU s | CPU µs per pattern | patterns per wall second |\n"
          f"|---:|---:|---:|---:|---:|\n"
          f"| {len(ids)} | {best:.3f} | {cpu:.3f} | {1e6 * cpu / len(ids):.0f} | {len(ids) / best:,.0f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--heldout", help="a catalog of depth-3 hexagon patterns the model never saw")
    ap.add_argument("--count", type=int, default=20_000, help="sampled depth-3 IDs to rank (speed)")
    ap.add_argument("--no-cv", action="store_true", help="skip the cross-validation (about a minute)")
    a = ap.parse_args()
    if not a.no_cv:
        cross_validation()
    if a.heldout:
        held_out(a.heldout)
    speed(a.count)


if __name__ == "__main__":
    main()
