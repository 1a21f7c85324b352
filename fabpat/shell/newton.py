"""The Newton iteration every driver of the shell engine runs: one convergence test, one Newton step.

A driver (:func:`fabpat.shell.solve.solve_nonlinear`, load control on the catalog's scenarios;
:func:`fabpat.shell.linked.solve_path`, path following with rigid links and prescribed motion) keeps
only its stepping — which λ to aim for next, what to do when an increment fails — and hands each
increment to :func:`iterate` through a :class:`NewtonSystem`: the residual of an iterate, its tangent
and right-hand side in matrix order, and the driver's last word on a corrected iterate (pinning
prescribed dofs, recording the step). Every iteration is then, in the manner of scikit-fem's Newton
loop around one ``solve(*condense(K, r, D=...))``:

1. the residual and the one convergence test :meth:`Convergence.met`,
   ‖r‖ ≤ max(rtol · reference, floor), with the round-off floor of the internal forces;
2. the rules that give up on a lost increment (three rises in a row unless the driver allows more, a
   blow-up, still 100× its baseline residual after 10 iterations);
3. the tangent and its factorization, kept while the residual falls by ``reuse_ratio`` per
   iteration (a back-substitution is ~50× cheaper than a new tangent and LU) after corrections no larger
   than the driver allows (``Rules.reuse_rotation``);
4. the correction, scaled down when its largest nodal rotation passes ``max_rotation_step``, and the
   update x += Δx, R ← exp([Δθ]×) R (spatial spins: Crisfield vol. 2 §17).

Nodal states are (n, 3) positions (mm) and (n, 3, 3) rotation matrices; corrections (n, 6)
translations (mm) and spins (rad).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from fabpat.errors import SolverError
from fabpat.shell.linalg import Factor
from fabpat.shell.rotations import expmap

Arr = NDArray[np.float64]

#: Round-off floor of the residual test, as a multiple of ε·L·‖diag K‖ (ε machine epsilon, L the
#: largest node coordinate, K the linear stiffness on the free dofs). The corotational internal
#: forces subtract positions of size L, so their round-off is about ε·L·K: measured on 0x2d88
#: (Cantilever, E = 1000…2e5 N/mm², t = 0.5…10 mm) Newton stalls at 0.007–0.11 × ε·L·‖diag K‖.
#: Half of it keeps stiff plates converging and stays below 1e-8·‖f‖ for the default PLA plate at
#: full load, so the default results do not change.
ROUNDOFF_FACTOR = 0.5


def roundoff_noise(X: Arr, diag: Arr) -> float:
    """The round-off level (N) of the corotational internal forces, ε·L·‖diag K‖.

    X: (n, 3) node coordinates (mm), L their largest magnitude; diag: the diagonal of the linear
    stiffness (N/mm and N·mm/rad) over the dofs the driver tests. Raises nothing.
    """
    return np.finfo(np.float64).eps * float(np.abs(X).max()) * float(np.linalg.norm(diag))


@dataclass(frozen=True)
class Convergence:
    """The one convergence test of the shell engine: ‖r‖ ≤ max(rtol · reference, floor).

    ``reference``: the force scale (N, forces and moments in one norm) the driver measures against
    (the applied load, the reactions, the link forces); ``floor``: the round-off level of the internal
    forces times :data:`ROUNDOFF_FACTOR` (:meth:`at_roundoff`): without it a stiff plate
    (E·t ≳ 1e5 N/mm) asks for a residual below what floating point resolves.
    """

    rtol: float
    floor: float

    @classmethod
    def at_roundoff(cls, rtol: float, noise: float) -> Convergence:
        """The test with the floor :data:`ROUNDOFF_FACTOR` × ``noise`` (:func:`roundoff_noise`, N)."""
        return cls(rtol, ROUNDOFF_FACTOR * noise)

    def tolerance(self, reference: float) -> float:
        """The residual norm (N) below which an iterate with force scale ``reference`` (N) has converged."""
        return max(self.rtol * reference, self.floor)

    def met(self, residual: float, reference: float) -> bool:
        """Whether the residual norm (N) passes the test against ``reference`` (N)."""
        return residual <= self.tolerance(reference)


@dataclass(frozen=True)
class Residual:
    """One iterate's residual as the iteration reads it: ``norm`` (N) over the tested dofs, the force
    scale ``reference`` (N) of the convergence test, and ``pending``: prescribed dofs still short of
    their targets (the iterate cannot have converged, the correction must reach them in full, and a
    rise of the residual is not a sign of divergence)."""

    norm: float
    reference: float
    pending: bool = False


class Factorizer(Protocol):
    """A sparse LU back-end (:func:`fabpat.shell.linalg.factorizer`)."""

    def factor(self, K: sp.csc_matrix) -> Factor:
        """The factorization of K; raises SolverError when K is singular."""
        ...


class NewtonSystem(Protocol):
    """What a driver tells :func:`iterate` about its increment.

    ``dofs``: (k,) the global dof (node·6 + component) of each row of the tangent, in matrix order;
    ``n_dofs``: the global count (6 n). The residual, tangent and right-hand side are those of the
    iterate last passed to :meth:`evaluate`.
    """

    @property
    def dofs(self) -> NDArray[np.int64]:
        """(k,) global dof of each matrix row."""
        ...

    @property
    def n_dofs(self) -> int:
        """Global dof count."""
        ...

    def evaluate(self, x: Arr, R: Arr) -> Residual:
        """Evaluate the iterate ((n, 3) mm, (n, 3, 3)) and return its residual."""
        ...

    def tangent(self, x: Arr, R: Arr, iteration: int) -> sp.csc_matrix:
        """(k, k) tangent of the iterate in matrix order (``iteration`` counts from 1)."""
        ...

    def rhs(self) -> Arr:
        """(k,) right-hand side of the correction in matrix order (N, N·mm)."""
        ...

    def factored(self, iteration: int) -> None:
        """Told after every new factorization (counts, the solver's news)."""
        ...

    def place(self, x: Arr, R: Arr, D: Arr) -> tuple[Arr, Arr]:
        """The driver's last word on an iterate corrected by D (n, 6): pinned, placed or recorded."""
        ...


@dataclass(frozen=True)
class Rules:
    """How one increment iterates: at most ``max_iter`` iterations; the factorization kept while the
    residual falls by ``reuse_ratio`` per iteration (0: full Newton) after a correction whose largest nodal
    rotation was at most ``reuse_rotation`` (rad; default any); corrections scaled to a largest
    nodal rotation of ``max_rotation_step`` (rad); given up when the residual rises in ``rises``
    iterations in a row, passes ``blowup`` (N) or is still 100× the residual of iteration ``baseline``
    after 10 iterations."""

    max_iter: int
    reuse_ratio: float
    max_rotation_step: float
    blowup: float = np.inf
    baseline: int = 1
    rises: int = 3
    reuse_rotation: float = np.inf


@dataclass(frozen=True)
class NewtonRun:
    """Outcome of :func:`iterate`: ``converged``; ``iterations`` done (the converging test included);
    the last iterate ``x`` (n, 3) mm and ``R`` (n, 3, 3); the last ``factor`` (for the next increment's
    predictor); ``residual``: the last residual norm (N) a correction was taken from (inf if none);
    ``seconds_tangent`` and ``seconds_solve`` spent on tangents and on factorizations with solves."""

    converged: bool
    iterations: int
    x: Arr
    R: Arr
    factor: Factor | None
    residual: float
    seconds_tangent: float
    seconds_solve: float


def iterate(system: NewtonSystem, x: Arr, R: Arr, test: Convergence, rules: Rules, fz: Factorizer,
            lu: Factor | None = None) -> NewtonRun:
    """Newton–Raphson from the iterate (x (n, 3) mm, R (n, 3, 3)) until ``test`` is met (module doc).

    ``lu``: a factorization to take the first iteration with (a predictor on the last increment's
    tangent), or None. A singular tangent (SolverError from ``fz``), a non-finite residual or
    correction, or a lost increment (:class:`Rules`) ends the run unconverged; nothing is raised.
    """
    first = lu
    moved = 0.0  # the largest nodal rotation of the last correction (rad)
    ok, its, last, res0, growth = False, 0, np.inf, np.inf, 0
    t_tan = t_lu = 0.0
    for its in range(1, rules.max_iter + 1):  # noqa: B007 (its used after the loop)
        e = system.evaluate(x, R)
        res = e.norm
        if not np.isfinite(res):
            break
        if not e.pending and test.met(res, e.reference):
            ok = True
            break
        if its == rules.baseline:
            res0 = res
        growth = growth + 1 if res > last and not e.pending else 0
        # rises in a row (three by default), a blow-up, or still far above the baseline after 10 iterations:
        # the increment is lost (Newton then wanders between membrane-stretch spikes; a halved step is cheaper)
        if growth >= rules.rises or res > rules.blowup or (its >= 10 and res > 100.0 * res0):
            break
        # keep the factorization while the residual falls fast; the first iteration takes the one given
        # … and only near the equilibrium: after a large correction the old tangent describes another state
        reuse = lu is not None and ((not e.pending and res < rules.reuse_ratio * last and moved <= rules.reuse_rotation)
                                    or (its == 1 and lu is first))
        last = res
        ta = time.perf_counter()
        K = None if reuse else system.tangent(x, R, its)
        tb = time.perf_counter()
        du = np.zeros(system.n_dofs)
        try:
            if K is not None:
                lu = fz.factor(K)
                system.factored(its)
            assert lu is not None  # reuse implies a factorization
            du[system.dofs] = lu.solve(system.rhs())
        except SolverError:
            break
        t_tan += tb - ta
        t_lu += time.perf_counter() - tb
        if not np.all(np.isfinite(du)):
            break
        D = du.reshape(-1, 6)
        moved = rot = float(np.max(np.linalg.norm(D[:, 3:], axis=1)))
        if not e.pending:  # (prescribed dofs must reach their targets in full)
            if rot > rules.max_rotation_step:
                D = D * (rules.max_rotation_step / rot)
        x, R = system.place(x + D[:, :3], np.einsum("nij,njk->nik", expmap(D[:, 3:]), R), D)
    return NewtonRun(ok, its, x, R, lu, last, t_tan, t_lu)
