"""One pattern's scenario energies: fillet → mesh → each scenario's (nonlinear) solve → strain energies.

The one pipeline behind ``fabpat sweep`` (:func:`fabpat.catalog.sweep.simulate_pattern`, one catalog
row per scenario) and ``fabpat simulate`` (:mod:`fabpat.cli.simulate_cmds`): :func:`scenario_energies`
fillets a pattern (or takes a filleted one), reads its filleted metrics and narrowest feature, meshes it
once — one Triangle mesh of ``h``, or by default a mesh and its nested refinement
(:func:`fabpat.simulation.convergence.nested_meshes`) whose energies are Richardson-extrapolated to the
mesh-converged value, as the built-in catalog — and runs every scenario asked on those meshes
(:func:`fabpat.simulation.convergence.run_converged`). All scenarios share the meshes: meshing is ~3 % of a
solve, but would otherwise be repeated per scenario.

The same calls with the same arguments as the sweep and the command made before they shared this code,
so the built-in catalog's rows recompute to the same numbers (``tests/test_catalog.py``). This module is
not among the modules whose code the catalog's solver version digests
(:mod:`fabpat.catalog.version`): it only composes them.

Errors: by default the first :class:`~fabpat.errors.FabpatError` propagates (a scenario's
:class:`~fabpat.errors.SolverError` prefixed with the scenario and the pattern, as the command says it);
``keep_errors=True`` (the sweep) records each one instead, as ``"GeometryError: …"`` text on the result
(filleting, validating, meshing) or on the scenario's run (its solve), so one failing scenario does not
lose the others. Units: mm, N, N·mm, s.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from fabpat.errors import FabpatError, GeometryError, SolverError
from fabpat.geometry.fillet import DEFAULT_WEIGHT, FilletedPattern, fillet_pattern
from fabpat.simulation.convergence import (
    ONE_MESH_H,
    ConvergedResult,
    converged_h,
    nested_meshes,
    run_converged,
)
from fabpat.simulation.mesh import DEFAULT_MAX_ELEMENTS, MAX_H_PER_MIN_WIDTH, ShellMesh, mesh_outline
from fabpat.simulation.mesh_size import check_element_count, check_resolves
from fabpat.simulation.scenarios import SCENARIOS, scenario_name
from fabpat.validate import check, round_down

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.patterns.pattern import Pattern
    from fabpat.patterns.variation import Variation


class Reporter(Protocol):
    """Where :func:`scenario_energies` says what it is doing: :class:`fabpat.progress.Progress` fits."""

    def update(self, text: str, done: float | None = None) -> None:
        """The work now (``text``) and how many scenarios are done (``done``)."""

    def item(self, text: str) -> None:
        """One scenario finished (``text`` names it and its energy)."""


@dataclass(frozen=True, eq=False)
class ScenarioRun:
    """One scenario's solve on the pattern's meshes.

    ``result``: the converged run (:class:`~fabpat.simulation.convergence.ConvergedResult`: ``energy`` N·mm,
    extrapolated when there are two meshes; ``fine`` the finest mesh's run), None when it failed;
    ``error``: ``"SolverError: …"`` when it failed (only with ``keep_errors``); ``seconds``: the solves'
    time (s), summed over the meshes, or the time until the failure.
    """

    scenario: str
    result: ConvergedResult | None
    error: str | None
    seconds: float

    @property
    def energy(self) -> float:
        """Strain energy (N·mm) of the scenario; NaN when the solve failed."""
        return float(self.result.energy) if self.result is not None else math.nan

    @property
    def converged(self) -> bool:
        """Whether every mesh's solve converged (False when it failed)."""
        return self.result is not None and all(r.converged for r in self.result.runs)


@dataclass(frozen=True, eq=False)
class ScenarioEnergies:
    """What :func:`scenario_energies` computed for one pattern.

    ``filleted``: the filleted pattern (None if filleting failed); ``columns``: its filleted columns
    (:meth:`~fabpat.geometry.fillet.FilletedPattern.catalog_columns`: ``filleted_area`` mm², ``filleted_perimeter``
    mm, ``filleted_ratio``, ``filleted_polar_moment`` mm⁴, ``min_width`` mm; empty if the outline is
    invalid); ``meshes``: (h mm, mesh) coarsest first, one or two (empty if meshing failed); ``runs``: one
    :class:`ScenarioRun` per scenario asked, in order (each with the geometry's error if there was one);
    ``error``: the geometry step's failure as ``"GeometryError: …"`` (only with ``keep_errors``);
    ``geometry_seconds``: the time (s) of filleting, validating and meshing.
    """

    filleted: FilletedPattern | None
    columns: dict[str, float]
    meshes: tuple[tuple[float, ShellMesh], ...]
    runs: tuple[ScenarioRun, ...]
    error: str | None = None
    geometry_seconds: float = 0.0

    @property
    def min_width(self) -> float:
        """Narrowest feature (mm) of the filleted outline; NaN if it was not measured."""
        return float(self.columns.get("min_width", math.nan))

    @property
    def mesh(self) -> ShellMesh | None:
        """The finest mesh (the one whose nodes, fields and files a result reports), None if not meshed."""
        return self.meshes[-1][1] if self.meshes else None

    @property
    def energies(self) -> dict[str, float]:
        """{scenario: strain energy (N·mm)} of the scenarios that were solved."""
        return {r.scenario: r.energy for r in self.runs if r.result is not None}

    def run(self, scenario: str) -> ScenarioRun:
        """The run of ``scenario`` (any capitalisation); :class:`SolverError` if it was not asked for."""
        name = scenario_name(scenario)
        for r in self.runs:
            if r.scenario == name:
                return r
        ran = ", ".join(r.scenario for r in self.runs) or "none"
        raise SolverError(f"scenario {name!r} was not run; these were: {ran}")


def energy_meshes(filleted: FilletedPattern, min_width: float, *, h: float | None = None, extrapolate: bool = True,
                  h_is_bound: bool = False, max_elements: int = DEFAULT_MAX_ELEMENTS,
                  option: str = "raise it with --max-elements") -> list[tuple[float, ShellMesh]]:
    """The meshes [(h, mesh), …] (mm) of a filleted pattern whose narrowest feature is ``min_width`` mm.

    ``extrapolate``: a Triangle mesh and its nested refinement (h/2) whose energies
    :func:`~fabpat.simulation.convergence.run_converged` extrapolates; the coarse h is ``h`` if given (a
    user's mesh: refused, naming one that works, if too coarse for the necks) or
    :func:`~fabpat.simulation.convergence.converged_h` (2.5 mm, finer for narrow necks), as
    :func:`~fabpat.simulation.convergence.mesh_converged`. ``h_is_bound`` (the sweep): a given ``h`` is an
    upper bound that ``converged_h`` lowers for narrow necks instead. Otherwise one mesh of ``h``
    (default 1.5 mm), as :func:`~fabpat.simulation.scenarios.mesh_filleted`. Raises
    :class:`GeometryError` for an h outside its range or too coarse, a mesh above ``max_elements``
    triangles (``option``: how to raise the limit) or an outline Triangle cannot mesh.
    """
    what = f"pattern {filleted.pattern.id}"
    if not extrapolate:
        h1 = check("h", ONE_MESH_H if h is None else h, "mesh size h", error=GeometryError)
        check_resolves(h1, min_width, what)
        outline = filleted.outline
        check_element_count(outline.area, outline.perimeter, h1, max_elements, option=option,
                            h_max=round_down(MAX_H_PER_MIN_WIDTH * min_width) if math.isfinite(min_width) else None)
        return [(h1, mesh_outline(filleted, h1, max_elements=max_elements))]
    if h is None or h_is_bound:
        coarse = converged_h(min_width, h)
    else:  # a given h is the user's: refused, naming the h that works, rather than changed
        coarse = check("h", h, "mesh size h", error=GeometryError)
        check_resolves(coarse, min_width, what)
    return nested_meshes(filleted, coarse, max_elements=max_elements, option=option,
                         h_max=round_down(MAX_H_PER_MIN_WIDTH * min_width))


def scenario_energies(
    pattern: Pattern | FilletedPattern, scenarios: Sequence[str] = SCENARIOS, *, weight: float | None = None,
    variation: Variation | None = None, h: float | None = None, extrapolate: bool | None = None,
    h_is_bound: bool = False, thickness: float = 2.0, E: float = 1000.0, nu: float = 0.35,
    nonlinear: bool = True, max_elements: int = DEFAULT_MAX_ELEMENTS, option: str = "raise it with --max-elements",
    keep_errors: bool = False, name: str | None = None, progress: Reporter | None = None,
) -> ScenarioEnergies:
    """Fillet, mesh and solve one pattern in ``scenarios``: its strain energies (N·mm) and what they came from.

    ``pattern``: a :class:`~fabpat.patterns.pattern.Pattern`, filleted here with interface ``weight``
    (default the paper's 0.2) and the family member ``variation`` (default the paper's), or an already
    :class:`~fabpat.geometry.fillet.FilletedPattern` (then ``weight`` and ``variation`` must be None).
    ``h``, ``extrapolate``, ``h_is_bound``, ``max_elements``, ``option``: the meshes, as
    :func:`energy_meshes` (``extrapolate`` None: True unless ``h`` is given, as ``fabpat simulate``).
    ``thickness`` (mm), ``E`` (N/mm²), ``nu``, ``nonlinear``: the shell, as
    :func:`~fabpat.simulation.scenarios.run_scenario`. The pattern is meshed even when ``scenarios`` is
    empty (a catalog's pattern row records whether it meshes). ``name``: how errors name the pattern
    (default its label, ``"0x0488 b0.5"``). ``progress``: told "meshing", each scenario as it starts (on
    how many elements) and as it ends (with its energy). Raises, unless ``keep_errors`` (module doc),
    :class:`GeometryError` (filleting, an invalid outline, meshing) and :class:`SolverError` (a bad
    scenario or material, nonconvergence, an implausible result: ``"dome scenario of 0x0488: …"``).
    """
    names = [scenario_name(s) for s in scenarios]  # a misspelt scenario is the caller's error, never a row
    extrapolate = h is None if extrapolate is None else extrapolate
    t0 = time.perf_counter()
    filleted: FilletedPattern | None = None
    columns: dict[str, float] = {}
    meshes: list[tuple[float, ShellMesh]] = []
    try:
        if isinstance(pattern, FilletedPattern):
            if weight is not None or variation is not None:
                raise GeometryError("a filleted pattern has its weight and variation: give the Pattern to change them")
            filleted = pattern
        else:
            filleted = fillet_pattern(pattern, DEFAULT_WEIGHT if weight is None else weight, variation)
        if progress is not None:
            progress.update("meshing", 0)
        columns = filleted.catalog_columns()  # an invalid outline raises GeometryError
        meshes = energy_meshes(filleted, columns["min_width"], h=h, extrapolate=extrapolate, h_is_bound=h_is_bound,
                               max_elements=max_elements, option=option)
    except FabpatError as e:
        if not keep_errors:
            raise
        failed = f"{type(e).__name__}: {e}"
        return ScenarioEnergies(filleted, columns, tuple(meshes), tuple(ScenarioRun(s, None, failed, 0.0)
                                                                          for s in names),
                                failed, time.perf_counter() - t0)
    geometry_seconds = time.perf_counter() - t0
    label = name if name is not None else filleted.label
    runs = [_solve(meshes, sc, k, len(names), filleted, label, thickness=thickness, E=E, nu=nu, nonlinear=nonlinear,
                   keep_errors=keep_errors, progress=progress) for k, sc in enumerate(names)]
    return ScenarioEnergies(filleted, columns, tuple(meshes), tuple(runs), None, geometry_seconds)


def _solve(meshes: list[tuple[float, ShellMesh]], scenario: str, k: int, n: int, filleted: FilletedPattern,
           label: str, *, thickness: float, E: float, nu: float, nonlinear: bool, keep_errors: bool,
           progress: Reporter | None) -> ScenarioRun:
    """Scenario ``k`` of ``n`` on the meshes: its :class:`ScenarioRun` (see :func:`scenario_energies`)."""
    if progress is not None:
        sizes = " and ".join(f"{m.n_elements} elements" for _, m in meshes)
        progress.update(f"{scenario} ({k + 1} of {n}) on {sizes}", k)
    t0 = time.perf_counter()
    try:
        c = run_converged(meshes, scenario, sides=filleted.sides, edge=filleted.edge, thickness=thickness, E=E,
                          nu=nu, nonlinear=nonlinear)
    except FabpatError as e:
        if keep_errors:
            return ScenarioRun(scenario, None, f"{type(e).__name__}: {e}", time.perf_counter() - t0)
        if isinstance(e, SolverError):  # say which of the scenarios and which pattern
            raise SolverError(f"{scenario} scenario of {label}: {e}") from None
        raise
    if progress is not None:
        progress.item(f"{scenario} finished ({k + 1} of {n}), energy {c.energy:.6g} N·mm")
    return ScenarioRun(scenario, c, None, float(sum(x.seconds for x in c.runs)))
