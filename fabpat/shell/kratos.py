"""Cross-check of a :class:`ShellProblem` with Kratos Multiphysics (optional peer solver).

Same mesh, material, supports and loads, solved with Kratos' shear-deformable corotational triangle
``ShellThickElementCorotational3D3N`` (or the thin ``ShellThinElementCorotational3D3N``),
geometrically nonlinear, load-controlled Newton–Raphson over ``steps`` equal load increments.
Needs ``pip install KratosMultiphysics KratosStructuralMechanicsApplication
KratosLinearSolversApplication`` (≈ 150 MB; the last gives Eigen's SparseLU, else the slow skyline LU).

Kratos' STRAIN_ENERGY output is 0 for these elements, so the strain energy is the work of the loads
(conservative loads, elastic material: work = energy at equilibrium):
W = Σ F·(u(1) − ∫₀¹ u dλ) + M·(φ(1) − ∫₀¹ φ dλ) (integration by parts of ∫ λ F·du), the integrals by
Simpson's rule over the load steps. φ is Kratos' nodal ROTATION, which the corotational shells
accumulate from the spatial rotation increments, the variable conjugate to a fixed-axis moment.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SolverError
from fabpat.shell.solve import ShellProblem

Arr = NDArray[np.float64]

THICK = "ShellThickElementCorotational3D3N"
THIN = "ShellThinElementCorotational3D3N"


def available() -> bool:
    """True when Kratos and its structural application import."""
    try:
        _import()
    except ImportError:
        return False
    return True


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Send file descriptor 1 to /dev/null: Kratos prints its banners from C++, past sys.stdout."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _import():  # noqa: ANN202 (module objects)
    with _quiet_stdout():
        import KratosMultiphysics as KM
        import KratosMultiphysics.StructuralMechanicsApplication as SMA
        try:
            import KratosMultiphysics.LinearSolversApplication as LSA
        except ImportError:
            LSA = None
    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)
    return KM, SMA, LSA


@dataclass(frozen=True)
class KratosResult:
    """energy (N·mm, work of the loads); displacement, rotation (n, 3) at λ = 1; steps; seconds."""

    energy: float
    displacement: Arr
    rotation: Arr
    steps: int


def solve_kratos(p: ShellProblem, *, steps: int = 20, element: str = THICK, rtol: float = 1e-7,
                 atol: float = 1e-10, max_iter: int = 50) -> KratosResult:
    """Geometrically nonlinear Kratos solution of ``p`` in ``steps`` (even) equal load increments.

    Convergence: residual norm below ``rtol`` × the step's first one, or below ``atol`` (Kratos'
    ResidualCriteria; its relative residual bottoms out near 1e-8, so tighter ratios never converge).

    Raises SolverError when a load step does not converge.
    """
    if steps % 2:
        raise ValueError("Simpson's rule needs an even number of load steps")
    KM, SMA, LSA = _import()
    model = KM.Model()
    mp = model.CreateModelPart("shell")
    mp.ProcessInfo[KM.DOMAIN_SIZE] = 3
    for var in (KM.DISPLACEMENT, KM.ROTATION, KM.REACTION, KM.REACTION_MOMENT):
        mp.AddNodalSolutionStepVariable(var)
    prop = mp.GetProperties()[1]
    prop[KM.YOUNG_MODULUS] = p.material.E
    prop[KM.POISSON_RATIO] = p.material.nu
    prop[KM.THICKNESS] = p.material.t
    prop[KM.DENSITY] = 1.0
    prop[KM.CONSTITUTIVE_LAW] = SMA.LinearElasticPlaneStress2DLaw()
    for i, X in enumerate(p.X):
        mp.CreateNewNode(i + 1, float(X[0]), float(X[1]), float(X[2]))
    for e, tri in enumerate(p.F):
        mp.CreateNewElement(element, e + 1, [int(a) + 1 for a in tri], prop)
    dofs = [(KM.DISPLACEMENT_X, KM.REACTION_X), (KM.DISPLACEMENT_Y, KM.REACTION_Y),
            (KM.DISPLACEMENT_Z, KM.REACTION_Z), (KM.ROTATION_X, KM.REACTION_MOMENT_X),
            (KM.ROTATION_Y, KM.REACTION_MOMENT_Y), (KM.ROTATION_Z, KM.REACTION_MOMENT_Z)]
    for var, reac in dofs:
        KM.VariableUtils().AddDof(var, reac, mp)
    for i, fx in zip(*np.nonzero(p.fixed), strict=True):
        mp.Nodes[int(i) + 1].Fix(dofs[int(fx)][0])
    conds = []  # (condition, variable, full load vector)
    c_id = 1
    for i in np.flatnonzero(np.abs(p.loads[:, :3]).max(axis=1) > 0):
        c = mp.CreateNewCondition("PointLoadCondition3D1N", c_id, [int(i) + 1], prop)
        conds.append((c, SMA.POINT_LOAD, p.loads[i, :3]))
        c_id += 1
    for i in np.flatnonzero(np.abs(p.loads[:, 3:]).max(axis=1) > 0):
        c = mp.CreateNewCondition("PointMomentCondition3D1N", c_id, [int(i) + 1], prop)
        conds.append((c, SMA.POINT_MOMENT, p.loads[i, 3:]))
        c_id += 1
    if LSA is not None:
        lin = LSA.SparseLUSolver()
    else:  # core Kratos only: correct but slow
        lin = KM.SkylineLUFactorizationSolver()
    scheme = KM.ResidualBasedIncrementalUpdateStaticScheme()
    crit = KM.ResidualCriteria(rtol, atol)  # ratio to the step's first residual, or absolute (N)
    crit.SetEchoLevel(0)
    bs = KM.ResidualBasedBlockBuilderAndSolver(lin)
    strategy = KM.ResidualBasedNewtonRaphsonStrategy(mp, scheme, crit, bs, max_iter, True, False, True)
    strategy.SetEchoLevel(0)
    strategy.Initialize()
    n = p.X.shape[0]
    hist_u = np.zeros((steps + 1, n, 3))
    hist_r = np.zeros((steps + 1, n, 3))
    nodes = [mp.Nodes[i + 1] for i in range(n)]
    for k in range(1, steps + 1):
        lam = k / steps
        mp.CloneTimeStep(float(k))
        mp.ProcessInfo[KM.STEP] = k
        for c, var, vec in conds:
            c.SetValue(var, KM.Array3([float(v) for v in lam * vec]))
        strategy.InitializeSolutionStep()
        strategy.Predict()
        converged = strategy.SolveSolutionStep()
        strategy.FinalizeSolutionStep()
        if not converged:
            raise SolverError(f"Kratos did not converge in load step {k}/{steps} (λ = {lam:.3f})")
        hist_u[k] = [nd.GetSolutionStepValue(KM.DISPLACEMENT) for nd in nodes]
        hist_r[k] = [nd.GetSolutionStepValue(KM.ROTATION) for nd in nodes]
    wts = np.ones(steps + 1)
    wts[1:-1:2], wts[2:-1:2] = 4.0, 2.0
    wts /= 3.0 * steps  # Simpson weights of ∫₀¹ · dλ
    int_u = np.tensordot(wts, hist_u, axes=1)
    int_r = np.tensordot(wts, hist_r, axes=1)
    work = float(np.sum(p.loads[:, :3] * (hist_u[-1] - int_u)) + np.sum(p.loads[:, 3:] * (hist_r[-1] - int_r)))
    return KratosResult(work, hist_u[-1], hist_r[-1], steps)

