"""Why does the nonlinear Dome of the lacy pattern 0x0488 differ between fabpat and Kratos? Prints Markdown.

Run (from the repository root, Kratos installed)::

    .venv/bin/python benchmarks/study_kratos_dome.py            # everything, ≈ 10 min on 2 shared cores
    .venv/bin/python benchmarks/study_kratos_dome.py --quick    # h = 2, 1 only, no thin-shell sweep, ≈ 3 min
    .venv/bin/python benchmarks/study_kratos_dome.py --h 2 1 0.5 --no-thin

Sections (each a Markdown table):

1. In-plane cantilever strip 30 × 3 × 2 mm (E = 1000, ν = 0.35), structured triangles, 1–6 elements
   across the width, LINEAR tip shear, tip deflection / Timoshenko beam theory: fabpat (OPT membrane),
   Kratos ``ShellThickElementCorotational3D3N`` (the cross-check's element) and Kratos
   ``ShellThinElementCorotational3D3N``.
2. The same strip, geometrically NONLINEAR in-plane tip load (deflection ≈ 0.3 L), against a fine mesh.
3. Dome on 0x0488 at h = 2: energy, external work, membrane/bending/shear split, max displacement and
   rotation, field differences, for fabpat and both Kratos elements.
4. Mesh convergence of the nonlinear Dome (fabpat, Kratos thick, Kratos thin), fabpat and Kratos
   linear, three-point Richardson extrapolation on the three finest meshes.
5. Load-step sensitivity of Kratos and energy / λ² along the load path (both codes), with the smallest
   eigenvalues of fabpat's tangent at each λ (a sign change would reveal a bifurcation).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.sparse.linalg as spla

from fabpat.shell import ShellProblem, solve_linear
from fabpat.shell.assembly import Assembler
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import Material
from fabpat.shell.kratos import THICK, THIN, solve_kratos
from fabpat.shell.rotations import expmap
from fabpat.shell.solve import solve_nonlinear
from fabpat.simulation.scenarios import build_problem

E, NU, T = 1000.0, 0.35, 2.0
LIN_SCALE = 1e-4  # Kratos has no linear solver here: a tiny load, energy scaled by λ⁻²


def lacy_mesh(h: float):  # noqa: ANN201 (ShellMesh)
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import mesh_outline

    return mesh_outline(fillet_pattern(get_pattern("0x0488")).outline, h, 6, 36.0)


def scaled(p: ShellProblem, s: float) -> ShellProblem:
    return ShellProblem(p.X, p.F, p.material, p.fixed, s * p.loads)


def kratos_linear(p: ShellProblem, element: str = THICK) -> float:
    return solve_kratos(scaled(p, LIN_SCALE), steps=2, element=element).energy / LIN_SCALE**2


def timed(fn, *a, **kw):  # noqa: ANN001, ANN002, ANN003, ANN201
    t0 = time.perf_counter()
    r = fn(*a, **kw)
    return r, time.perf_counter() - t0


# ---------------------------------------------------------------------------------------------- strip
def strip_problem(ny: int, P: float, L: float = 30.0, b: float = 3.0) -> tuple[ShellProblem, np.ndarray]:
    """Clamped-free strip [0, L] × [0, b], nx = 10 ny, alternating diagonals; in-plane tip shear P (N)
    spread by tributary length over the tip nodes. Returns the problem and the tip node ids."""
    nx = 10 * ny
    xs, ys = np.linspace(0.0, L, nx + 1), np.linspace(0.0, b, ny + 1)
    X = np.array([[x, y, 0.0] for x in xs for y in ys])
    F = []
    for i in range(nx):
        for j in range(ny):
            a, c = i * (ny + 1) + j, (i + 1) * (ny + 1) + j
            if (i + j) % 2 == 0:
                F += [[a, c, c + 1], [a, c + 1, a + 1]]
            else:
                F += [[a, c, a + 1], [c, c + 1, a + 1]]
    n = X.shape[0]
    fixed = np.zeros((n, 6), dtype=bool)
    fixed[X[:, 0] < 1e-9] = True
    tip = np.flatnonzero(X[:, 0] > L - 1e-9)
    tip = tip[np.argsort(X[tip, 1])]
    w = np.zeros(tip.size)
    seg = np.diff(X[tip, 1])
    w[:-1] += seg / 2
    w[1:] += seg / 2
    loads = np.zeros((n, 6))
    loads[tip, 1] = P * w / w.sum()
    return ShellProblem(X, np.array(F), Material(E, NU, T), fixed, loads), tip


def timoshenko(P: float, L: float = 30.0, b: float = 3.0) -> float:
    inertia, G = T * b**3 / 12, E / (2 * (1 + NU))
    return P * L**3 / (3 * E * inertia) + P * L / (5 / 6 * G * b * T)


def section_strip_linear() -> None:
    print("## 1. In-plane cantilever strip 30 × 3 × 2, linear tip shear: tip v / Timoshenko\n")
    ref = timoshenko(1.0)
    print(f"Timoshenko (κ = 5/6): v = {ref:.4f} mm per N.\n")
    print("| elements across | elements | fabpat (OPT) | Kratos thick 3N | Kratos thin 3N |")
    print("|---|---|---|---|---|")
    for ny in (1, 2, 3, 4, 6):
        p, tip = strip_problem(ny, 1.0)
        v = solve_linear(p).displacement[tip, 1].mean()
        vk = [solve_kratos(scaled(p, LIN_SCALE), steps=2, element=el).displacement[tip, 1].mean() / LIN_SCALE
              for el in (THICK, THIN)]
        print(f"| {ny} | {p.F.shape[0]} | {v / ref:.4f} | {vk[0] / ref:.4f} | {vk[1] / ref:.4f} |")
    print()


def section_strip_nonlinear() -> None:
    P = 5.0
    print(f"## 2. Same strip, geometrically nonlinear in-plane tip load P = {P} N (follows no rotation)\n")
    pf, tipf = strip_problem(8, P)
    rf = solve_nonlinear(pf)
    vref = rf.displacement[tipf, 1].mean()
    uref = rf.displacement[tipf, 0].mean()
    print(f"Reference: fabpat, 8 elements across: tip v = {vref:.4f}, u = {uref:.4f} mm, "
          f"energy {rf.energy:.4f} N·mm (linear Timoshenko v = {timoshenko(P):.3f}).\n")
    print("| elements across | fabpat v / ref | Kratos thick v / ref | Kratos thin v / ref |")
    print("|---|---|---|---|")
    for ny in (2, 3, 8):
        p, tip = strip_problem(ny, P)
        v = solve_nonlinear(p).displacement[tip, 1].mean()
        vk = [solve_kratos(p, steps=10, element=el).displacement[tip, 1].mean() for el in (THICK, THIN)]
        print(f"| {ny} | {v / vref:.4f} | {vk[0] / vref:.4f} | {vk[1] / vref:.4f} |")
    print()


# ----------------------------------------------------------------------------------------------- dome
def section_dome_h2() -> None:
    print("## 3. Dome on 0x0488, h = 2 mm, nonlinear (Kratos: 20 equal load steps)\n")
    m = lacy_mesh(2.0)
    p = build_problem(m, "dome", sides=6)
    lin = solve_linear(p)
    r, tf = timed(solve_nonlinear, p)
    r64, _ = timed(solve_nonlinear, p, initial_step=1 / 64)
    split = r.element_energy.sum(axis=0)
    print(f"{m.n_nodes} nodes, {m.n_elements} triangles. fabpat linear energy {lin.energy:.2f} N·mm, "
          f"linear Kratos thick {kratos_linear(p):.2f}, linear Kratos thin {kratos_linear(p, THIN):.2f}.\n")
    print(f"fabpat nonlinear: strain energy {r.energy:.3f}, trapezoid work of the loads over its own steps "
          f"{r.external_work:.3f} ({r.steps} step(s)); started at λ = 1/64: energy {r64.energy:.3f}, "
          f"work {r64.external_work:.3f} ({r64.steps} steps). Split membrane / bending / shear: "
          f"{split[0]:.1f} / {split[1]:.1f} / {split[2]:.1f}.\n")
    rows = [("fabpat (OPT + DKMT)", r.energy, r.displacement, r.rotation, tf)]
    for name, el in (("Kratos thick 3N", THICK), ("Kratos thin 3N", THIN)):
        k, tk = timed(solve_kratos, p, steps=20, element=el)
        rows.append((name, k.energy, k.displacement, k.rotation, tk))
    umax = np.linalg.norm(r.displacement, axis=1).max()
    print("| solver | energy (N·mm) | max |u| (mm) | max |θ| (rad, deg) | max |u − u_fabpat| / max |u_fabpat| "
          "| RMS | s |")
    print("|---|---|---|---|---|---|---|")
    for name, en, u, th, sec in rows:
        du = np.linalg.norm(u - r.displacement, axis=1)
        thm = np.linalg.norm(th, axis=1).max()
        print(f"| {name} | {en:.2f} | {np.linalg.norm(u, axis=1).max():.3f} | {thm:.3f} ({np.degrees(thm):.0f}°) "
              f"| {du.max() / umax:.3f} | {np.sqrt(np.mean(du**2)) / umax:.3f} | {sec:.1f} |")
    print("\n(Kratos' θ is its accumulated ROTATION variable, fabpat's the log of the nodal rotation.)\n")


def richardson(hs: list[float], es: list[float]) -> tuple[float, float] | None:
    """E(h) = E∞ + C h^p through the last three points (p by bisection); None if not monotone."""
    if len(hs) < 3:
        return None
    (h1, h2, h3), (e1, e2, e3) = hs[-3:], es[-3:]
    d12, d23 = e1 - e2, e2 - e3
    if d12 == 0 or d23 == 0 or d12 * d23 < 0:
        return None
    ratio = d12 / d23

    def g(p: float) -> float:
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio

    lo, hi = 0.05, 8.0
    if g(lo) * g(hi) > 0:
        return None
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if g(lo) * g(mid) > 0 else (lo, mid)
    p = 0.5 * (lo + hi)
    C = d23 / (h2**p - h3**p)
    return e3 - C * h3**p, p


def section_convergence(hs: list[float], thin: bool, thin_min_h: float) -> None:
    print("## 4. Mesh convergence, Dome on 0x0488 (energies in N·mm; Kratos 20 load steps)\n")
    print("| h | nodes | fabpat linear | Kratos thick linear | fabpat NL | max u | s | Kratos thick NL | max u | s "
          "| Kratos thin NL | max u | s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    cols: dict[str, list[tuple[float, float]]] = {"fl": [], "kl": [], "fn": [], "kn": [], "tn": [], "tl": []}
    for h in hs:
        m = lacy_mesh(h)
        p = build_problem(m, "dome", sides=6)
        el = solve_linear(p).energy
        kl = kratos_linear(p)
        r, tf = timed(solve_nonlinear, p)
        k, tk = timed(solve_kratos, p, steps=20)
        cols["fl"].append((h, el))
        cols["kl"].append((h, kl))
        cols["fn"].append((h, r.energy))
        cols["kn"].append((h, k.energy))
        line = (f"| {h} | {m.n_nodes} | {el:.2f} | {kl:.2f} | {r.energy:.2f} | {r.max_displacement:.2f} | {tf:.1f} "
                f"| {k.energy:.2f} | {np.linalg.norm(k.displacement, axis=1).max():.2f} | {tk:.1f} ")
        if thin and h >= thin_min_h:
            t, tt = timed(solve_kratos, p, steps=20, element=THIN)
            cols["tn"].append((h, t.energy))
            cols["tl"].append((h, kratos_linear(p, THIN)))
            line += f"| {t.energy:.2f} | {np.linalg.norm(t.displacement, axis=1).max():.2f} | {tt:.1f} |"
        else:
            line += "| – | – | – |"
        print(line, flush=True)
    print("\nRichardson (three finest meshes, E(h) = E∞ + C hᵖ):\n")
    print("| series | E∞ | observed order p |")
    print("|---|---|---|")
    names = {"fl": "fabpat linear", "kl": "Kratos thick linear", "fn": "fabpat NL", "kn": "Kratos thick NL",
             "tn": "Kratos thin NL", "tl": "Kratos thin linear"}
    for key, name in names.items():
        pts = cols[key]
        ext = richardson([a for a, _ in pts], [b for _, b in pts])
        print(f"| {name} | {'n/a' if ext is None else f'{ext[0]:.2f}'} | "
              f"{'n/a (non-monotone or < 3 meshes)' if ext is None else f'{ext[1]:.2f}'} |")
    print("\nNonlinear / linear energy of the same element on the same mesh (cancels the Kirchhoff-vs-"
          "Mindlin bending difference, which is a linear effect):\n")
    print("| h | fabpat | Kratos thick | Kratos thin |")
    print("|---|---|---|---|")
    thin_nl, thin_lin = dict(cols["tn"]), dict(cols["tl"])
    for (h, fl), (_, kl), (_, fn), (_, kn) in zip(cols["fl"], cols["kl"], cols["fn"], cols["kn"], strict=True):
        tr = f"{thin_nl[h] / thin_lin[h]:.3f}" if h in thin_nl else "–"
        print(f"| {h} | {fn / fl:.3f} | {kn / kl:.3f} | {tr} |")
    print()


def smallest_eigs(p: ShellProblem, u: np.ndarray, rot: np.ndarray, k: int = 3) -> np.ndarray:
    """Smallest-magnitude eigenvalues (real parts) of fabpat's tangent at the state (u, rot)."""
    model = CorotationalTriangles(p.X, p.F, p.material)
    asm = Assembler(model.edofs, ~p.fixed.ravel())
    xe, Re = model.gather(p.X + u, expmap(rot))
    _, _, d = model.element_forces(xe, Re)
    K = asm.matrix(model.element_tangents(xe, Re, d))
    vals = spla.eigs(K.tocsc(), k=k, sigma=0.0, return_eigenvectors=False)
    return np.sort(vals.real)


