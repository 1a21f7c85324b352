"""Refit the built-in learned response and measure it on the depth-3 patterns by cross-validation.

Run: ``python benchmarks/fit_response.py [--write]`` — the built-in catalog's hexagon rows (the depth-2 library and
the shipped depth-3 patterns: docs/learned-response.md, "The shipped depth-3 patterns"), 5-fold cross-validated as
:func:`fabpat.catalog.response.fit_response` does; prints, per depth, the Spearman rank correlation and median
relative error of the out-of-fold predictions and the coverage of 90 % intervals calibrated on the even-numbered
rows' residuals and checked on the odd-numbered ones. ``--write`` then stores the fitted responses beside the
built-in catalog (``fabpat/data/catalog.sqlite.response.npz``).
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.stats import spearmanr

import fabpat
from fabpat.catalog import response as R
from fabpat.catalog import response_file as RF


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="store the refitted built-in responses")
    a = ap.parse_args()
    rows = list(fabpat.catalog(sides=6)) + list(fabpat.catalog(sides=6, depth=3))
    ids, Y = R.training_arrays(rows)
    X = R.cell_features(R.check_ids(ids, 6), 6)
    depth = X[:, 75].astype(int)
    k = len(R.LEARNED)
    resid = R.out_of_fold(X, Y[:, :k]) - np.log(Y[:, :k])
    print("| hexagons, target (5-fold) | depth | patterns | Spearman | median error | 90 % interval covers |")
    print("|---|---:|---:|---:|---:|---:|")
    for d in (2, 3):
        sel = np.nonzero(depth == d)[0]
        for j, name in enumerate(R.LEARNED):
            y, pred = Y[sel, j], np.exp(np.log(Y[sel, j]) + resid[sel, j])
            q = R.conformal_quantile(resid[sel[0::2], j])
            odd = np.abs(resid[sel[1::2], j]) <= q
            rho = spearmanr(pred, y).statistic
            print(f"| {name} | {d} | {len(sel)} | {rho:.3f} | {100 * np.median(np.abs(pred / y - 1)):.1f} % | "
                  f"{100 * odd.mean():.0f} % |")
    if a.write:
        print(RF.refit_responses(None))


if __name__ == "__main__":
    main()
