"""Does an anisotropic boundary-layer mesh (thin rows along the free edges) cure the h = 1.5 energy deficit?
Prints Markdown.

Run (from the repository root)::

    python benchmarks/study_boundary_layer.py            # ≈ 2.5 min of CPU on one core
    python benchmarks/study_boundary_layer.py --only pilots --repeat 1

The Reissner–Mindlin plate has free-edge layers of width t/√(12κ) ≈ 0.6 mm (t = 2 mm, κ = 5/6) that an
isotropic h = 1.5 mm mesh cannot form (docs/accuracy.md). The candidate mesh, built here and not in
:mod:`fabpat.simulation.mesh` (it did not pay: docs/accuracy.md, "Boundary-layer rows"): every boundary loop, cut to
≤ h as
:func:`fabpat.simulation.mesh.mesh_polygons` cuts it, gets one or more rows of quads split into triangles on its
material side — each node moved along the bisector of its sides' normals (miter offset), the rows thin
across the edge (the row depths, mm) and as long as the boundary pieces along it — and the region inside
the innermost row is meshed by Triangle at h as today, with no Steiner points on that row (``Y``) so the
two parts share its nodes. Interface segments lie on the outer boundary, whose nodes are unchanged, so
their tags and order are those of the uniform mesh.

Sections:

1. ``pilots``: 0x0488 and 0x2d08 in the three nonlinear scenarios (as the sweep runs them), energies
   against the refined references of ``tests/test_convergence.py`` (h = 1.0–0.35 extrapolated with
   p = 1.2), nodes, and CPU seconds (meshing + solve, one process, one BLAS thread, the least of
   ``--repeat`` runs) relative to the uniform h = 1.5 mesh of the same pattern-scenario.
2. ``torsion``: the mechanism on the bars' own shape — a straight bar 60 × 3 mm, t = 2 mm (b = 1.5 t,
   like the lacy bars), clamped at x = 0, torque at x = 60 (linear); twist rate in the middle third
   times G·J, J = b t³/3 · (1 − 0.630 t/b) (Saint-Venant's rectangle as approximated in Roark's
   Formulas' torsion table, within ≈ 1.5 % of the exact J at b = 1.5 t; the same divisor for every
   mesh), on structured meshes of element length dx along the bar and various rows across it, and on
   the Triangle meshes with and without boundary rows.
3. ``element``: the element on the layer's shapes (aspect ratio up to ≈ 17): tip deflection of a
   cantilever strip 100 × 10 × 1 mm against beam theory and the constant-curvature patch energy.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from fabpat.simulation.mesh import (
    AREA_FACTOR,
    FLATTEN_TOL_PER_H,
    ShellMesh,
    _clean_loop,
    _point_inside,
    _signed_area,
    _subdivide,
    tag_segments,
)

#: N·mm, the references of tests/test_convergence.py (uniform meshes h = 1.0–0.35, E∞ − C·h^1.2 fitted)
REFERENCE = {
    ("0x2d08", "cantilever"): 16.667, ("0x2d08", "cylinder"): 15.967, ("0x2d08", "dome"): 172.61,
    ("0x0488", "cantilever"): 21.727, ("0x0488", "cylinder"): 34.570, ("0x0488", "dome"): 430.56,
}

#: (h, row depths) of the meshes compared; () is today's uniform mesh
VARIANTS: list[tuple[float, tuple[float, ...]]] = [
    (1.5, ()), (2.0, ()), (1.0, ()),
    (1.5, (0.3,)), (1.5, (0.5,)), (1.5, (0.8,)), (1.5, (0.3, 0.4)), (1.5, (0.1, 0.15, 0.25, 0.35)), (2.0, (0.5,)),
]


def offset_rows(loop: NDArray[np.float64], depths: Sequence[float]) -> list[NDArray[np.float64]]:
    """Copies of a closed loop moved to its left (material) side by each cumulative depth (mm), each node
    along the bisector of its sides' left normals by depth / cos(half the turn) (miter factor ≤ 2)."""
    t = np.roll(loop, -1, axis=0) - loop
    t /= np.linalg.norm(t, axis=1)[:, None]
    n_out = np.c_[-t[:, 1], t[:, 0]]
    m = n_out + np.roll(n_out, 1, axis=0)
    m /= np.linalg.norm(m, axis=1)[:, None]
    scale = 1.0 / np.clip(np.einsum("ij,ij->i", m, n_out), 0.5, None)
    return [loop + d * scale[:, None] * m for d in np.cumsum(depths)]


