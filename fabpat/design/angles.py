"""A closed design's sleeve angles by exact sensitivities: the adjoint gradient of the design error.

**The error.** J(α) = Σ_i d_i² over the plate nodes of the closed assembly, d_i the signed distance of node i
from the target after the best similarity fit (:meth:`fabpat.design.target.ClosedTarget.fit`); α (s,) the
angles (rad) the s sleeves are printed at. By the envelope theorem the fit's parameters are held at their
optimum, so ∂J/∂x_i = 2 d_i ∇d_i (:attr:`fabpat.design.surface.SurfaceFit.gradient`), plus the term of a fit
parameter that follows from the nodes instead (an open target's scale: :attr:`~fabpat.design.surface.SurfaceFit.extra`).

**The adjoint.** The closed state u (translations and spins of the nodes that are neither slaves of a sleeve
nor held) solves R(u, α) = 0, R the reduced net force of :func:`fabpat.shell.linked.solve_path`. Then

    dJ/dα = ∂J/∂α − λᵀ ∂R/∂α,   Kᵀ λ = ∂J/∂u,

K = ∂R/∂u the reduced tangent at the converged state, factorised once
(:meth:`fabpat.shell.linked.LinkedState.adjoint`); ∂J/∂u is the nodes' gradient moved onto the unknowns as a
force is (a slave's onto its sleeve: Σ g and Σ c × g). The angle α_j enters only through sleeve j's two
slot motions (:func:`fabpat.assembly.solve.closure.slot_motions`: the turn by ∓(dihedral − α_j)/2 about the
joint's axis and, on a nearly regular tiling, the slot's offset): ∂R/∂α_j and ∂J/∂α_j (the slaves moving
with their held sleeve) are central differences over ±:data:`ANGLE_STEP` of the *residual* with the state
held — one element-force evaluation each, no solve. Differences rather than the slot motions' formula:
the motions are a rotation's logarithm and an offset of the slot's geometry, whose derivatives the
differences give to ~1e-10 relative without a second derivation to keep in step with them, and the
residual's own derivative with the state held would need the slaves' unreduced tangent, which the
engine never assembles.

**The check** (:func:`gradient_check`): J from full solves at α ± δ·v for random unit directions v against
the adjoint's ∇J·v (:data:`CHECK_STEP`).

**The search** (:func:`optimise_angles`): a bound-constrained quasi-Newton (L-BFGS-B, Byrd, Lu, Nocedal &
Zhu, SIAM J. Sci. Comput. 16 (1995) 1190; scipy's) on the printed angles within ``[sleeve] angle_range``,
each function value one full solve warm-started from the last, with its adjoint gradient.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.assembly.place.placement import Assembly
    from fabpat.assembly.solve.closure import ClosureRun, ClosureSetup
    from fabpat.assembly.solve.model import ModelPlate, ModelSleeve
    from fabpat.assembly.spec.types import AssemblySpec
    from fabpat.design.surface import SurfaceFit
    from fabpat.design.target import ClosedTarget
    from fabpat.shell.element import Material
    from fabpat.shell.linked import LinkedState
    from fabpat.shell.rigid_links import SolverSetup

Arr = NDArray[np.float64]

#: rad: the central-difference step of the residual in a sleeve's angle (truncation ~ step², round-off of
#: the element forces ~ 1e-16 / step, both ≲ 1e-9 relative)
ANGLE_STEP = 1e-5
#: rad: the step δ of the gradient check's full solves along a unit direction of all the angles; the
#: solver's tolerance (1e-8 of the sleeve forces) leaves J's differences far above its noise
CHECK_STEP = 1e-3
#: directions of the gradient check
CHECK_DIRECTIONS = 3
#: L-BFGS-B stops when a step lowers J by less than this fraction
ANGLE_FTOL = 1e-4
#: rad: the largest turn of a joint in the search's first step
FIRST_TURN = math.radians(5.0)
#: the printed angles' step in the spec (degrees): the search ends on them (``[sleeve] angles``)
SPEC_STEP = 0.1


@dataclass(frozen=True, eq=False)
class AngleModel:
    """A closed assembly whose sleeves' printed angles vary: the placed ``asm`` and its ``plates`` (meshed
    once), the ``labels`` of the sleeves, each one's ``dihedral`` (s,) and printed ``angle0`` (s,) rad as the
    spec places it, and the plates' ``material`` and strain limit. ``solver``: the sparse pattern and PARDISO
    analysis its closures share (:class:`fabpat.shell.rigid_links.SolverSetup`): the meshes and supports
    stay, only the angles change, so every closure after the first only refactors."""

    asm: Assembly
    plates: list[ModelPlate]
    labels: list[str]
    dihedral: Arr
    angle0: Arr
    material: Material
    strain_limit: float
    solver: SolverSetup = field(default_factory=lambda: _solver_setup(), repr=False)

    def setup(self, angles: Arr) -> ClosureSetup:
        """The closure with sleeve j printed at ``angles[j]`` (rad; not rounded)."""
        from fabpat.assembly.solve.closure import closure_model

        return closure_model(self.plates, [self.sleeve(j, float(a)) for j, a in enumerate(angles)], self.material)

    def sleeve(self, j: int, angle: float) -> ModelSleeve:
        """Sleeve j of the model printed at ``angle`` (rad): its turn and slot motions
        (:func:`fabpat.assembly.solve.closure.slot_motions`)."""
        from fabpat.assembly.solve.closure import slot_motions
        from fabpat.assembly.solve.model import ModelSleeve

        s = dataclasses.replace(self.asm.sleeves[j], angle=angle)
        return ModelSleeve(s.label, s.transform, s.plates, float(s.dihedral - angle),
                           slot_motions(self.asm, s, self.plates))


def _solver_setup() -> SolverSetup:
    """A fresh :class:`fabpat.shell.rigid_links.SolverSetup` (the shell engine imported when a model is made)."""
    from fabpat.shell.rigid_links import SolverSetup

    return SolverSetup()


def angle_model(spec: AssemblySpec, face_patterns: list[str], h: float) -> AngleModel:
    """The :class:`AngleModel` of a closed spec with face patterns (plain IDs, or candidate names ``"ID bW"``).
    Raises GeometryError as :func:`fabpat.assembly.solve.closure.closure_setup`."""
    from fabpat.assembly.choose.members import with_candidates
    from fabpat.assembly.place.shaped import place_assembly
    from fabpat.assembly.solve.model import check_h, model_plates, plate_material

    spec, ids = with_candidates(spec, list(face_patterns))
    asm = place_assembly(spec, ids)
    check_h(h, asm.plate_edge, spec.plates.weight)
    plates = model_plates(asm, h, spec.plates.weight)
    return AngleModel(asm, plates, [s.label for s in asm.sleeves], np.array([s.dihedral for s in asm.sleeves]),
                      np.array([s.angle for s in asm.sleeves]), plate_material(spec), spec.material.strain_limit)


def solve_angles(model: AngleModel, angles: Arr, start: ClosureRun | None = None) -> ClosureRun:
    """One full closure at printed ``angles`` (s,) rad, warm-started from ``start`` (a closure of the same
    model) if given. Raises SolverError."""
    from fabpat.assembly.solve.closure import run_closure, warm_start

    setup = model.setup(angles)
    return run_closure(setup, strain_limit=model.strain_limit,
                       start=None if start is None else warm_start(start, setup), solver=model.solver)


def design_error(run: ClosureRun, target: ClosedTarget, axis: Arr) -> tuple[float, SurfaceFit]:
    """J (mm²), the summed squared distances of the plate nodes from the fitted target, and the fit."""
    n = len(run.setup.model.X)
    fit = target.fit(run.x[:n], axis)
    return float(np.sum(fit.signed ** 2)), fit


def _support(run: ClosureRun, solver: SolverSetup | None = None) -> LinkedState:
    """The run's linked problem (held as :func:`fabpat.assembly.solve.closure.run_closure` holds it) and the
    shell engine's hook on its closed state; ``solver``: the model's shared set-up (:attr:`AngleModel.solver`)."""
    from fabpat.assembly.solve.closure import closure_supports
    from fabpat.shell.linked import LinkedState

    m = run.setup.model
    N, n = m.n_nodes, len(m.X)
    fixed, zero = np.zeros((N, 6), dtype=bool), np.zeros((N, 6))
    if m.sleeves:
        fixed[n:] = closure_supports(run.setup, m.problem(fixed, zero, zero).masters)
    fin = run.result.final
    return LinkedState(m.problem(fixed, zero, zero), fin.displacement, fin.rotation, setup=solver)


def angle_gradient(model: AngleModel, angles: Arr, run: ClosureRun, fit: SurfaceFit) -> Arr:
    """(s,) dJ/dα (mm² per rad) at the closed state ``run`` (a :func:`solve_angles` at ``angles``) with the
    target's ``fit`` to it (module doc: the adjoint). Raises SolverError if the tangent is singular."""
    assert fit.gradient is not None
    state = _support(run, model.solver)
    m = run.setup.model
    n = len(m.X)
    G = np.zeros((m.n_nodes, 6))
    G[:n, :3] = fit.error_gradient
    lam = state.adjoint(state.reduce(G))
    free = state.free
    base = list(m.sleeves)
    out = np.zeros(len(angles))
    for j, a in enumerate(angles):
        params = []
        for sign in (1.0, -1.0):
            sleeves = base.copy()
            sleeves[j] = model.sleeve(j, float(a) + sign * ANGLE_STEP)
            p = dataclasses.replace(m, sleeves=tuple(sleeves))._links()
            params.append((p[2], p[4]))
        dR = (state.residual(*params[0]) - state.residual(*params[1])) / (2.0 * ANGLE_STEP)
        dx = (state.placed(*params[0])[0] - state.placed(*params[1])[0]) / (2.0 * ANGLE_STEP)
        out[j] = float(np.sum(G[:n, :3] * dx[:n])) - float(np.sum(lam[free] * dR[free]))
    return out


