"""How far are catalog energies from the mesh-converged value, and what does each cure cost? Prints Markdown.

Run (from the repository root)::

    python benchmarks/study_convergence.py                      # 24 patterns, ≈ 4 min on 2 free cores
    python benchmarks/study_convergence.py --patterns 6 --workers 1
    python benchmarks/study_convergence.py --h 2 1.5 1 0.7 0.5 0.35 --patterns 6   # the pilot

For ``--patterns`` random library patterns (``sample_library(6, 2, N, seed)``, seeded) and the three
scenarios (nonlinear, as the sweep runs them), every pattern is filleted and meshed at each mesh size of
``--h`` (uniform Triangle meshes, :func:`fabpat.simulation.mesh.mesh_outline`) and solved.

Reference: the three finest meshes (by default h = 1.0, 0.7, 0.5) extrapolated to h → 0 with the model
E(h) = E∞ − C·hᵖ, least squares per pattern-scenario, with the order p = :data:`REFERENCE_ORDER` = 1.2
measured on *nested* meshes (every triangle of a Triangle mesh split in four, twice: h = 1.5, 0.75,
0.375, linear runs: p = 1.09–1.29 on 0x2d08 and 0x0488; docs/accuracy.md). Nested meshes are
needed to measure it: independent Delaunay meshes scatter by a few tenths of a percent in energy,
and a p fitted to them over h = 1.0–0.5 comes out anywhere between 0.3 and 2.5. With p fixed, the reference moves by
≤ 0.17 % when the meshes are 0.7–0.35 instead of 1.0–0.5 (six pilot pattern-scenarios, nine cases).

Methods compared against it (each reports the worst and median error, the discordant pairs of its
ranking against the reference ranking per scenario — out of N(N−1)/2 — and the seconds per
pattern-scenario, meshing included, summed over the meshes it needs):

* a single mesh h (h = 1.5 is what the catalog first shipped with, marked "one mesh before");
* two-mesh Richardson extrapolation E₂ + (E₂ − E₁)/((h₁/h₂)ᵖ − 1) from two independent Triangle meshes,
  p = 1 (the pair 1.5 / 1.0 mm was the catalog's next method, marked "two meshes before");
* the shipped method (:func:`fabpat.simulation.convergence.mesh_converged`, as ``fabpat sweep``): a Triangle mesh of
  h = :data:`fabpat.simulation.convergence.CONVERGED_MESHES` [0] = 2.5 mm with its chord tolerance (finer for necks
  narrower than 2.27 mm: :func:`fabpat.simulation.convergence.converged_h`; the table header counts the patterns per
  coarse h), and its nested
  refinement (every triangle split into four, new boundary nodes on the exact outline), extrapolated
  with p = :data:`fabpat.simulation.convergence.RICHARDSON_ORDER` (1.2; the rows with p = 1.0 and 1.1 show how much
  the order matters) — and the refined mesh alone.

Seconds are CPU seconds of the worker process (one BLAS thread), so a machine shared with other jobs
(the load average is printed) slows the wall clock but hardly the figures.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from fabpat.patterns.library import sample_library
from fabpat.simulation.convergence import CONVERGED_MESHES, RICHARDSON_ORDER, mesh_converged, richardson
from fabpat.simulation.scenarios import SCENARIOS

#: (scenario, h) → (energy, seconds, nodes); h a float for uniform meshes, "nested 2" / "nested 1" for the
#: coarse and fine mesh of the shipped method's pair (keys from when it was 2 / 1 mm; the file's
#: "nested_h" says which pair)
Row = dict[tuple[str, float | str], tuple[float, float, int]]

#: the order of the two-independent-mesh extrapolation shipped before the nested meshes
BEFORE_ORDER = 1.0


def _init() -> None:
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)  # the pool already uses the cores


def run_pattern(pid: str, hs: tuple[float, ...]) -> tuple[str, Row]:
    """Energy, seconds (meshing shared by the three scenarios) and nodes of every (scenario, h)."""
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import mesh_outline
    from fabpat.simulation.scenarios import run_scenario

    t0 = time.process_time()
    filleted = fillet_pattern(get_pattern(pid))
    outline = filleted.outline
    t_fillet = time.process_time() - t0
    out: Row = {}
    for h in hs:
        t0 = time.process_time()
        mesh = mesh_outline(outline, h, 6, 36.0)
        t_mesh = (time.process_time() - t0 + t_fillet) / len(SCENARIOS)
        for sc in SCENARIOS:
            t0 = time.process_time()
            r = run_scenario(mesh, sc, sides=6)
            out[sc, h] = (r.energy, time.process_time() - t0 + t_mesh, mesh.n_nodes)
    from _graded import graded_mesh

    for h in hs[-3:]:
        mesh = graded_mesh(outline, h)
        for sc in SCENARIOS:
            out[sc, f"graded {h:g}"] = (run_scenario(mesh, sc, sides=6).energy, 0.0, mesh.n_nodes)
    t0 = time.process_time()
    pair = mesh_converged(filleted)  # as the sweep: coarse h = converged_h(min_width), its refinement
    t_mesh = (time.process_time() - t0 + t_fillet) / len(SCENARIOS) / 2
    out[COARSE_H] = (pair[0][0], 0.0, 0)
    for (_h, mesh), label in zip(pair, NESTED, strict=True):
        for sc in SCENARIOS:
            t0 = time.process_time()
            r = run_scenario(mesh, sc, sides=6)
            out[sc, label] = (r.energy, time.process_time() - t0 + t_mesh, mesh.n_nodes)
    return pid, out


NESTED = ("nested 2", "nested 1")
#: the key under which a pattern's row keeps the coarse h of its nested pair (mm)
COARSE_H = ("nested", "coarse h")


#: asymptotic order of the energy error, measured on nested meshes (module docstring)
REFERENCE_ORDER = 1.2


def extrapolate(E: np.ndarray, hs: np.ndarray, p: float = REFERENCE_ORDER) -> np.ndarray:
    """Per-case limits E∞ of E(h) = E∞ − C hᵖ, least squares; E: (cases, k) energies on the k meshes hs."""
    A = np.column_stack([np.ones_like(hs), -(hs**p)])
    coef, *_ = np.linalg.lstsq(A, E.T, rcond=None)
    return coef[0]


def discordant(a: list[float], b: list[float]) -> int:
    """Pairs ordered one way by a and the other way by b."""
    return sum(1 for i, j in itertools.combinations(range(len(a)), 2) if (a[i] - a[j]) * (b[i] - b[j]) < 0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--patterns", type=int, default=24)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--h", type=float, nargs="+", default=[2.0, 1.5, 1.0, 0.7, 0.5],
                    help="mesh sizes (mm); the three finest make the reference")
    ap.add_argument("--save", help="write the raw energies, seconds and nodes to this JSON file")
    ap.add_argument("--load", help="tabulate a file written by --save instead of computing")
    a = ap.parse_args()
    if a.load:
        raw = json.loads(Path(a.load).read_text())
        ids, hs, wall, load0, load1, workers = (raw[k] for k in ("ids", "h", "wall", "load0", "load1", "workers"))
        hs = tuple(hs)
        nested_h = tuple(raw.get("nested_h", (2.0, 1.0)))  # files written before 2.5 / 1.25 used 2 / 1
        data = {pid: {(sc, h): tuple(v) for sc, h, *v in raw["data"][pid]} for pid in ids}
    else:
        hs = tuple(sorted(set(a.h), reverse=True))
        nested_h = CONVERGED_MESHES
        ids = list(sample_library(6, 2, a.patterns, a.seed).ids)
        t0 = time.perf_counter()
        load0, workers = os.getloadavg()[0], a.workers
        data = {}
        with ProcessPoolExecutor(a.workers, initializer=_init) as pool:
            for fut in as_completed([pool.submit(run_pattern, pid, hs) for pid in ids]):
                pid, d = fut.result()
                data[pid] = d
                wall, load1 = time.perf_counter() - t0, os.getloadavg()[0]
                print(f"{len(data)}/{len(ids)} patterns, {wall:.0f} s", file=sys.stderr, flush=True)
                if a.save:  # after every pattern: a long run interrupted keeps what it has (--load it)
                    done = [i for i in ids if i in data]
                    Path(a.save).write_text(json.dumps({
                        "ids": done, "h": hs, "nested_h": nested_h, "wall": wall, "load0": load0, "load1": load1,
                        "workers": workers,
                        "data": {i: [[sc, h, *v] for (sc, h), v in data[i].items()] for i in done}}))
        ids = [i for i in ids if i in data]
    ref_h = np.array(hs[-3:])
    coarse = [data[pid][COARSE_H][0] for pid in ids if COARSE_H in data[pid]]
    print(f"{len(ids)} patterns: {', '.join(ids)}; meshes h = {', '.join(f'{h:g}' for h in hs)} "
          f"mm; {wall:.0f} s wall with {workers} workers (load average {load0:.1f} → {load1:.1f})\n")
    if coarse:
        counts = ", ".join(f"{h:g} mm × {coarse.count(h)}" for h in sorted(set(coarse), reverse=True))
        print(f"Coarse h of the nested pairs (converged_h of each pattern's min_width): {counts}.\n")
    # (name, meshes, order): one mesh, or Richardson from the last two with that order
    methods: list[tuple[str, tuple[float | str, ...], float]] = [
        (f"h = {h:g}" + (" (one mesh before)" if h == 1.5 else ""), (h,), 0.0) for h in hs[:-1]]
    methods += [(f"Richardson h = {h1:g} / {h2:g}, p = {BEFORE_ORDER:g}"
                 + (" (two meshes before)" if (h1, h2) == (1.5, 1.0) else ""), (h1, h2), BEFORE_ORDER)
                for h1, h2 in itertools.combinations(hs[:-1], 2)]
    if all((SCENARIOS[0], NESTED[1]) in data[pid] for pid in ids):  # files saved before nested meshes lack it
        n1, n2 = nested_h
        current = tuple(nested_h) == CONVERGED_MESHES
        pair = f"{n1:g} / {n2:g}" if len(set(coarse)) < 2 else f"{max(coarse):g}–{min(coarse):g} / half"
        methods += [("nested, the refined mesh alone" if len(set(coarse)) > 1 else f"nested h = {n2:g} alone",
                     (NESTED[1],), 0.0)]
        methods += [(f"nested {pair}, p = {p:g}" + (" (shipped)" if current and p == RICHARDSON_ORDER else ""),
                     NESTED, p) for p in (1.0, 1.1, RICHARDSON_ORDER)]
    graded = all((SCENARIOS[0], f"graded {h:g}") in data[pid] for pid in ids for h in ref_h)
    refs: dict[str, dict[str, np.ndarray]] = {"U": {}, "G": {}}
    for sc in SCENARIOS:
        refs["U"][sc] = extrapolate(np.array([[data[pid][sc, h][0] for h in ref_h] for pid in ids]), ref_h)
        if graded:
            refs["G"][sc] = extrapolate(np.array([[data[pid][sc, f"graded {h:g}"][0] for h in ref_h]
                                                  for pid in ids]), ref_h)
    names = ["U", "G"] if graded else ["U"]
    print(f"References: uniform meshes (U) and meshes graded to the local width (G, benchmarks/_graded.py) of "
          f"h = {', '.join(f'{h:g}' for h in ref_h)} mm, each extrapolated with p = {REFERENCE_ORDER:g}.")
    if graded:
        for sc in SCENARIOS:
            d = 100.0 * (refs["G"][sc] / refs["U"][sc] - 1.0)
            print(f"{sc}: G / U − 1 median {np.median(d):+.2f} %, from {d.min():+.2f} to {d.max():+.2f} %.")
    print()
    cols = " | ".join(f"worst error ({n})" for n in names) + " | " + " | ".join(f"median ({n})" for n in names)
    print(f"| scenario | method | {cols} | discordant pairs ({names[0]}) | within 1 % ({'/'.join(names)}) "
          "| CPU s per pattern-scenario | nodes (median) |")
    print("|---|---|" + "---|" * (2 * len(names) + 4))
    for sc in SCENARIOS:
        ref = refs["U"][sc]
        pairs = len(ids) * (len(ids) - 1) // 2
        for name, mh, p in methods:
            if len(mh) == 1:
                est = [data[pid][sc, mh[0]][0] for pid in ids]
            else:
                h1, h2 = nested_h if mh == NESTED else mh
                est = [richardson(data[pid][sc, mh[0]][0], data[pid][sc, mh[1]][0], float(h1), float(h2), p)
                       for pid in ids]
            errs = [100.0 * (np.array(est) / refs[n][sc] - 1.0) for n in names]
            worst = " | ".join(f"{e[np.argmax(np.abs(e))]:+.2f} %" for e in errs)
            med = " | ".join(f"{np.median(e):+.2f} %" for e in errs)
            within = "/".join(str(int((np.abs(e) <= 1.0).sum())) for e in errs)
            secs = statistics.mean(sum(data[pid][sc, h][1] for h in mh) for pid in ids)
            nodes = statistics.median(data[pid][sc, mh[-1]][2] for pid in ids)
            print(f"| {sc} | {name} | {worst} | {med} | {discordant(est, list(ref))} / {pairs} | "
                  f"{within} of {len(ids)} | {secs:.2f} | {nodes:.0f} |")


if __name__ == "__main__":
    main()
