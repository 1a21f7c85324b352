"""A closed design's plate thicknesses by exact sensitivities: the adjoint gradient of the design error in each plate's
thickness (the first part of ``--vary thickness``; the search over thicknesses is not run yet).

**The model.** The plates, meshed once, and the sleeves at their printed angles of an
:class:`~fabpat.design.angles.AngleModel`; plate i's elements take the thickness t_i (mm) in the shell engine
(:attr:`fabpat.assembly.solve.model.AssemblyModel.element_thickness`), its placement held: the mid-surface stays where
the spec's own thickness puts it, so t_i enters the closure only through the plate's stiffness.

**The adjoint** (as :mod:`fabpat.design.angles`): the closed state u solves R(u, t) = 0, so

    dJ/dt_i = ∂J/∂t_i − λᵀ ∂R/∂t_i,   Kᵀ λ = ∂J/∂u,

with ∂J/∂t_i = 0 (no node moves with t_i while the state is held) and ∂R/∂t_i a central difference over
±:data:`THICKNESS_STEP` of t_i of the *residual* with the state held (:class:`fabpat.shell.linked.LinkedState` of the
model with plate i thinner or thicker: two element-force evaluations, no solve), the same differences the angles use.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.assembly.solve.closure import ClosureRun, ClosureSetup
    from fabpat.design.angles import AngleModel
    from fabpat.design.surface import SurfaceFit

Arr = NDArray[np.float64]

#: relative step of the residual's central difference in a plate's thickness (the element forces are cubic in t at
#: most: truncation ~ step², round-off ~ 1e-16 / step, both ≲ 1e-9 relative)
THICKNESS_STEP = 1e-5


def thickness_setup(model: AngleModel, thickness: Arr) -> ClosureSetup:
    """The closure of ``model`` at its printed angles with plate i of thickness ``thickness[i]`` (mm; (plates,))."""
    from fabpat.assembly.solve.closure import closure_model

    plates = [dataclasses.replace(p, thickness=float(t)) for p, t in zip(model.plates, thickness, strict=True)]
    return closure_model(plates, [model.sleeve(j, float(a)) for j, a in enumerate(model.angle0)], model.material)


def solve_thickness(model: AngleModel, thickness: Arr, start: ClosureRun | None = None) -> ClosureRun:
    """One full closure at plate thicknesses ``thickness`` (plates,) mm, warm-started from ``start`` (a closure of
    the same model) if given. Raises SolverError."""
    from fabpat.assembly.solve.closure import run_closure, warm_start

    setup = thickness_setup(model, thickness)
    return run_closure(setup, strain_limit=model.strain_limit,
                       start=None if start is None else warm_start(start, setup))


def thickness_gradient(model: AngleModel, thickness: Arr, run: ClosureRun, fit: SurfaceFit) -> Arr:
    """(plates,) dJ/dt (mm² per mm) at the closed state ``run`` (a :func:`solve_thickness` at ``thickness``) with the
    target's ``fit`` to it (module doc: the adjoint). Raises SolverError if the tangent is singular."""
    from fabpat.assembly.solve.closure import closure_supports
    from fabpat.design.angles import _support
    from fabpat.shell.linked import LinkedState

    assert fit.gradient is not None
    state = _support(run)
    m = run.setup.model
    n = len(m.X)
    G = np.zeros((m.n_nodes, 6))
    G[:n, :3] = 2.0 * fit.signed[:, None] * fit.gradient
    lam = state.adjoint(state.reduce(G))
    free = state.free
    fin = run.result.final
    zero = np.zeros((m.n_nodes, 6))
    out = np.zeros(len(thickness))
    for i, t in enumerate(thickness):
        R = []
        for sign in (1.0, -1.0):
            plates = list(m.plates)
            plates[i] = dataclasses.replace(plates[i], thickness=float(t) * (1.0 + sign * THICKNESS_STEP))
            mi = dataclasses.replace(m, plates=tuple(plates))
            fixed = np.zeros((m.n_nodes, 6), dtype=bool)
            if mi.sleeves:  # held as the run held it (fabpat.design.angles._support)
                fixed[n:] = closure_supports(run.setup, mi.problem(fixed, zero, zero).masters)
            R.append(LinkedState(mi.problem(fixed, zero, zero), fin.displacement, fin.rotation).residual())
        dR = (R[0] - R[1]) / (2.0 * THICKNESS_STEP * float(t))
        out[i] = -float(np.sum(lam[free] * dR[free]))
    return out
