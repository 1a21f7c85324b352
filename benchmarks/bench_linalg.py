"""Linear-solver benchmark: SuperLU against PARDISO (analysis once, then numerical refactorisations)
on the tangents of the scenarios, for a few meshes.

Run: ``python benchmarks/bench_linalg.py [--ids 0x2d08,0x0488] [--h 1.5,1.0,0.7]``. For each mesh the
Dome tangent at a perturbed state is factored by SuperLU (as before PARDISO) and by PARDISO; times are
the least of 5 repeats on one thread. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from fabpat.geometry.fillet import fillet_pattern
from fabpat.patterns.library import enumerate_library
from fabpat.shell.linalg import Pardiso, SuperLUFactorizer, factorizer
from fabpat.shell.solve import _setup
from fabpat.simulation.mesh import mesh_outline
from fabpat.simulation.scenarios import build_problem


def best(fn: Callable[[], object], k: int = 5) -> float:
    t = np.inf
    for _ in range(k):
        t0 = time.perf_counter()
        fn()
        t = min(t, time.perf_counter() - t0)
    return t


def dome_tangent(outline: object, h: float) -> sp.csc_matrix:
    """The Dome scenario's tangent (CSC) of a mesh of ``outline`` (edge h, mm) at a perturbed state."""
    p = build_problem(mesh_outline(outline, h, 6, 36.0), "dome", sides=6)
    model, asm, _ = _setup(p)
    x = p.X + np.random.default_rng(0).normal(0, 0.3, p.X.shape)
    R = np.broadcast_to(np.eye(3), (p.X.shape[0], 3, 3)).copy()
    _, _, d = model.element_forces(*model.gather(x, R))
    return asm.matrix(model.element_tangents(*model.gather(x, R), d))


def calibration() -> float:
    """Seconds of the machine's "fixed sparse LU", by which timing goals are scaled: SuperLU's factorisation
    of 0x2d08's Dome tangent at h = 0.7 mm (23 430 dofs; the row of the table below), least of 5."""
    K = dome_tangent(fillet_pattern(enumerate_library(6, 2).pattern("0x2d08"), 0.2).outline, 0.7)
    slu = SuperLUFactorizer()
    return best(lambda: slu.factor(K))


def measure(fz: Pardiso, outline: object, h: float) -> tuple[float, float, float, float, float, float, object]:
    """Times (s) and the largest relative difference of the two solutions, for one mesh."""
    K = dome_tangent(outline, h)
    b = np.random.default_rng(1).normal(size=K.shape[0])
    slu = SuperLUFactorizer()
    t_slu = best(lambda: slu.factor(K))
    t_first = best(lambda: factorizer().factor(K))
    t_re = best(lambda: fz.factor(K))
    lu = slu.factor(K)
    t_ss = best(lambda: lu.solve(b))
    t_ps = best(lambda: fz.solve(b))
    xs, xp = lu.solve(b), fz.solve(b)
    diff = float(np.abs(xp - xs).max() / np.abs(xs).max())
    return t_slu, t_first, t_re, t_ss, t_ps, diff, K


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ids", default="0x2d08,0x0488")
    ap.add_argument("--h", default="1.5,1.0,0.7")
    a = ap.parse_args()
    fz = factorizer()
    if not isinstance(fz, Pardiso):
        raise SystemExit("MKL is not installed here: nothing to compare")
    lib = enumerate_library(6, 2)
    print("| pattern | h (mm) | dofs | SuperLU factor (ms) | PARDISO analysis + factor (ms) | PARDISO refactor (ms) "
          "| SuperLU solve (ms) | PARDISO solve (ms) | max rel. difference |")
    print("|---|---|---|---|---|---|---|---|---|")
    for pid in a.ids.split(","):
        fp = fillet_pattern(lib.pattern(pid), 0.2)
        for h in map(float, a.h.split(",")):
            t_slu, t_first, t_re, t_ss, t_ps, diff, K = measure(fz, fp.outline, h)
            print(f"| {pid} | {h:g} | {K.shape[0]} | {1e3 * t_slu:.1f} | {1e3 * t_first:.1f} | {1e3 * t_re:.1f} "
                  f"| {1e3 * t_ss:.2f} | {1e3 * t_ps:.2f} | {diff:.1e} |")


if __name__ == "__main__":
    main()
