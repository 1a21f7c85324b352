"""Shell solver benchmark: nodes, Newton iterations and seconds per nonlinear scenario, and the mesh
convergence of the energy. Prints Markdown tables. Run: ``python benchmarks/bench_shell.py [h ...]``.

Shapes: the notes' solid hexagon (whole edges as interfaces) and a hexagon with a hexagonal hole that
leaves 3.2 mm necks at the corners and real 3.75 mm interface segments (a pattern-like stand-in until
the library outlines are meshed here). Options: ``--ccx`` also times CalculiX on the exported deck
(NLGEOM for the cantilever, linear for the moment scenarios, see notes); ``--holed``: holed hexagon only.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fabpat.exchange.inp import read_ccx_energy, write_inp
from fabpat.lattice import polygon_vertices
from fabpat.mesh import interface_segments, mesh_polygons, solid_polygon_mesh
from fabpat.scenarios import SCENARIOS, run_scenario


def holed_hexagon(h: float):
    a = np.radians(np.arange(6) * 60.0)
    hole = np.c_[27.0 * np.cos(a), 27.0 * np.sin(a)][::-1]
    segs = interface_segments(6, 36.0)
    P = polygon_vertices(6, 36.0)
    outer = np.concatenate([np.stack([P[i], *segs[i]]) for i in range(6)])  # interface ends are vertices
    return mesh_polygons([outer, hole], h, interfaces=segs)


def ccx_seconds(mesh, scenario: str, nonlinear: bool) -> tuple[float, float]:
    with tempfile.TemporaryDirectory() as d:
        write_inp(Path(d) / "j.inp", mesh, scenario, sides=6, nonlinear=nonlinear)
        t = time.perf_counter()
        subprocess.run(["ccx", "-i", "j"], cwd=d, capture_output=True, check=True, timeout=1800)
        return time.perf_counter() - t, read_ccx_energy(Path(d) / "j.dat")


def main(argv: list[str]) -> None:
    use_ccx = "--ccx" in argv and shutil.which("ccx") is not None
    hs = [float(a) for a in argv if not a.startswith("--")] or [1.5]
    shapes = [("solid hexagon", lambda h: solid_polygon_mesh(6, 36.0, h)), ("holed hexagon", holed_hexagon)]
    if "--holed" in argv:
        shapes = shapes[1:]
    print("| shape | h (mm) | nodes | scenario | energy linear | energy nonlinear (N·mm) | Newton its | "
          "s nonlinear |" + (" ccx s | ccx energy |" if use_ccx else ""))
    print("|---|---|---|---|---|---|---|---|" + ("---|---|" if use_ccx else ""))
    for name, make in shapes:
        for h in hs:
            mesh = make(h)
            for sc in SCENARIOS:
                lin = run_scenario(mesh, sc, sides=6, nonlinear=False)
                nl = run_scenario(mesh, sc, sides=6, nonlinear=True)
                row = (f"| {name} | {h:g} | {mesh.n_nodes} | {sc} | {lin.energy:.4f} | {nl.energy:.4f} | "
                       f"{nl.iterations} | {nl.seconds:.2f} |")
                if use_ccx:
                    s, e = ccx_seconds(mesh, sc, nonlinear=(sc == "cantilever"))
                    row += f" {s:.1f} | {e:.4f} |"
                print(row, flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