def gradient_check(model: AngleModel, angles: Arr, run: ClosureRun, target: ClosedTarget, axis: Arr,
                   gradient: Arr, directions: int = CHECK_DIRECTIONS, seed: int = 0,
                   solved: Callable[[], None] | None = None) -> dict[str, Any]:
    """The adjoint ``gradient`` (s,) against central differences of full solves (warm-started from ``run``) at
    ``angles`` ± :data:`CHECK_STEP`·v, v ``directions`` seeded random unit directions. Returns
    {``max_relative_error``, ``directions``: [{``adjoint``, ``differences``} mm² per rad], ``step`` rad};
    ``solved()`` is told after every solve. Raises SolverError."""
    rng = np.random.default_rng(seed)
    rows, worst = [], 0.0
    for _ in range(directions):
        v = rng.normal(size=len(angles))
        v /= np.linalg.norm(v)
        J = []
        for sign in (1.0, -1.0):
            r = solve_angles(model, angles + sign * CHECK_STEP * v, run)
            if solved is not None:
                solved()
            J.append(design_error(r, target, axis)[0])
        fd, adj = (J[0] - J[1]) / (2.0 * CHECK_STEP), float(gradient @ v)
        worst = max(worst, abs(fd - adj) / max(abs(fd), 1e-300))
        rows.append({"adjoint": adj, "differences": fd})
    return {"max_relative_error": worst, "directions": rows, "step": CHECK_STEP}


