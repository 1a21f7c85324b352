"""An assembly as one shell model: placed plate meshes joined by sleeves (paper §5, "full restraint").

Every plate keeps its own mesh and nodes (nothing is welded by merging): its flat mesh (polygon
frame, mm) is sent into 3D by the plate's rigid placement (:mod:`fabpat.assembly.place.placement`), and
its triangles keep their own local frames in the corotational solver.

**Sleeve joint**: each sleeve is one extra 6-dof node, the sleeve frame (origin at the sleeve's
centre, the joint's edge midpoint); every node of slot A's interface segment and of slot B's moves
rigidly with it (a rigid link, :mod:`fabpat.shell.rigid_links`: x_i = x_s + R_s Q_i r_i, R_i = R_s Q_i).
The sleeve is a printed part that grips both plates' necks along the whole slot, far stiffer than the
lacy plates, so it is modelled as rigid, by elimination: no penalty stiffness to choose, the
constraint holds to round-off and the system does not grow (the two plates' interface nodes are
replaced by one node). The measured check is in ``docs/assembly-solver.md``: on two coincident
segments a sleeve agrees with welding the meshes there to 0.1 % in energy.

**Sleeve angle**: Q_i = exp(±(λ α/2) [a]×), a the sleeve axis (its frame's X, along the edge): slot
B turns by +α/2 and slot A by −α/2 about the axis relative to the sleeve body, so at λ = 1 the angle
between the slots has changed by α (positive: B turns right-handed about a). α is ramped with the
load parameter; α = 0 is the as-printed sleeve.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.geometry.fillet import interface_half_length
from fabpat.geometry.polygons import triangle_areas
from fabpat.shell.element import Material
from fabpat.shell.rigid_links import LinkedProblem
from fabpat.shell.rotations import logmap
from fabpat.simulation.mesh import ShellMesh

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.assembly.place.placement import Assembly, PlateType
    from fabpat.assembly.spec.types import AssemblySpec
    from fabpat.geometry.fillet import FilletedPattern

Arr = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ModelPlate:
    """One plate: ``label``, its flat ``mesh`` (polygon frame, interfaces tagged) and ``transform``
    (4, 4) sending polygon-frame points (x, y, 0) of the mid-surface to the world (mm); ``thickness``
    (mm) its own, None: the model's ``material.t``."""

    label: str
    mesh: ShellMesh
    transform: Arr
    thickness: float | None = None


@dataclass(frozen=True, eq=False)
class ModelSleeve:
    """One sleeve: ``label``, ``frame`` (4, 4) its local frame in the world (origin at its centre, X
    along the joint's edge), ``slots`` ((plate index, interface index) of slot A, of slot B) and the
    change of the angle between its slots at λ = 1, ``angle`` (rad, about the frame's X)."""

    label: str
    frame: Arr
    slots: tuple[tuple[int, int], tuple[int, int]]
    angle: float = 0.0
    #: per slot (A, B), the rigid motion it makes relative to the sleeve body by λ = 1: a rotation
    #: vector (3,) rad and an offset (3,) mm, world reference axes (:class:`fabpat.shell.rigid_links.LinkedProblem`);
    #: None: the turn of ∓``angle``/2 about the frame's X. A plate placed off its slot (a tiling only
    #: nearly regular, :func:`slot_motions`) is brought into it this way
    motions: tuple[tuple[Arr, Arr], tuple[Arr, Arr]] | None = None


