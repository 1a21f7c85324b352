"""Shell solver benchmark: nodes, Newton iterations and seconds per nonlinear scenario. Prints Markdown.

Run: ``python benchmarks/bench_shell.py [h ...] [--repeat N] [--solid] [--holed] [--ccx] [--kratos]``

Default shapes: two real library patterns, filleted and meshed as ``fabpat simulate`` does —
``0x2d88`` (dense) and ``0x0488`` (lacy) — at h = 1.5 mm (the default mesh) unless h values are given.
``--solid``/``--holed`` add the notes' solid hexagon (whole edges as interfaces) and a hexagon with a
hexagonal hole. ``--ccx`` also times CalculiX on the exported deck (NLGEOM for the cantilever, linear
for the moment scenarios, see notes); ``--kratos`` times Kratos' thick corotational triangles on the
same mesh and loads (optional dependency). Seconds are wall-clock (best of ``--repeat`` runs, default
3) with the process CPU seconds beside them: the machine is shared, so the load average is printed
first. Setup (element matrices, sparsity pattern) is included; meshing is not.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from fabpat.patterns.lattice import polygon_vertices
from fabpat.simulation.inp import read_ccx_energy, write_inp
from fabpat.simulation.mesh import ShellMesh, interface_segments, mesh_outline, mesh_polygons, solid_polygon_mesh
from fabpat.simulation.scenarios import SCENARIOS, build_problem, run_scenario

PATTERNS = ("0x2d88", "0x0488")


def library_pattern(pid: str) -> Callable[[float], ShellMesh]:
    """Mesh factory h ↦ mesh of the filleted library pattern ``pid`` (hexagon, edge 36 mm)."""
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    outline = fillet_pattern(get_pattern(pid)).outline
    return lambda h: mesh_outline(outline, h, 6, 36.0)


def holed_hexagon(h: float) -> ShellMesh:
    a = np.radians(np.arange(6) * 60.0)
    hole = np.c_[27.0 * np.cos(a), 27.0 * np.sin(a)][::-1]
    segs = interface_segments(6, 36.0)
    P = polygon_vertices(6, 36.0)
    outer = np.concatenate([np.stack([P[i], *segs[i]]) for i in range(6)])  # interface ends are vertices
    return mesh_polygons([outer, hole], h, interfaces=segs)


def ccx_seconds(mesh: ShellMesh, scenario: str, nonlinear: bool) -> tuple[float, float]:
    with tempfile.TemporaryDirectory() as d:
        write_inp(Path(d) / "j.inp", mesh, scenario, sides=6, nonlinear=nonlinear)
        t = time.perf_counter()
        subprocess.run(["ccx", "-i", "j"], cwd=d, capture_output=True, check=True, timeout=1800)
        return time.perf_counter() - t, read_ccx_energy(Path(d) / "j.dat")


def main(argv: list[str]) -> None:
    use_ccx = "--ccx" in argv and shutil.which("ccx") is not None
    use_kratos = "--kratos" in argv
    repeat, hs = 3, []
    it = iter(argv)
    for a in it:
        if a == "--repeat":
            repeat = int(next(it))
        elif not a.startswith("--"):
            hs.append(float(a))
    hs = hs or [1.5]
    shapes: list[tuple[str, Callable[[float], ShellMesh]]] = [(pid, library_pattern(pid)) for pid in PATTERNS]
    if "--solid" in argv:
        shapes.append(("solid hexagon", lambda h: solid_polygon_mesh(6, 36.0, h)))
    if "--holed" in argv:
        shapes.append(("holed hexagon", holed_hexagon))
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; best of {repeat}")
    head = "| shape | h (mm) | nodes | scenario | energy (N·mm) | Newton its | LU | s | cpu s |"
    sep = "|---|---|---|---|---|---|---|---|---|"
    if use_ccx:
        head, sep = head + " ccx s | ccx energy |", sep + "---|---|"
    if use_kratos:
        head, sep = head + " Kratos s | Kratos energy |", sep + "---|---|"
    print(head)
    print(sep)
    total = 0.0
    for name, make in shapes:
        for h in hs:
            mesh = make(h)
            for sc in SCENARIOS:
                best, cpu = np.inf, np.inf
                for _ in range(repeat):
                    c0 = time.process_time()
                    nl = run_scenario(mesh, sc, sides=6, nonlinear=True)
                    best, cpu = min(best, nl.seconds), min(cpu, time.process_time() - c0)
                total += best
                n_lu = int(nl.result.seconds.get("factorizations", 0))
                row = (f"| {name} | {h:g} | {mesh.n_nodes} | {sc} | {nl.energy:.4f} | {nl.iterations} | {n_lu} | "
                       f"{best:.2f} | {cpu:.2f} |")
                if use_ccx:
                    s, e = ccx_seconds(mesh, sc, nonlinear=(sc == "cantilever"))
                    row += f" {s:.1f} | {e:.4f} |"
                if use_kratos:
                    from fabpat.shell.kratos import solve_kratos

                    t = time.perf_counter()
                    e = solve_kratos(build_problem(mesh, sc, sides=6), steps=20).energy
                    row += f" {time.perf_counter() - t:.1f} | {e:.4f} |"
                print(row, flush=True)
    print(f"\ntotal {total:.2f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
