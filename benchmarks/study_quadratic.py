"""Would a quadratic (6-node) plate triangle carry the narrow bars' twist on a coarse mesh? Prints Markdown.

Run (from the repository root)::

    python benchmarks/study_quadratic.py          # ≈ 1 min of CPU

The catalog's energies are low at h = 1.5 mm mainly because bars about as wide as the plate is thick
(b ≈ 1.5 t) twist with Reissner–Mindlin free-edge layers (width t/√(12κ) ≈ 0.6 mm) that the 3-node
DKMT triangle forms only on fine meshes (docs/accuracy.md). This study puts the same bar — 60 × 3 mm,
t = 2 mm, ν = 0, clamped at x = 0, end torque T at x = 60, linear — on two elements over the same
Triangle meshes and compares the twist rate in the middle third times G·J/T (J of Saint-Venant's
rectangle as in ``study_boundary_layer.py``):

* **T3**: fabpat's shell triangle (DKMT bending + shear, :mod:`fabpat.shell.element`);
* **T6**: a textbook quadratic Reissner–Mindlin triangle written here (not part of fabpat): w, θx, θy
  quadratic on the 6 nodes of each triangle (corner nodes of the T3 mesh plus the mid-side nodes),
  bending κ = (θy,x, −θx,y, θy,y − θx,x) and shear γ = (w,x + θy, w,y − θx) with κ = 5/6 (Hughes, The
  Finite Element Method (1987) §5.5), both integrated with Dunavant's 6-point rule (degree 4, exact for
  this stiffness on straight-sided triangles), or the shear with the 3-point rule (degree 2; "reduced").
  At t/h ≈ 1 shear locking — the reason plate elements need MITC/DSG tricks when t ≪ h — is not at
  stake, so the plain element is a fair test of what quadratic fields buy.

Node counts are given because a T6 mesh of size h has about as many nodes as a T3 mesh of h/2: the
question is accuracy per node (and so per unit of solver cost), not per element.
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from fabpat.shell import Material, ShellProblem, solve_linear
from fabpat.simulation.mesh import mesh_polygons
from fabpat.simulation.scenarios import tributary_weights

L_BAR, B_BAR, T_BAR, E_BAR = 60.0, 3.0, 2.0, 1000.0
G_BAR = E_BAR / 2.0  # ν = 0
J_BAR = B_BAR * T_BAR**3 / 3.0 * (1.0 - 0.630 * T_BAR / B_BAR)

# Dunavant's rules on the triangle: (area coordinates (q, 3), weights (q,) summing to 1)
_A, _B = 0.445948490915965, 0.108103018168070
_C, _D = 0.091576213509771, 0.816847572980459
RULE6 = (np.array([[_A, _A, _B], [_A, _B, _A], [_B, _A, _A], [_C, _C, _D], [_C, _D, _C], [_D, _C, _C]]),
         np.array([0.223381589678011] * 3 + [0.109951743655322] * 3))
RULE3 = (np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]), np.full(3, 1 / 3))
_EDGES = ((0, 1), (1, 2), (2, 0))


def to_t6(V: NDArray, F: NDArray) -> tuple[NDArray, NDArray]:
    """Straight-sided 6-node triangles (m, 6): corners of F, then the midpoints of sides 01, 12, 20."""
    e = np.sort(np.concatenate([F[:, [i, j]] for i, j in _EDGES]), axis=1)
    uniq, inv = np.unique(e, axis=0, return_inverse=True)
    mids = 0.5 * (V[uniq[:, 0]] + V[uniq[:, 1]])
    m = len(F)
    return np.vstack([V, mids]), np.column_stack([F, len(V) + inv.reshape(3, m).T])


def t6_geometry(x: NDArray, y: NDArray) -> tuple[NDArray, NDArray]:
    """Areas (m,) and area-coordinate gradients (m, 3, 2) of triangles with corners x, y (m, 3)."""
    A2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    gL = np.stack([np.stack([y[:, 1] - y[:, 2], x[:, 2] - x[:, 1]], -1),
                   np.stack([y[:, 2] - y[:, 0], x[:, 0] - x[:, 2]], -1),
                   np.stack([y[:, 0] - y[:, 1], x[:, 1] - x[:, 0]], -1)], axis=1) / A2[:, None, None]
    return 0.5 * A2, gL


def t6_shape(lam: NDArray, gL: NDArray) -> tuple[NDArray, NDArray]:
    """Quadratic shape functions N (6,) and their gradients (m, 6, 2) at area coordinates lam (3,): corners,
    then the mid-sides 01, 12, 20."""
    N = np.array([lam[0] * (2 * lam[0] - 1), lam[1] * (2 * lam[1] - 1), lam[2] * (2 * lam[2] - 1),
                  4 * lam[0] * lam[1], 4 * lam[1] * lam[2], 4 * lam[2] * lam[0]])
    dN = np.stack([(4 * lam[0] - 1) * gL[:, 0], (4 * lam[1] - 1) * gL[:, 1], (4 * lam[2] - 1) * gL[:, 2],
                   4 * (lam[0] * gL[:, 1] + lam[1] * gL[:, 0]), 4 * (lam[1] * gL[:, 2] + lam[2] * gL[:, 1]),
                   4 * (lam[2] * gL[:, 0] + lam[0] * gL[:, 2])], axis=1)
    return N, dN


def t6_stiffness(V: NDArray, F6: NDArray, mat: Material, shear_rule: tuple[NDArray, NDArray]) -> sp.csr_matrix:
    """Global stiffness on dofs (w, θx, θy) per node of the quadratic Reissner–Mindlin triangles F6 (m, 6)."""
    D = mat.D_bending
    Ds = mat.D_shear
    P = V[F6[:, :3]]
    area, gL = t6_geometry(P[..., 0], P[..., 1])
    m = len(F6)

    def shape(lam: NDArray) -> tuple[NDArray, NDArray]:
        return t6_shape(lam, gL)

    K = np.zeros((m, 18, 18))
    for lam, wq in zip(*RULE6, strict=True):  # bending
        _, dN = shape(lam)
        Bb = np.zeros((m, 3, 18))
        Bb[:, 0, 2::3] = dN[..., 0]  # θy,x
        Bb[:, 1, 1::3] = -dN[..., 1]  # −θx,y
        Bb[:, 2, 2::3] = dN[..., 1]  # θy,y
        Bb[:, 2, 1::3] = -dN[..., 0]  # −θx,x
        K += Bb.transpose(0, 2, 1) @ D @ Bb * (wq * area)[:, None, None]
    for lam, wq in zip(*shear_rule, strict=True):
        N, dN = shape(lam)
        Bs = np.zeros((m, 2, 18))
        Bs[:, 0, 0::3] = dN[..., 0]
        Bs[:, 0, 2::3] = N
        Bs[:, 1, 0::3] = dN[..., 1]
        Bs[:, 1, 1::3] = -N
        K += Bs.transpose(0, 2, 1) @ Bs * (Ds * wq * area)[:, None, None]
    dofs = (3 * F6[:, :, None] + np.arange(3)).reshape(m, 18)
    rows = np.repeat(dofs, 18, axis=1).ravel()
    cols = np.tile(dofs, (1, 18)).ravel()
    n = 3 * len(V)
    return sp.csr_matrix((K.ravel(), (rows, cols)), shape=(n, n))


def t6_twist(V: NDArray, F6: NDArray, shear_rule: tuple[NDArray, NDArray]) -> float:
    """Twist rate × G·J / T of the bar on the quadratic mesh (T = 1 N·mm as a uniform end moment)."""
    mat = Material(E_BAR, 0.0, T_BAR)
    K = t6_stiffness(V, F6, mat, shear_rule)
    n = len(V)
    f = np.zeros(3 * n)
    # consistent loads of a uniform line moment T/b along the end x = L: (1/6, 1/6, 2/3) × side length
    for a, b_, c in ((0, 1, 3), (1, 2, 4), (2, 0, 5)):
        on = (np.abs(V[F6[:, a], 0] - L_BAR) < 1e-9) & (np.abs(V[F6[:, b_], 0] - L_BAR) < 1e-9)
        for e in np.flatnonzero(on):
            le = abs(V[F6[e, a], 1] - V[F6[e, b_], 1])
            for node, share in ((F6[e, a], 1 / 6), (F6[e, b_], 1 / 6), (F6[e, c], 2 / 3)):
                f[3 * node + 1] += share * le / B_BAR
    free = np.ones(3 * n, bool)
    free[(3 * np.flatnonzero(V[:, 0] < 1e-9)[:, None] + np.arange(3)).ravel()] = False
    u = np.zeros(3 * n)
    u[free] = spla.spsolve(K[free][:, free].tocsc(), f[free])
    mid = (V[:, 0] > L_BAR / 3) & (V[:, 0] < 2 * L_BAR / 3)
    return float(np.polyfit(V[mid, 0], u[1::3][mid], 1)[0] * G_BAR * J_BAR)


def t3_twist(V: NDArray, F: NDArray) -> float:
    """The same with fabpat's shell triangle (the torque shared by tributary length, as the study does)."""
    n = len(V)
    fixed = np.zeros((n, 6), bool)
    fixed[V[:, 0] < 1e-9] = True
    tip = np.flatnonzero(np.abs(V[:, 0] - L_BAR) < 1e-9)
    tip = tip[np.argsort(V[tip, 1])]
    loads = np.zeros((n, 6))
    loads[tip, 3] = tributary_weights(V, tip)
    r = solve_linear(ShellProblem(V, F, Material(E_BAR, 0.0, T_BAR), fixed, loads))
    mid = (V[:, 0] > L_BAR / 3) & (V[:, 0] < 2 * L_BAR / 3)
    return float(np.polyfit(V[mid, 0], r.rotation[mid, 0], 1)[0] * G_BAR * J_BAR)