@dataclass(frozen=True, eq=False)
class AssemblyModel:
    """Placed plates + sleeves as one mesh. ``X`` (n, 3) world coordinates (mm) of every plate node,
    plate p's nodes at ``offsets[p]`` … ``offsets[p + 1]``; ``F`` (m, 3) triangles, plate p's at
    ``element_offsets[p]`` …; sleeve j is master node n + j. ``material`` is shared by all plates; a
    plate's own ``thickness`` replaces its ``t`` on that plate's elements (:attr:`element_thickness`)."""

    plates: tuple[ModelPlate, ...]
    sleeves: tuple[ModelSleeve, ...]
    material: Material
    X: Arr
    F: NDArray[np.int64]
    offsets: NDArray[np.int64]
    element_offsets: NDArray[np.int64]

    @property
    def n_nodes(self) -> int:
        """Plate nodes plus one node per sleeve."""
        return len(self.X) + len(self.sleeves)

    def nodes(self, plate: int, interface: int) -> NDArray[np.int64]:
        """Global node numbers of a plate's interface segment (ordered along the edge)."""
        return self.plates[plate].mesh.interfaces[interface] + self.offsets[plate]

    @property
    def plate_of_node(self) -> NDArray[np.int64]:
        """(n + s,) plate index of each node; sleeves get −1."""
        out = np.repeat(np.arange(len(self.plates)), np.diff(self.offsets))
        return np.concatenate([out, np.full(len(self.sleeves), -1)])

    def plate_slices(self, plate: int) -> tuple[slice, slice]:
        """Plate ``plate``'s nodes (rows of ``X``) and elements (rows of ``F``) as slices."""
        o, e = self.offsets, self.element_offsets
        return slice(int(o[plate]), int(o[plate + 1])), slice(int(e[plate]), int(e[plate + 1]))

    def per_plate(self, values: Arr, reduce: Callable[[Arr], Any] = np.sum) -> dict[str, float]:
        """{plate label: ``reduce`` of its elements' ``values``} for per-element ``values`` (m,): e.g. a plate's
        strain energy (N·mm, ``np.sum``) or its peak strain (``np.max``)."""
        return {p.label: float(reduce(values[self.plate_slices(i)[1]])) for i, p in enumerate(self.plates)}

    @property
    def element_thickness(self) -> Arr | None:
        """(m,) each element's thickness (mm) when a plate's own differs from ``material.t``, else None
        (every element has ``material.t``: the solver's numbers are then those of one material)."""
        own = [self.material.t if p.thickness is None else p.thickness for p in self.plates]
        if all(t == self.material.t for t in own):
            return None
        return np.repeat(np.array(own, dtype=np.float64), np.diff(self.element_offsets))

    @property
    def congruent(self) -> NDArray[np.int64]:
        """(m,) for each triangle the same triangle of the first plate of its mesh and thickness, the engine's
        hint that their reference data are equal (:mod:`fabpat.shell.congruent`): plates of one type share one
        mesh (:func:`plate_mesh`), and a placement is an isometry (of a flat mesh, a mirror image is a half
        turn). A plate whose transform is not one (a scale) keeps its own triangles."""
        out = np.arange(len(self.F), dtype=np.int64)
        first: dict[tuple[int, float], int] = {}
        for i, p in enumerate(self.plates):
            A = np.asarray(p.transform, dtype=np.float64)[:3, :3]
            if not np.allclose(A.T @ A, np.eye(3), rtol=0.0, atol=1e-12):
                continue
            key = (id(p.mesh), self.material.t if p.thickness is None else float(p.thickness))
            j = first.setdefault(key, i)
            a, b = self.element_offsets[i], self.element_offsets[i + 1]
            out[a:b] = np.arange(len(p.mesh.F), dtype=np.int64) + self.element_offsets[j]
        return out

    def links(self) -> tuple[NDArray[np.int64], NDArray[np.int64], Arr, NDArray[np.int64]]:
        """Slave nodes, their sleeve numbers, their relative spins at λ = 1 (k, 3) and their slot (0 A, 1 B)."""
        sl, ma, sp, slot, _ = self._links()
        return sl, ma, sp, slot

    def _links(self) -> tuple[NDArray[np.int64], NDArray[np.int64], Arr, NDArray[np.int64], Arr]:
        """:meth:`links` and the relative offsets at λ = 1 (k, 3) mm."""
        sl, ma, sp, slot, off = [], [], [], [], []
        for j, s in enumerate(self.sleeves):
            axis = s.frame[:3, 0] / np.linalg.norm(s.frame[:3, 0])
            for k, (p, i) in enumerate(s.slots):
                nd = self.nodes(p, i)
                sl.append(nd)
                ma.append(np.full(nd.size, j))
                if s.motions is None:
                    sp.append(np.tile((0.5 * s.angle if k else -0.5 * s.angle) * axis, (nd.size, 1)))
                    off.append(np.zeros((nd.size, 3)))
                else:
                    spin, shift = s.motions[k]
                    sp.append(np.tile(spin, (nd.size, 1)))
                    off.append(np.tile(shift, (nd.size, 1)))
                slot.append(np.full(nd.size, k))
        if not sl:
            z = np.zeros(0, np.int64)
            return z, z, np.zeros((0, 3)), z, np.zeros((0, 3))
        return np.concatenate(sl), np.concatenate(ma), np.vstack(sp), np.concatenate(slot), np.vstack(off)

    def problem(self, fixed: NDArray[np.bool_], prescribed: Arr, loads: Arr,
                dead_loads: Arr | None = None, dead_ramp: float = 0.0) -> LinkedProblem:
        """The linked shell problem with (n + s, 6) supports, prescribed values and loads (λ = 1), and
        ``dead_loads`` reached at λ = ``dead_ramp`` and held after it
        (:class:`fabpat.shell.rigid_links.LinkedProblem`); plates of one mesh share their triangles'
        reference data (:attr:`congruent`)."""
        sl, ma, sp, _, off = self._links()
        masters = np.array([s.frame[:3, 3] for s in self.sleeves]).reshape(-1, 3)
        return LinkedProblem(self.X, self.F, self.material, masters, sl, ma, sp, fixed, prescribed, loads, off,
                             dead_loads, dead_ramp, self.element_thickness, self.congruent)

    def surface_strains(self, x: Arr, R: Arr) -> Arr:
        """(m,) per element the peak surface strain (dimensionless, :func:`fabpat.shell.strain.surface_strains`)
        of the plates at node positions x (n, 3) mm and rotations R (n, 3, 3), from the compiled kernels'
        local dofs on the congruent triangles' shared data (:attr:`congruent`; no local stiffness per
        element). Raises GeometryError on a degenerate deformed triangle."""
        from fabpat.shell.congruent import CongruentTriangles

        tri = CongruentTriangles(self.X, self.F, self.material, self.congruent, thickness=self.element_thickness)
        return tri.surface_strains(x, R)

    def lumped_area(self) -> Arr:
        """(n,) nodal share of the plates' area (mm²), a third of each triangle's area."""
        tri = triangle_areas(self.X, self.F)
        return np.bincount(self.F.ravel(), np.repeat(tri / 3.0, 3), minlength=len(self.X))