def section_path() -> None:
    print("## 5. Load path and load steps, Dome on 0x0488, h = 2\n")
    p = build_problem(lacy_mesh(2.0), "dome", sides=6)
    print("Kratos thick, number of equal load steps:\n")
    print("| steps | energy | max u |")
    print("|---|---|---|")
    for st in (4, 10, 20, 40):
        k = solve_kratos(p, steps=st)
        print(f"| {st} | {k.energy:.3f} | {np.linalg.norm(k.displacement, axis=1).max():.3f} |")
    lin0 = smallest_eigs(p, np.zeros_like(p.X), np.zeros_like(p.X))
    print(f"\nEnergy / λ² along the path (linear would be constant); fabpat tangent's smallest eigenvalues "
          f"(λ = 0: {', '.join(f'{v:.4g}' for v in lin0)}):\n")
    print("| λ | fabpat E/λ² | Kratos thick E/λ² | Kratos thin E/λ² | fabpat max u | Kratos thick max u "
          "| fabpat smallest tangent eigenvalues |")
    print("|---|---|---|---|---|---|---|")
    for lam in (0.25, 0.5, 0.75, 1.0):
        q = scaled(p, lam)
        r = solve_nonlinear(q)
        st = max(4, 2 * round(10 * lam))
        k = solve_kratos(q, steps=st)
        t = solve_kratos(q, steps=st, element=THIN)
        ev = smallest_eigs(q, r.displacement, r.rotation)
        print(f"| {lam} | {r.energy / lam**2:.2f} | {k.energy / lam**2:.2f} | {t.energy / lam**2:.2f} "
              f"| {r.max_displacement:.2f} | {np.linalg.norm(k.displacement, axis=1).max():.2f} "
              f"| {', '.join(f'{v:.4g}' for v in ev)} |", flush=True)
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--h", type=float, nargs="+", default=[2.0, 1.5, 1.0, 0.75, 0.5])
    ap.add_argument("--quick", action="store_true", help="h = 2, 1; no thin-shell sweep")
    ap.add_argument("--no-thin", action="store_true", help="skip Kratos thin shells in the h sweep")
    ap.add_argument("--thin-min-h", type=float, default=0.75, help="thin shells only for h ≥ this (slow)")
    a = ap.parse_args()
    hs = [2.0, 1.0] if a.quick else sorted(a.h, reverse=True)
    t0 = time.perf_counter()
    section_strip_linear()
    section_strip_nonlinear()
    section_dome_h2()
    section_convergence(hs, thin=not (a.no_thin or a.quick), thin_min_h=a.thin_min_h)
    section_path()
    print(f"_Total {time.perf_counter() - t0:.0f} s._")


if __name__ == "__main__":
    main()
