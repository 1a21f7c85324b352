"""Linear and geometrically nonlinear static analysis of flat triangle shells.

Loads are nodal forces (N) and moments (N·mm) in global axes that keep their direction (no
follower loads; this is also what Abaqus/CalculiX ``*CLOAD`` does). Supports fix global dofs.
The nonlinear solve is load-controlled Newton–Raphson on the proportional load λ·F (λ: 0 → 1) with
the corotational tangent, automatic step growth after easy steps and step halving after a failed
one; a run that cannot reach λ = 1 raises :class:`fabpat.errors.SolverError`.
"""

from __future__ import annotations

import hashlib
import threading
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SolverError
from fabpat.shell.assembly import Assembler, SupportedAssembler
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import Material
from fabpat.shell.linalg import BACKENDS, Pardiso, SuperLUFactorizer, factorizer, superlu
from fabpat.shell.results import ShellResult
from fabpat.shell.rotations import expmap, logmap

Arr = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ShellProblem:
    """A static shell problem.

    X: (n, 3) or (n, 2) node coordinates (mm; 2D means z = 0). F: (m, 3) triangles.
    fixed: (n, 6) bool, constrained global dofs (ux, uy, uz, rx, ry, rz) held at 0.
    loads: (n, 6) nodal forces (N) and moments (N·mm), global axes, fixed directions.
    """

    X: Arr
    F: NDArray[np.int64]
    material: Material
    fixed: NDArray[np.bool_]
    loads: Arr

    def __post_init__(self) -> None:
        X = np.asarray(self.X, dtype=np.float64)
        if X.shape[1] == 2:
            X = np.column_stack([X, np.zeros(X.shape[0])])
        object.__setattr__(self, "X", X)
        object.__setattr__(self, "F", np.asarray(self.F, dtype=np.int64))
        object.__setattr__(self, "fixed", np.asarray(self.fixed, dtype=bool).reshape(-1, 6))
        object.__setattr__(self, "loads", np.asarray(self.loads, dtype=np.float64).reshape(-1, 6))


#: Round-off floor of the residual test, as a multiple of ε·L·‖diag K‖ (ε machine epsilon, L the
#: largest node coordinate, K the linear stiffness on the free dofs). The corotational internal
#: forces subtract positions of size L, so their round-off is about ε·L·K: measured on 0x2d88
#: (Cantilever, E = 1000…2e5 N/mm², t = 0.5…10 mm) Newton stalls at 0.007–0.11 × ε·L·‖diag K‖.
#: Half of it keeps stiff plates converging and stays below 1e-8·‖f‖ for the default PLA plate at
#: full load, so the default results do not change.
ROUNDOFF_FACTOR = 0.5


class _MeshSetup:
    """What problems on one mesh and material share: the corotational model (local stiffness, linear
    element matrices), the all-dofs Assembler and the factorisers (their symbolic analysis)."""

    def __init__(self, p: ShellProblem) -> None:
        self.model = CorotationalTriangles(p.X, p.F, p.material)
        self.full = Assembler(self.model.edofs, np.ones(6 * p.X.shape[0], dtype=bool))
        self.factorizers: dict[str, Pardiso | SuperLUFactorizer] = {}

    def factorizer(self, backend: str) -> Pardiso | SuperLUFactorizer:
        if backend not in self.factorizers:
            self.factorizers[backend] = factorizer(backend)
        return self.factorizers[backend]


#: The last meshes' set-ups (key: node and triangle bytes, material), per thread. A catalog row runs
#: three scenarios on one mesh; their problems differ only in supports and loads, so the element
#: set-up, the assembly pattern and the factoriser's analysis are built once (≈ 130 ms of a 1 s run at
#: 2 k nodes). Per thread because a model keeps scratch arrays for its tangents (dask workers run tasks
#: in threads).
_SETUPS = threading.local()
_SETUPS_KEPT = 2


def _mesh_setup(p: ShellProblem) -> _MeshSetup:
    cache: dict[tuple[bytes, bytes, Material], _MeshSetup] = _SETUPS.__dict__.setdefault("cache", {})
    key = (hashlib.sha1(p.X.tobytes()).digest(), hashlib.sha1(p.F.tobytes()).digest(), p.material)
    entry = cache.pop(key, None)
    if entry is None:
        entry = _MeshSetup(p)
    cache[key] = entry  # most recent last
    while len(cache) > _SETUPS_KEPT:
        del cache[next(iter(cache))]
    return entry