#: Largest mesh edge h (mm) as a multiple of the interface segment's length 2d (3.75 mm on a 36 mm
#: hexagon): a sleeve grips the segment and the plate's load passes through the neck behind it, so
#: elements much larger than the segment cannot carry it (the mesher would still put 2 nodes on it)
MAX_H_PER_INTERFACE = 2.0


@lru_cache(maxsize=32)
def plate_mesh(pattern_id: str, sides: int, edge: float, weight: float, h: float,  # noqa: ANN201 - ShellMesh
               bridge_weight: float = 1.0):
    """The filleted pattern's mesh (target edge h, mm) with its interfaces tagged, cached per type and
    family member (``bridge_weight``, :mod:`fabpat.patterns.variation`); the pattern's depth is its ID's (a strip
    designed with ``[patterns] depth = 3`` has depth-3 plates).

    Raises GeometryError when an interface gets fewer than 2 nodes (h too coarse).
    """
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.patterns.variation import Variation
    from fabpat.simulation.mesh import mesh_outline

    outline = fillet_pattern(get_pattern(pattern_id, sides, None, edge), weight, Variation(bridge_weight)).outline
    return mesh_outline(outline, h, sides, edge, weight=weight)


def check_h(h: float, plate_edge: float, weight: float) -> None:
    """Raise GeometryError unless 0 < h ≤ ``MAX_H_PER_INTERFACE`` × the interface segment 2d (mm)."""
    # the interface segment's length 2d (fabpat.simulation.mesh.interface_segments)
    seg = 2.0 * interface_half_length(plate_edge, weight=weight)
    if not 0 < h <= MAX_H_PER_INTERFACE * seg:
        raise GeometryError(f"mesh too coarse for the interface: h = {h:g} mm, the interface segment is {seg:.3g} mm "
                            f"long; use h ≤ {math.floor(MAX_H_PER_INTERFACE * seg * 1000) / 1000:g} mm")


