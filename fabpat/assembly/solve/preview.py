"""What the user will get: the predicted bent assembly of a closure run, as a GLB, a PNG and a mesh.

With sleeves printed at an angle other than the joint's dihedral (``[sleeve] angle``), the flat plates
bend when the sleeves close the object (:mod:`fabpat.assembly.solve.closure`). This module turns a
:class:`~fabpat.assembly.solve.closure.ClosureRun` into plain data (:class:`PredictedShape`) and writes it:

* **Plates**: the solver's deformed mid-surface per plate (:func:`positions` and the model's triangles split
  by ``element_offsets``), thickened by ±t/2 along each node's director (the plate normal turned by
  the node's rotation, ``expmap(rotation) @ n₀``: the shell's own kinematics) into a closed shell
  with side walls on the mesh boundary, so slicers and CAD open it as a solid per plate.
* **Colour**: strain-energy density, each element's energy over its area (N·mm/mm², the reference
  area), averaged to the vertices with area weights for smooth colouring, one colour map
  (:data:`COLOUR_MAP`, perceptually uniform) from 0 to the largest vertex value.
* **Sleeves on the deformed joints**: sleeve j's body is the master node ``n + j``; its pose is
  ``[R_s · F | x_s]`` with ``R_s = expmap(rotation[n + j])`` and ``F`` the placement frame's rotation.
  The model's slots turn by ∓α/2 (α = dihedral − sleeve angle) about the frame's X relative to the
  body (:mod:`fabpat.assembly.solve.model`), so at λ = 1 the slots lie at the printed sleeve angle,
  symmetric about the frame's Z: the printed sleeve solid (``Sleeve(angle).solid()``) placed by that
  pose grips the deformed interfaces exactly (:func:`joint_fit` measures it, mm).

Writers (not atomic: :mod:`fabpat.assembly.kit.build` writes into a temporary folder):
:func:`write_predicted_glb` (``assembly.glb``), :func:`render_predicted_png` (``assembly.png``),
:func:`write_predicted_stl` (``predicted.stl``) and :func:`prediction_record` (``prediction.json``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from fabpat.geometry.polygons import boundary_edges, triangle_areas

if TYPE_CHECKING:
    import trimesh

    from fabpat.assembly.place.parts import PartLibrary
    from fabpat.assembly.place.placement import Assembly
    from fabpat.assembly.place.sleeve import Sleeve
    from fabpat.assembly.solve.closure import ClosureRun
    from fabpat.assembly.solve.model import AssemblyModel
    from fabpat.assembly.solve.strip import StripRun

Arr = NDArray[np.float64]

#: matplotlib colour map of the strain-energy density (perceptually uniform, readable in grey)
COLOUR_MAP = "viridis"
DENSITY_UNIT = "N·mm/mm²"


@dataclass(frozen=True, eq=False)
class PredictedPlate:
    """One deformed plate: ``label`` ("H01"), ``key`` its part key ("hex 0x0488"); mid-surface ``V``
    (n, 3) mm and ``F`` (m, 3); unit directors ``N`` (n, 3); ``density`` (m,) element strain-energy
    density and ``vertex_density`` (n,) its area-weighted vertex average (N·mm/mm²); ``thickness`` (mm) its
    own (``[plates] thicknesses``), None: the shape's."""

    label: str
    key: str
    V: Arr
    F: NDArray[np.int64]
    N: Arr
    density: Arr
    vertex_density: Arr
    thickness: float | None = None


@dataclass(frozen=True, eq=False)
class PredictedShape:
    """The assembled object as predicted: ``plates``; ``sleeves`` one (label, part key, pose (4, 4))
    per sleeve; ``thickness`` (mm); ``density_range`` (lo, hi) of the colour map (N·mm/mm²); and a
    closure's ``radius`` (mm), ``sphericity_rms``/``sphericity_max`` (fractions of the radius; None for
    a strip, which is not closed, and for a closure no sphere describes: ``closed`` tells them apart); a tube's
    ``cylinder_radius`` (mm) and ``cylindricity_rms`` (None for every other shape)."""

    plates: tuple[PredictedPlate, ...]
    sleeves: tuple[tuple[str, str, Arr], ...]
    thickness: float
    density_range: tuple[float, float]
    radius: float | None
    sphericity_rms: float | None
    sphericity_max: float | None
    #: a closure (False: a strip); its radius and sphericity are None when no sphere describes it
    closed: bool = False
    cylinder_radius: float | None = None
    cylindricity_rms: float | None = None