def layered_mesh(loops: Sequence[NDArray[np.float64]], h: float, depths: Sequence[float],
                 interfaces: Sequence = (), min_angle: float = 25.0) -> ShellMesh:
    """Boundary rows of the given depths (mm) along every loop, Triangle inside at h (module docstring).

    Raises ValueError if a row folds (a triangle of the strip inverted): a neck or curve too narrow."""
    import triangle

    cleaned = [_clean_loop(raw) for raw in loops]
    strip_V, strip_F, inner, holes = [], [], [], []
    base = 0
    for k, P in enumerate(cleaned):
        if (k == 0) == (_signed_area(P) < 0):
            P = P[::-1]  # outer CCW, holes CW: the material is on the left of every loop
        if k > 0:
            holes.append(_point_inside(P))
        rows = [_subdivide(P, h)]
        rows += offset_rows(rows[0], depths)
        n = rows[0].shape[0]
        i, j = np.arange(n), (np.arange(n) + 1) % n
        X = np.concatenate(rows)
        for r in range(len(rows) - 1):
            a, b, c, d = r * n + i, r * n + j, (r + 1) * n + j, (r + 1) * n + i  # quad a b c d, CCW
            ac = np.linalg.norm(X[c] - X[a], axis=1) <= np.linalg.norm(X[d] - X[b], axis=1)  # shorter diagonal
            T = np.concatenate([np.where(ac[:, None], np.c_[a, b, c], np.c_[a, b, d]),
                                np.where(ac[:, None], np.c_[a, c, d], np.c_[b, c, d])])
            u, v = X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]]
            if np.any(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0] <= 0):
                raise ValueError(f"boundary row {r + 1} of loop {k} folds: a neck or curve is too narrow")
            R, before = len(rows) - 1, sum(q.shape[0] for q in inner)
            strip_F.append(np.where(T < R * n, T + base, -(1 + before + T - R * n)))
        strip_V.append(np.concatenate(rows[:-1]))
        base += strip_V[-1].shape[0]
        inner.append(rows[-1])
    segs, off = [], 0
    for Q in inner:
        q = Q.shape[0]
        segs.append(off + np.stack([np.arange(q), (np.arange(q) + 1) % q], axis=1))
        off += q
    data = {"vertices": np.concatenate(inner), "segments": np.concatenate(segs)}
    if holes:
        data["holes"] = np.array(holes)
    amax = AREA_FACTOR * math.sqrt(3.0) / 4.0 * h * h
    t = triangle.triangulate(data, f"pq{min_angle:g}a{amax:.10g}Y")
    n_strip = base
    V = np.concatenate([*strip_V, t["vertices"]])
    # strip indices ≥ 0 are strip nodes; −(1 + m) is node m of Triangle's output (its first nodes are the rows)
    F = np.concatenate([np.where(f >= 0, f, n_strip - 1 - f) for f in strip_F] + [t["triangles"] + n_strip])
    return ShellMesh(V, F.astype(np.int64), tag_segments(V, interfaces))


def mesh_pattern(outline: object, h: float, depths: Sequence[float]) -> ShellMesh:
    """Today's :func:`fabpat.simulation.mesh.mesh_outline`, or the layered mesh of the same flattened outline."""
    from fabpat.simulation.mesh import mesh_outline

    if not depths:
        return mesh_outline(outline, h, 6, 36.0)
    return layered_mesh(outline.flatten(FLATTEN_TOL_PER_H * h), h, depths, list(outline.polygon.interfaces))


def check_interfaces(outline: object, h: float, m: ShellMesh) -> None:
    """Raise RuntimeError unless m's interface nodes are those of today's mesh at h, in the same order."""
    from fabpat.simulation.mesh import mesh_outline

    ref = mesh_outline(outline, h, 6, 36.0)
    if any(a.shape != b.shape or not np.array_equal(m.V[a], ref.V[b])
           for a, b in zip(m.interfaces, ref.interfaces, strict=True)):
        raise RuntimeError("the layered mesh changed an interface's nodes")


def quality(m: ShellMesh) -> tuple[float, float]:
    """(smallest angle in degrees, largest aspect ratio = longest side² / (2·area))."""
    P = m.V[m.F]
    L = np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2)
    return m.min_angle(), float(np.max(L.max(axis=1) ** 2 / (2.0 * m.areas)))


