"""What the user will get: the predicted bent assembly of a closure run, as a GLB, a PNG and a mesh.

With sleeves printed at an angle other than the joint's dihedral (``[sleeve] angle``), the flat plates
bend when the sleeves close the object (:mod:`fabpat.assembly.closure`). This module turns a
:class:`~fabpat.assembly.closure.ClosureRun` into plain data (:class:`PredictedShape`) and writes it:

* **Plates**: the solver's deformed mid-surface per plate (``run.x[:n]`` and the model's triangles split
  by ``element_offsets``), thickened by ±t/2 along each node's director (the plate normal turned by
  the node's rotation, ``expmap(rotation) @ n₀``: the shell's own kinematics) into a closed shell
  with side walls on the mesh boundary, so slicers and CAD open it as a solid per plate.
* **Colour**: strain-energy density, each element's energy over its area (N·mm/mm², the reference
  area), averaged to the vertices with area weights for smooth colouring, one colour map
  (:data:`COLOUR_MAP`, perceptually uniform) from 0 to the largest vertex value.
* **Sleeves on the deformed joints**: sleeve j's body is the master node ``n + j``; its pose is
  ``[R_s · F | x_s]`` with ``R_s = expmap(rotation[n + j])`` and ``F`` the placement frame's rotation.
  The model's slots turn by ∓α/2 (α = dihedral − sleeve angle) about the frame's X relative to the
  body (:mod:`fabpat.assembly.model`), so at λ = 1 the slots lie at the printed sleeve angle,
  symmetric about the frame's Z: the printed sleeve solid (``Sleeve(angle).solid()``) placed by that
  pose grips the deformed interfaces exactly (:func:`joint_fit` measures it, mm).

Writers (not atomic: :mod:`fabpat.assembly.build` writes into a temporary folder):
:func:`write_predicted_glb` (``assembly.glb``), :func:`render_predicted_png` (``assembly.png``),
:func:`write_predicted_stl` (``predicted.stl``) and :func:`prediction_record` (``prediction.json``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

Arr = NDArray[np.float64]

#: matplotlib colour map of the strain-energy density (perceptually uniform, readable in grey)
COLOUR_MAP = "viridis"
DENSITY_UNIT = "N·mm/mm²"


@dataclass(frozen=True, eq=False)
class PredictedPlate:
    """One deformed plate: ``label`` ("H01"), ``key`` its part key ("hex 0x0488"); mid-surface ``V``
    (n, 3) mm and ``F`` (m, 3); unit directors ``N`` (n, 3); ``density`` (m,) element strain-energy
    density and ``vertex_density`` (n,) its area-weighted vertex average (N·mm/mm²)."""

    label: str
    key: str
    V: Arr
    F: NDArray[np.int64]
    N: Arr
    density: Arr
    vertex_density: Arr


@dataclass(frozen=True, eq=False)
class PredictedShape:
    """The assembled object as predicted: ``plates``; ``sleeves`` one (label, part key, pose (4, 4))
    per sleeve; ``thickness`` (mm); ``density_range`` (lo, hi) of the colour map (N·mm/mm²); and the
    closure's ``radius`` (mm), ``sphericity_rms``/``sphericity_max`` (fractions of the radius)."""

    plates: tuple[PredictedPlate, ...]
    sleeves: tuple[tuple[str, str, Arr], ...]
    thickness: float
    density_range: tuple[float, float]
    radius: float
    sphericity_rms: float
    sphericity_max: float


def _areas(P: Arr, F: NDArray[np.int64]) -> Arr:
    A = P[F]
    return 0.5 * np.linalg.norm(np.cross(A[:, 1] - A[:, 0], A[:, 2] - A[:, 0]), axis=1)


def sleeve_poses(run: Any) -> list[Arr]:
    """(4, 4) pose of every sleeve body at λ = 1: ``[expmap(θ_s) · frame rotation | x_s]`` (mm)."""
    from fabpat.shell.rotations import expmap

    m = run.setup.model
    n = len(m.X)
    out = []
    for j, s in enumerate(m.sleeves):
        T = np.eye(4)
        T[:3, :3] = expmap(run.result.final.rotation[n + j]) @ np.asarray(s.frame)[:3, :3]
        T[:3, 3] = run.x[n + j]
        out.append(T)
    return out