def positions(run: StripRun | ClosureRun) -> Arr:
    """(n + s, 3) deformed positions (mm) of every node of a ClosureRun or StripRun at λ = 1: the plates'
    nodes, then one per sleeve (its centre)."""
    m = run.setup.model
    masters = np.array([np.asarray(s.frame)[:3, 3] for s in m.sleeves]).reshape(-1, 3)
    return np.vstack([m.X, masters]) + np.asarray(run.result.final.displacement)[:, :3]


def sleeve_poses(run: StripRun | ClosureRun) -> list[Arr]:
    """(4, 4) pose of every sleeve body at λ = 1: ``[expmap(θ_s) · frame rotation | x_s]`` (mm)."""
    from fabpat.shell.rotations import expmap

    m = run.setup.model
    n = len(m.X)
    x = positions(run)
    out = []
    for j, s in enumerate(m.sleeves):
        T = np.eye(4)
        T[:3, :3] = expmap(run.result.final.rotation[n + j]) @ np.asarray(s.frame)[:3, :3]
        T[:3, 3] = x[n + j]
        out.append(T)
    return out


def predicted_shape(run: StripRun | ClosureRun, assembly: Assembly) -> PredictedShape:
    """The deformed plates and placed sleeves of a ClosureRun or StripRun of ``assembly`` (plain arrays, mm).

    ``assembly`` (:class:`~fabpat.assembly.place.placement.Assembly`) gives each plate's part key and each
    sleeve's kind; its plates and sleeves are in the model's order (``closure_setup`` and
    ``strip_setup`` build both).
    """
    from fabpat.shell.rotations import expmap

    m = run.setup.model
    n = len(m.X)
    x = positions(run)
    energy = np.asarray(run.result.element_energy, dtype=np.float64).sum(axis=1)
    area0 = triangle_areas(m.X, m.F)
    dens = energy / np.maximum(area0, 1e-300)
    R = expmap(run.result.final.rotation[:n])
    plates = []
    for p, mp in enumerate(m.plates):
        nodes, elements = m.plate_slices(p)
        a, b = nodes.start, nodes.stop
        F = m.F[elements] - a
        n0 = np.asarray(mp.transform)[:3, 2]
        N = R[a:b] @ n0
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        w = np.bincount(F.ravel(), np.repeat(area0[elements], 3), minlength=b - a)
        vd = np.bincount(F.ravel(), np.repeat(area0[elements] * dens[elements], 3), minlength=b - a) / np.maximum(w,
        1e-300)
        plates.append(PredictedPlate(mp.label, assembly.plates[p].type.label, x[a:b].copy(), F, N,
                                     dens[elements].copy(), vd, mp.thickness))
    hi = max(float(pl.vertex_density.max()) for pl in plates) if plates else 0.0
    sleeves = tuple((s.label, ps.kind, T) for s, ps, T in zip(m.sleeves, assembly.sleeves, sleeve_poses(run),
                                                              strict=True))
    tube = getattr(run, "cylinder_radius", None) is not None  # its cylinder, never a sphere
    radius, rms, worst = (None if tube or getattr(run, k, None) is None else float(getattr(run, k))
                          for k in ("radius", "sphericity_rms", "sphericity_max"))
    return PredictedShape(tuple(plates), sleeves, float(m.material.t), (0.0, hi), radius, rms, worst,
                          hasattr(run, "sphere_note"),
                          getattr(run, "cylinder_radius", None), getattr(run, "cylindricity_rms", None))


