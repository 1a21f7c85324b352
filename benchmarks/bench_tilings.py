"""Closures of the built-in surfaces from an approximate placement: cost and realization independence.

Run: ``python benchmarks/bench_tilings.py [--h 3] [--skip-planar]`` — prints a Markdown table, one row per
closure: plates, sleeves, Newton iterations, factorizations, wall seconds, radius of the least-squares
sphere (or cylinder), its RMS deviation, the mesh deviation (the closed shape against its placement),
peak strain; then the pairs that must close to the same shape, compared after the best rigid fit of
their plate centroids (RMS and largest distance between matching plates' centroids, mm, and the RMS of
every node's distance to the other closure's nearest node).

* GP(1, 1) placed at its best fit against the truncated icosahedron built exactly (the same
  combinatorics; plates matched by nearest centroid);
* GP(2, 0) from its two realizations, the geodesic dual projected to the sphere and the planar-face
  polar reciprocal (the same face order).

Every spec uses the shipped sphere's plates (0x0488 hexagons, 0x0508 pentagons, 1 mm, straight sleeves).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from fabpat.assembly.solve.simulation import simulate_assembly
from fabpat.assembly.spec.load import load_spec, parse_spec

ROOT = Path(__file__).resolve().parents[1]


def spec(kind: str, **keys: object) -> Any:
    data = {"name": kind, "tiling": {"kind": kind, "edge": 36.0, **keys},
            "patterns": {"hexagon": "0x0488"} if kind == "hex-tube" else {"hexagon": "0x0488", "pentagon": "0x0508"},
            "plates": {"thickness": 1.0}, "sleeve": {"angle": "flat"}}
    return parse_spec(data, f"{kind}.toml")


def centroids(sim: Any) -> np.ndarray:
    m, x = sim.model, sim.deformed()
    return np.array([x[m.offsets[i]:m.offsets[i + 1]].mean(axis=0) for i in range(len(m.plates))])


def compare(a: Any, b: Any, match: bool) -> tuple[float, float, float]:
    """(centroid RMS, centroid max, node RMS) mm after the rigid fit of b's plate centroids onto a's."""
    ca, cb = centroids(a), centroids(b)
    if match:  # order b's plates as a's, by nearest centroid after centring and a sphere-radius scale
        _, idx = cKDTree(cb - cb.mean(axis=0)).query(ca - ca.mean(axis=0))
        if len(set(idx.tolist())) != len(idx):
            return float("nan"), float("nan"), float("nan")
        cb = cb[idx]
    A, B = ca - ca.mean(axis=0), cb - cb.mean(axis=0)
    U, _, Vt = np.linalg.svd(B.T @ A)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(Vt.T @ U.T)))])
    R = Vt.T @ D @ U.T
    d = np.linalg.norm(B @ R.T - A, axis=1)
    xb = (b.deformed() - cb.mean(axis=0)) @ R.T + ca.mean(axis=0)
    nn = cKDTree(xb).query(a.deformed())[0]
    return float(np.sqrt(np.mean(d * d))), float(d.max()), float(np.sqrt(np.mean(nn * nn)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--h", type=float, default=3.0, help="mesh edge (mm), default 3 (simulate-assembly's)")
    ap.add_argument("--skip-planar", action="store_true", help="leave out GP(2, 0)'s planar realization (slow)")
    args = ap.parse_args()
    cases = [("truncated icosahedron (exact)", load_spec(ROOT / "assemblies" / "truncated-icosahedron.toml")),
             ("GP(1, 1) dual, best fit", spec("goldberg", m=1, n=1)),
             ("GP(2, 0) dual, best fit", spec("goldberg", m=2, n=0))]
    if not args.skip_planar:
        cases.append(("GP(2, 0) planar, best fit", spec("goldberg", m=2, n=0, realization="planar")))
    cases += [("hex-cap, 2 rings around a pentagon", spec("hex-cap", rings=2)),
              ("hex-tube, 8 around × 3 along", spec("hex-tube", rows=8, columns=3))]
    sims = {}
    print(f"h = {args.h:g} mm\n")
    print("| surface | plates | sleeves | iterations | factorizations | s | radius (mm) | rms deviation (%) | "
          "mesh deviation rms (mm) | peak strain |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, s in cases:
        t0 = time.perf_counter()
        sim = simulate_assembly(s, h=args.h)
        dt = time.perf_counter() - t0
        sims[name] = sim
        f = sim.fields()
        tube = f["cylinder_radius"] is not None
        radius, dev = (f["cylinder_radius"], f["cylindricity_rms"]) if tube else (f["radius"], f["sphericity_rms"])
        print(f"| {name} | {f['plates']} | {f['sleeves']} | {f['iterations']} | {f['factorizations']} | {dt:.1f} | "
              f"{radius:.3f}{' (cylinder)' if tube else ''} | {100 * dev:.3f} | {f['mesh_deviation_rms']:.2f} | "
              f"{f['peak_strain']:.4f} |", flush=True)
    print("\n| pair | centroid rms (mm) | centroid max (mm) | node rms (mm) | energy ratio |")
    print("|---|---:|---:|---:|---:|")
    pairs = [("truncated icosahedron (exact)", "GP(1, 1) dual, best fit", True),
             ("GP(2, 0) dual, best fit", "GP(2, 0) planar, best fit", False)]
    for a, b, match in pairs:
        if a in sims and b in sims:
            rms, mx, nn = compare(sims[a], sims[b], match)
            ratio = sims[b].fields()["energy"] / sims[a].fields()["energy"]
            print(f"| {a} / {b} | {rms:.4f} | {mx:.4f} | {nn:.4f} | {ratio:.5f} |")


if __name__ == "__main__":
    main()