def model_plates(asm: Assembly, h: float, weight: float,
                 filleted: dict[PlateType, FilletedPattern] | None = None) -> list[ModelPlate]:
    """The placed plates of a kit's Assembly as model plates: each type meshed once (target edge h, mm),
    its mid-surface placed at half the thickness (mm) of the solid the placement maps, each plate of its
    own thickness (:attr:`~fabpat.assembly.place.placement.PlacedPlate.thickness`). ``filleted``:
    the kit's FilletedPattern per plate type, meshed instead of filleting the type again (the same
    outline: :func:`plate_mesh` fillets it as the kit does). A shaped plate (:mod:`fabpat.assembly.place.shaped`)
    meshes its own outline, its interfaces on its polygon's edges."""
    from fabpat.assembly.place.shaped import is_shaped, plate_outline
    from fabpat.simulation.mesh import mesh_outline

    plates = []
    own: dict[PlateType, ShellMesh] = {}
    for pl in asm.plates:
        if is_shaped(pl.type) and pl.type not in own:  # its outline carries its polygon: no common edge
            fp = filleted[pl.type] if filleted is not None and pl.type in filleted else plate_outline(
                pl.type, asm.plate_edge, weight, asm.spec.source)
            own[pl.type] = mesh_outline(fp.outline, h, pl.type.sides, None, weight=weight)
        if pl.type in own:
            mesh = own[pl.type]
        elif filleted is not None and pl.type in filleted:
            own[pl.type] = mesh_outline(filleted[pl.type].outline, h, pl.type.sides,
                                        asm.plate_edge, weight=weight)
            mesh = own[pl.type]
        else:
            mesh = plate_mesh(pl.type.pattern_id, pl.type.sides, asm.plate_edge, weight, h,
                              pl.type.bridge_weight)
        T = pl.transform.copy()
        T[:3, 3] += T[:3, 2] * (0.5 * pl.thickness)  # the transform maps the solid z ∈ [0, t]: mid-surface at t/2
        plates.append(ModelPlate(pl.label, mesh, T, pl.thickness))
    return plates


def plate_material(spec: AssemblySpec, E: float | None = None, nu: float | None = None) -> Material:
    """The plates' :class:`~fabpat.shell.element.Material` for every kind of assembly: Young's modulus ``E``
    (N/mm²) and Poisson's ratio ``nu``, each defaulting to the spec's ``[material]``
    (:class:`fabpat.assembly.spec.types.MaterialSpec`: 1000 N/mm² and 0.35, the scenarios' own), and the spec's
    plate thickness (mm; a plate of ``[plates] thicknesses`` has its own, :class:`ModelPlate`)."""
    m = spec.material
    return Material(m.youngs_modulus if E is None else E, m.poisson if nu is None else nu,
                    spec.plates.thickness)