@dataclass
class AngleSearch:
    """State of :func:`optimise_angles`: every solve's relative rms, J (mm²), seconds and peak strain in
    ``history``, the best (angles rad, J, run, fit) in ``best``; ``before()`` is called before every solve (it
    may raise to stop the search, the solves done kept here) and ``after()`` after it."""

    model: AngleModel
    target: ClosedTarget
    axis: Arr
    history: list[dict[str, Any]] = field(default_factory=list)
    best: tuple[Arr, float, ClosureRun, SurfaceFit] | None = None
    last: ClosureRun | None = None
    best_gradient: Arr = field(default_factory=lambda: np.zeros(0))
    before: Callable[[], None] | None = None
    after: Callable[[], None] | None = None

    def evaluate(self, angles: Arr) -> tuple[float, Arr]:
        """J (mm²) and dJ/dα (mm² per rad) at ``angles`` (rad): one full solve warm-started from the last."""
        t0 = time.perf_counter()
        if self.before is not None:
            self.before()
        run = solve_angles(self.model, angles, self.last)
        if self.after is not None:
            self.after()
        self.last = run
        J, fit = design_error(run, self.target, self.axis)
        grad = angle_gradient(self.model, angles, run, fit)
        if self.best is None or J < self.best[1]:
            self.best = (angles.copy(), J, run, fit)
            self.best_gradient = grad
        self.history.append({"relative_rms": float(fit.relative_rms), "J": J, "seconds": time.perf_counter() - t0,
                             "peak_strain": float(run.peak_strain)})
        return J, grad