def predicted_shape(run: Any, assembly: Any) -> PredictedShape:
    """The deformed plates and placed sleeves of a ClosureRun of ``assembly`` (plain arrays, mm).

    ``assembly`` (:class:`~fabpat.assembly.placement.Assembly`) gives each plate's part key and each
    sleeve's kind; its plates and sleeves are in the model's order (``closure_setup`` builds both).
    """
    from fabpat.shell.rotations import expmap

    m = run.setup.model
    n = len(m.X)
    energy = np.asarray(run.result.element_energy, dtype=np.float64).sum(axis=1)
    area0 = _areas(m.X, m.F)
    dens = energy / np.maximum(area0, 1e-300)
    R = expmap(run.result.final.rotation[:n])
    plates = []
    for p, mp in enumerate(m.plates):
        a, b = int(m.offsets[p]), int(m.offsets[p + 1])
        ea, eb = int(m.element_offsets[p]), int(m.element_offsets[p + 1])
        F = m.F[ea:eb] - a
        n0 = np.asarray(mp.transform)[:3, 2]
        N = R[a:b] @ n0
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        w = np.bincount(F.ravel(), np.repeat(area0[ea:eb], 3), minlength=b - a)
        vd = np.bincount(F.ravel(), np.repeat(area0[ea:eb] * dens[ea:eb], 3), minlength=b - a) / np.maximum(w, 1e-300)
        plates.append(PredictedPlate(mp.label, assembly.plates[p].type.label, run.x[a:b].copy(), F, N,
                                     dens[ea:eb].copy(), vd))
    hi = max(float(pl.vertex_density.max()) for pl in plates) if plates else 0.0
    sleeves = tuple((s.label, ps.kind, T) for s, ps, T in zip(m.sleeves, assembly.sleeves, sleeve_poses(run),
                                                              strict=True))
    return PredictedShape(tuple(plates), sleeves, float(m.material.t), (0.0, hi), float(run.radius),
                          float(run.sphericity_rms), float(run.sphericity_max))


def joint_fit(run: Any, sleeve_types: dict[str, Any], kinds: list[str]) -> tuple[float, float]:
    """How well the printed sleeves, placed by :func:`sleeve_poses`, grip the deformed plates (mm).

    For every sleeve (kind ``kinds[j]``, type ``sleeve_types[kind]``, a :class:`Sleeve` at the printed
    angle) and both slots: the interface nodes of the slot's plate, in the sleeve's frame. Returns
    (largest distance of a node from its slot's mid-plane, largest distance of a node outside its slot
    along the slot's length and depth; 0 when every node lies within the slot). Both are round-off
    when the sleeve fits.
    """
    m = run.setup.model
    plane, outside = 0.0, 0.0
    for j, (s, T) in enumerate(zip(m.sleeves, sleeve_poses(run), strict=True)):
        sl = sleeve_types[kinds[j]]
        for side, (p, i) in enumerate(s.slots):
            L = (run.x[m.nodes(p, i)] - T[:3, 3]) @ T[:3, :3]  # world → sleeve frame
            YZ = L[:, 1:]
            plane = max(plane, float(np.abs(YZ @ sl.plate_normal(side)).max()))
            depth = YZ @ sl.direction(side)
            lo, hi = sl.setback - 0.5 * sl.clearance, sl.arm_end
            outside = max(outside, float(np.maximum(lo - depth, 0).max()), float(np.maximum(depth - hi, 0).max()),
                          float(np.maximum(np.abs(L[:, 0]) - 0.5 * sl.slot_length, 0).max()))
    return plane, outside


# -- meshes -------------------------------------------------------------------------------------------


