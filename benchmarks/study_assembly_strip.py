"""The shipped graded strip pushed into its arch: solver cost by mesh size, and the sparse solvers.

    python benchmarks/study_assembly_strip.py                 # table at h = 3 (full path, 10 %)
    python benchmarks/study_assembly_strip.py --h 3 2 1.5     # the table of docs/assembly-solver.md
    python benchmarks/study_assembly_strip.py --solvers --h 3 2 1.5   # one tangent, each solver
    python benchmarks/study_assembly_strip.py --profiles docs/img/assembly-strip-profiles.png --h 4

Columns: nodes (plate nodes + sleeves), dofs (unknowns after eliminating slaves and fixed dofs),
LU factorizations, seconds per factorization (PARDISO where MKL is installed, else SuperLU; factor +
solves), total seconds of the path solve (10 report steps to 10 % end shortening), the reaction at
10 % (N) and the arch's peak.
``--solvers`` factors the reduced tangent of the strip (unloaded; the pins' rows replaced by identity
rows, so it is unsymmetric) with every solver that is installed and reports seconds and the relative
residual of one solve.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fabpat.assembly.choose.choice import face_patterns
from fabpat.assembly.solve.strip import run_strip, strip_setup, write_profiles_png
from fabpat.assembly.spec.load import load_spec

SPEC = "assemblies/graded-strip.toml"


def table(hs: list[float], steps: int) -> None:
    spec = load_spec(SPEC)
    ids = face_patterns(spec)
    print(f"{'h mm':>5} {'nodes':>7} {'dofs':>8} {'factorizations':>15} {'s/factorization':>16} {'total s':>8} "
          f"{'reaction N':>11} {'peak':>6}")
    for h in hs:
        setup = strip_setup(spec, ids, h=h)
        t0 = time.perf_counter()
        r = run_strip(setup, 0.1, steps=steps)
        total = time.perf_counter() - t0
        res = r.result
        print(f"{h:5.2f} {setup.model.n_nodes:7d} {res.dofs:8d} {res.factorizations:15d} "
              f"{res.seconds['factor_solve'] / max(res.factorizations, 1):16.2f} {total:8.1f} {r.reaction:11.4f} "
              f"{r.peak:6.3f}", flush=True)


def solvers(hs: list[float]) -> None:
    """Factor the strip's reduced tangent (unloaded state, pins' prescribed rows in place) with each
    installed solver: seconds for factor + one solve, and the relative residual of that solve."""
    import scipy.sparse.linalg as spla

    from fabpat.shell.linalg import factorizer, superlu
    from fabpat.shell.rigid_links import _Reduced

    spec = load_spec(SPEC)
    ids = face_patterns(spec)
    for h in hs:
        setup = strip_setup(spec, ids, h=h)
        m = setup.model
        N = m.n_nodes
        fixed = np.zeros((N, 6), dtype=bool)
        fixed[setup.left, :3] = True
        fixed[setup.right, :3] = True
        pres = np.zeros((N, 6))
        pres[setup.right, 0] = -0.1 * setup.length
        p = m.problem(fixed, pres, np.zeros((N, 6)))
        red = _Reduced(p)
        x = np.vstack([p.X, p.masters])
        R = np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
        g, _, _, d = red.forces(p, x, R, 0.0)
        K = red.matrix(p, x, R, d, g, 1.0)
        b = np.random.default_rng(0).standard_normal(K.shape[0])
        print(f"h = {h}: {N} nodes, {K.shape[0]} dofs, {K.nnz} nonzeros", flush=True)
        rows = []
        t = time.perf_counter()
        y = superlu(K).solve(b)
        rows.append(("SuperLU (scipy; fabpat's MMD node order, threshold 0.1)", time.perf_counter() - t, y))
        fz = factorizer()
        t = time.perf_counter()
        y = fz.factor(K).solve(b)
        rows.append((f"fabpat's factoriser ({type(fz).__name__}; analysis + factor + solve)",
                     time.perf_counter() - t, y))
        t = time.perf_counter()
        y = spla.splu(K.tocsc(), permc_spec="COLAMD").solve(b)
        rows.append(("SuperLU (scipy; COLAMD, partial pivoting)", time.perf_counter() - t, y))
        try:
            import pypardiso

            solver = pypardiso.PyPardisoSolver(mtype=11)  # real unsymmetric
            Kr = K.tocsr()
            t = time.perf_counter()
            solver.factorize(Kr)
            y = solver.solve(Kr, b)
            rows.append(("PARDISO (pypardiso 0.4.7, MKL, real unsymmetric)", time.perf_counter() - t, y))
        except ImportError:
            print("pypardiso not installed")
        try:
            from sksparse.cholmod import cholesky

            t = time.perf_counter()
            y = cholesky(K.tocsc())(b)
            rows.append(("CHOLMOD (scikit-sparse; symmetric only)", time.perf_counter() - t, y))
        except ImportError:
            print("scikit-sparse not installed")
        for name, sec, y in rows:
            print(f"  {name:<58} {sec:7.2f} s   residual {np.linalg.norm(K @ y - b) / np.linalg.norm(b):.1e}",
                  flush=True)


def profiles(path: str, h: float, steps: int) -> None:
    spec = load_spec(SPEC)
    ids = face_patterns(spec)
    cols, nrows = spec.tiling.columns, spec.tiling.rows
    rev = [ids[(cols - 1 - f // nrows) * nrows + f % nrows] for f in range(len(ids))]  # columns reversed
    runs = []
    for name, pats in (("graded (stiff at column 0)", ids), ("mirrored", rev),
                       ("uniform (softest)", [ids[-1]] * len(ids))):
        t0 = time.perf_counter()
        r = run_strip(strip_setup(spec, pats, h=h), 0.1, steps=steps)
        res = r.result
        print(f"{name:<28} peak {r.peak:.4f} half_ratio {r.half_ratio:.3f} reaction {r.reaction:.4f} N "
              f"max_deflection {r.max_deflection:.2f} mm; {r.setup.model.n_nodes} nodes, {res.dofs} dofs, "
              f"{res.factorizations} factorizations, {res.seconds['factor_solve'] / max(res.factorizations, 1):.2f} "
              f"s/factorization, {time.perf_counter() - t0:.0f} s", flush=True)
        runs.append((name, r))
    write_profiles_png(path, runs)
    print(f"wrote {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--h", type=float, nargs="+", default=[3.0])
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--solvers", action="store_true")
    ap.add_argument("--profiles", metavar="PNG")
    a = ap.parse_args()
    if a.solvers:
        solvers(a.h)
    elif a.profiles:
        profiles(a.profiles, a.h[0], a.steps)
    else:
        table(a.h, a.steps)


if __name__ == "__main__":
    main()
