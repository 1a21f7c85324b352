"""Base tilings mapped onto non-spherical targets and relaxed into flat, nearly regular faces.

Run: ``python benchmarks/bench_remesh.py [--bases ti,gp3,gp4] [--target T …] [--target-weight 10] [--no-fit]``
— prints one Markdown table, a row
per base tiling and target: the truncated icosahedron, GP(3, 0) and GP(4, 0) (edge 36 mm) onto ``sphere``
(the floor: a regular or nearly regular base on its own shape), ``ellipsoid:1,1,1.15``,
``ellipsoid:1.04,1,0.97`` and an egg (a surface of revolution, :func:`egg`, written as OBJ in a temporary
folder and turned by a seeded random rotation). Columns: the largest planarity over the size, the largest
edge deviation and angle deviation (:class:`fabpat.design.remesh.Measures`), the corners' distance from the
target (rms, max, % of the size), then the polyhedral approximation error after the design's best similarity
(:func:`fabpat.design.remesh.approximation_error`: the corners, and the points of the planar faces), the
steps and the seconds of the relaxation. ``--no-fit`` leaves out the similarity fits (the egg's ICP takes
half a minute to a minute each); ``--target-weight`` sets :class:`fabpat.design.remesh.Weights`' ``target``
(the trade-off between regular faces and corners on the target), ``--target`` (repeated) a subset.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fabpat.assembly.surface.polyhedra import goldberg
from fabpat.assembly.surface.tiling import truncated_icosahedron
from fabpat.design.remesh import TARGET_WEIGHT, Weights, approximation_error, map_tiling, relax
from fabpat.design.remesh_target import place_target

TARGETS = ("sphere", "ellipsoid:1,1,1.15", "ellipsoid:1.04,1,0.97", "egg")


def egg(path: Path, rings: int = 40, segments: int = 80, seed: int = 0) -> Path:
    """An egg as an OBJ file: the surface of revolution at polar angle θ of height z = −1.25 cos θ and radius
    ρ = sin θ (1 − 0.12 cos θ) (blunt end up, 1.25 : 1), ``rings`` rings of ``segments`` vertices, turned by
    the seeded random rotation and moved off the origin (so that no axis is given away)."""
    th = np.linspace(0.0, math.pi, rings + 1)[1:-1]
    ph = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    rings_xyz = [(r * math.cos(p), r * math.sin(p), -1.25 * math.cos(t))
                 for t, r in zip(th, np.sin(th) * (1.0 - 0.12 * np.cos(th)), strict=True) for p in ph]
    V = np.array([(0.0, 0.0, -1.25), *rings_xyz, (0.0, 0.0, 1.25)])
    V = V @ Rotation.random(random_state=seed).as_matrix().T + np.array([0.3, -0.2, 0.1])
    n, top = segments, len(V) - 1
    F = [(0, 1 + (j + 1) % n, 1 + j) for j in range(n)]
    for i in range(rings - 2):
        a, b = 1 + i * n, 1 + (i + 1) * n
        for j in range(n):
            F += [(a + j, a + (j + 1) % n, b + (j + 1) % n), (a + j, b + (j + 1) % n, b + j)]
    a = 1 + (rings - 2) * n
    F += [(a + j, a + (j + 1) % n, top) for j in range(n)]
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V.tolist())
                    + "".join(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in F), encoding="utf-8")
    return path


def bases(names: list[str]) -> list[tuple[str, np.ndarray, tuple[tuple[int, ...], ...]]]:
    out = []
    for name in names:
        if name == "ti":
            t = truncated_icosahedron(36.0)
            out.append(("truncated icosahedron", t.V, t.faces))
        else:
            m = int(name.removeprefix("gp"))
            V, F = goldberg(m, 0)
            out.append((f"GP({m}, 0)", V * 36.0, F))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bases", default="ti,gp3,gp4")
    ap.add_argument("--target", action="append", help="one target (repeat the option); default all four")
    ap.add_argument("--target-weight", type=float, default=TARGET_WEIGHT)
    ap.add_argument("--no-fit", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        egg_path = str(egg(Path(d) / "egg.obj"))
        print("| base | target | faces | planarity / size | edge dev | angle dev ° | dist rms % | dist max % | "
              "corners (fit) % | face points (fit) % | steps | s |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for name, V, F in bases(args.bases.split(",")):
            for target in args.target or TARGETS:
                t = egg_path if target == "egg" else target
                surface, _ = place_target(V, F, t)
                start = time.perf_counter()
                r = relax(map_tiling(V, F, t), F, surface, weights=Weights(target=args.target_weight))
                seconds = time.perf_counter() - start  # the mapping and the relaxation
                m = r.measures
                fits = ("–", "–") if args.no_fit else (f"{100 * approximation_error(r.V, F, t, corners=True):.3f}",
                                                      f"{100 * approximation_error(r.V, F, t):.3f}")
                print(f"| {name} | {target} | {len(F)} | {m.planarity.max() / m.size:.1e} | "
                      f"{m.edge_deviation.max():.2%} | {math.degrees(float(m.angle_deviation.max())):.2f} | "
                      f"{100 * m.distance_rms:.3f} | {100 * m.distance_max:.3f} | {fits[0]} | {fits[1]} | "
                      f"{r.iterations} | {seconds:.2f} |", flush=True)


if __name__ == "__main__":
    main()
