"""A first run after an install against a later one: two processes, one after the other, each solving a small
shell path with a fresh kernel cache (``FABPAT_CACHE`` set to a new temporary folder, removed afterwards).

Run: ``python benchmarks/bench_first_run.py`` — prints, per process, the seconds (wall and CPU) to import
the solver, to compile or load its kernels (:func:`fabpat.shell.compiled.ensure_kernels`), until its first
solve starts and until it is done (a cantilever of 0x6808 at h = 6 mm, one report step), and what the
solver told its listeners (the first compilation is announced). The first process compiles the kernels
into the folder, the second loads them from it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import resource, time
t0 = time.perf_counter()
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
import numpy as np
from fabpat.assembly.solve.model import plate_mesh
from fabpat.shell import news
from fabpat.shell.compiled import ensure_kernels
from fabpat.shell.linked import solve_path
from fabpat.shell.rigid_links import LinkedProblem
from fabpat.simulation.scenarios import build_problem
t1, c1 = time.perf_counter(), cpu()
heard = []
with news.listening(heard.append):
    ensure_kernels()
t2, c2 = time.perf_counter(), cpu()
mesh = plate_mesh("0x6808", 6, 36.0, 0.2, 6.0)
p = build_problem(mesh, "cantilever", sides=6)
prob = LinkedProblem(p.X, p.F, p.material, np.zeros((0, 3)), [], [], np.zeros((0, 3)), p.fixed,
                     np.zeros((mesh.n_nodes, 6)), p.loads)
t3, c3 = time.perf_counter(), cpu()
solve_path(prob, steps=1)
t4, c4 = time.perf_counter(), cpu()
print(f"| {t1 - t0:.1f} / {c1:.1f} | {t2 - t1:.1f} / {c2 - c1:.1f} | {t3 - t0:.1f} / {c3:.1f} | "
      f"{t4 - t0:.1f} / {c4:.1f} | {'; '.join(heard) or '–'} |")
"""


def main() -> None:
    print("| process | imports s (wall / CPU) | kernels s | first solve starts at s | done at s | told |")
    print("|---|---:|---:|---:|---:|---|")
    with tempfile.TemporaryDirectory(prefix="fabpat-first-run-") as cache:
        env = dict(os.environ, FABPAT_CACHE=cache)
        env.pop("NUMBA_CACHE_DIR", None)
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        for label in ("first", "second"):
            out = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True)
            print(f"| {label} " + out.stdout.strip())


if __name__ == "__main__":
    main()