def t6_scenario(mesh: object, scenario: str, shear_rule: tuple[NDArray, NDArray]) -> tuple[float, int]:
    """Linear strain energy (N·mm) and node count of ``scenario`` on the T6 version of a fabpat mesh.

    The loads and supports are those of :func:`fabpat.simulation.scenarios.build_problem` (each interface's
    total force or moment spread uniformly along it; here with the quadratic edges' consistent shares
    1/6, 2/3, 1/6), restricted to the plate dofs: with moments and transverse forces only, the linear
    membrane is unloaded.
    """
    from fabpat.simulation.scenarios import build_problem

    p = build_problem(mesh, scenario, sides=6)
    V2 = np.asarray(mesh.V)[:, :2]
    V6, F6 = to_t6(V2, np.asarray(mesh.F))
    edge_mid = {}
    for tri in F6:
        for (i, j), k in zip(_EDGES, (3, 4, 5), strict=True):
            edge_mid[frozenset((int(tri[i]), int(tri[j])))] = int(tri[k])
    n = len(V6)
    f = np.zeros(3 * n)
    fixed = np.zeros((n, 3), bool)
    for nodes in mesh.interfaces:
        nodes = [int(v) for v in nodes]
        total = p.loads[nodes].sum(axis=0)  # (6,) force and moment on this interface
        seg = [(a, b, edge_mid[frozenset((a, b))]) for a, b in zip(nodes, nodes[1:], strict=False)]
        length = sum(np.linalg.norm(V6[a] - V6[b]) for a, b, _ in seg)
        load = np.array([total[2], total[3], total[4]]) / length  # (fz, mx, my) per mm
        fix = p.fixed[nodes[0]][[2, 3, 4]]  # an interface is supported alike at all its nodes
        for a, b, c in seg:
            le = np.linalg.norm(V6[a] - V6[b])
            for node, share in ((a, 1 / 6), (b, 1 / 6), (c, 2 / 3)):
                f[3 * node:3 * node + 3] += share * le * load
                fixed[node] |= fix
    K = t6_stiffness(V6, F6, Material(1000.0, 0.35, 2.0), shear_rule)
    free = ~fixed.ravel()
    u = np.zeros(3 * n)
    u[free] = spla.spsolve(K[free][:, free].tocsc(), f[free])
    return 0.5 * float(f @ u), n