def assembly_model(plates: list[ModelPlate], sleeves: list[ModelSleeve], material: Material) -> AssemblyModel:
    """Stack the placed plate meshes into one node/triangle set (no merging).

    Raises GeometryError if a sleeve's slot names an interface with fewer than 2 mesh nodes (a mesh too
    coarse for the interface), or if a plate interface is in two sleeves.
    """
    Xs, Fs, offs, eoffs = [], [], [0], [0]
    for p in plates:
        V = p.mesh.V
        P = np.column_stack([V, np.zeros(len(V)), np.ones(len(V))]) @ np.asarray(p.transform).T
        Xs.append(P[:, :3])
        Fs.append(p.mesh.F + offs[-1])
        offs.append(offs[-1] + len(V))
        eoffs.append(eoffs[-1] + len(p.mesh.F))
    used: set[tuple[int, int]] = set()
    for s in sleeves:
        for p, i in s.slots:
            if (p, i) in used:
                raise GeometryError(f"sleeve {s.label}: interface {i} of plate {plates[p].label} is already "
                                    "in a sleeve")
            used.add((p, i))
            if i >= len(plates[p].mesh.interfaces) or plates[p].mesh.interfaces[i].size < 2:
                raise GeometryError(f"sleeve {s.label}: interface {i} of plate {plates[p].label} has fewer than 2 "
                                    "mesh nodes (mesh too coarse for the interface: lower h)")
    return AssemblyModel(tuple(plates), tuple(sleeves), material, np.vstack(Xs), np.vstack(Fs),
                         np.array(offs, dtype=np.int64), np.array(eoffs, dtype=np.int64))


def sleeve_moments(model: AssemblyModel, x: Arr, link_forces: Arr) -> Arr:
    """(s,) magnitude of the moment (N·mm) each sleeve transmits from slot A to slot B, about its centre.

    x: (n + s, 3) deformed positions; link_forces: (k, 6) forces/moments the slot nodes' elements put
    on the links (:class:`fabpat.shell.linked.PathPoint`), in the order of :meth:`AssemblyModel.links`.
    """
    sl, ma, _, slot = model.links()
    n = len(model.X)
    c = x[sl] - x[n + ma]
    m = link_forces[:, 3:] + np.cross(c, link_forces[:, :3])
    out = np.zeros((len(model.sleeves), 3))
    a = slot == 0
    np.add.at(out, ma[a], m[a])
    return np.linalg.norm(out, axis=1)


#: largest peak surface strain a solved assembly may show and still be reported: the shell element's
#: material is linear elastic in small strains (fabpat.shell.element), so beyond a few per cent its
#: energies are a model's, not a plastic's; 20 % is ten times PLA's yield strain (the default
#: ``[material] strain_limit``), far past anything a kit could be built to, yet above every result of
#: the shipped specs (at most 3.5 %, the 1 × 3 test strip at 10 % end shortening)
PLAUSIBLE_STRAIN = 0.2


def check_plausible(model: AssemblyModel, energy: float, displacement: Arr, peak_strain: float, what: str) -> None:
    """Raise SolverError unless a solved assembly is plausible: finite and within the displacement bound
    of the scenarios (:func:`fabpat.simulation.scenarios.check_plausible`, nonlinear: at most twice the assembly's
    size, the diagonal of its plates' bounding box, mm), and with a peak surface strain (dimensionless)
    at most :data:`PLAUSIBLE_STRAIN`. ``displacement`` (N, ≥ 3) is the nodes' final displacement (mm);
    ``what`` starts the message."""
    from fabpat.errors import SolverError
    from fabpat.simulation.scenarios import check_plausible as check_scenario

    n = len(model.X)
    size = float(np.linalg.norm(np.ptp(model.X, axis=0)))
    moved = float(np.linalg.norm(np.asarray(displacement)[:n, :3], axis=1).max()) if n else 0.0
    check_scenario(energy, moved, size, True, what)
    if not peak_strain <= PLAUSIBLE_STRAIN:  # NaN too
        raise SolverError(f"{what}: a peak surface strain of {100 * peak_strain:.3g} % is outside the validity of the "
                          f"small-strain shell model (at most {100 * PLAUSIBLE_STRAIN:g} %): the material is far too "
                          "soft for the load (material.youngs_modulus, --youngs-modulus) or the plates far too thick")


#: degree of the polynomial field over a plate's plane that carries a changed plate's state
WARM_DEGREE = 3