def joint_fit(run: StripRun | ClosureRun, sleeve_types: dict[str, Sleeve], kinds: list[str]) -> tuple[float, float]:
    """How well the printed sleeves, placed by :func:`sleeve_poses`, grip the deformed plates (mm).

    For every sleeve (kind ``kinds[j]``, type ``sleeve_types[kind]``, a :class:`Sleeve` at the printed
    angle) and both slots: the interface nodes of the slot's plate, in the sleeve's frame. Returns
    (largest distance of a node from its slot's mid-plane, largest distance of a node outside its slot
    along the slot's length and depth; 0 when every node lies within the slot). Both are round-off
    when the sleeve fits.
    """
    m = run.setup.model
    x = positions(run)
    plane, outside = 0.0, 0.0
    for j, (s, T) in enumerate(zip(m.sleeves, sleeve_poses(run), strict=True)):
        sl = sleeve_types[kinds[j]]
        for side, (p, i) in enumerate(s.slots):
            L = (x[m.nodes(p, i)] - T[:3, 3]) @ T[:3, :3]  # world → sleeve frame
            YZ = L[:, 1:]
            plane = max(plane, float(np.abs(YZ @ sl.plate_normal(side)).max()))
            depth = YZ @ sl.direction(side)
            lo, hi = sl.setback - 0.5 * sl.clearance, sl.arm_end
            outside = max(outside, float(np.maximum(lo - depth, 0).max()), float(np.maximum(depth - hi, 0).max()),
                          float(np.maximum(np.abs(L[:, 0]) - 0.5 * sl.slot_length, 0).max()))
    return plane, outside


# -- meshes -------------------------------------------------------------------------------------------


def thickened(V: Arr, F: NDArray[np.int64], N: Arr, thickness: float) -> tuple[Arr, NDArray[np.int64]]:
    """Closed shell of a mid-surface (n, 3) mm thickened by ±t/2 along the unit directors N (n, 3).

    Top = V + N t/2 (triangles as given, facing +N), bottom = V − N t/2 (reversed), and a wall of two
    triangles on every boundary edge. Returns (2n, 3) vertices and (2m + 2k, 3) triangles, outward
    when F faces +N.
    """
    n = len(V)
    h = 0.5 * thickness
    W = np.vstack([V + h * N, V - h * N])
    B = boundary_edges(F)
    a, b = B[:, 0], B[:, 1]
    walls = np.concatenate([np.column_stack([b, a, a + n]), np.column_stack([b, a + n, b + n])])
    return W, np.vstack([F, F[:, ::-1] + n, walls]).astype(np.int64)


def colour_of(values: Arr, lo: float, hi: float) -> Arr:
    """(k, 4) RGBA in [0, 1] of values on :data:`COLOUR_MAP` over [lo, hi] (clipped)."""
    import matplotlib

    cmap = matplotlib.colormaps[COLOUR_MAP]
    span = hi - lo if hi > lo else 1.0
    return np.asarray(cmap(np.clip((np.asarray(values) - lo) / span, 0.0, 1.0)), dtype=np.float64)


def solid_meshes(shape: PredictedShape, lib: PartLibrary, tolerance: float) -> list[tuple[str, Arr, NDArray[np.int64]]]:
    """(label, V (mm), F) of every predicted part as a closed mesh: thickened plates, then placed sleeves
    (``lib`` a :class:`PartLibrary` whose sleeve types are the printed ones, meshed within ``tolerance`` mm)."""
    from fabpat.assembly.place.parts import apply

    out = [(pl.label, *thickened(pl.V, pl.F, pl.N, shape.thickness if pl.thickness is None else pl.thickness))
           for pl in shape.plates]
    for label, key, T in shape.sleeves:
        V, F = lib.mesh(key, tolerance)
        out.append((label, apply(T, V), F))
    return out


# -- writers ------------------------------------------------------------------------------------------