def optimise_angles(search: AngleSearch, start: Arr, bounds: tuple[float, float], budget: int) -> None:
    """L-BFGS-B on the printed angles (rad) from ``start`` within ``bounds`` (rad) for at most ``budget`` full
    solves (module doc; ``start`` is solved first unless it is ``search``'s best already); every solve is in
    ``search``. The variables are scaled so that the first step, a unit one along the projected steepest
    descent, is half the step to J = 0 of the linear model, at most :data:`FIRST_TURN` on a joint. Stops
    when a step lowers J by less than :data:`ANGLE_FTOL` of it, or when no joint can move downhill within
    its bounds."""
    from scipy.optimize import minimize

    lo, hi = bounds
    x0 = np.clip(start, lo, hi)
    if search.best is None or not np.array_equal(search.best[0], x0):
        if budget <= 0:
            return
        search.evaluate(x0)
        budget -= 1
    assert search.best is not None
    J, g = search.best[1], search.best_gradient
    gp = np.where(((x0 <= lo) & (g > 0)) | ((x0 >= hi) & (g < 0)), 0.0, g)
    if budget <= 0 or not np.any(gp):
        return
    # the first step, a unit one in the scaled variables, is half the step that the linear model says would
    # take J to 0 (Polyak's), at most FIRST_TURN on any joint: a 1° step on the most sensitive joint lowered J
    # by 0.07 % on the mapped ellipsoid, below the stopping test, where the angles had degrees to go
    norm = float(np.linalg.norm(gp))
    scale = min(0.5 * J / norm, FIRST_TURN * norm / float(np.abs(gp).max()))
    J0 = max(J, 1e-300)

    left = [budget]

    def objective(y: Arr) -> tuple[float, Arr]:
        x = np.clip(y * scale, lo, hi)
        if np.array_equal(x, x0):  # L-BFGS-B's first call: the start, solved already
            return J / J0, g * scale / J0
        if left[0] <= 0:  # L-BFGS-B may pass maxfun inside a line search: the budget is the budget
            raise _Spent
        left[0] -= 1
        Jx, gx = search.evaluate(x)
        return Jx / J0, gx * scale / J0

    # maxfun counts the start's value, which costs no solve
    with contextlib.suppress(_Spent):
        minimize(objective, x0 / scale, jac=True, method="L-BFGS-B", bounds=[(lo / scale, hi / scale)] * len(x0),
                 options={"maxfun": budget + 1, "maxiter": budget, "ftol": ANGLE_FTOL, "gtol": 1e-12})


class _Spent(Exception):
    """The search's budget of solves is spent (ends :func:`optimise_angles`' L-BFGS-B)."""