def pilots(repeat: int = 1) -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.scenarios import SCENARIOS, run_scenario

    print(f"## Pilots (load average {os.getloadavg()[0]:.1f})\n")
    print("| pattern | scenario | mesh | energy (N·mm) | error vs reference | nodes | min angle | max aspect "
          "| CPU s | CPU / uniform h = 1.5 |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for pid in ("0x0488", "0x2d08"):
        outline = fillet_pattern(get_pattern(pid)).outline
        base: dict[str, float] = {}
        for h, depths in VARIANTS:
            name = f"h = {h:g}" + (f", rows {' + '.join(f'{d:g}' for d in depths)} mm" if depths else " uniform")
            try:
                t_mesh = math.inf
                for _ in range(repeat):
                    t0 = time.process_time()
                    mesh = mesh_pattern(outline, h, depths)
                    t_mesh = min(t_mesh, time.process_time() - t0)
            except ValueError as exc:
                print(f"| {pid} | all | {name} | {exc} | | | | | | |")
                continue
            check_interfaces(outline, h, mesh)
            ang, asp = quality(mesh)
            for sc in SCENARIOS:
                cpu = math.inf
                for _ in range(repeat):
                    t0 = time.process_time()
                    e = run_scenario(mesh, sc, sides=6).energy
                    cpu = min(cpu, time.process_time() - t0 + t_mesh)
                base.setdefault(sc, cpu)
                print(f"| {pid} | {sc} | {name} | {e:.3f} | {100 * (e / REFERENCE[pid, sc] - 1):+.2f} % | "
                      f"{mesh.n_nodes} | {ang:.1f}° | {asp:.1f} | {cpu:.2f} | {cpu / base[sc]:.2f} |", flush=True)


def _grid(xs: NDArray, ys: NDArray) -> tuple[NDArray, NDArray]:
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    V = np.c_[X.ravel(), Y.ravel()]
    ny, F = len(ys) - 1, []
    for i in range(len(xs) - 1):
        for j in range(ny):
            a, c = i * (ny + 1) + j, (i + 1) * (ny + 1) + j
            F += [[a, c, c + 1], [a, c + 1, a + 1]] if (i + j) % 2 else [[a, c, a + 1], [c, c + 1, a + 1]]
    return V, np.array(F)


def _tip(V: NDArray, x: float) -> tuple[NDArray, NDArray]:
    """Nodes at x and their tributary-length shares (sum 1)."""
    nodes = np.flatnonzero(np.abs(V[:, 0] - x) < 1e-9)
    s = np.argsort(V[nodes, 1])
    seg = np.diff(V[nodes[s], 1])
    w = np.zeros(nodes.size)
    w[s[:-1]] += seg / 2
    w[s[1:]] += seg / 2
    return nodes, w / w.sum()


def torsion() -> None:
    from fabpat.shell import Material, ShellProblem, solve_linear

    L, b, t, E = 60.0, 3.0, 2.0, 1000.0
    G, J = E / 2.0, b * t**3 / 3.0 * (1.0 - 0.630 * t / b)

    def rate(V: NDArray, F: NDArray) -> float:
        n = len(V)
        fixed = np.zeros((n, 6), bool)
        fixed[V[:, 0] < 1e-9] = True
        tip, w = _tip(V, L)
        loads = np.zeros((n, 6))
        loads[tip, 3] = w
        r = solve_linear(ShellProblem(V, F, Material(E, 0.0, t), fixed, loads))
        mid = (V[:, 0] > L / 3) & (V[:, 0] < 2 * L / 3)
        return float(np.polyfit(V[mid, 0], r.rotation[mid, 0], 1)[0] * G * J)

    print(f"\n## Torsion of a bar {L:g} × {b:g} mm, t = {t:g} mm: twist rate × G·J / T (Saint-Venant)\n")
    across = {"2 rows": np.linspace(0, b, 3), "4 rows": np.linspace(0, b, 5), "12 rows": np.linspace(0, b, 13),
              "10 rows graded 0.1 mm at the edges": np.r_[0, 0.1, 0.25, 0.5, 0.85, 1.5, 2.15, 2.5, 2.75, 2.9, 3]}
    dxs = (1.5, 1.0, 0.5, 0.25)
    print("| structured, across the bar | " + " | ".join(f"dx = {dx:g}" for dx in dxs) + " |")
    print("|---|" + "---|" * len(dxs))
    for name, ys in across.items():
        print(f"| {name} | " + " | ".join(f"{rate(*_grid(np.arange(0, L + 1e-9, dx), ys)):.4f}" for dx in dxs) + " |",
              flush=True)
    rect = [np.array([[0, 0], [L, 0], [L, b], [0, b]], float)]
    print("\n| Triangle mesh | nodes | twist rate × G·J / T |\n|---|---|---|")
    for h, depths in ((1.5, ()), (1.0, ()), (0.5, ()), (0.25, ()), (1.5, (0.5,)), (1.5, (0.3, 0.4)),
                      (1.5, (0.1, 0.15, 0.25, 0.35))):
        from fabpat.simulation.mesh import mesh_polygons

        m = layered_mesh(rect, h, depths) if depths else mesh_polygons(rect, h)
        name = f"h = {h:g}" + (f", rows {' + '.join(f'{d:g}' for d in depths)} mm" if depths else " uniform")
        print(f"| {name} | {m.n_nodes} | {rate(m.V, m.F):.4f} |", flush=True)


def element() -> None:
    from fabpat.shell import Material, ShellProblem, solve_linear
    from fabpat.shell.corotational import CorotationalTriangles

    L, b, t, E = 100.0, 10.0, 1.0, 1e4
    Iy, Iz, GA = b * t**3 / 12, t * b**3 / 12, 5 / 6 * E / 2 * b * t
    print("\n## The element on the layer's shapes: strip 100 × 10 × 1 mm, h = 2.5, "
          "tip deflection / beam theory, constant-curvature patch\n")
    print("| rows | nodes | min angle | max aspect | tip shear | tip moment | in-plane shear (Timoshenko) "
          "| patch energy error |\n|---|---|---|---|---|---|---|---|")
    for depths in ((), (0.5,), (0.3, 0.4), (0.15, 0.25)):
        from fabpat.simulation.mesh import mesh_polygons

        rect = [np.array([[0, 0], [L, 0], [L, b], [0, b]], float)]
        m = layered_mesh(rect, 2.5, depths) if depths else mesh_polygons(rect, 2.5)
        V, F, n = m.V, m.F, m.n_nodes
        fixed = np.zeros((n, 6), bool)
        fixed[V[:, 0] < 1e-9] = True
        tip, w = _tip(V, L)
        out = []
        for dof, comp, ref in ((2, 2, L**3 / (3 * E * Iy)), (4, 2, -(L**2) / (2 * E * Iy)),
                               (1, 1, L**3 / (3 * E * Iz) + L / GA)):
            loads = np.zeros((n, 6))
            loads[tip, dof] = w
            r = solve_linear(ShellProblem(V, F, Material(E, 0.0, t), fixed, loads))
            out.append(f"{r.displacement[tip, comp].mean() / ref:.4f}")
        mat = Material(1000.0, 0.3, 1.0)
        kx, ky, kxy = 2e-3, -1e-3, 1.5e-3
        x, y = V[:, 0], V[:, 1]
        u = np.zeros((n, 6))
        u[:, 2] = -(kx * x**2 + ky * y**2 + kxy * x * y) / 2
        u[:, 4] = kx * x + 0.5 * kxy * y
        u[:, 3] = -(ky * y + 0.5 * kxy * x)
        model = CorotationalTriangles(np.c_[V, np.zeros(n)], F, mat)
        k = np.array([kx, ky, kxy])
        patch = model.energy_split(model.linear_local_dofs(u))[:, 1].sum() / (0.5 * L * b * k @ mat.D_bending @ k) - 1
        ang, asp = quality(m)
        name = " + ".join(f"{d:g}" for d in depths) or "none (uniform)"
        print(f"| {name} | {n} | {ang:.1f}° | {asp:.1f} | {' | '.join(out)} | {patch:.1e} |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", choices=("pilots", "torsion", "element"))
    ap.add_argument("--repeat", type=int, default=3, help="pilots: CPU seconds are the least of this many runs")
    a = ap.parse_args()
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    if a.only in (None, "pilots"):
        pilots(a.repeat)
    if a.only in (None, "torsion"):
        torsion()
    if a.only in (None, "element"):
        element()


if __name__ == "__main__":
    main()