def predicted_scene(shape: PredictedShape, lib: PartLibrary, name: str, tolerance: float) -> trimesh.Scene:
    """``trimesh.Scene`` in metres: one mesh per plate (its own deformed, thickened geometry, vertex
    colours of the strain-energy density, named by its label) and one shared mesh per sleeve kind
    placed by one node per sleeve (named by its label). The colour map's range is in the scene's
    extras (``density_range``, ``density_unit``, ``colour_map``) and in the root node's name."""
    import trimesh

    from fabpat.assembly.show.export import GLB_UNIT, SLEEVE_COLOUR, slug, srgb_to_linear

    lo, hi = shape.density_range
    sc = trimesh.Scene()
    root = f"{name} predicted (strain-energy density {lo:.3g}–{hi:.3g} {DENSITY_UNIT})"
    sc.graph.update(frame_from=sc.graph.base_frame, frame_to=root, matrix=np.eye(4))
    for pl in shape.plates:
        W, F = thickened(pl.V, pl.F, pl.N, shape.thickness if pl.thickness is None else pl.thickness)
        rgba = colour_of(np.concatenate([pl.vertex_density, pl.vertex_density]), lo, hi)
        mesh = trimesh.Trimesh(W * GLB_UNIT, F, vertex_colors=(255 * rgba).round().astype(np.uint8), process=False)
        sc.add_geometry(mesh, node_name=pl.label, geom_name=pl.label, parent_node_name=root)
    grey = [*srgb_to_linear(SLEEVE_COLOUR), 1.0]
    for key in dict.fromkeys(k for _, k, _ in shape.sleeves):
        from trimesh.visual.material import PBRMaterial

        V, F = lib.mesh(key, tolerance)
        m = trimesh.Trimesh(V * GLB_UNIT, F, process=False)
        m.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(name=slug(key), baseColorFactor=grey,
                                                                      metallicFactor=0.0, roughnessFactor=0.6))
        sc.geometry[slug(key)] = m
    for label, key, T in shape.sleeves:
        M = np.array(T, dtype=np.float64)
        M[:3, 3] *= GLB_UNIT
        sc.graph.update(frame_from=root, frame_to=label, matrix=M, geometry=slug(key))
    sc.metadata.update({"density_range": [lo, hi], "density_unit": DENSITY_UNIT, "colour_map": COLOUR_MAP})
    if shape.radius is not None:  # a closed object's roundness
        sc.metadata.update({"radius_mm": shape.radius, "sphericity_rms": shape.sphericity_rms,
                            "sphericity_max": shape.sphericity_max})
    if shape.cylinder_radius is not None:  # a tube's roundness: its cylinder
        sc.metadata.update({"cylinder_radius_mm": shape.cylinder_radius, "cylindricity_rms": shape.cylindricity_rms})
    return sc


def write_predicted_glb(shape: PredictedShape, lib: PartLibrary, path: str | os.PathLike[str], name: str,
                        tolerance: float) -> None:
    """The predicted object as binary glTF 2.0 (metres), see :func:`predicted_scene`. Plates are closed
    shells ±t/2 about the deformed mid-surface (so a viewer shows their thickness from both sides).
    Raises :class:`fabpat.io.WriteFailed` if the file cannot be written."""
    from fabpat.assembly.show.export import glb_bytes
    from fabpat.io import writer_failed

    data = glb_bytes(predicted_scene(shape, lib, name, tolerance))  # y-up, as every kit GLB
    try:
        Path(path).write_bytes(data)
    except OSError as exc:
        raise writer_failed(path, "cannot write the GLB file", exc) from exc


def write_predicted_stl(shape: PredictedShape, lib: PartLibrary, path: str | os.PathLike[str], tolerance: float) -> int:
    """The predicted object as one binary STL (mm): every plate a closed shell (±t/2 about the deformed
    mid-surface) and every sleeve placed on its deformed joint, as separate closed shells (plates and
    sleeves do not overlap: the slots leave ``clearance``/2 on each face). Returns the triangle count.
    Raises :class:`fabpat.io.WriteFailed` if the file cannot be written."""
    import trimesh

    from fabpat.io import writer_failed

    parts = solid_meshes(shape, lib, tolerance)
    Vs, Fs, off = [], [], 0
    for _, V, F in parts:
        Vs.append(V)
        Fs.append(F + off)
        off += len(V)
    mesh = trimesh.Trimesh(np.vstack(Vs), np.vstack(Fs), process=False)
    try:
        Path(path).write_bytes(mesh.export(file_type="stl"))
    except OSError as exc:
        raise writer_failed(path, "cannot write the STL file", exc) from exc
    return len(mesh.faces)


