"""Shells with rigid links and prescribed motions: path following (the links and their master–slave
elimination: :mod:`fabpat.shell.rigid_links`).

**Prescribed motion**: ``fixed`` dofs follow ``λ · prescribed`` (translations in mm; rotations as a
rotation vector exp(λ [θ]×), only on nodes whose three rotations are all prescribed). Dofs fixed at 0
are eliminated; dofs with a nonzero prescribed value stay in the matrix with their rows replaced by
identity rows whose right-hand side is the increment still missing, so the first iteration of a step
is the tangent predictor K_ff Δu_f = r_f − K_fp Δu_p and later ones keep them in place.

**Path following** (:func:`solve_path`): λ goes 0 → 1 in ``steps`` equal report intervals, each
crossed by as many Newton increments as needed (halved after a failure, doubled after easy ones),
each one run of the engine's Newton iteration (:func:`fabpat.shell.newton.iterate`).
With loads scaled by λ this is load control; with prescribed motion it is displacement control,
which follows a structure through buckling and along a post-buckling plateau (a limit point in the
*prescribed* variable, a snap-back, would still stop it). A symmetric bifurcation is only left if
something breaks the symmetry (an imperfection load); nonconvergence raises SolverError naming the
load fraction reached.
"""

from __future__ import annotations

import os
import threading
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from fabpat.errors import SolverError
from fabpat.shell import news
from fabpat.shell.compiled import ensure_kernels, solver_threads
from fabpat.shell.linalg import Factor, Pardiso, SuperLUFactorizer, factorizer
from fabpat.shell.newton import Convergence, Residual, Rules, iterate, roundoff_noise
from fabpat.shell.rigid_links import LinkedProblem, SolverSetup, _Reduced
from fabpat.shell.rotations import expmap, logmap

Arr = NDArray[np.float64]

#: one path at a time per process: PARDISO's thread count is process-wide (compiled.solver_threads),
#: and two overlapping solves from Python threads crashed in PARDISO or lost their path
_PATH_LOCK = threading.Lock()


def _fresh_lock_in_child() -> None:
    # a child forked while another thread of the parent was in a path would wait for its lock for ever
    global _PATH_LOCK
    _PATH_LOCK = threading.Lock()


os.register_at_fork(after_in_child=_fresh_lock_in_child)

#: an increment that converged within this many iterations (the predictor included) doubles the next
#: one: on the strip's post-buckling branch increments take 6 iterations, and 4 kept them at 1/12 of
#: the path after the knee
EASY_ITERATIONS = 6
#: … or within this many factorizations: with the predictor on the last increment's factorization a
#: post-buckling increment takes 6–8 iterations but 3 factorizations (three Newton corrections), and
#: doubling after them took the graded strip from the knee to 10 % in 93 factorizations, not 105 (h = 6);
#: 4 rather than 3 lets the knee's increments (3–4 factorizations each) double: 69 → 64 at h = 3
EASY_FACTORIZATIONS = 4
#: a path that stops converging is abandoned (SolverError naming why) once this many factorizations have
#: advanced λ by less than :data:`STALL_ADVANCE` of the path: a whole strip path takes 54–105 (h = 3 … 6,
#: the knee included), a closure 9–11, so 300 with no real progress is a crawl of tiny increments that
#: would otherwise run for hours (an 18-minute design solve was seen), not a hard stretch of the path
STALL_FACTORIZATIONS = 300
STALL_ADVANCE = 0.01
#: a warm start (``start`` of :func:`solve_path`) is given up after at most this many iterations, however
#: many an increment of the path may take: a guess near the equilibrium converges in 5–10, and a longer
#: try only adds to the cold path that follows it
WARM_ITERATIONS = 25
#: … and given up sooner when it is not converging: after its k-th factorization (k ≥ 2) its smallest
#: residual must be below WARM_FALL^(k−1) of the guess's own. A guess within Newton's reach gets there
#: with room (the 1 × 3 test strip with a column changed: 505 N → 9.9 N after 4 factorizations, a
#: flipped cantilever 2.1e4 → 14 N), where a guess too far off creeps (3× a cantilever's deflection:
#: 5.2e4 → 1.2e4 N over 10 factorizations, unconverged after 25) and its factorizations would only
#: be added to the cold path's
WARM_FALL = 0.5
#: a leap (``leap`` of :func:`solve_path`: the rest of the path in one increment) is given up once this many
#: iterations in a row have not halved its smallest residual. Its residual falls through spikes of membrane
#: stretch: leaps that converged went up to 12 iterations without a halving (the 1 × 3 test strip at h = 3,
#: the shipped graded strip at h = 6, which creeps), 4 for the shipped strip at h = 3; a 1 × 4 strip of two
#: stiff and two soft tiles stalls near 20 N and would spend 42 factorizations in 60 iterations before
#: failing (given up after 21 iterations instead)
LEAP_PATIENCE = 15


