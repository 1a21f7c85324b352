"""The paper's three load scenarios (§4.1) on a meshed pattern of a regular n-gon.

Loads and supports act on interface nodes only (``ShellMesh.interfaces[i]`` = nodes on polygon edge i).
Interface 0 is the bottom edge; the *opposite* interface is ``n // 2`` (for odd n the edge across the
polygon, i + n//2 with i = 0). t_i is the unit tangent of edge i taken counter-clockwise.

* **cantilever**: interface 0 fully fixed (6 dofs); force F = +1.5 N along +z at the opposite interface.
* **cylinder**: pins (ux, uy, uz) on interface 0, rollers (uz) on the opposite interface; moment vector
  M·t_i with M = −50 N·mm on both (Mx = −50 at interface 0, the paper's value; the two moments are
  opposite in the global frame, so the load is self-equilibrated and the rollers slide toward the pins).
* **dome**: pins on interface 0, rollers (uz) on every other interface; moment M·t_i with M = −100 N·mm
  on every interface (Σ t_i = 0: self-equilibrated).

With this sign the interfaces turn so that the pattern curls up from its supported edges (the edge
region rises relative to the interior); −M mirrors the shape in z and leaves the energy unchanged.

Distribution: each interface's force or moment is a uniform line load over the interface segment; a
node's share is its tributary length along the edge (half of each adjacent node gap) over the segment
length. This is the consistent load of the linear-edge membrane and of the DKMT normal rotation, which
is linear along a side. Loads keep their global direction during deformation (no follower loads, as
Abaqus/CalculiX ``*CLOAD``).

Plausibility (what is called converged): a result whose energy or displacements are not finite, or
whose largest displacement exceeds what the model can describe, is a :class:`SolverError`. The bound
is the plate's size D = 2 R (R the polygon's circumradius): a linear (small-rotation) solution that
moves a point by more than D implies rotations of order one radian, far outside linear theory; a
nonlinear one that moves a point by more than 2 D (every point is within D of a support) implies
membrane strains above 100 %, outside the small-strain material of the shell element.

Rigid-body motion: with ≥ 2 nodes on every interface (``mesh_outline`` guarantees it) these supports
already remove all six rigid motions (cylinder: the pins' line is locked against rotation by the
rollers; dome: likewise by the other rollers), so no extra constraint is added; a singular system
raises :class:`fabpat.errors.SolverError`.

:func:`simulate` is the one-mesh entry (``fabpat.simulate(filleted, "dome", h=1.5)``): it meshes a filleted
pattern (whose outline knows its polygon) and runs one scenario.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import ExportError, GeometryError, SolverError
from fabpat.shell.element import Material
from fabpat.shell.results import ShellResult
from fabpat.shell.solve import ShellProblem, solve_linear, solve_nonlinear
from fabpat.simulation.mesh import DEFAULT_MAX_ELEMENTS, ShellMesh, mesh_outline
from fabpat.validate import check, check_path, round_down

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.patterns.pattern import Pattern

SCENARIOS = ("cantilever", "cylinder", "dome")
#: the suffixes :meth:`ScenarioResult.to_vtu` and :meth:`ScenarioResult.to_png` (and ``fabpat simulate``) accept
VTU_SUFFIXES = (".vtu",)
PNG_SUFFIXES = (".png",)


def scenario_name(scenario: object) -> str:
    """The scenario's name in :data:`SCENARIOS` for any capitalisation (``"Cantilever"`` → ``"cantilever"``);
    :class:`SolverError` naming the scenarios otherwise."""
    name = scenario.lower() if isinstance(scenario, str) else None
    if name not in SCENARIOS:
        raise SolverError(f"unknown scenario {scenario!r}; expected one of {', '.join(SCENARIOS)}")
    return name

#: the paper's load magnitudes: force (N) and moments (N·mm, signed as described above)
CANTILEVER_FORCE = 1.5
CYLINDER_MOMENT = -50.0
DOME_MOMENT = -100.0


@dataclass(frozen=True, eq=False)
class ScenarioResult:
    """Summary of one pattern-scenario run; ``result`` and ``problem`` hold the full fields.

    ``energy``: total strain energy (N·mm); ``max_displacement`` (mm); ``mesh`` the meshed pattern
    (set by :func:`run_scenario`), which :meth:`to_vtu` and :meth:`to_png` draw deformed. ``h``: the mesh
    sizes (mm) the energy comes from and ``mesh_energies`` (N·mm) their energies: one mesh, or two when
    the energy is extrapolated to the mesh-converged value (:func:`fabpat.simulation.convergence.simulate`; every
    other field is then the finer mesh's); empty when the caller did not say (:func:`run_scenario`).
    ``pattern_id``: the pattern's ID when :func:`simulate` made the result ("" from :func:`run_scenario`);
    ``member``: its family member's tag (``"b0.5"``, :meth:`fabpat.patterns.variation.Variation.tag`; "" for the
    paper's). :attr:`label` is the two together, as the repr and the caption show them.
    In a notebook it shows as the picture :meth:`to_png` draws (``_repr_png_``).
    """

    scenario: str
    energy: float  # N·mm
    max_displacement: float  # mm
    converged: bool
    iterations: int
    seconds: float
    nodes: int
    elements: int
    nonlinear: bool
    result: ShellResult
    problem: ShellProblem
    mesh: ShellMesh | None = None
    h: tuple[float, ...] = ()
    mesh_energies: tuple[float, ...] = ()
    pattern_id: str = ""  # the simulated pattern's ID, when the caller knew it (:func:`simulate`)
    member: str = ""  # the family member's tag ("b0.5"), "" for the paper's

    @property
    def label(self) -> str:
        """``"0x0488 b0.5"``: the pattern ID and the member's tag, as far as they are known."""
        return " ".join(x for x in (self.pattern_id, self.member) if x)

    def __repr__(self) -> str:
        kind = "nonlinear" if self.nonlinear else "linear"
        who = f"{self.label!r}, " if self.label else ""
        return (f"ScenarioResult({who}{self.scenario!r}, energy={self.energy:.6g} N·mm, "
                f"max_displacement={self.max_displacement:.4g} mm, {kind}, {self.nodes} nodes, "
                f"converged={self.converged})")

    def caption(self) -> str:
        """The picture's caption: pattern, scenario and load, then this result's ``energy`` (the number the
        API returns, to 4 significant digits) and largest displacement, e.g. ``"0x0488 · Dome, M = 100 N·mm\n
        U = 430.5 N·mm, max |u| = 3.2 mm"``."""
        head = " · ".join(x for x in (self.label, load_label(self.scenario)) if x)
        return f"{head}\nU = {self.energy:.4g} N·mm, max |u| = {self.max_displacement:.3g} mm"

    def _repr_png_(self) -> bytes:
        """The deformed pattern as :meth:`to_png` draws it (PNG bytes), for a notebook."""
        from fabpat.simulation.png_result import png_bytes

        mesh = self._need_mesh()
        return png_bytes(mesh.V, mesh.F, self.result, caption=self.caption())

    def _need_mesh(self) -> ShellMesh:
        if self.mesh is None:
            raise SolverError("this result has no mesh to draw (make it with simulate or run_scenario)")
        return self.mesh

    def to_vtu(self, path: str | os.PathLike[str]) -> Path:
        """Write the deformed mesh with its fields for ParaView (.vtu; see
        :func:`fabpat.simulation.vtu.write_vtu`), atomically. Returns the path. Raises
        :class:`~fabpat.errors.ExportError` if the suffix is not ``.vtu``."""
        from fabpat.io import atomic_outputs, check_suffix
        from fabpat.simulation.vtu import write_vtu  # a writer: loaded only when a file is asked for

        path = check_path(path, "a VTU file name", error=ExportError)
        check_suffix(path, VTU_SUFFIXES, "a VTU file name")
        mesh = self._need_mesh()
        with atomic_outputs(path) as (tmp,):
            write_vtu(tmp, mesh.V, mesh.F, self.result)
        return Path(path)

    def to_png(self, path: str | os.PathLike[str], *, title: str | None = None) -> Path:
        """Write a picture of the deformed pattern coloured by strain-energy density (PNG), atomically,
        captioned by :meth:`caption` (``title``, a string, replaces its first line; the energy line stays).
        Raises :class:`~fabpat.errors.ExportError` if ``path`` is not a path ending in ``.png`` or
        ``title`` is not a string."""
        from fabpat.io import atomic_outputs, check_suffix
        from fabpat.simulation.png_result import write_png

        path = check_path(path, "a PNG file name", error=ExportError)
        check_suffix(path, PNG_SUFFIXES, "a PNG file name")
        if title is not None and not isinstance(title, str):
            raise ExportError(f"title must be a string, got {type(title).__name__}")
        mesh = self._need_mesh()
        caption = self.caption()
        if title:
            caption = title + "\n" + caption.split("\n", 1)[1]
        with atomic_outputs(path) as (tmp,):
            write_png(tmp, mesh.V, mesh.F, self.result, title=caption)
        return Path(path)

    def summary(self) -> dict[str, object]:
        """JSON-ready dict of the scalar fields (with ``h``, ``mesh_energies`` and ``extrapolated``, as the
        JSON of ``fabpat simulate``, when the result names its meshes)."""
        out: dict[str, object] = {
            "scenario": self.scenario, "energy": self.energy, "max_displacement": self.max_displacement,
            "converged": self.converged, "iterations": self.iterations, "seconds": self.seconds,
            "nodes": self.nodes, "elements": self.elements, "nonlinear": self.nonlinear}
        if self.h:
            out.update(h=list(self.h), mesh_energies=list(self.mesh_energies), extrapolated=len(self.h) > 1)
        return out


def load_label(scenario: str) -> str:
    """The scenario and its load as a picture names them: ``"Dome, M = 100 N·mm"`` (magnitudes of
    :data:`CANTILEVER_FORCE`, :data:`CYLINDER_MOMENT`, :data:`DOME_MOMENT`)."""
    load = {"cantilever": f"F = {CANTILEVER_FORCE:g} N", "cylinder": f"M = {abs(CYLINDER_MOMENT):g} N·mm",
            "dome": f"M = {abs(DOME_MOMENT):g} N·mm"}.get(scenario)
    return f"{scenario.capitalize()}, {load}" if load else scenario


def opposite(i: int, sides: int) -> int:
    """Index of the interface across the polygon from interface i: (i + n//2) mod n."""
    return (i + sides // 2) % sides


def edge_tangents(sides: int) -> NDArray[np.float64]:
    """(n, 3) unit tangents of the polygon edges, counter-clockwise, z = 0."""
    phi = -np.pi / 2 + 2 * np.pi * np.arange(sides) / sides  # direction of edge i's midpoint
    return np.column_stack([-np.sin(phi), np.cos(phi), np.zeros(sides)])


def tributary_weights(V: NDArray[np.float64], nodes: NDArray[np.int64]) -> NDArray[np.float64]:
    """(k,) shares (summing to 1) of a uniform line load over the polyline through ``nodes`` (ordered)."""
    if nodes.size < 2:
        raise SolverError(f"an interface needs at least 2 nodes to carry a line load, got {nodes.size}")
    seg = np.linalg.norm(np.diff(V[nodes], axis=0), axis=1)
    w = np.zeros(nodes.size)
    w[:-1] += 0.5 * seg
    w[1:] += 0.5 * seg
    return w / w.sum()


def build_problem(mesh: ShellMesh, scenario: str, *, sides: int | None = None, thickness: float = 2.0,
                  E: float = 1000.0, nu: float = 0.35) -> ShellProblem:
    """Supports and nodal loads of ``scenario`` on ``mesh`` (see module docstring). ``sides`` defaults to
    the mesh's number of interface sets (one per polygon edge); if given, they must agree."""
    sides = len(mesh.interfaces) if sides is None else sides
    thickness = check("thickness", thickness, error=SolverError)
    E, nu = check("youngs_modulus", E, error=SolverError), check("poisson", nu, error=SolverError)
    if scenario not in SCENARIOS:
        raise SolverError(f"unknown scenario {scenario!r}; expected one of {', '.join(SCENARIOS)}")
    if len(mesh.interfaces) != sides:
        raise SolverError(f"mesh has {len(mesh.interfaces)} interface sets, expected {sides}")
    for i, nodes in enumerate(mesh.interfaces):
        if nodes.size < 2:
            raise SolverError(f"interface {i} has {nodes.size} nodes; the scenarios need ≥ 2 per interface")
    n = mesh.n_nodes
    fixed = np.zeros((n, 6), dtype=bool)
    loads = np.zeros((n, 6))
    t = edge_tangents(sides)
    o = opposite(0, sides)
    ifs = mesh.interfaces

    def moment(i: int, M: float) -> None:
        w = tributary_weights(mesh.V, ifs[i])
        np.add.at(loads, (ifs[i][:, None], np.arange(3, 6)[None, :]), M * w[:, None] * t[i][None, :])

    if scenario == "cantilever":
        fixed[ifs[0]] = True
        np.add.at(loads[:, 2], ifs[o], CANTILEVER_FORCE * tributary_weights(mesh.V, ifs[o]))
    elif scenario == "cylinder":
        fixed[ifs[0], :3] = True
        fixed[ifs[o], 2] = True
        moment(0, CYLINDER_MOMENT)
        moment(o, CYLINDER_MOMENT)
    else:
        for i in range(sides):
            fixed[ifs[i], 2] = True
            moment(i, DOME_MOMENT)
        fixed[ifs[0], :3] = True
    return ShellProblem(mesh.V, mesh.F, Material(E, nu, thickness), fixed, loads)


def run_scenario(mesh: ShellMesh, scenario: str, *, sides: int | None = None, edge: float = 36.0,
                 thickness: float = 2.0, E: float = 1000.0, nu: float = 0.35, nonlinear: bool = True) -> ScenarioResult:
    """Run one scenario on ``mesh`` of a regular ``sides``-gon (default: one per interface set) of
    edge ``edge`` (mm).

    Raises SolverError if it does not converge, the result is implausible (module docstring) or a
    parameter is outside its range (:mod:`fabpat.validate`).
    """
    if not isinstance(mesh, ShellMesh):
        raise SolverError("run_scenario needs a ShellMesh (fabpat.simulation.mesh.mesh_outline), "
                          f"got {type(mesh).__name__}")
    edge = check("edge", edge, error=SolverError)
    sides = len(mesh.interfaces) if sides is None else sides
    t0 = time.perf_counter()
    p = build_problem(mesh, scenario, sides=sides, thickness=thickness, E=E, nu=nu)
    r = solve_nonlinear(p) if nonlinear else solve_linear(p)
    check_plausible(r.energy, r.max_displacement, plate_size(sides, edge), nonlinear, scenario)
    return ScenarioResult(scenario, r.energy, r.max_displacement, r.converged, r.iterations,
                          time.perf_counter() - t0, mesh.n_nodes, mesh.n_elements, nonlinear, r, p, mesh)


def simulate(
    filleted: Any, scenario: str, *, h: float = 1.5, linear: bool = False, thickness: float = 2.0,
    youngs_modulus: float = 1000.0, poisson: float = 0.35, max_elements: int = DEFAULT_MAX_ELEMENTS,
) -> ScenarioResult:
    """Mesh a filleted pattern once (size h) and run one of the paper's scenarios (§4.1).

    ``fabpat.simulate`` (:func:`fabpat.simulation.convergence.simulate`) calls this when given ``h``; without it,
    it extrapolates the energy from two meshes to the mesh-converged value, as ``fabpat simulate``.

    ``filleted``: a :class:`~fabpat.geometry.fillet.FilletedPattern` (its polygon and interfaces come with it);
    ``scenario``: "cantilever", "cylinder" or "dome" (any capitalisation); ``h``: target mesh edge (mm);
    ``linear``: small displacements instead of the geometrically nonlinear analysis; ``thickness`` (mm),
    ``youngs_modulus`` (N/mm², PLA 1000 as in the paper), ``poisson`` (0.35, our choice for PLA).
    Returns a :class:`ScenarioResult` (``energy`` N·mm, ``max_displacement`` mm, ``to_vtu``,
    ``to_png``). Raises :class:`SolverError` for a bad argument (ranges: :mod:`fabpat.validate`),
    nonconvergence or an implausible result, and :class:`~fabpat.errors.GeometryError` if the outline
    cannot be meshed at this h (too coarse for its narrowest feature, or more than ``max_elements``
    triangles).
    """
    scenario, h, thickness, E, nu = simulate_inputs(filleted, scenario, h, thickness, youngs_modulus, poisson,
                                                    linear)
    mesh = mesh_filleted(filleted, h, max_elements=max_elements)
    r = run_scenario(mesh, scenario, sides=filleted.sides, edge=filleted.edge, thickness=thickness, E=E,
                     nu=nu, nonlinear=not linear)
    return dataclasses.replace(r, h=(float(h),), mesh_energies=(r.energy,), pattern_id=filleted.pattern.id,
                               member=filleted.variation.tag())


def simulate_inputs(filleted: Any, scenario: str, h: float, thickness: float, youngs_modulus: float,
                    poisson: float, linear: object = False) -> tuple[str, float, float, float, float]:
    """(scenario, h, thickness, E, ν) of :func:`simulate`'s arguments, checked against
    :mod:`fabpat.validate`'s ranges; SolverError (one line) for a bad one, a ``linear`` that is not a
    bool (``linear="no"`` would otherwise mean True) or a non-filleted pattern."""
    if not hasattr(filleted, "outline") or not hasattr(filleted, "sides"):
        raise SolverError(f"simulate needs a FilletedPattern (pattern.fillet()), got {type(filleted).__name__}")
    if not isinstance(linear, bool | np.bool_):
        raise SolverError(f"linear must be True or False, got {linear!r}")
    return (scenario_name(scenario), check("h", h, error=SolverError), check("thickness", thickness, error=SolverError),
            check("youngs_modulus", youngs_modulus, error=SolverError), check("poisson", poisson, error=SolverError))


def plate_size(sides: int, edge: float) -> float:
    """D = 2 R = edge / sin(π/n) (mm): the diameter of the regular n-gon's circumcircle."""
    return edge / math.sin(math.pi / sides)


def check_plausible(energy: float, max_displacement: float, size: float, nonlinear: bool, what: str) -> None:
    """SolverError if a solution is not finite or moves further than the model can describe.

    ``size`` (mm) is the structure's diameter; linear solutions may move at most ``size``, nonlinear
    ones at most 2 × ``size`` (see the module docstring for why).
    """
    if not (math.isfinite(energy) and math.isfinite(max_displacement)):
        raise SolverError(f"{what}: the solution is not finite (energy {energy:g} N·mm, largest displacement "
                          f"{max_displacement:g} mm): the stiffness is too small for the loads")
    bound = (2.0 if nonlinear else 1.0) * size
    if max_displacement > bound:
        theory = ("nonlinear: membrane strains above 100 %" if nonlinear
                  else "linear theory assumes small rotations; drop --linear")
        raise SolverError(f"{what}: the largest displacement {max_displacement:.4g} mm is beyond what the model "
                          f"allows ({bound:.4g} mm for a part {size:.4g} mm across; {theory})")


def mesh_filleted(filleted: Any, h: float, *, max_elements: int = DEFAULT_MAX_ELEMENTS) -> ShellMesh:
    """Mesh a :class:`~fabpat.geometry.fillet.FilletedPattern` with target edge ``h`` (mm), as the scenarios need.

    Refuses (GeometryError) an h above ``MAX_H_PER_MIN_WIDTH`` × the outline's min_width, naming the
    h that would work, and a mesh estimated above ``max_elements`` triangles.
    """
    from fabpat.simulation.mesh import MAX_H_PER_MIN_WIDTH, check_element_count, check_resolves

    h = check("h", h, "mesh size h", error=GeometryError)
    min_width = filleted.validate(raise_on_error=False).min_width
    check_resolves(h, min_width, f"pattern {filleted.pattern.id}")
    outline = filleted.outline
    check_element_count(outline.area, outline.perimeter, h, max_elements,
                        h_max=round_down(MAX_H_PER_MIN_WIDTH * min_width) if math.isfinite(min_width) else None)
    return mesh_outline(filleted, h, max_elements=max_elements)


def mesh_pattern(pattern: Pattern, weight: float, h: float, *, max_elements: int = DEFAULT_MAX_ELEMENTS) -> ShellMesh:
    """Fillet ``pattern`` with interface weight ``weight`` and mesh it (see :func:`mesh_filleted`)."""
    from fabpat.geometry.fillet import fillet_pattern

    return mesh_filleted(fillet_pattern(pattern, weight), h, max_elements=max_elements)
