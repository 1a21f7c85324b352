"""Would a quadratic corotational shell triangle give converged *nonlinear* energies on a coarse mesh?
Prints Markdown.

Run (from the repository root)::

    python benchmarks/study_quadratic_shell.py          # ≈ 10 min of CPU

A prototype, not part of fabpat: it measures what the element is worth before it is built properly.
``study_quadratic.py`` showed, in linear analysis, that quadratic rotations form the narrow bars'
free-edge layers on a 1.5 mm mesh. The catalog is nonlinear (rotations up to 1.4 rad in the Dome),
so here the same quadratic triangle (T6) is made a shell and run through the scenarios as the sweep
runs them:

* **element** (flat, local axes, six freedoms per node u, v, w, θx, θy, θz as fabpat's): quadratic
  membrane (plane stress), the Reissner–Mindlin plate of ``study_quadratic.py`` (shear factor 5/6),
  and the drilling rotation tied to the in-plane rotation ½(v,x − u,y) by a penalty γ = G·t
  (Hughes & Brezzi, CMAME 72 (1989) 105); Dunavant's 6-point rule throughout (with the 3-point rule
  for the penalty, the six nodes' θz keep a zero-energy mode and Newton's first step turns them by 67 rad);
* **kinematics**: fabpat's element-independent corotational frame of the corner triangle
  (:class:`fabpat.shell.corotational.CorotationalTriangles`: normal, in-plane axes from the polar
  decomposition); every node — corners and mid-side nodes — gets deformational translations Eᵀ(x − x_c)
  − X⁰ and rotations log(Eᵀ R E₀); the internal force is the exact gradient of ½ dᵀ K d (the 3-node
  code's formula with six nodes), the tangent its forward difference (36 force evaluations: slow, but
  only the answer is measured here, not the time);
* **solve**: Newton–Raphson on the full load with step halving, residual ≤ 1e-8 of the load, as
  ``fabpat.shell.solve``; loads and supports of :func:`fabpat.simulation.scenarios.build_problem` spread on the
  quadratic sides with the consistent shares 1/6, 2/3, 1/6.

Checks printed first: at a load 1e-3 of the scenario's, the energy / load² equals the linear T6 plate
of ``study_quadratic.py``; the nonlinear T6 energies are then compared with the nonlinear references
of ``study_boundary_layer.py`` (today's triangle on meshes down to h = 0.35 extrapolated, ±0.4 %).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).parent))
from study_boundary_layer import REFERENCE  # noqa: E402
from study_quadratic import RULE6, t6_geometry, t6_scenario, t6_shape, to_t6  # noqa: E402

from fabpat.shell.corotational import CorotationalTriangles  # noqa: E402
from fabpat.shell.element import Material, element_frames  # noqa: E402
from fabpat.shell.rotations import dexp_inv, expmap, logmap  # noqa: E402

Arr = NDArray[np.float64]


def local_stiffness6(xy: Arr, mat: Material) -> Arr:
    """(m, 36, 36) local stiffness of flat 6-node triangles with local node coordinates xy (m, 6, 2)."""
    area, gL = t6_geometry(xy[:, :3, 0], xy[:, :3, 1])
    m = len(xy)
    Dm, Db, Ds = mat.D_membrane, mat.D_bending, mat.D_shear
    gamma = mat.E / (2 * (1 + mat.nu)) * mat.t

    def shape(lam: Arr) -> tuple[Arr, Arr]:
        return t6_shape(lam, gL)

    K = np.zeros((m, 36, 36))
    for lam, wq in zip(*RULE6, strict=True):
        N, dN = shape(lam)
        w = (wq * area)[:, None, None]
        Bm = np.zeros((m, 3, 36))
        Bm[:, 0, 0::6] = dN[..., 0]
        Bm[:, 1, 1::6] = dN[..., 1]
        Bm[:, 2, 0::6] = dN[..., 1]
        Bm[:, 2, 1::6] = dN[..., 0]
        Bb = np.zeros((m, 3, 36))
        Bb[:, 0, 4::6] = dN[..., 0]
        Bb[:, 1, 3::6] = -dN[..., 1]
        Bb[:, 2, 4::6] = dN[..., 1]
        Bb[:, 2, 3::6] = -dN[..., 0]
        Bs = np.zeros((m, 2, 36))
        Bs[:, 0, 2::6] = dN[..., 0]
        Bs[:, 0, 4::6] = N
        Bs[:, 1, 2::6] = dN[..., 1]
        Bs[:, 1, 3::6] = -N
        K += (Bm.transpose(0, 2, 1) @ Dm @ Bm + Bb.transpose(0, 2, 1) @ Db @ Bb
              + Ds * Bs.transpose(0, 2, 1) @ Bs) * w
    for lam, wq in zip(*RULE6, strict=True):  # 6 points: with 3, θz of the 6 nodes has a zero-energy mode
        N, dN = shape(lam)
        Bd = np.zeros((m, 1, 36))  # θz − ½(v,x − u,y)
        Bd[:, 0, 5::6] = N
        Bd[:, 0, 1::6] = -0.5 * dN[..., 0]
        Bd[:, 0, 0::6] = 0.5 * dN[..., 1]
        K += gamma * Bd.transpose(0, 2, 1) @ Bd * (wq * area)[:, None, None]
    return K


class Quadratic:
    """Corotational 6-node triangles: X (n, 3) initial nodes, F6 (m, 6) (corners, then mid-sides 01, 12, 20)."""

    def __init__(self, X: Arr, F6: NDArray[np.int64], mat: Material) -> None:
        self.X, self.F6 = X, F6
        self.tri = CorotationalTriangles(X, F6[:, :3], mat)  # the corner triangle's frame machinery
        E0, _, _ = element_frames(X, F6[:, :3])
        Xc = X[F6[:, :3]].mean(axis=1)
        self.E0 = E0
        self.X0 = np.einsum("mai,mij->maj", X[F6] - Xc[:, None], E0)  # (m, 6, 3) initial local coords (z = 0)
        self.K = local_stiffness6(self.X0[..., :2], mat)
        self.edofs = (6 * F6[:, :, None] + np.arange(6)).reshape(-1, 36)

    def forces(self, xe: Arr, Re: Arr) -> tuple[Arr, Arr]:
        """Element forces (m, 36) in global components and strain energies (m,) at node positions xe
        (m, 6, 3) and rotations Re (m, 6, 3, 3)."""
        _, fr = self.tri.deformational(xe[:, :3], Re[:, :3])
        E = fr["E"]
        Et = E.transpose(0, 2, 1)
        xc = xe[:, :3].mean(axis=1)
        r = xe - xc[:, None]  # (m, 6, 3)
        loc = np.einsum("mai,mij->maj", r, E)
        Rloc = (Et[:, None] @ Re) @ self.E0[:, None]
        th = logmap(Rloc)
        d = np.concatenate([loc - self.X0, th], axis=-1).reshape(-1, 36)
        fl = (self.K @ d[..., None])[..., 0]
        U = 0.5 * np.einsum("mi,mi->m", d, fl)
        f = fl.reshape(-1, 6, 6)
        g = f[..., :3] @ Et  # E f_a (row vectors)
        mg = ((f[..., 3:, None].swapaxes(-1, -2) @ dexp_inv(th))[..., 0, :]) @ Et
        h = -np.cross(r, g).sum(axis=1) - mg.sum(axis=1)  # conjugate to the frame spin
        v, q, n = CorotationalTriangles._spin_parts_static(fr, self.tri.gN)
        fx = g.copy()
        fx[:, :3] -= g.sum(axis=1, keepdims=True) / 3.0  # δr_a = δx_a − mean of the corners' δx
        fx[:, :3] += n[:, None, :] * (v @ h[..., None]) + (n * h).sum(-1)[:, None, None] * q
        return np.concatenate([fx, mg], axis=-1).reshape(-1, 36), U

    def tangents(self, xe: Arr, Re: Arr, f0: Arr, eps: float = 1e-7) -> Arr:
        """(m, 36, 36) forward-difference tangent of :meth:`forces` (spatial spins for rotations)."""
        m = len(xe)
        K = np.empty((m, 36, 36))
        for j in range(36):
            a, k = divmod(j, 6)
            x2, R2 = xe, Re
            if k < 3:
                x2 = xe.copy()
                x2[:, a, k] += eps
            else:
                R2 = Re.copy()
                w = np.zeros(3)
                w[k - 3] = eps
                R2[:, a] = expmap(w) @ Re[:, a]
            K[:, :, j] = (self.forces(x2, R2)[0] - f0) / eps
        return K


def solve(model: Quadratic, fixed: Arr, loads: Arr, rtol: float = 1e-8, max_iter: int = 30) -> tuple[float, int]:
    """Strain energy (N·mm) and Newton iterations of the nonlinear solution at the full load (residual ≤
    ``rtol`` of the load, or the round-off floor of :mod:`fabpat.shell.solve`)."""
    n = len(model.X)
    free = ~fixed.ravel()
    f = loads.ravel()
    fnorm = float(np.linalg.norm(f[free]))
    # the round-off floor of fabpat.shell.solve: ½ ε · L · ‖diag K‖ (internal forces subtract positions of size L)
    diag = np.bincount(model.edofs.ravel(), np.einsum("mii->mi", model.K).ravel(), minlength=6 * n)[free]
    floor = 0.5 * np.finfo(float).eps * float(np.abs(model.X).max()) * float(np.linalg.norm(diag))
    rows = np.repeat(model.edofs, 36, axis=1).ravel()
    cols = np.tile(model.edofs, (1, 36)).ravel()
    x, R = model.X.copy(), np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    lam, dlam, its_total = 0.0, 1.0, 0
    while lam < 1.0 - 1e-12:
        target = min(1.0, lam + dlam)
        xt, Rt = x.copy(), R.copy()
        ok, last = False, np.inf
        for _ in range(max_iter):
            fe, U = model.forces(xt[model.F6], Rt[model.F6])
            r = target * f - np.bincount(model.edofs.ravel(), fe.ravel(), minlength=6 * n)
            res = float(np.linalg.norm(r[free]))
            its_total += 1
            if not np.isfinite(res) or res > 1e6 * fnorm:
                break
            if res <= max(rtol * target * fnorm, floor):
                ok = True
                break
            Ke = model.tangents(xt[model.F6], Rt[model.F6], fe)
            Kg = sp.csc_matrix((Ke.ravel(), (rows, cols)), shape=(6 * n, 6 * n))[free][:, free]
            du = np.zeros(6 * n)
            du[free] = spla.splu(Kg.tocsc()).solve(r[free])
            D = du.reshape(-1, 6)
            rot = float(np.max(np.linalg.norm(D[:, 3:], axis=1)))
            if rot > 0.5:
                D *= 0.5 / rot
            xt = xt + D[:, :3]
            Rt = expmap(D[:, 3:]) @ Rt
            last = res
        if ok:
            x, R, lam = xt, Rt, target
            energy = float(U.sum())
        else:
            dlam *= 0.5
            if dlam < 1 / 256:
                raise RuntimeError(f"no convergence at λ = {lam:.3f} (residual {last:.2e})")
    return energy, its_total


def scenario_problem(mesh: object, scenario: str, scale: float = 1.0) -> tuple[Quadratic, Arr, Arr]:
    """The quadratic model, supports (n, 6) and loads (n, 6) of ``scenario`` on the T6 version of ``mesh``."""
    from fabpat.simulation.scenarios import build_problem

    p = build_problem(mesh, scenario, sides=6)
    V2 = np.asarray(mesh.V)[:, :2]
    V6, F6 = to_t6(V2, np.asarray(mesh.F))
    X = np.column_stack([V6, np.zeros(len(V6))])
    mid = {}
    for tri in F6:
        for (i, j), k in zip(((0, 1), (1, 2), (2, 0)), (3, 4, 5), strict=True):
            mid[frozenset((int(tri[i]), int(tri[j])))] = int(tri[k])
    n = len(X)
    loads, fixed = np.zeros((n, 6)), np.zeros((n, 6), bool)
    for nodes in mesh.interfaces:
        nodes = [int(v) for v in nodes]
        total = p.loads[nodes].sum(axis=0) * scale
        seg = [(a, b, mid[frozenset((a, b))]) for a, b in zip(nodes, nodes[1:], strict=False)]
        length = sum(np.linalg.norm(X[a] - X[b]) for a, b, _ in seg)
        for a, b, c in seg:
            le = np.linalg.norm(X[a] - X[b])
            for node, share in ((a, 1 / 6), (b, 1 / 6), (c, 2 / 3)):
                loads[node] += share * le * total / length
                fixed[node] |= p.fixed[nodes[0]]
    return Quadratic(X, F6, p.material), fixed, loads


def main() -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import enumerate_library
    from fabpat.simulation.mesh import mesh_outline
    from fabpat.simulation.scenarios import SCENARIOS, run_scenario

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--h", type=float, nargs="+", default=[2.0, 1.5, 1.0])
    ap.add_argument("--ids", nargs="+", default=["0x2d08", "0x0488"])
    a = ap.parse_args()
    lib = enumerate_library(6, 2)
    print("## Check: small load (1e-3 of the scenario's), energy / scale² against the linear T6 plate\n")
    fp = fillet_pattern(lib.pattern(a.ids[0]), 0.2)
    mesh = mesh_outline(fp.outline, 2.0, 6, 36.0)
    for sc in SCENARIOS:
        model, fixed, loads = scenario_problem(mesh, sc, 1e-3)
        e, _ = solve(model, fixed, loads)
        lin, _ = t6_scenario(mesh, sc, RULE6)
        print(f"* {a.ids[0]} {sc}, h = 2: shell {e / 1e-6:.6g}, plate {lin:.6g} N·mm ({e / 1e-6 / lin - 1:+.1e})",
              flush=True)
    print("\n## Nonlinear scenarios: energy / reference − 1 (nodes, CPU s)\n")
    print("| pattern, scenario | reference (N·mm) | " + " | ".join(f"T3 h = {h:g}" for h in a.h) + " | "
          + " | ".join(f"T6 h = {h:g}" for h in a.h) + " |")
    print("|---|---|" + "---|" * (2 * len(a.h)))
    for pid in a.ids:
        fp = fillet_pattern(lib.pattern(pid), 0.2)
        meshes = {h: mesh_outline(fp.outline, h, 6, 36.0) for h in a.h}
        for sc in SCENARIOS:
            ref = REFERENCE[pid, sc]
            cells = []
            for h in a.h:
                r = run_scenario(meshes[h], sc, sides=6)
                cells.append(f"{r.energy / ref - 1:+.2%} ({meshes[h].n_nodes}, {r.seconds:.1f})")
            for h in a.h:
                t0 = time.process_time()
                model, fixed, loads = scenario_problem(meshes[h], sc)
                e, _ = solve(model, fixed, loads)
                cells.append(f"{e / ref - 1:+.2%} ({len(model.X)}, {time.process_time() - t0:.0f})")
            print(f"| {pid} {sc} | {ref:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