@dataclass(frozen=True, eq=False)
class PathPoint:
    """State at one report point λ: displacement (N, 3) mm, rotation (N, 3) rad (rotation vectors),
    reactions (N, 6) N / N·mm at prescribed dofs (0 elsewhere), energy N·mm, and link_forces (k, 6):
    the force (N) and moment (N·mm) each slave's elements put on its link (f_int − λ f_ext at the
    slave, global axes), from which a joint's transmitted moment follows. ``exact``: an equilibrium
    (False: interpolated between the converged states on either side, see ``max_step`` of
    :func:`solve_path`)."""

    lam: float
    displacement: Arr
    rotation: Arr
    reactions: Arr
    energy: float
    link_forces: Arr
    exact: bool = True


def _between(a: PathPoint, b: PathPoint, lam: float) -> PathPoint:
    """The point at ``lam`` linearly interpolated between the equilibria a and b (a.lam < lam < b.lam),
    every field (rotation vectors included: the increments are small rotations)."""
    w = (lam - a.lam) / (b.lam - a.lam)

    def mix(u: Arr, v: Arr) -> Arr:
        return (1.0 - w) * u + w * v

    return PathPoint(lam, mix(a.displacement, b.displacement), mix(a.rotation, b.rotation),
                     mix(a.reactions, b.reactions), (1.0 - w) * a.energy + w * b.energy,
                     mix(a.link_forces, b.link_forces), exact=False)


@dataclass(frozen=True, eq=False)
class PathResult:
    """Outcome of :func:`solve_path`: ``points`` at λ = k/steps (k = 1 … steps), the last one the
    final state with its ``element_energy`` (m, 3) split (membrane, bending, shear) N·mm; counts of
    Newton ``iterations``, accepted ``increments``, step ``cuts`` and LU ``factorizations``; ``seconds``
    by phase (``tangent``, ``factor_solve``, ``residual`` — the element forces — and ``total``); ``dofs``
    the size of the linear systems; ``warm`` True when a warm start converged."""

    points: list[PathPoint]
    element_energy: Arr
    iterations: int
    increments: int
    cuts: int
    factorizations: int
    dofs: int
    seconds: dict[str, float] = field(default_factory=dict)
    warm: bool = False

    @property
    def final(self) -> PathPoint:
        """The state at λ = 1 (the last report point)."""
        return self.points[-1]


