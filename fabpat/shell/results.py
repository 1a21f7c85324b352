"""Result of a shell analysis."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True, eq=False)
class ShellResult:
    """Outcome of :func:`fabpat.shell.solve.solve_linear` / ``solve_nonlinear``.

    displacement: (n, 3) nodal translations (mm), global axes.
    rotation: (n, 3) nodal rotation vectors (rad), principal log of the total rotation (|θ| < π).
    energy: total strain energy (N·mm).
    element_energy: (m, 3) per-element strain energy split (membrane, bending, transverse shear), N·mm.
    reactions: (n, 6) support reactions (N, N·mm) at constrained dofs, 0 elsewhere.
    external_work: work of the applied loads (N·mm); equals ``energy`` at equilibrium for the
        conservative loads used here. In nonlinear runs it is a trapezoid rule over the accepted load
        steps, so it checks the energy only when there are several: a run done in one step gives the
        chord (measured 408.5 against an energy of 394.4 on a lacy Dome; 394.369 with 64 steps).
    iterations: total Newton iterations (1 for a linear solve); steps: accepted load steps;
    cuts: step halvings; converged: always True for a returned result (nonconvergence raises).
    seconds: wall-clock timings by phase.
    """

    displacement: NDArray[np.float64]
    rotation: NDArray[np.float64]
    energy: float
    element_energy: NDArray[np.float64]
    reactions: NDArray[np.float64]
    external_work: float
    iterations: int
    steps: int
    cuts: int
    converged: bool
    nonlinear: bool
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def max_displacement(self) -> float:
        """Largest nodal translation magnitude (mm)."""
        return float(np.max(np.linalg.norm(self.displacement, axis=1)))

    @property
    def element_energy_total(self) -> NDArray[np.float64]:
        """(m,) element strain energy (N·mm)."""
        return self.element_energy.sum(axis=1)