def _monomials(u: Arr, wrt: int | None = None) -> Arr:
    """(n, k) the monomials u^i v^j, i + j ≤ :data:`WARM_DEGREE`, of plane coordinates u (n, 2), or their
    derivatives with respect to u (``wrt`` = 0) or v (1)."""
    def mono(i: int, j: int) -> Arr:
        if wrt is None:
            return u[:, 0] ** i * u[:, 1] ** j
        if wrt == 0:
            return i * u[:, 0] ** max(i - 1, 0) * u[:, 1] ** j
        return j * u[:, 0] ** i * u[:, 1] ** max(j - 1, 0)

    return np.column_stack([mono(i, j) for i in range(WARM_DEGREE + 1) for j in range(WARM_DEGREE + 1 - i)])


def warm_guess(old_X: Arr, old_offsets: NDArray[np.int64], displacement: Arr, rotation: Arr, new_X: Arr,
               new_offsets: NDArray[np.int64]) -> tuple[Arr, Arr]:
    """A warm start for :func:`fabpat.shell.linked.solve_path` from the equilibrium of a similar assembly:
    the same plates in the same places (the same tiling), some with another pattern (another mesh).

    ``old_X`` (n, 3) and ``new_X`` (n', 3) the reference plate nodes (mm), ``*_offsets`` (plates + 1,)
    each plate's first node; ``displacement`` and ``rotation`` (n + s, 3) the old state (mm, rotation
    vectors rad), plate nodes then the s sleeve nodes. A plate whose nodes are unchanged keeps its state;
    another gets the old plate's displacement as a least-squares polynomial field of degree
    :data:`WARM_DEGREE` over the plate's plane and, at each node, the polar rotation of that field's
    deformation gradient; the sleeve nodes keep theirs. Returns the guess (n' + s, 3) × 2.
    Raises GeometryError if the two models do not have the same plates and sleeves."""
    s = len(displacement) - int(old_offsets[-1])
    if len(old_offsets) != len(new_offsets) or s < 0 or len(rotation) != len(displacement):
        raise GeometryError("a warm start needs an assembly of the same tiling: the plates or sleeves differ")
    n_new = int(new_offsets[-1])
    U, W = np.zeros((n_new + s, 3)), np.zeros((n_new + s, 3))
    U[n_new:], W[n_new:] = displacement[int(old_offsets[-1]):], rotation[int(old_offsets[-1]):]
    for i in range(len(new_offsets) - 1):
        a, b = int(old_offsets[i]), int(old_offsets[i + 1])
        c, d = int(new_offsets[i]), int(new_offsets[i + 1])
        if b - a == d - c and np.array_equal(old_X[a:b], new_X[c:d]):
            U[c:d], W[c:d] = displacement[a:b], rotation[a:b]
            continue
        # a changed pattern: the old plate's displacement as a smooth field over the plate's plane
        # (least-squares polynomial of degree WARM_DEGREE), and each node's rotation the polar rotation of
        # that field's deformation gradient, so that the two agree (a node-by-node copy of either puts
        # kinks into the new mesh's bars)
        c0 = old_X[a:b].mean(axis=0)
        axes = np.linalg.svd(old_X[a:b] - c0, full_matrices=False)[2][:2]
        scale = max(float(np.abs((old_X[a:b] - c0) @ axes.T).max()), 1e-12)
        coef = np.linalg.lstsq(_monomials((old_X[a:b] - c0) @ axes.T / scale), displacement[a:b], rcond=None)[0]
        uv = (new_X[c:d] - c0) @ axes.T / scale
        U[c:d] = _monomials(uv) @ coef
        du, dv = (_monomials(uv, wrt) @ coef / scale for wrt in (0, 1))  # (k, 3) ∂u/∂ξ, ∂u/∂η (per mm)
        t1, t2 = axes[0] + du, axes[1] + dv
        nrm = np.cross(t1, t2)
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        Fd = np.stack([t1, t2, nrm], axis=2)  # deformed triad (columns)
        E = np.stack([axes[0], axes[1], np.cross(axes[0], axes[1])], axis=1)  # reference triad (columns)
        Uu, _, Vt = np.linalg.svd(Fd @ E.T)
        W[c:d] = logmap(Uu @ Vt)
    return U, W