@dataclass
class _Newton:
    """One increment of :func:`solve_path` as a :class:`fabpat.shell.newton.NewtonSystem` (the reduced,
    slave-free system at a fixed target λ, prescribed dofs as scaled identity rows), with the counters the
    path keeps across increments."""

    p: LinkedProblem
    red: _Reduced
    X: Arr
    all_rot: NDArray[np.bool_]
    dscale: float
    test: Convergence
    rules: Rules
    link_reference: bool
    fz: Pardiso | SuperLUFactorizer
    iterations: int = 0
    factorizations: int = 0
    t_tan: float = 0.0
    t_lu: float = 0.0
    t_res: float = 0.0
    residual: float = np.inf
    state: tuple[Arr, Arr, Arr, Arr] | None = None  # (g, fe, U, d) of the last evaluated iterate
    label: str = ""  # the increment under way, for the solver's news
    target: float = 0.0
    _gr: Arr = field(default_factory=lambda: np.zeros(0))  # reduced net force of the last evaluated iterate
    _inc: Arr = field(default_factory=lambda: np.zeros(0))  # its increments still missing at prescribed dofs
    #: a warm start under way: (factorizations when it began, its guess's residual, its smallest so far)
    warm: tuple[int, float, float] | None = None
    #: a leap under way: (iterations since its residual last halved, that residual)
    leap: tuple[int, float] | None = None

    @property
    def dofs(self) -> NDArray[np.int64]:
        """The global dof of each row of the reduced tangent."""
        return self.red.asm.free

    @property
    def n_dofs(self) -> int:
        """6 × nodes (masters included)."""
        return 6 * self.red.N

    def targets(self, target: float, xs: Arr, Rs: Arr) -> Arr:
        """(N, 6) increments still missing at the prescribed dofs (spins for rotations)."""
        p, inc = self.p, np.zeros((self.red.N, 6))
        inc[:, :3] = self.X + target * p.prescribed[:, :3] - xs
        if self.all_rot.any():
            Rt = expmap(target * p.prescribed[self.all_rot, 3:])
            inc[self.all_rot, 3:] = logmap(Rt @ Rs[self.all_rot].transpose(0, 2, 1))
        return np.where(p.fixed, inc, 0.0)

    def pin(self, xt: Arr, Rt: Arr, target: float) -> tuple[Arr, Arr]:
        """Prescribed dofs exactly on their targets (no drift from the scaled rows' round-off), slaves
        placed from their masters."""
        p = self.p
        xt = np.where(p.fixed[:, :3], self.X + target * p.prescribed[:, :3], xt)
        if self.all_rot.any():
            Rt[self.all_rot] = expmap(target * p.prescribed[self.all_rot, 3:])
        self.red.place_slaves(p, xt, Rt, target)
        return xt, Rt

    def evaluate(self, xt: Arr, Rt: Arr) -> Residual:
        """The residual over the dofs that are neither prescribed nor slaves, measured against the
        largest of the load, the reactions and (``link_reference``) the link forces."""
        p, red = self.p, self.red
        t_r = time.perf_counter()
        g, fe, U, d = red.forces(p, xt, Rt, self.target)
        self.t_res += time.perf_counter() - t_r
        self.state = (g, fe, U, d)
        self._gr = red.reduce(p, g, xt)
        self._inc = self.targets(self.target, xt, Rt)
        ref = max(float(np.linalg.norm(p.load_at(self.target).ravel()[red.test])),
                  float(np.linalg.norm(self._gr.ravel()[p.fixed.ravel()])),
                  float(np.linalg.norm(g[p.link_slave])) if self.link_reference else 0.0)
        pending = float(np.abs(self._inc).max())
        if pending <= 1e-12 * (1.0 + float(np.abs(self.X).max())):
            pending = 0.0
        norm = float(np.linalg.norm(self._gr.ravel()[red.test]))
        if (self.warm is not None and not self._warm_on(norm)) or (self.leap is not None and not self._leap_on(
                norm, pending != 0.0)):
            norm = np.inf  # a non-finite residual ends the Newton run unconverged (newton.iterate)
        return Residual(norm, ref, pending != 0.0)

    def _leap_on(self, norm: float, pending: bool) -> bool:
        """Whether a leap is converging (:data:`LEAP_PATIENCE`), its last halving updated with ``norm``."""
        assert self.leap is not None
        if pending:  # the predictor's residual (prescribed dofs still moving) is no measure of it
            return True
        since, mark = self.leap
        if not np.isfinite(mark) or norm <= 0.5 * mark:
            self.leap = (0, norm)
            return True
        self.leap = (since + 1, mark)
        return since + 1 < LEAP_PATIENCE

    def _warm_on(self, norm: float) -> bool:
        """Whether a warm start is converging (:data:`WARM_FALL`), its smallest residual updated with ``norm``."""
        assert self.warm is not None
        f0, first, best = self.warm
        if not np.isfinite(first):
            first = best = norm
        best = min(best, norm)
        self.warm = (f0, first, best)
        k = self.factorizations - f0
        return k < 2 or best <= first * WARM_FALL ** (k - 1)

    def tangent(self, x: Arr, R: Arr, iteration: int) -> sp.csc_matrix:
        """The reduced tangent of the last evaluated iterate, prescribed rows scaled by ``dscale``."""
        assert self.state is not None  # evaluated before
        g, _, _, d = self.state
        return self.red.matrix(self.p, x, R, d, g, self.dscale)

    def rhs(self) -> Arr:
        """−(reduced net force); at the prescribed rows the increment still missing (× ``dscale``)."""
        red = self.red
        rhs = -self._gr.ravel()
        rhs[red.moving] = self.dscale * self._inc.ravel()[red.moving]
        return rhs[red.asm.free]

    def factored(self, iteration: int) -> None:
        """Counts the factorization and tells the solver's listeners."""
        self.factorizations += 1
        if news.listened():  # a long increment (a warm start's one to λ = 1) is not silent
            news.tell(f"{self.label}, iteration {iteration}, {self.factorizations} factorizations")

    def place(self, x: Arr, R: Arr, D: Arr) -> tuple[Arr, Arr]:
        """The corrected iterate pinned (:meth:`pin`)."""
        return self.pin(x, R, self.target)

    def run(self, xt: Arr, Rt: Arr, target: float, lu: Factor | None, max_iter: int) -> tuple[bool, int, Arr, Arr,
                                                                                               Factor | None]:
        """Iterate from (xt, Rt) at λ = target (:func:`fabpat.shell.newton.iterate`, at most ``max_iter``
        iterations); ``lu``: the factorization the previous increment converged with, for the first
        (predictor) iteration — the tangent of a state a Newton correction away from the converged one, one
        factorization per increment saved — or None. Returns (converged, iterations, x, R, last factorization)."""
        self.target = target
        out = iterate(self, xt, Rt, self.test, replace(self.rules, max_iter=max_iter), self.fz, lu)
        self.iterations += out.iterations
        self.t_tan += out.seconds_tangent
        self.t_lu += out.seconds_solve
        if out.residual != np.inf:
            self.residual = out.residual
        return out.converged, out.iterations, out.x, out.R, out.factor