def _supported(ms: _MeshSetup, p: ShellProblem) -> tuple[SupportedAssembler, Arr]:
    """The assembler of p's supports on its mesh set-up and the global load vector (N)."""
    free = ~p.fixed.ravel()
    diag = ms.full.vector(np.einsum("mii->mi", ms.model.linear_element_matrices()))[free]
    scale = float(np.abs(diag).mean()) if diag.size else 1.0
    return SupportedAssembler(ms.full, p.fixed, scale), p.loads.ravel()


def _setup(p: ShellProblem) -> tuple[CorotationalTriangles, SupportedAssembler, Arr]:
    ms = _mesh_setup(p)
    return ms.model, *_supported(ms, p)


def solve_linear(p: ShellProblem) -> ShellResult:
    """Small-displacement solution K u = f. Raises SolverError if K is singular."""
    t0 = time.perf_counter()
    model, asm, f = _setup(p)
    Ke = model.linear_element_matrices()
    K = asm.matrix(Ke)
    t1 = time.perf_counter()
    u = asm.scatter(superlu(K).solve(asm.rhs(f)))
    if not np.all(np.isfinite(u)):
        raise SolverError("linear solve produced non-finite displacements (ill-posed supports?)")
    t2 = time.perf_counter()
    U6 = u.reshape(-1, 6)
    d = model.linear_local_dofs(U6)
    ee = model.energy_split(d)
    fint = asm.vector(np.einsum("mij,mj->mi", Ke, u[model.edofs]))
    react = np.where(p.fixed.ravel(), fint - f, 0.0).reshape(-1, 6)
    return ShellResult(U6[:, :3].copy(), U6[:, 3:].copy(), float(ee.sum()), ee, react, float(0.5 * f @ u),
                       1, 1, 0, True, False,
                       {"assemble": t1 - t0, "solve": t2 - t1, "total": time.perf_counter() - t0})