#: direction from the object to the camera of the predicted pictures: a closed object from above one side;
#: a strip (x along its length, z up) nearly from the side, so its arch shows
VIEW_CLOSED = (1.0, -1.4, 0.9)
VIEW_STRIP = (0.2, -1.0, 0.35)


def _paint_png(plates: list[tuple[Arr, NDArray[np.int64], Arr]], sleeves: list[tuple[Arr, NDArray[np.int64]]],
               path: str | os.PathLike[str], title: str, label: str, cmap: str, lo: float, hi: float,
               dpi: int = 110, view: tuple[float, float, float] = VIEW_CLOSED) -> None:
    """Painter's projection (:mod:`fabpat.assembly.show.render`) of plate mid-surfaces (V, F, one value per
    face; both sides visible) coloured on ``cmap`` over [lo, hi] with a colour bar ``label``, and grey
    closed sleeve meshes (V world, F), seen from ``view``; the figure's height follows the picture's
    aspect (a long strip gets no blank bands)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    from fabpat.assembly.show.export import SLEEVE_COLOUR
    from fabpat.assembly.show.render import _camera, _hex, draw, project

    C = _camera(np.array(view, dtype=np.float64))
    span = hi - lo if hi > lo else 1.0
    colours = matplotlib.colormaps[cmap]
    items = [(V, F, np.asarray(colours(np.clip((vals - lo) / span, 0.0, 1.0)))[:, :3], False) for V, F, vals in plates]
    grey = _hex(SLEEVE_COLOUR)
    items += [(V, F, np.tile(grey, (len(F), 1)), True) for V, F in sleeves]
    P2, S = project(items, C)
    extent = np.ptp(P2.reshape(-1, 2), axis=0)
    aspect = float(extent[1] / extent[0]) if extent[0] > 0 else 1.0
    fig, ax = plt.subplots(figsize=(9.5, min(8.0, max(3.5, 7.5 * aspect + 1.5))))
    draw(ax, P2, S)
    fig.colorbar(ScalarMappable(norm=Normalize(lo, lo + span), cmap=cmap), ax=ax, shrink=0.7, label=label)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(os.fspath(path), dpi=dpi, format="png")
    plt.close(fig)


def render_predicted_png(shape: PredictedShape, lib: PartLibrary, path: str | os.PathLike[str], title: str,
                         dpi: int = 110) -> None:
    """Draw the predicted object: plates coloured by strain-energy density (:data:`COLOUR_MAP`, the GLB's
    range) with a colour bar, sleeves grey on their deformed joints; ``title`` on top."""
    from fabpat.assembly.place.parts import PICTURE_TOLERANCE, apply

    lo, hi = shape.density_range
    plates = [(pl.V, pl.F, pl.vertex_density[pl.F].mean(axis=1)) for pl in shape.plates]
    sleeves = []
    for _, key, T in shape.sleeves:
        V, F = lib.mesh(key, PICTURE_TOLERANCE)
        sleeves.append((apply(T, V), F))
    view = VIEW_CLOSED if shape.closed else VIEW_STRIP
    _paint_png(plates, sleeves, path, title, f"strain-energy density ({DENSITY_UNIT})", COLOUR_MAP, lo, hi, dpi,
               view)


#: colour bar label and unit of each field of :func:`render_prediction_png`
FIELD_LABELS = {"energy": f"strain-energy density ({DENSITY_UNIT})", "strain": "peak surface strain (%)",
                "mean_curvature": "mean curvature (1/mm)", "gaussian_curvature": "gaussian curvature (1/mm²)"}


class _Solved(Protocol):
    """What :func:`render_prediction_png` reads of an :class:`~fabpat.assembly.solve.result.AssemblySimulation` (a
    module that imports this one)."""

    @property
    def name(self) -> str: ...
    @property
    def h(self) -> float: ...
    @property
    def model(self) -> AssemblyModel: ...
    @property
    def run(self) -> StripRun | ClosureRun: ...
    @property
    def element_strain(self) -> Arr: ...
    @property
    def curvature(self) -> Mapping[str, Arr]: ...


def render_prediction_png(sim: _Solved, path: str | os.PathLike[str], field: str = "energy", dpi: int = 110) -> None:
    """Draw a closed assembly of ``fabpat simulate-assembly`` (an :class:`~fabpat.assembly.solve.simulation.
    AssemblySimulation`): its deformed plates (mid-surfaces; no sleeve solids: the simulation keeps no
    part geometry) coloured by ``field``: ``energy`` (strain-energy density, N·mm/mm², per element over
    its reference area), ``strain`` (each element's peak surface strain, %), ``mean_curvature`` (1/mm)
    or ``gaussian_curvature`` (1/mm²) (nodal fields averaged per triangle; a diverging map symmetric
    about 0). Title: name, h, radius, sphericity. Raises SpecError for another field."""
    from fabpat.errors import SpecError

    if field not in FIELD_LABELS:
        raise SpecError(f"png field must be one of {', '.join(FIELD_LABELS)}, got {field!r}")
    m, run = sim.model, sim.run
    n = len(m.X)
    x = positions(run)[:n]
    if field == "energy":
        energy = np.asarray(run.result.element_energy, dtype=np.float64).sum(axis=1)
        cell = energy / np.maximum(triangle_areas(m.X, m.F), 1e-300)
    elif field == "strain":
        cell = 100.0 * np.asarray(sim.element_strain, dtype=np.float64)
    else:
        cell = np.asarray(sim.curvature[field], dtype=np.float64)[m.F].mean(axis=1)
    signed = field.endswith("curvature")
    if signed:
        top = float(np.abs(cell).max()) or 1.0
        lo, hi, cmap = -top, top, "coolwarm"
    else:
        lo, hi, cmap = 0.0, float(cell.max()), COLOUR_MAP
    plates = []
    for p in range(len(m.plates)):
        nodes, elements = m.plate_slices(p)
        plates.append((x[nodes], m.F[elements] - nodes.start, cell[elements]))
    from fabpat.assembly.show.render import plain_text
    from fabpat.assembly.solve.closure import ClosureRun, sphere_text

    assert isinstance(run, ClosureRun)  # a closed kind is solved by run_closure
    title = (f"{plain_text(sim.name)}: closed by its sleeves (shell solver, h = {sim.h:g} mm), coloured by {field}\n"
             f"{sphere_text(run)}")
    _paint_png(plates, [], path, title, FIELD_LABELS[field], cmap, lo, hi, dpi)


def prediction_title(name: str, run: StripRun | ClosureRun, h: float) -> str:
    """Title of the predicted picture: what it is, radius and sphericity (a closure) or the arch's peak
    and height (a strip), peak strain."""
    from fabpat.assembly.show.render import plain_text
    from fabpat.assembly.solve.strip import StripRun

    name = plain_text(name)
    if isinstance(run, StripRun):
        return (f"{name}: predicted shape once its end pins push it together by {100 * run.end_shortening:g} % of "
                f"its length (shell solver, h = {h:g} mm)\npeak of the arch at {run.peak:.3f} of the length, "
                f"{run.max_deflection:.1f} mm high; peak strain {100 * run.peak_strain:.2f} % on "
                f"{run.peak_strain_plate} (limit {100 * run.strain_limit:.2f} %"
                + (f"; {len(run.over_limit)} plates over it)" if run.over_limit else ")"))
    from fabpat.assembly.solve.closure import sphere_text

    return (f"{name}: predicted shape once the sleeves close it (shell solver, h = {h:g} mm)\n"
            f"{sphere_text(run)}, peak strain {100 * run.peak_strain:.2f} % on "
            f"{run.peak_strain_plate} (limit {100 * run.strain_limit:.2f} %"
            + (f"; {len(run.over_limit)} plates over it)" if run.over_limit else ")"))
