"""Mesh-converged scenario energies by Richardson extrapolation from two uniform meshes.

Why (measured; ``benchmarks/study_convergence.py`` and docs/accuracy.md): on library patterns the
strain energy of the flat shell triangles rises towards its mesh-converged value only like h^1.1–1.3, and
at h = 1.5 mm it is 1.5–11 % low. The deficit sits in the narrow necks and bars (2–3 mm wide, 1–2
elements across): on 0x0488 (Cylinder) 5 % of the elements carry 60 % of it, the elements within 2 mm of
the interface-segment ends almost none. The membrane is not the cause (Felippa's OPT triangle, exact
in in-plane bending; membrane energy < 0.1 % of the total there); the transverse shear is: the
Kirchhoff limit of the same element (DKT) is only 1.8 % low at h = 1.5 but 13–23 % stiffer, because
bars about as wide as they are thick twist with Reissner–Mindlin free-edge layers of width
t/√(12κ) ≈ 0.6 mm that a 1.5 mm mesh cannot form. Grading the mesh by local width saved ≈ 20 % of the
nodes for the same energy; refining a band along the free edges saved none. So the cure kept is
extrapolation: with E(h) ≈ E∞ − C·hᵖ, two meshes h₁ > h₂ give
E∞ ≈ E₂ + (E₂ − E₁) / ((h₁/h₂)ᵖ − 1)  (Richardson, Phil. Trans. R. Soc. A 210 (1911) 307).

Displacements, rotations and fields of a converged run are those of the finer mesh; only the
energy is extrapolated. Used by ``fabpat simulate`` and ``fabpat.simulate`` (:func:`simulate`) unless
they are given a mesh size, and by ``fabpat sweep`` (:func:`fabpat.sweep.simulate_pattern`) unless
told ``--no-extrapolate``: the built-in catalog's energies are extrapolated this way. A quadratic
triangle forms the edge layers on a 1.5 mm mesh and would converge without extrapolation at about
5× the nodes (``benchmarks/study_quadratic.py``).
Units: mm, N·mm.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from fabpat.errors import SolverError
from fabpat.mesh import DEFAULT_MAX_ELEMENTS, ShellMesh, check_element_count
from fabpat.scenarios import ScenarioResult, mesh_filleted, run_scenario, simulate_inputs
from fabpat.scenarios import simulate as simulate_mesh

#: order p used for the pair :data:`CONVERGED_MESHES`. On nested meshes the order is 1.1–1.3
#: (docs/accuracy.md), but between h = 1.5 and 1.0 the energy rises more slowly than that predicts:
#: on the pilot (0x2d08, 0xf608, 0x0488 × 3 scenarios) p = 1 came within 0.25 % of the reference in
#: 7 of 9 cases (0x0488: Cylinder −0.65 %, Dome −2.0 %), p = 1.2 up to 1 % lower
RICHARDSON_ORDER = 1.0

#: the two mesh sizes (mm) of a converged run: coarse, fine
CONVERGED_MESHES = (1.5, 1.0)


def richardson(e_coarse: float, e_fine: float, h_coarse: float, h_fine: float,
               order: float = RICHARDSON_ORDER) -> float:
    """Extrapolated energy E₂ + (E₂ − E₁)/((h₁/h₂)ᵖ − 1) of energies on meshes h₁ > h₂ (N·mm, mm).

    Raises SolverError if h_coarse ≤ h_fine or order ≤ 0 (the formula would divide by ≤ 0).
    """
    if not h_coarse > h_fine > 0 or not order > 0:
        raise SolverError(f"Richardson extrapolation needs h_coarse > h_fine > 0 and order > 0, got "
                          f"{h_coarse:g}, {h_fine:g}, {order:g}")
    return e_fine + (e_fine - e_coarse) / ((h_coarse / h_fine) ** order - 1.0)


@dataclass(frozen=True, eq=False)
class ConvergedResult:
    """A scenario run on several meshes: ``energy`` extrapolated (N·mm), ``runs`` one per mesh
    (coarsest first; the last one's fields — displacement, iterations, nodes — describe the run)."""

    scenario: str
    energy: float
    h: tuple[float, ...]
    runs: tuple[ScenarioResult, ...]

    @property
    def fine(self) -> ScenarioResult:
        """The run on the finest mesh (its fields are the ones reported besides the energy)."""
        return self.runs[-1]

    def as_result(self) -> ScenarioResult:
        """The finest run with the extrapolated ``energy``, all meshes' ``h`` and ``mesh_energies`` and the
        summed ``seconds``."""
        return dataclasses.replace(self.fine, energy=self.energy, h=self.h,
                                   mesh_energies=tuple(r.energy for r in self.runs),
                                   seconds=sum(r.seconds for r in self.runs),
                                   converged=all(r.converged for r in self.runs))

    def summary(self) -> dict[str, object]:
        """JSON-ready scalars: the finest run's summary with the extrapolated ``energy``, the mesh sizes
        ``h`` (mm), the per-mesh ``mesh_energies`` (N·mm) and the total ``seconds``."""
        out = self.fine.summary()
        out.update(energy=self.energy, h=list(self.h), mesh_energies=[r.energy for r in self.runs],
                   extrapolated=len(self.runs) > 1, seconds=sum(r.seconds for r in self.runs),
                   converged=all(r.converged for r in self.runs))
        return out


def run_converged(meshes: Sequence[tuple[float, ShellMesh]], scenario: str, *, sides: int, edge: float = 36.0,
                  thickness: float = 2.0, E: float = 1000.0, nu: float = 0.35, nonlinear: bool = True,
                  order: float = RICHARDSON_ORDER) -> ConvergedResult:
    """Run ``scenario`` on each (h, mesh), coarsest first, and extrapolate the energy of the last two.

    One mesh gives its own energy (no extrapolation). Raises SolverError if a run does not converge
    or the mesh sizes do not decrease.
    """
    if not meshes:
        raise SolverError("run_converged needs at least one mesh")
    hs = tuple(float(h) for h, _ in meshes)
    if any(a <= b for a, b in zip(hs, hs[1:], strict=False)):
        raise SolverError(f"mesh sizes must decrease, got {hs}")
    runs = tuple(run_scenario(m, scenario, sides=sides, edge=edge, thickness=thickness, E=E, nu=nu,
                              nonlinear=nonlinear) for _, m in meshes)
    energy = runs[0].energy if len(runs) == 1 else richardson(runs[-2].energy, runs[-1].energy, hs[-2], hs[-1],
                                                              order)
    return ConvergedResult(scenario, energy, hs, runs)


def mesh_converged(filleted: Any, h: float, *, max_elements: int = DEFAULT_MAX_ELEMENTS,
                   option: str = "raise it with --max-elements") -> list[tuple[float, ShellMesh]]:
    """The two meshes [(h, mesh), (h·2/3, mesh)] of an extrapolated run of a filleted pattern (mm).

    Raises GeometryError before meshing if the finer mesh would exceed ``max_elements`` (the message
    names it and suggests a coarse h that fits; ``option``: how to raise the limit), or if h is too
    coarse for the outline (:func:`fabpat.scenarios.mesh_filleted`).
    """
    ratio = CONVERGED_MESHES[1] / CONVERGED_MESHES[0]
    outline = filleted.outline
    check_element_count(outline.area, outline.perimeter, h, max_elements, fine_ratio=ratio, option=option)
    return [(s, mesh_filleted(filleted, s, max_elements=max_elements)) for s in (h, h * ratio)]


def simulate(
    filleted: Any, scenario: str, *, h: float | None = None, extrapolate: bool | None = None, linear: bool = False,
    thickness: float = 2.0, youngs_modulus: float = 1000.0, poisson: float = 0.35,
    max_elements: int = DEFAULT_MAX_ELEMENTS,
) -> ScenarioResult:
    """Run one of the paper's scenarios (§4.1) on a filleted pattern — ``fabpat.simulate``, as the CLI's.

    By default the energy is the mesh-converged value, as in the built-in catalog: the pattern is
    meshed at h = 1.5 and 1.0 mm and the energies extrapolated (:func:`richardson`); every other field
    (displacements, iterations, nodes, ``to_vtu``) is the 1.0 mm mesh's, and ``seconds`` the sum of
    both. Given ``h`` (mm), it solves one mesh of that size, for a user who wants a given mesh;
    ``extrapolate=True`` then uses h and h/1.5, and ``extrapolate=False`` without ``h`` one mesh of
    1.5 mm. ``scenario``: "cantilever", "cylinder" or "dome" (any capitalisation); ``linear``: small
    displacements; ``thickness`` (mm), ``youngs_modulus`` (N/mm², PLA 1000 as in the paper),
    ``poisson`` (0.35). The result's ``h`` and ``mesh_energies`` name the meshes used. Raises
    :class:`SolverError` (bad argument, nonconvergence, implausible result) and
    :class:`~fabpat.errors.GeometryError` (outline not meshable at this h, or the finer mesh above
    ``max_elements``), as :func:`fabpat.scenarios.simulate`.
    """
    if extrapolate is None:
        extrapolate = h is None
    if not isinstance(extrapolate, bool):
        raise SolverError(f"extrapolate must be True, False or None, got {extrapolate!r}")
    coarse = CONVERGED_MESHES[0] if h is None else h
    if not extrapolate:
        return simulate_mesh(filleted, scenario, h=coarse, linear=linear, thickness=thickness,
                             youngs_modulus=youngs_modulus, poisson=poisson, max_elements=max_elements)
    scenario, coarse, thickness, E, nu = simulate_inputs(filleted, scenario, coarse, thickness, youngs_modulus,
                                                         poisson)
    meshes = mesh_converged(filleted, coarse, max_elements=max_elements, option="raise max_elements")
    c = run_converged(meshes, scenario, sides=filleted.sides, edge=filleted.edge, thickness=thickness, E=E, nu=nu,
                      nonlinear=not linear)
    return c.as_result()
