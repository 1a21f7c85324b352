"""Mesh-converged scenario energies by Richardson extrapolation from a mesh and its nested refinement.

Why (measured; ``benchmarks/study_convergence.py`` and docs/accuracy.md): on library patterns the
strain energy of the flat shell triangles rises towards its mesh-converged value only like h^1.1–1.3, and
at h = 1.5 mm it is 1.5–11 % low. The deficit sits in the narrow necks and bars (2–3 mm wide, 1–2
elements across), where bars about as wide as they are thick twist with Reissner–Mindlin free-edge
layers of width t/√(12κ) ≈ 0.6 mm that a 1.5 mm mesh cannot form; the membrane is not the cause
(Felippa's OPT triangle; membrane energy < 0.1 % of the Cylinder's). Grading the mesh by local width
or refining a band along the free edges saved nodes but did not converge faster. So the cure kept is
extrapolation: with E(h) ≈ E∞ − C·hᵖ, two meshes h₁ > h₂ give
E∞ ≈ E₂ + (E₂ − E₁) / ((h₁/h₂)ᵖ − 1)  (Richardson, Phil. Trans. R. Soc. A 210 (1911) 307).

The two meshes are *nested* (:func:`fabpat.simulation.mesh.refine_nested`: the finer one splits every triangle of
the coarser into four, its new boundary nodes on the exact outline), not two independent Delaunay
meshes: independent meshes of neighbouring h scatter by tenths of a percent, and on narrow necks by
whole percents (0x4888, Dome: 298.7–304.8 N·mm for h = 1.15–1.5 mm, in plateaus as the necks'
triangles change), which the extrapolation multiplies. With the shipped nested pair (2.5 / 1.25 mm,
finer where a neck is narrow: :func:`converged_h`) all 72 pattern-scenarios of the study are within 1 %
of references from meshes graded to the local width (worst −0.65 %), 68 of a reference from uniform
meshes (worst −1.72 %, where the two references differ by 0.5–1.1 %); two independent meshes of 1.5
and 1.0 mm are within 1 % in 68 and 66, worst −4.4 and −4.9 % (docs/accuracy.md).

Displacements, rotations and fields of a converged run are those of the finer mesh; only the
energy is extrapolated. Used by ``fabpat simulate`` and ``fabpat.simulate`` (:func:`simulate`) unless
they are given a mesh size, and by ``fabpat sweep`` (:func:`fabpat.catalog.sweep.simulate_pattern`) unless
told ``--no-extrapolate``: the built-in catalog's energies are extrapolated this way.
Units: mm, N·mm.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from fabpat.errors import GeometryError, SolverError
from fabpat.simulation.mesh import DEFAULT_MAX_ELEMENTS, MAX_H_PER_MIN_WIDTH, ShellMesh
from fabpat.simulation.scenarios import ScenarioResult, run_scenario, simulate_inputs
from fabpat.simulation.scenarios import simulate as simulate_mesh
from fabpat.validate import check, check_size, round_down, round_up

#: order p of the extrapolation, measured on nested meshes (each triangle split into four; the same
#: domain): the energy error falls like h^1.1–1.3 (docs/accuracy.md). ``benchmarks/study_convergence.py``
#: (24 patterns × 3 scenarios) with the nested pair 2.0 / 1.0 mm: p = 1.2 within 1 % in 72 / 68 of 72
#: against its graded- / uniform-mesh reference, p = 1.1 in 72 / 70, p = 1.0 in 56 / 60; with the shipped
#: pair (2.5 mm and the neck rule of :func:`converged_h`) p = 1.2 in 72 / 68, p = 1.1 in 72 / 70, p = 1.0 in
#: 57 / 61 (p = 1.1 raises the median error by about 0.25 %)
RICHARDSON_ORDER = 1.2

#: the two mesh sizes (mm) of a converged run: a Triangle mesh of h = 2.5 and its nested refinement
#: (:func:`fabpat.simulation.mesh.refine_nested`, half the edge length); :func:`converged_h` lowers the coarse h for
#: narrow necks. The study (docs/accuracy.md) measured 2.0 / 1.0 within 1 % in 72 / 68 of 72 (graded /
#: uniform reference) and 2.5 / 1.25 with the neck rule in 72 / 68 with 25 % less CPU (the curved
#: boundary, followed to a tolerance ∝ h, sets much of the node count);
#: 2.75 / 1.375 and 3.0 / 1.5 (one-off runs) left two and three lacy Cylinder and Dome energies
#: 1.2–1.4 % below the graded reference.
CONVERGED_MESHES = (2.5, 1.25)

#: mesh size (mm) of a one-mesh run when none is given (``extrapolate=False``, ``--no-extrapolate``)
ONE_MESH_H = 1.5

#: chord tolerance of the coarse mesh of a converged run, per mm of its h (0.0375 mm at h = 2.5): finer
#: than the one-mesh default (``fabpat.simulation.mesh.FLATTEN_TOL_PER_H``) because the refined mesh inherits the
#: coarse mesh's boundary vertices. One-off runs on the study's 24 patterns (p = 1.2), coarse h = 2:
#: 0.04 mm left the lacy 0x4888 1.4–1.6 % below the mean of the two references (Cylinder, Dome; its
#: 2.3 mm necks); 0.03 and 0.0375 mm kept all 72 within 1 % of the graded one (worst +0.59, +0.54 %),
#: 0.02 mm within 0.6 % with 27 % more nodes.
NESTED_FLATTEN_TOL_PER_H = 0.015


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


def nested_meshes(outline: Any, h: float, sides: int | None = None, edge: float | None = None, *,
                  weight: float | None = None, max_elements: int = DEFAULT_MAX_ELEMENTS,
                  option: str = "raise it with --max-elements", h_max: float | None = None,
                  ) -> list[tuple[float, ShellMesh]]:
    """[(h, coarse), (h/2, fine)]: a Triangle mesh of ``outline`` and its nested refinement (mm).

    The coarse mesh follows curves to ``NESTED_FLATTEN_TOL_PER_H`` · h; the fine one is
    :func:`fabpat.simulation.mesh.refine_nested` of it (new boundary nodes on the exact outline), with exactly 4×
    its triangles. ``sides``, ``edge``, ``weight``: as :func:`fabpat.simulation.mesh.mesh_outline`. Raises
    GeometryError if the finer mesh would exceed ``max_elements``: the message names it and the
    smallest coarse h (in steps of 15 %, up to ``h_max`` mm if given) whose refinement fits, found by
    meshing (``option``: how to raise the limit).
    """
    from fabpat.simulation.mesh import INTERFACE_WEIGHT, estimate_elements, mesh_outline, refine_nested

    outline = getattr(outline, "outline", outline)
    if not hasattr(outline, "flatten"):
        raise GeometryError(f"nested_meshes needs an Outline or a FilletedPattern, got {type(outline).__name__}")
    h = check("h", h, "mesh size h", error=GeometryError)
    max_elements = int(check("max_elements", max_elements, error=GeometryError))
    w = INTERFACE_WEIGHT if weight is None else weight
    cap = 1000.0 if h_max is None else min(float(h_max), 1000.0)  # the h range's top

    def coarse_mesh(x: float) -> ShellMesh:
        return mesh_outline(outline, x, sides, edge, weight=w, max_elements=max(max_elements, 10**9),
                            flatten_tol=NESTED_FLATTEN_TOL_PER_H * x)

    def refuse(count: float) -> None:
        # the smallest h that fits, by meshing: curved boundaries, followed to a tolerance ∝ h, make the
        # count fall more slowly than 1/h², so no formula gives an h that surely passes
        x = h
        while x <= cap and 4 * estimate_elements(outline.area, outline.perimeter, x) > max_elements:
            x *= 1.15  # meshing is only tried where even the (low) estimate fits
        found = None
        while x <= cap:
            x = round_up(x * 1.15)
            if x > cap:
                break
            if 4 * coarse_mesh(x).n_elements <= max_elements:
                found = x
                break
        hint = f"or use h ≥ {found:g} mm" if found is not None else \
            f"no h up to {cap:g} mm{' (the most this outline allows)' if h_max is not None else ''} fits"
        check_size(count, max_elements, f"mesh elements of the finer mesh of h = {h:g} mm (its refinement to "
                   f"{h * (CONVERGED_MESHES[1] / CONVERGED_MESHES[0]):g} mm)", option, hint, error=GeometryError)

    estimate = 4 * estimate_elements(outline.area, outline.perimeter, h)
    if estimate > max_elements:  # before meshing: a tiny h must not reach Triangle
        refuse(estimate)
    coarse = coarse_mesh(h)
    if 4 * coarse.n_elements > max_elements:
        refuse(4 * coarse.n_elements)
    return [(h, coarse), (h * (CONVERGED_MESHES[1] / CONVERGED_MESHES[0]), refine_nested(coarse, outline))]


#: the coarse mesh of a converged run resolves the outline's narrowest neck: h ≤ this × min_width
#: (:func:`converged_h`). Coarser, Triangle puts one element across the neck, the pair leaves the range
#: where the energy error falls like hᵖ and the extrapolation overshoots. Measured on the library's
#: sparsest patterns (necks of min_width 1.95 mm; Dome, nested pair of coarse h = 2.0 / 2.1 / 2.2 / 2.3 /
#: 2.4 / 2.5 / 2.6 mm): 0x0488 +0.02 / −0.10 / −0.11 / +0.45 / +0.43 / +0.94 / +0.63 % against its
#: converged value 430.9 N·mm (nested meshes from 2.0 and 2.5 mm down to 0.25 and 0.31 mm, 29 600 and 23 000
#: nodes, extrapolated with their observed order 1.7–1.8: 430.8 and 431.0); 0x0b08 +0.00 / +0.03 (2.2) / +0.32
#: (2.25) / +0.56 % (2.5) against its 2.0 / 1.0 mm value; the jump lies between 2.2 and 2.25 mm, i.e.
#: 1.13–1.15 × min_width. (A one-mesh run only needs h ≤ ``fabpat.simulation.mesh.MAX_H_PER_MIN_WIDTH`` × min_width.)
CONVERGED_H_PER_MIN_WIDTH = 1.1


def converged_h(min_width: float, h: float | None = None) -> float:
    """The coarse mesh size (mm) of a converged run: ``h`` (default CONVERGED_MESHES[0], 2.5), made finer
    for an outline whose narrowest feature ``min_width`` (mm) it would not resolve: at most
    :data:`CONVERGED_H_PER_MIN_WIDTH` × min_width, rounded down to 3 digits (2.14 mm for the library's
    sparsest patterns, min_width 1.95 mm; 0.969 mm for the triangle 0x0488 of min_width 0.881 mm)."""
    import math

    h = CONVERGED_MESHES[0] if h is None else float(h)
    return min(h, round_down(CONVERGED_H_PER_MIN_WIDTH * min_width)) if math.isfinite(min_width) else h


def mesh_converged(filleted: Any, h: float | None = None, *, max_elements: int = DEFAULT_MAX_ELEMENTS,
                   option: str = "raise it with --max-elements") -> list[tuple[float, ShellMesh]]:
    """The two meshes [(h, mesh), (h/2, nested refinement)] of an extrapolated run of a filleted pattern.

    ``h`` None: :func:`converged_h` (2.5 mm, finer for an outline with necks narrower than 2.27 mm). Raises
    GeometryError before meshing if the finer mesh would exceed ``max_elements`` (see
    :func:`nested_meshes`), or if a given h is too coarse for the outline (as
    :func:`fabpat.simulation.scenarios.mesh_filleted`).
    """
    from fabpat.simulation.mesh import check_resolves

    min_width = filleted.validate(raise_on_error=False).min_width
    if h is not None:  # a given h is the user's: refused, naming the h that works, rather than changed
        h = check("h", h, "mesh size h", error=GeometryError)
        check_resolves(h, min_width, f"pattern {filleted.pattern.id}")
    else:
        h = converged_h(min_width)
    return nested_meshes(filleted, h, max_elements=max_elements, option=option,
                         h_max=round_down(MAX_H_PER_MIN_WIDTH * min_width))


def simulate(
    filleted: Any, scenario: str, *, h: float | None = None, extrapolate: bool | None = None, linear: bool = False,
    thickness: float = 2.0, youngs_modulus: float = 1000.0, poisson: float = 0.35,
    max_elements: int = DEFAULT_MAX_ELEMENTS,
) -> ScenarioResult:
    """Run one of the paper's scenarios (§4.1) on a filleted pattern — ``fabpat.simulate``, as the CLI's.

    By default the energy is the mesh-converged value, as in the built-in catalog: the pattern is
    meshed at h = 2.5 mm (finer for outlines with necks narrower than 2.27 mm, :func:`converged_h`), that
    mesh refined once (h/2, :func:`nested_meshes`) and the two energies
    extrapolated (:func:`richardson`, p = 1.2); every other field (displacements, iterations, nodes,
    ``to_vtu``) is the refined mesh's, and ``seconds`` the sum of both. Given ``h`` (mm), it solves one
    mesh of that size, for a user who wants a given mesh; ``extrapolate=True`` then uses h and its
    refinement h/2, and ``extrapolate=False`` without ``h`` one mesh of 1.5 mm. ``scenario``:
    "cantilever", "cylinder" or "dome" (any capitalisation); ``linear``: small displacements;
    ``thickness`` (mm), ``youngs_modulus`` (N/mm², PLA 1000 as in the paper), ``poisson`` (0.35). The
    result's ``h`` and ``mesh_energies`` name the meshes used. Raises :class:`SolverError` (bad
    argument, nonconvergence, implausible result) and :class:`~fabpat.errors.GeometryError` (outline
    not meshable at this h, or the finer mesh above ``max_elements``), as
    :func:`fabpat.simulation.scenarios.simulate`.
    """
    if extrapolate is None:
        extrapolate = h is None
    if not isinstance(extrapolate, bool):
        raise SolverError(f"extrapolate must be True, False or None, got {extrapolate!r}")
    if not extrapolate:
        return simulate_mesh(filleted, scenario, h=ONE_MESH_H if h is None else h, linear=linear, thickness=thickness,
                             youngs_modulus=youngs_modulus, poisson=poisson, max_elements=max_elements)
    scenario, _, thickness, E, nu = simulate_inputs(filleted, scenario, CONVERGED_MESHES[0] if h is None else h,
                                                    thickness, youngs_modulus, poisson, linear)
    meshes = mesh_converged(filleted, h, max_elements=max_elements, option="raise max_elements")
    c = run_converged(meshes, scenario, sides=filleted.sides, edge=filleted.edge, thickness=thickness, E=E, nu=nu,
                      nonlinear=not linear)
    return dataclasses.replace(c.as_result(), pattern_id=filleted.pattern.id, member=filleted.variation.tag())