def _on_branch(X: Arr, xt: Arr, Rt: Arr, direction: Arr | None) -> bool:
    """Whether the state's displacement (translations and rotation vectors) projects non-negatively on
    ``direction`` (no direction: always)."""
    if direction is None:
        return True
    return float(np.sum(np.concatenate([xt - X, logmap(Rt)], axis=1) * direction)) >= 0.0


def solve_path(
    p: LinkedProblem,
    *,
    steps: int = 10,
    rtol: float = 1e-8,
    max_iter: int = 25,
    min_step: float = 1.0 / 4096,
    max_rotation_step: float = 0.5,
    reuse_ratio: float = 0.1,
    direction: Arr | None = None,
    first_step: float | None = None,
    link_reference: bool = False,
    progress: Callable[[float], None] | None = None,
    start: tuple[Arr, Arr] | None = None,
    threads: int | None = None,
    max_step: float | None = None,
    stall: tuple[int, float] | None = (STALL_FACTORIZATIONS, STALL_ADVANCE),
    leap: int | None = None,
    setup: SolverSetup | None = None,
    rises: int = 3,
    reuse_rotation: float = np.inf,
) -> PathResult:
    """Follow λ = 0 → 1 (loads λ·loads, prescribed dofs λ·prescribed, joint angles λ·φ); see module doc.

    ``first_step``: size of the first increment (fraction of the path, at most ``max_step``; default one
    report interval).
    A small one lets the increments grow through a bifurcation that comes early on the path instead
    of leaping past it: from far beyond it Newton may land on any equilibrium, e.g. a wavy higher
    mode of a long strip.
    ``direction``: optional (N, 6) field; an increment is rejected (and halved) when the displacement
    it reaches has a negative projection on it (translations and rotation vectors): it names the
    branch to follow past a symmetric bifurcation, e.g. the imperfection load. Past the bifurcation
    the imperfect structure's other equilibria (the unstable near-flat one and the opposite buckle)
    deflect against the imperfection, and Newton converges onto them just as well: from the flat
    state the tangent has a negative eigenvalue there and points the wrong way. (Retrying a rejected
    increment from its state reflected in the strip's plane was tried and dropped: the reflection
    converged at once, but the increments after it took 6–19 factorizations each, see the docs'
    Solver speed.)
    ``link_reference``: also measure the residual against the forces the links carry (‖g‖ at the
    slaves): a problem driven only by joint angles has no loads and no reactions to compare with.
    ``progress``: called with λ after every report point.
    ``start``: a warm start, (displacement (N, 3) mm, rotation vectors (N, 3) rad) guessed for λ = 1 (e.g.
    the equilibrium of a similar problem, :func:`fabpat.assembly.solve.model.warm_guess`): Newton first tries
    λ = 1 from there in one increment (of at most :data:`WARM_ITERATIONS` iterations); if that converges
    (``warm`` in the result) the only report point is λ = 1, else the path is followed from λ = 0 as
    without it (its iterations and factorizations counted). A warm start reaches the same equilibrium
    only where the problem has one near the guess.
    ``max_step``: the largest increment (fraction of the path; default, and at least, one report
    interval 1/steps). Larger ones let the increments run past report points where the path is easy;
    a report point an increment jumps over is then interpolated linearly between the two converged
    states around it (``PathPoint.exact`` False), and λ = 1 is always an equilibrium.
    ``threads``: threads for the element kernels, the matrix sums and the factorisations (default: the
    cores this process may use, :func:`fabpat.shell.compiled.cores`).
    ``leap``: after the first increment, try the rest of the path in one increment of at most ``leap``
    iterations (default None: no leap), given up once :data:`LEAP_PATIENCE` iterations in a row have not
    halved its residual; the path then goes on from the first increment as without it (the leap counted
    as a step cut). For a path whose only hard stretch is near its start, a buckling knee: the shipped
    graded strip reaches λ = 1 in 23 factorizations rather than 54 (docs/assembly-solver.md). The report
    points it jumps over are interpolated (``max_step``).
    ``stall``: (factorizations n, advance a): abandon the path (SolverError, "stalled") when n
    factorizations have moved λ by less than a (defaults :data:`STALL_FACTORIZATIONS`,
    :data:`STALL_ADVANCE`); None follows a crawling path however long it takes.
    ``rises``: an increment is given up (and halved) once its residual has risen in this many iterations in a
    row (:class:`fabpat.shell.newton.Rules`); a path whose one long increment passes a stretch of slowly
    rising residuals before converging (a large closure: docs/assembly-solver.md) allows more.
    ``reuse_rotation``: the factorization is reused only after a correction whose largest nodal rotation is at
    most this (rad; default ``inf``: after any, as :func:`fabpat.shell.solve.solve_nonlinear`); a closure takes
    0.01 rad (:data:`fabpat.assembly.solve.closure.CLOSURE_REUSE_ROTATION`).
    ``setup``: the assembler and factoriser shared with earlier solves of the same mesh
    (:class:`fabpat.shell.rigid_links.SolverSetup`; default: this solve's own).
    The solver's listeners (:mod:`fabpat.shell.news`) are told the increment, λ and the factorizations
    so far after every increment, and the increment's target and iteration after every factorization.

    Convergence of an increment: ‖r‖ ≤ max(rtol · max(‖λ f‖, ‖reactions‖), floor) over the dofs that
    are neither prescribed nor slaves, with the round-off floor of :mod:`fabpat.shell.newton`. Each
    increment starts from the last converged state with the prescribed increment applied through the
    tangent the last increment converged with (no new factorization); the LU is then reused while the
    residual falls by ``reuse_ratio`` per iteration after corrections of at most ``reuse_rotation``.
    Increments start at the last successful size (at
    most one report interval), halve on failure and double after ≤ ``EASY_ITERATIONS`` iterations or
    ≤ ``EASY_FACTORIZATIONS`` factorizations. (A secant predictor, extrapolating the last increment,
    was dropped: on the graded strip it took 593 factorizations against 93, as a straight-line
    extrapolation of a rising arch stretches it.)
    Raises SolverError (naming the λ reached) when an increment falls below ``min_step`` or the path
    stalls (``stall``).

    One function: the report intervals, the Newton increments (halved after a failure, doubled after
    easy ones) and the warm start share the state of one path (module doc: path following).
    """
    if steps < 1:
        raise ValueError(f"steps must be ≥ 1, got {steps}")
    t0 = time.perf_counter()
    ensure_kernels()  # compiled once per process (and said so: the first run after an install takes ~40 s)
    red = _Reduced(p, threads, setup)
    N, n = red.N, red.n
    X = np.vstack([p.X, p.masters])
    diagK: Arr = np.asarray(np.bincount(red.model.edofs.ravel(), weights=red.model.linear_diagonal().ravel(),
                                        minlength=6 * n), dtype=np.float64)  # (float already: typed as such)
    dscale = float(np.mean(diagK[diagK > 0])) if np.any(diagK > 0) else 1.0
    # the first iteration of an increment is its predictor (prescribed dofs moved, the last increment's
    # factorization): the increment's baseline residual is the second's
    nw = _Newton(p, red, X, p.fixed[:, 3:].all(axis=1), dscale, Convergence.at_roundoff(rtol, roundoff_noise(X, diagK)),
                 Rules(max_iter, reuse_ratio, max_rotation_step, baseline=2, rises=rises,
                       reuse_rotation=reuse_rotation), link_reference,
                 factorizer() if setup is None else setup.factorizer())
    x, R = X.copy(), np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
    largest = 1.0 / steps if max_step is None else max(float(max_step), 1.0 / steps)
    lam, dlam = 0.0, min(first_step, largest) if first_step else 1.0 / steps
    incs = cuts = 0
    points: list[PathPoint] = []
    next_report = 1
    unstable = warm = False
    guess, kept = start, None
    leapt = False  # the leap (``leap``) tried
    here = PathPoint(0.0, np.zeros((N, 3)), np.zeros((N, 3)), np.zeros((N, 6)), 0.0, np.zeros((len(p.link_slave), 6)))
    anchor = (0, 0.0)  # (factorizations, λ) when λ last advanced by stall[1]
    with _PATH_LOCK, solver_threads(red.model.threads):  # one large matrix: its factorisations may use every core
        while lam < 1.0 - 1e-12:
            if guess is not None:
                next_report = steps  # one increment to λ = 1
            goal = next_report / steps if largest <= 1.0 / steps else 1.0
            leaping = leap is not None and guess is None and incs >= 1 and not leapt
            leapt = leapt or leaping
            target = min(goal, lam + dlam) if guess is None and not leaping else 1.0
            if goal - target < 1e-9:
                target = goal
            xt, Rt = x.copy(), R.copy()
            if guess is not None:  # the guess starts on the targets; else the predictor takes them there
                xt, Rt = nw.pin(X + np.asarray(guess[0], dtype=np.float64),
                                expmap(np.asarray(guess[1], dtype=np.float64)), target)
            else:
                red.place_slaves(p, xt, Rt, target)
            f0 = nw.factorizations
            nw.label = f"increment {incs + cuts + 1}, λ = {lam:.3f} → {target:.3f}"
            nw.warm = None if guess is None else (f0, np.inf, np.inf)
            nw.leap = (0, np.inf) if leaping else None
            tries = max_iter if guess is None else min(max_iter, WARM_ITERATIONS)
            ok, its, xt, Rt, lu = nw.run(xt, Rt, target, kept if guess is None else None,
                                         leap if leaping and leap is not None else tries)
            nw.warm = nw.leap = None
            if ok and not _on_branch(X, xt, Rt, direction):
                ok, unstable = False, True  # the other branch (see ``direction``)
            if guess is not None:
                guess = None
                if not ok:  # the guess was too far: follow the path from the start instead
                    next_report = 1
                    continue
                warm = True
            if leaping and not ok:  # the path goes on from the first increment, as without the leap
                cuts += 1
                continue
            kept = lu if ok else None
            if ok:
                unstable = False
                prev = here
                x, R, lam = xt, Rt, target
                incs += 1
                if its <= EASY_ITERATIONS or nw.factorizations - f0 <= EASY_FACTORIZATIONS:
                    dlam = min(2.0 * dlam, largest)
                assert nw.state is not None
                g, _, U, _ = nw.state
                react = np.where(p.fixed, red.reduce(p, g, x), 0.0)
                here = PathPoint(lam, x - X, logmap(R), react, float(U.sum()), g[p.link_slave].copy())
                while next_report <= steps and next_report / steps <= lam + 1e-12:
                    goal = next_report / steps
                    points.append(here if abs(lam - goal) < 1e-12 else _between(prev, here, goal))
                    next_report += 1
                    if progress is not None:
                        progress(goal)
            else:
                cuts += 1
                dlam = 0.5 * (target - lam)
                if dlam < min_step:
                    raise SolverError(
                        f"path following did not converge: the increment fell below {min_step:g} at load fraction "
                        f"λ = {lam:.4f} (aiming for {target:.4f}) after {nw.iterations} iterations and {cuts} step "
                        f"cuts (residual {nw.residual:.3e}"
                        + ("; it converges only onto a branch against ``direction``" if unstable else "")
                        + "); the path may snap back or the mesh may be too coarse")
            if news.listened():
                news.tell(f"increment {incs + cuts}, λ = {lam:.3f}, {nw.factorizations} factorizations"
                          + (f", {cuts} step cuts" if cuts else ""))
            if stall is not None:
                if lam - anchor[1] >= stall[1]:
                    anchor = (nw.factorizations, lam)
                elif nw.factorizations - anchor[0] >= stall[0]:
                    raise SolverError(
                        f"path following stalled: abandoned at load fraction λ = {lam:.4f}, which "
                        f"{nw.factorizations - anchor[0]} factorizations advanced by only {lam - anchor[1]:.2g} "
                        f"({incs} increments, {cuts} step cuts); the path may be near a snap-back or the mesh "
                        "too coarse")
    assert nw.state is not None
    ee = red.model.energy_split(nw.state[3])
    seconds = {"tangent": nw.t_tan, "factor_solve": nw.t_lu, "residual": nw.t_res, "total": time.perf_counter() - t0}
    return PathResult(points, ee, nw.iterations, incs, cuts, nw.factorizations, red.asm.n_free, seconds, warm)


