"""Linear and geometrically nonlinear static analysis of flat triangle shells.

Loads are nodal forces (N) and moments (N·mm) in global axes that keep their direction (no
follower loads; this is also what Abaqus/CalculiX ``*CLOAD`` does). Supports fix global dofs.
The nonlinear solve is load-controlled Newton–Raphson on the proportional load λ·F (λ: 0 → 1) with
the corotational tangent, automatic step growth after easy steps and step halving after a failed
one; a run that cannot reach λ = 1 raises :class:`fabpat.errors.SolverError`. Each load step is one
run of the engine's Newton iteration (:func:`fabpat.shell.newton.iterate`), as the increments of
:func:`fabpat.shell.linked.solve_path` are.
"""

from __future__ import annotations

import hashlib
import threading
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from fabpat.errors import SolverError
from fabpat.shell.assembly import Assembler, SupportedAssembler
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import Material
from fabpat.shell.linalg import BACKENDS, Pardiso, SuperLUFactorizer, factorizer, superlu
from fabpat.shell.newton import Convergence, Residual, Rules, iterate, roundoff_noise
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


class _LoadStep:
    """One load step of :func:`solve_nonlinear` as a :class:`fabpat.shell.newton.NewtonSystem`: the
    residual λ f − f_int(x, R) over the free dofs, the corotational tangent (the linear stiffness at the
    unstressed start) with the supports as unit rows, and the step's displacement for the external work."""

    def __init__(self, model: CorotationalTriangles, asm: SupportedAssembler, f: Arr, fnorm: float, K0e: Arr) -> None:
        self.model, self.asm, self.f, self.fnorm, self.K0e = model, asm, f, fnorm, K0e
        self.dofs, self.n_dofs = asm.order, asm.n_dofs
        self.target, self.unstressed = 0.0, False
        self.step = np.zeros(asm.n_dofs)
        self.evaluations = self.factorizations = 0
        self.r = self.fe = self.d = np.zeros(0)

    def start(self, target: float, unstressed: bool) -> None:
        """Aim at λ = target; ``unstressed``: the first iterate is the unloaded plate."""
        self.target, self.unstressed = target, unstressed
        self.step = np.zeros(self.asm.n_dofs)

    def evaluate(self, x: Arr, R: Arr) -> Residual:
        self.evaluations += 1
        self.fe, _, self.d = self.model.element_forces(*self.model.gather(x, R))
        self.r = self.target * self.f - self.asm.vector(self.fe)
        return Residual(float(np.linalg.norm(self.r[self.asm.free])), self.target * self.fnorm)

    def tangent(self, x: Arr, R: Arr, iteration: int) -> sp.csc_matrix:
        # at the unstressed start the tangent is exactly the linear stiffness
        Ke = self.K0e if self.unstressed and iteration == 1 else \
            self.model.element_tangents(*self.model.gather(x, R), self.d)
        return self.asm.matrix(Ke)

    def rhs(self) -> Arr:
        return self.asm.rhs(self.r)

    def factored(self, iteration: int) -> None:
        self.factorizations += 1

    def place(self, x: Arr, R: Arr, D: Arr) -> tuple[Arr, Arr]:
        self.step += D.ravel()
        return x, R


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

    Each load step is a Newton iteration of :func:`fabpat.shell.newton.iterate` (the one the assembly
    solver runs too). Convergence: ‖r_free‖ ≤ max(rtol·‖λ f_free‖, floor) (forces and moments in one
    norm), where the floor is the round-off level of the internal forces,
    ``ROUNDOFF_FACTOR``·ε·L·‖diag K‖ (:class:`fabpat.shell.newton.Convergence`). A Newton correction whose
    largest nodal rotation exceeds ``max_rotation_step`` (rad) is scaled down (keeps the iteration
    inside the basin where rotations are resolved). The tangent and its LU are reused while the
    residual drops by at least ``reuse_ratio`` per iteration (0 → full Newton).
    A step that fails (no convergence in ``max_iter``, growing residual, still 100× its first residual
    after 10 iterations, 1e6 × the load, or non-finite values) is halved; below ``min_step`` of the load a
    SolverError is raised. Steps double after ≤ 4 iterations. ``predictor``: start each step from the last
    converged increment extrapolated (secant). ``linear_solver``: "auto", "pardiso" or "superlu"
    (:func:`fabpat.shell.linalg.factorizer`; the results agree to the Newton tolerance).
    """
    t0 = time.perf_counter()
    if linear_solver not in BACKENDS:
        factorizer(linear_solver)  # raises, naming the choices
    ms = _mesh_setup(p)  # hashes the mesh: once per solve
    model, (asm, f), fz = ms.model, _supported(ms, p), ms.factorizer(linear_solver)
    fnorm = float(np.linalg.norm(f[asm.free]))
    if fnorm == 0.0:
        raise SolverError("no load applied to free dofs")
    K0e = model.linear_element_matrices()
    noise = roundoff_noise(p.X, asm.vector(np.einsum("mii->mi", K0e))[asm.free])
    test = Convergence.at_roundoff(rtol, noise)
    rules = Rules(max_iter, reuse_ratio, max_rotation_step, blowup=1e6 * fnorm)
    load = _LoadStep(model, asm, f, fnorm, K0e)
    x, R = p.X.copy(), np.broadcast_to(np.eye(3), (p.X.shape[0], 3, 3)).copy()
    lam, dlam = 0.0, float(initial_step)
    its_total, steps, cuts, work, t_tan, t_lu = 0, 0, 0, 0.0, 0.0, 0.0
    prev: tuple[Arr, Arr, float] | None = None  # last converged (Δx, spin, Δλ)
    while lam < 1.0 - 1e-12:
        target = min(1.0, lam + dlam)
        x_try, R_try = x.copy(), R.copy()
        load.start(target, unstressed=steps == 0 and not predictor)
        if predictor and prev is not None:  # secant predictor: extrapolate the last converged increment
            s_ = (target - lam) / prev[2]
            x_try += s_ * prev[0]
            R_try = np.einsum("nij,njk->nik", expmap(s_ * prev[1]), R_try)
            load.step[:] = s_ * np.concatenate([prev[0], prev[1]], axis=1).ravel()
        run = iterate(load, x_try, R_try, test, rules, fz)
        its_total += run.iterations
        t_tan, t_lu = t_tan + run.seconds_tangent, t_lu + run.seconds_solve
        if run.converged:
            work += 0.5 * (lam + target) * float(f @ load.step)
            prev = (run.x - x, logmap(np.einsum("nij,nkj->nik", run.R, R)), target - lam)
            x, R, lam = run.x, run.R, target
            steps += 1
            if run.iterations <= 4:
                dlam *= 2.0
            elif run.iterations >= 10:
                dlam *= 0.5
            continue
        cuts += 1
        dlam *= 0.5
        prev = None  # the extrapolation may be what failed
        if dlam < min_step:
            why = (f"the residual stalled near the round-off level of the internal forces (about "
                   f"{noise:.1e}): the model is ill-conditioned (very stiff or very thin?)"
                   if run.residual <= 10.0 * noise else
                   "the structure may buckle or snap, or the loads may be too large for a load-controlled "
                   "analysis")
            raise SolverError(
                f"Newton–Raphson did not converge: load step fell below {min_step:g} of the load at "
                f"load fraction λ = {lam:.4f} after {its_total} iterations and {cuts} step cuts (residual "
                f"{run.residual:.3e} vs tolerance {test.tolerance(target * fnorm):.3e}); {why}")
    react = np.where(p.fixed.ravel(), asm.vector(load.fe) - f, 0.0).reshape(-1, 6)
    ee = model.energy_split(load.d)
    seconds = {"tangent": t_tan, "factor_solve": t_lu, "factorizations": float(load.factorizations),
               "residuals": float(load.evaluations), "total": time.perf_counter() - t0}
    return ShellResult(x - p.X, logmap(R), float(ee.sum()), ee, react, work, its_total, steps, cuts, True, True,
                       seconds)