def solve_nonlinear(
    p: ShellProblem,
    *,
    rtol: float = 1e-8,
    max_iter: int = 25,
    initial_step: float = 1.0,
    min_step: float = 1.0 / 1024,
    max_rotation_step: float = 0.5,
    predictor: bool = False,
    reuse_ratio: float = 0.1,
    linear_solver: str = "auto",
) -> ShellResult:
    """Geometrically nonlinear (corotational) solution under the loads ``p.loads`` at λ = 1.

    Convergence: ‖r_free‖ ≤ max(rtol·‖λ f_free‖, floor) (forces and moments in one norm), where the
    floor is the round-off level of the internal forces, ``ROUNDOFF_FACTOR``·ε·L·‖diag K‖: without it a
    stiff plate (E·t ≳ 1e5 N/mm) asks for a residual below what floating point resolves. A Newton correction whose
    largest nodal rotation exceeds ``max_rotation_step`` (rad) is scaled down (keeps the iteration
    inside the basin where rotations are resolved). The tangent and its LU are reused while the
    residual drops by at least ``reuse_ratio`` per iteration (0 → full Newton).
    A step that fails (no convergence in ``max_iter``, growing residual, still 100× its first residual
    after 10 iterations, or non-finite values) is halved; below ``min_step`` of the load a
    SolverError is raised. Steps double after ≤ 4 iterations. ``linear_solver``: "auto", "pardiso" or
    "superlu" (:func:`fabpat.shell.linalg.factorizer`; the results agree to the Newton tolerance).

    One function: the load stepping, the Newton loop, the step cuts and the error that says what was reached
    share the solver state; its stages are commented in order.
    """
    t0 = time.perf_counter()
    if linear_solver not in BACKENDS:
        factorizer(linear_solver)  # raises, naming the choices
    ms = _mesh_setup(p)  # hashes the mesh: once per solve
    model, (asm, f), fz = ms.model, _supported(ms, p), ms.factorizer(linear_solver)
    free = asm.free
    fnorm = float(np.linalg.norm(f[free]))
    if fnorm == 0.0:
        raise SolverError("no load applied to free dofs")
    n = p.X.shape[0]
    K0e = model.linear_element_matrices()
    diagK = asm.vector(np.einsum("mii->mi", K0e))[free]
    noise = np.finfo(np.float64).eps * float(np.abs(p.X).max()) * float(np.linalg.norm(diagK))
    floor = ROUNDOFF_FACTOR * noise
    x, R = p.X.copy(), np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    lam, dlam = 0.0, float(initial_step)
    its_total, steps, cuts, n_eval = 0, 0, 0, 0
    work, t_tan, t_lu = 0.0, 0.0, 0.0
    n_fact = 0
    fe = d = None
    prev: tuple[Arr, Arr, float] | None = None  # last converged (Δx, spin, Δλ)

    def state(x0: Arr, R0: Arr, D: Arr) -> tuple[Arr, Arr]:
        return x0 + D[:, :3], np.einsum("nij,njk->nik", expmap(D[:, 3:]), R0)

    def residual(xs: Arr, Rs: Arr, target: float) -> tuple[Arr, Arr, Arr]:
        nonlocal n_eval
        n_eval += 1
        fe_, _, d_ = model.element_forces(*model.gather(xs, Rs))
        return target * f - asm.vector(fe_), fe_, d_

    while lam < 1.0 - 1e-12:
        target = min(1.0, lam + dlam)
        x_try, R_try = x.copy(), R.copy()
        step_disp = np.zeros(asm.n_dofs)
        if predictor and prev is not None:  # secant predictor: extrapolate the last converged increment
            s_ = (target - lam) / prev[2]
            x_try += s_ * prev[0]
            R_try = np.einsum("nij,njk->nik", expmap(s_ * prev[1]), R_try)
            step_disp[:] = s_ * np.concatenate([prev[0], prev[1]], axis=1).ravel()
        ok, its, last_res = False, 0, np.inf
        lu = None
        growth = 0
        r, fe, d = residual(x_try, R_try, target)
        for its in range(1, max_iter + 1):  # noqa: B007 (its used after the loop)
            res = float(np.linalg.norm(r[free]))
            if not np.isfinite(res):
                break
            if res <= max(rtol * target * fnorm, floor):
                ok = True
                break
            if its == 1:
                res0 = res
            growth = growth + 1 if res > last_res else 0
            # give up on a step early when it is clearly lost: three rises in a row, a blow-up, or
            # still far above the step's first residual after 10 iterations (Newton then wanders
            # between membrane-stretch spikes; a halved step is cheaper than 15 more tries)
            if growth >= 3 or res > 1e6 * fnorm or (its >= 10 and res > 100.0 * res0):
                break
            # keep the factorization while the residual falls fast (≥ reuse_ratio per iteration):
            # one back-substitution is ~50× cheaper than a new tangent + LU
            reuse = lu is not None and res < reuse_ratio * last_res
            last_res = res
            ta = time.perf_counter()
            if not reuse:  # at the unstressed start the tangent is exactly the linear stiffness
                Ke = K0e if steps == 0 and its == 1 and not predictor else \
                    model.element_tangents(*model.gather(x_try, R_try), d)
                K = asm.matrix(Ke)
            tb = time.perf_counter()
            try:
                if not reuse:
                    lu = fz.factor(K)
                    n_fact += 1
                du = asm.scatter(lu.solve(asm.rhs(r)))
            except SolverError:
                break
            t_tan += tb - ta
            t_lu += time.perf_counter() - tb
            if not np.all(np.isfinite(du)):
                break
            D = du.reshape(-1, 6)
            rot = float(np.max(np.linalg.norm(D[:, 3:], axis=1)))
            if rot > max_rotation_step:
                D *= max_rotation_step / rot
            x_try, R_try = state(x_try, R_try, D)
            r, fe, d = residual(x_try, R_try, target)
            step_disp += D.ravel()
        its_total += its
        if ok:
            work += 0.5 * (lam + target) * float(f @ step_disp)
            spin = logmap(np.einsum("nij,nkj->nik", R_try, R))
            prev = (x_try - x, spin, target - lam)
            x, R, lam = x_try, R_try, target
            steps += 1
            if its <= 4:
                dlam *= 2.0
            elif its >= 10:
                dlam *= 0.5
        else:
            cuts += 1
            dlam *= 0.5
            prev = None  # the extrapolation may be what failed
            if dlam < min_step:
                tol = max(rtol * target * fnorm, floor)
                why = (f"the residual stalled near the round-off level of the internal forces (about "
                       f"{noise:.1e}): the model is ill-conditioned (very stiff or very thin?)"
                       if last_res <= 10.0 * noise else
                       "the structure may buckle or snap, or the loads may be too large for a load-controlled "
                       "analysis")
                raise SolverError(
                    f"Newton–Raphson did not converge: load step fell below {min_step:g} of the load at "
                    f"load fraction λ = {lam:.4f} after {its_total} iterations and {cuts} step cuts (residual "
                    f"{last_res:.3e} vs tolerance {tol:.3e}); {why}")
    assert fe is not None and d is not None
    fint = asm.vector(fe)
    react = np.where(p.fixed.ravel(), fint - f, 0.0).reshape(-1, 6)
    ee = model.energy_split(d)
    seconds = {"tangent": t_tan, "factor_solve": t_lu, "factorizations": float(n_fact),
               "residuals": float(n_eval), "total": time.perf_counter() - t0}
    return ShellResult(x - p.X, logmap(R), float(ee.sum()), ee, react, work, its_total, steps, cuts, True, True,
                       seconds)