def pilots(hs3: list[float], hs6: list[float], ids: list[str]) -> None:
    """Linear energies of the lacy pilots: T3 (fabpat) and T6 against the finest T6 mesh."""
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import enumerate_library
    from fabpat.simulation.mesh import mesh_outline
    from fabpat.simulation.scenarios import SCENARIOS, run_scenario

    lib = enumerate_library(6, 2)
    print("\n## Library patterns, linear scenarios: energy / reference − 1 (nodes)\n")
    print(f"Reference: T6 at h = {min(hs6):g} mm (the finest here; the two finest T6 meshes differ by 0.1–0.2 %, "
          "so the reference is about that much low).\n")
    for pid in ids:
        fp = fillet_pattern(lib.pattern(pid), 0.2)
        meshes = {h: mesh_outline(fp.outline, h, 6, 36.0) for h in sorted(set(hs3) | set(hs6), reverse=True)}
        for sc in SCENARIOS:
            t6 = {h: t6_scenario(meshes[h], sc, RULE6) for h in hs6}
            ref = t6[min(hs6)][0]
            t3 = {h: (run_scenario(meshes[h], sc, sides=6, nonlinear=False).energy, meshes[h].n_nodes) for h in hs3}
            cells = [f"T3 h={h:g}: {e / ref - 1:+.2%} ({n})" for h, (e, n) in t3.items()]
            cells += [f"T6 h={h:g}: {e / ref - 1:+.2%} ({n})" for h, (e, n) in t6.items() if h != min(hs6)]
            print(f"* {pid} {sc} (reference {ref:.4g} N·mm): " + "; ".join(cells), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--h", type=float, nargs="+", default=[3.0, 2.0, 1.5, 1.0, 0.75, 0.5, 0.35, 0.25])
    ap.add_argument("--only", choices=("bar", "pilots"))
    a = ap.parse_args()
    if a.only != "bar":
        pilots([1.5, 1.0, 0.7, 0.5, 0.35], [3.0, 2.0, 1.5, 1.0, 0.7, 0.5], ["0x0488", "0x2d08"])
    if a.only == "pilots":
        return
    rect = [np.array([[0, 0], [L_BAR, 0], [L_BAR, B_BAR], [0, B_BAR]], float)]
    print(f"## Bar {L_BAR:g} × {B_BAR:g} mm, t = {T_BAR:g} mm, end torque: twist rate × G·J / T\n")
    print("| Triangle mesh h (mm) | T3 nodes | T3 (fabpat) | T6 nodes | T6 full | T6 reduced shear |")
    print("|---|---|---|---|---|---|")
    for h in a.h:
        m = mesh_polygons(rect, h)
        V6, F6 = to_t6(m.V, m.F)
        print(f"| {h:g} | {m.n_nodes} | {t3_twist(m.V, m.F):.4f} | {len(V6)} | {t6_twist(V6, F6, RULE6):.4f} | "
              f"{t6_twist(V6, F6, RULE3):.4f} |", flush=True)


if __name__ == "__main__":
    main()