def boundary_edges(F: NDArray[np.int64]) -> NDArray[np.int64]:
    """(k, 2) directed edges used by exactly one triangle, in that triangle's orientation."""
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = np.sort(E, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return E[counts[inv.reshape(-1)] == 1]


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


def solid_meshes(shape: PredictedShape, lib: Any, tolerance: float) -> list[tuple[str, Arr, NDArray[np.int64]]]:
    """(label, V (mm), F) of every predicted part as a closed mesh: thickened plates, then placed sleeves
    (``lib`` a :class:`PartLibrary` whose sleeve types are the printed ones, meshed within ``tolerance`` mm)."""
    from fabpat.assembly.parts import apply

    out = [(pl.label, *thickened(pl.V, pl.F, pl.N, shape.thickness)) for pl in shape.plates]
    for label, key, T in shape.sleeves:
        V, F = lib.mesh(key, tolerance)
        out.append((label, apply(T, V), F))
    return out


# -- writers ------------------------------------------------------------------------------------------


def predicted_scene(shape: PredictedShape, lib: Any, name: str, tolerance: float):  # type: ignore[no-untyped-def]
    """``trimesh.Scene`` in metres: one mesh per plate (its own deformed, thickened geometry, vertex
    colours of the strain-energy density, named by its label) and one shared mesh per sleeve kind
    placed by one node per sleeve (named by its label). The colour map's range is in the scene's
    extras (``density_range``, ``density_unit``, ``colour_map``) and in the root node's name."""
    import trimesh

    from fabpat.assembly.export import GLB_UNIT, SLEEVE_COLOUR, slug, srgb_to_linear

    lo, hi = shape.density_range
    sc = trimesh.Scene()
    root = f"{name} predicted (strain-energy density {lo:.3g}–{hi:.3g} {DENSITY_UNIT})"
    sc.graph.update(frame_from=sc.graph.base_frame, frame_to=root, matrix=np.eye(4))
    for pl in shape.plates:
        W, F = thickened(pl.V, pl.F, pl.N, shape.thickness)
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
    sc.metadata.update({"density_range": [lo, hi], "density_unit": DENSITY_UNIT, "colour_map": COLOUR_MAP,
                        "radius_mm": shape.radius, "sphericity_rms": shape.sphericity_rms,
                        "sphericity_max": shape.sphericity_max})
    return sc


def write_predicted_glb(shape: PredictedShape, lib: Any, path: str | os.PathLike[str], name: str,
                        tolerance: float) -> None:
    """The predicted object as binary glTF 2.0 (metres), see :func:`predicted_scene`. Plates are closed
    shells ±t/2 about the deformed mid-surface (so a viewer shows their thickness from both sides).
    Raises :class:`fabpat.io.WriteFailed` if the file cannot be written."""
    from fabpat.io import writer_failed

    data = predicted_scene(shape, lib, name, tolerance).export(file_type="glb", include_normals=False)
    try:
        Path(path).write_bytes(data)
    except OSError as exc:
        raise writer_failed(path, "cannot write the GLB file", exc) from exc


def write_predicted_stl(shape: PredictedShape, lib: Any, path: str | os.PathLike[str], tolerance: float) -> int:
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


def render_predicted_png(shape: PredictedShape, lib: Any, path: str | os.PathLike[str], title: str,
                         dpi: int = 110) -> None:
    """Draw the predicted object (painter's projection of :mod:`fabpat.assembly.render`): plates
    coloured by strain-energy density with a colour bar, sleeves grey; ``title`` on top."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    from fabpat.assembly.export import SLEEVE_COLOUR
    from fabpat.assembly.parts import PICTURE_TOLERANCE, apply
    from fabpat.assembly.render import _camera, _hex, draw, project

    C = _camera(np.array([1.0, -1.4, 0.9]))
    lo, hi = shape.density_range
    items = []
    for pl in shape.plates:  # the mid-surface, both sides visible (no culling)
        face = pl.vertex_density[pl.F].mean(axis=1)
        items.append((pl.V, pl.F, colour_of(face, lo, hi)[:, :3], False))
    grey = _hex(SLEEVE_COLOUR)
    for _, key, T in shape.sleeves:
        V, F = lib.mesh(key, PICTURE_TOLERANCE)
        items.append((apply(T, V), F, np.tile(grey, (len(F), 1)), True))
    fig, ax = plt.subplots(figsize=(9.5, 8.0))
    draw(ax, *project(items, C))
    sm = ScalarMappable(norm=Normalize(lo, hi if hi > lo else lo + 1.0), cmap=COLOUR_MAP)
    fig.colorbar(sm, ax=ax, shrink=0.7, label=f"strain-energy density ({DENSITY_UNIT})")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(os.fspath(path), dpi=dpi, format="png")
    plt.close(fig)


def prediction_title(name: str, run: Any, h: float) -> str:
    """Title of the predicted picture: what it is, radius, sphericity, peak strain."""
    return (f"{name}: predicted shape once the sleeves close it (shell solver, h = {h:g} mm)\n"
            f"radius {run.radius:.2f} mm, sphericity rms {100 * run.sphericity_rms:.2f} % "
            f"(max {100 * run.sphericity_max:.2f} %), peak strain {100 * run.peak_strain:.2f} % on "
            f"{run.peak_strain_plate} (limit {100 * run.strain_limit:.2f} %"
            + (f"; {len(run.over_limit)} plates over it)" if run.over_limit else ")"))


def prediction_record(run: Any, seconds: float, h: float) -> dict[str, Any]:
    """The ``prediction.json`` fields (those of ``fabpat simulate-assembly`` on a closed spec): counts,
    solver effort, energies (N·mm), sleeve moments (N·mm), reaction (N), lengths (mm), strains."""
    m = run.setup.model
    r = run.result
    return {
        "converged": True, "plates": len(m.plates), "sleeves": len(m.sleeves), "nodes": m.n_nodes,
        "dofs": r.dofs, "iterations": r.iterations, "seconds": round(seconds, 3), "energy": run.energy,
        "plate_energies": run.plate_energies, "sleeve_moments": run.sleeve_moments, "reaction": run.reaction,
        "max_deflection": run.max_deflection, "radius": run.radius, "sphericity_rms": run.sphericity_rms,
        "sphericity_max": run.sphericity_max, "peak_strain": run.peak_strain,
        "peak_strain_plate": run.peak_strain_plate, "strain_limit": run.strain_limit,
        "over_limit": list(run.over_limit), "h": h, "path": run.path,
    }