class LinkedState:
    """A converged state of a :class:`~fabpat.shell.rigid_links.LinkedProblem` at λ = 1, for exact
    sensitivities of a quantity of the state to the link parameters (adjoint method; e.g. Bendsøe &
    Sigmund, *Topology Optimization*, 2003, §1.2.3, for the nonlinear case Haftka & Gürdal, *Elements of
    Structural Optimization*, 1992, §7.3).

    ``displacement`` and ``rotation`` (N, 3): the state (mm, rotation vectors rad), e.g. a
    :class:`PathPoint`'s at λ = 1 (any rigid motion of an unloaded, self-equilibrated state is one too).
    The unknowns ``u`` are those of :func:`solve_path`: the nodes that are neither slaves nor fixed at 0,
    as translations (mm) and spatial spins (rad). :meth:`residual` is the reduced net force as a function
    of the link parameters (``link_spin``, ``link_offset``) with those unknowns held, :meth:`adjoint`
    solves Kᵀ λ = b with K the reduced tangent at the state (one factorization, the one the path's
    last Newton step would take). Prescribed nonzero dofs are not supported (ValueError). ``setup``: the
    assembler and analyses shared with the solves of the same mesh (:class:`SolverSetup`; the adjoint's
    transposed tangent has its own factoriser there).
    """

    def __init__(self, p: LinkedProblem, displacement: Arr, rotation: Arr, threads: int | None = None,
                 setup: SolverSetup | None = None) -> None:
        if (p.fixed & (p.prescribed != 0)).any():
            raise ValueError("LinkedState takes problems whose prescribed dofs are all 0")
        ensure_kernels()
        self.p = p
        self.setup = setup
        self.red = _Reduced(p, threads, setup)
        X = np.vstack([p.X, p.masters])
        self.x = X + np.asarray(displacement, dtype=np.float64)
        self.R = expmap(np.asarray(rotation, dtype=np.float64))
        self._factor: Factor | None = None

    def placed(self, link_spin: Arr | None = None, link_offset: Arr | None = None) -> tuple[Arr, Arr]:
        """Positions (N, 3) mm and rotations (N, 3, 3) of every node with the slaves placed from their
        masters by the given link parameters ((k, 3) rad and mm; None: the problem's)."""
        p = self._with(link_spin, link_offset)
        x, R = self.x.copy(), self.R.copy()
        self.red.place_slaves(p, x, R, 1.0)
        return x, R

    def residual(self, link_spin: Arr | None = None, link_offset: Arr | None = None) -> Arr:
        """(N, 6) reduced net force (N, N·mm: the slaves' forces moved to their masters) at the state
        with the slaves placed by the given link parameters; zero at the slaves, the reactions at the
        fixed dofs. At the problem's own parameters it is the equilibrium's residual (round-off)."""
        p = self._with(link_spin, link_offset)
        x, R = self.placed(link_spin, link_offset)
        g, _, _, _ = self.red.forces(p, x, R, 1.0)
        return self.red.reduce(p, g, x)

    def reduce(self, G: Arr) -> Arr:
        """(N, 6) a gradient G (N, 6) with respect to every node's translation and spin moved to the
        unknowns: a slave's onto its master (as its force, :meth:`residual`), zero at the slaves."""
        return self.red.reduce(self.p, np.asarray(G, dtype=np.float64), self.x)

    @property
    def free(self) -> NDArray[np.bool_]:
        """(N, 6) the unknowns: dofs neither fixed nor of a slave."""
        out = np.zeros(6 * self.red.N, dtype=bool)
        out[self.red.asm.free] = True
        return out.reshape(-1, 6)

    def adjoint(self, b: Arr) -> Arr:
        """(N, 6) λ with Kᵀ λ = b on the unknowns (zero elsewhere), K the reduced tangent at the state;
        b (N, 6) is read on the unknowns. The factorization is kept for later calls. Raises SolverError
        when K is singular (a state with a rigid-body motion left free)."""
        red, setup = self.red, self.setup
        # a shared factoriser solves with the latest matrix it factored: another state's, if it took it since
        mine = setup is None or (setup.transposed_of is not None and setup.transposed_of() is self)
        if self._factor is None or not mine:
            g, _, _, d = red.forces(self.p, self.x, self.R, 1.0)
            K = red.matrix(self.p, self.x, self.R, d, g, 1.0)
            with _PATH_LOCK, solver_threads(red.model.threads):
                fz = factorizer() if setup is None else setup.factorizer(transposed=True)
                self._factor = fz.factor(sp.csc_matrix(K.T))
            if setup is not None:
                setup.transposed_of = weakref.ref(self)
        lam = np.zeros(6 * red.N)
        with _PATH_LOCK, solver_threads(red.model.threads):
            lam[red.asm.free] = self._factor.solve(np.asarray(b, dtype=np.float64).ravel()[red.asm.free])
        return lam.reshape(-1, 6)

    def _with(self, link_spin: Arr | None, link_offset: Arr | None) -> LinkedProblem:
        if link_spin is None and link_offset is None:
            return self.p
        return replace(self.p, link_spin=self.p.link_spin if link_spin is None else link_spin,
                       link_offset=self.p.link_offset if link_offset is None else link_offset)
