"""Sweep benchmark: time per pattern-scenario, the share spent meshing / assembling / solving, and the
estimated full-library sweep (430 patterns × 3 nonlinear scenarios) on this machine.

Run: ``python benchmarks/bench_sweep.py [--patterns K] [--seed S] [--h MM] [--workers N] [--no-extrapolate]``.
Part 1 runs K random patterns one after the other in this process and splits the time by phase
(fillet + mesh once per pattern, shared by its three scenarios; tangent assembly; internal forces /
residual; LU factorisation + back-substitution). Part 2 runs the same K patterns through ``run_sweep``
with N worker processes into a temporary catalog, which measures the real parallel throughput
(including process start-up and catalog commits); the estimate scales that to 430 × 3. By default
part 2 runs ``fabpat sweep`` (energies extrapolated from a mesh of h = 2 mm and its nested refinement); with
``--no-extrapolate``, ``fabpat sweep --no-extrapolate`` (one mesh of h).
Prints Markdown tables.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path

from fabpat.catalog.sweep import SweepSetup, fine_mesh, run_sweep
from fabpat.patterns.library import enumerate_library, sample_library
from fabpat.simulation.energies import scenario_energies
from fabpat.simulation.scenarios import SCENARIOS


def sequential(ids: list[str], h: float) -> list[dict[str, float | str]]:
    """One dict per pattern-scenario with the seconds of each phase (meshing split over the scenarios): the
    sweep's pipeline (:func:`fabpat.simulation.energies.scenario_energies`) on one mesh of h."""
    lib = enumerate_library(6, 2)
    rows: list[dict[str, float | str]] = []
    for pid in ids:
        # fillet + validate (the sweep stores min_width: part of the per-pattern geometry cost) + mesh
        got = scenario_energies(lib.pattern(pid), SCENARIOS, h=h, extrapolate=False)
        assert got.mesh is not None
        for run in got.runs:
            assert run.result is not None
            r = run.result.fine
            s = r.result.seconds
            tangent, solve = s.get("tangent", 0.0), s.get("factor_solve", 0.0)
            rows.append({"id": pid, "scenario": run.scenario, "nodes": got.mesh.n_nodes, "iterations": r.iterations,
                         "mesh": got.geometry_seconds / len(SCENARIOS), "tangent": tangent, "solve": solve,
                         "residual": max(r.seconds - tangent - solve, 0.0), "energy": r.energy})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--patterns", type=int, default=6, help="random patterns to time (default 6)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--h", type=float, default=None,
                    help="mesh size in mm (default: the sweep's, 2.5 — lowered per pattern for narrow necks —"
                         " refined to half when extrapolating, else 1.5;"
                         " part 1 times one mesh of it)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes for part 2 (default 2)")
    ap.add_argument("--extrapolate", action=argparse.BooleanOptionalAction, default=True,
                    help="part 2: extrapolated energies from h and its nested refinement h/2 (the default), "
                         "or one mesh of h")
    a = ap.parse_args()
    ids = list(sample_library(6, 2, a.patterns, a.seed).ids)
    setup = SweepSetup(h=a.h, extrapolate=a.extrapolate)
    a.h = float(setup.h)  # type: ignore[arg-type]  # resolved by SweepSetup

    rows = sequential(ids, a.h)
    phases = ("mesh", "tangent", "residual", "solve")
    totals = {p: sum(float(r[p]) for r in rows) for p in phases}
    grand = sum(totals.values())
    print(f"## Part 1: {len(ids)} patterns × {len(SCENARIOS)} scenarios, one process, h = {a.h:g} mm\n")
    print("| scenario | runs | mean nodes | mean Newton its | mean s / run | min s | max s |")
    print("|---|---|---|---|---|---|---|")
    for sc in SCENARIOS:
        rs = [r for r in rows if r["scenario"] == sc]
        t = [sum(float(r[p]) for p in phases) for r in rs]
        print(f"| {sc} | {len(rs)} | {statistics.mean(float(r['nodes']) for r in rs):.0f} | "
              f"{statistics.mean(float(r['iterations']) for r in rs):.1f} | {statistics.mean(t):.2f} | "
              f"{min(t):.2f} | {max(t):.2f} |")
    per = grand / len(rows)
    print(f"| all | {len(rows)} | | | {per:.2f} | | |\n")
    print("| phase | what | share |")
    print("|---|---|---|")
    what = {"mesh": "fillet + validate + mesh (once per pattern)", "tangent": "assembling tangent matrices",
            "residual": "assembling internal forces / residuals, energies", "solve": "LU factorisation + solves"}
    for p in phases:
        print(f"| {p} | {what[p]} | {100 * totals[p] / grand:.1f} % |")
    n_rows = 430 * len(SCENARIOS)
    print(f"\nIdeal estimate, 430 × 3 on {a.workers} cores: {n_rows * per / a.workers / 60:.1f} min\n")

    with tempfile.TemporaryDirectory() as d:
        cpu0 = _children_cpu()
        t0 = time.perf_counter()
        rep = run_sweep(Path(d) / "bench.sqlite", ids, setup,
                        workers=a.workers)
        wall = time.perf_counter() - t0
        cpu = _children_cpu() - cpu0  # CPU seconds of the (finished) worker processes
    per_par = wall / rep.computed
    how = f", extrapolated from h = {a.h:g} and its refinement {fine_mesh(a.h):g} mm" if a.extrapolate else ""
    print(f"## Part 2: run_sweep{how}, {a.workers} workers, load average {os.getloadavg()[0]:.1f}\n")
    print("Wall time is what this (possibly shared) machine gave; worker CPU time / cores is what "
          f"{a.workers} dedicated cores would take.\n")
    print("| pattern-scenarios | wall s | wall s per pattern-scenario | estimate 430 × 3 (wall) | "
          "worker CPU s | estimate 430 × 3 (CPU / cores) |")
    print("|---|---|---|---|---|---|")
    print(f"| {rep.computed} | {wall:.1f} | {per_par:.2f} | {n_rows * per_par / 60:.1f} min | {cpu:.1f} | "
          f"{n_rows * cpu / rep.computed / a.workers / 60:.1f} min |")


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


if __name__ == "__main__":
    main()
