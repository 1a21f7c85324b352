"""Where every part goes: plates on the faces of a skeleton tiling, sleeves on its shared edges.

Plates of polygon edge ``e`` (the spec's edge) cannot sit exactly on a polyhedron of edge ``e``: at a
folded joint two 2 mm plates meeting at the edge line would overlap on the concave side, and the
sleeve needs a web between its slots. So the **skeleton** (the tiling whose faces carry the plates)
has a slightly longer edge ``E`` and each plate sits centred in its face, its mid-surface on the face
plane, every polygon edge parallel to the skeleton edge and set back by ``g_n = (E − e) / (2 tan(π/n))``
(the difference of the apothems). ``E`` is the smallest value for which every sleeve's web is at
least the wall thickness (:func:`skeleton_edge`). Sleeves are symmetric: both slots are set back by the
smaller ``g`` of the joint, so a sleeve cannot be mounted the wrong way round; the plate with the
larger setback simply enters a fraction of a millimetre less deep.

Sleeves are printed at the spec's ``[sleeve] angle`` (:func:`fabpat.assembly.spec.load.sleeve_angle`):
each joint's dihedral (a rigid polyhedron of flat plates), 180° (straight sleeves that bend the plates
when they close the sphere, paper §5) or one angle in between. Joints whose sleeves are printed at the
same angle share ONE part, set back by the smallest ``g`` of all those joints, and the same rule
holds across joints: a plate with a larger setback enters a fraction of a millimetre less deep
(:func:`check_geometry` bounds ``sleeve.depth`` by that spread). So the sphere with straight sleeves
has a single sleeve part, "S-flat", the same part as a strip's. The sleeve's *frame* still comes from
the skeleton: every plate lies on its face of the polyhedron, the closure solver's start state, and
each :class:`PlacedSleeve` carries both the joint's skeleton ``dihedral`` and its printed ``angle``
(the solver closes the joint by ``dihedral − angle``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.sleeve import Sleeve
from fabpat.assembly.spec.load import ANGLE_STEP, RADIUS_KINDS, AssemblySpec, sleeve_angle
from fabpat.assembly.surface.joints import joint_direction, joint_labels, min_plate_edge, setback, skeleton_edge
from fabpat.assembly.surface.tiling import FACE_LETTERS, Tiling, mean_distance
from fabpat.errors import GeometryError, SpecError
from fabpat.geometry.fillet import interface_half_length
from fabpat.patterns.variation import Variation

SHORT_NAMES = {3: "tri", 4: "quad", 5: "pent", 6: "hex"}
#: degrees: on a tiling whose joints of one polygon pair have several dihedral angles (a mesh), sleeves
#: printed at the joints' angles are one part per angle rounded to this step; a joint then closes by
#: the rest (at most half a step, 0.05°), which the closure solver models like any sleeve angle
DIHEDRAL_STEP = ANGLE_STEP


@dataclass(frozen=True)
class PlateType:
    """One distinct plate: polygon ``sides``, pattern ID and family member (``bridge_weight``, the
    paper's 1 by default; :mod:`fabpat.patterns.variation`); ``label`` like "hex 0x0488" or "hex 0x0488 b0.5".
    ``thickness`` (mm) is set when the spec gives plates their own thicknesses (``[plates] thicknesses``):
    plates of different thickness are then different parts, "hex 0x0488 t1.1"; None: the spec's one
    ``plates.thickness``."""

    sides: int
    pattern_id: str
    bridge_weight: float = 1.0
    thickness: float | None = None

    @property
    def label(self) -> str:
        """Part key shown everywhere: polygon short name, pattern ID and, for a family member, its
        bridge_weight, e.g. ``"hex 0x0488"``, ``"hex 0x0488 b0.5"``, and a thickness of its own in mm
        (``"hex 0x0488 t1.1"``)."""
        tag = self.variation.tag()
        return (f"{SHORT_NAMES.get(self.sides, f'{self.sides}-gon')} {self.pattern_id}" + (f" {tag}" if tag else "")
                + (f" t{self.thickness:g}" if self.thickness is not None else ""))

    @property
    def variation(self) -> Variation:
        """The family member as a :class:`~fabpat.patterns.variation.Variation`."""
        return Variation(self.bridge_weight)

    @property
    def depth(self) -> int:
        """Subdivision depth from the ID's length (1, 4 or 16 hex digits → 1, 2, 3)."""
        return {1: 1, 4: 2, 16: 3}[len(self.pattern_id) - 2]


@dataclass(frozen=True, eq=False)
class PlacedPlate:
    """Plate ``label`` on face ``face``: ``transform`` (4, 4) maps its solid (z from 0 to t) to the world.

    ``edge_labels[i]``: the joint label on polygon edge i ("E07"), "PIN" for a pinned end, "" if free;
    ``thickness`` (mm): the plate's (``[plates] thickness``, or its entry of ``thicknesses``).
    """

    label: str
    face: int
    type: PlateType
    transform: NDArray[np.float64]
    edge_labels: tuple[str, ...]
    thickness: float = 2.0


@dataclass(frozen=True, eq=False)
class PlacedSleeve:
    """Sleeve ``label`` (the joint's label) on skeleton edge ``edge``.

    ``kind``: key of its :class:`Sleeve` type; ``transform`` (4, 4) maps the sleeve's local frame to
    the world, oriented by the skeleton's ``dihedral`` (so slot A points along plate A as placed);
    ``plates``: ((plate index, polygon edge) of slot A, same for slot B). ``dihedral`` (rad) is the
    joint's interior dihedral angle on the skeleton, ``angle`` (rad) the angle its sleeve is printed at
    (:func:`fabpat.assembly.spec.load.sleeve_angle`); closing the joint changes it by ``dihedral − angle``.
    """

    label: str
    edge: int
    kind: str
    transform: NDArray[np.float64]
    plates: tuple[tuple[int, int], tuple[int, int]]
    dihedral: float
    angle: float


@dataclass(frozen=True, eq=False)
class Assembly:
    """Every part of the assembly, placed. Lengths in mm."""

    spec: AssemblySpec
    skeleton: Tiling
    plate_edge: float
    plates: tuple[PlacedPlate, ...]
    sleeves: tuple[PlacedSleeve, ...]
    sleeve_types: dict[str, Sleeve]
    pins: tuple[tuple[int, int], ...] = field(default=())

    @cached_property
    def plate_types(self) -> tuple[PlateType, ...]:
        """Distinct plates, in order of first use."""
        return tuple(dict.fromkeys(p.type for p in self.plates))

    def type_thickness(self, pt: PlateType) -> float:
        """The thickness (mm) of plate type ``pt``'s solid: its own, else ``plates.thickness``."""
        return self.spec.plates.thickness if pt.thickness is None else pt.thickness

    def counts(self) -> dict[str, int]:
        """How many of each distinct part (plate type label or sleeve kind)."""
        out: dict[str, int] = {}
        for p in self.plates:
            out[p.type.label] = out.get(p.type.label, 0) + 1
        for s in self.sleeves:
            out[s.kind] = out.get(s.kind, 0) + 1
        return out

    def placed_radius(self, axis: NDArray[np.float64] | None = None) -> float:
        """Mean distance (mm) of the plates' mid-surfaces, as placed, from the skeleton's centre (or its
        ``axis``): :func:`fabpat.assembly.surface.tiling.mean_distance` of the plates' polygons (what
        ``tiling.radius`` asks for)."""
        from fabpat.patterns.lattice import polygon_vertices

        loops = []
        for p in self.plates:
            C = polygon_vertices(p.type.sides, self.plate_edge)
            Q = np.column_stack([C, np.full(len(C), 0.5 * p.thickness), np.ones(len(C))])
            loops.append((p.transform @ Q.T).T[:, :3])
        return mean_distance(loops, self.skeleton.V.mean(axis=0), axis)


def build_tiling(spec: AssemblySpec) -> Tiling:
    """The unit skeleton of the spec (edge 1; scaled once the sleeve geometry fixes ``E``)."""
    return spec.tiling.skeleton()


def _pair_name(skel: Tiling, k: int) -> str:
    """The polygon pair of joint k, largest first, by face letter ("HH", "HP"; a polygon without a letter
    by its sides, "8Q")."""
    ns = sorted((len(skel.faces[f]) for f, _ in skel.edge_faces[k]), reverse=True)
    return "".join(FACE_LETTERS.get(n, str(n)) for n in ns)


def joint_thickness(spec: AssemblySpec, skel: Tiling, k: int) -> float:
    """The slot thickness (mm) of the sleeve on interior edge k: the thicker of its two plates
    (``[plates] thicknesses``). Both slots are that thickness + clearance wide, so the sleeve stays
    symmetric (it cannot be mounted the wrong way round) and the thinner plate has the difference as
    extra play; the plates' mid-surfaces stay on the slots' mid-planes."""
    return max(spec.plates.thickness_of(skel.labels[int(f)]) for f, _ in skel.edge_faces[k])


def sleeve_kinds(spec: AssemblySpec, skel: Tiling) -> dict[int, tuple[str, float, float]]:
    """Interior edge k → (sleeve part key, skeleton dihedral rad, printed angle rad).

    One key per printed angle: "S-flat" at 180°; at each joint's dihedral the polygon pair names it
    ("S-HH", "S-HP") when all its joints share one angle (printed at it) or one angle rounded to
    :data:`DIHEDRAL_STEP` (printed at that), else the rounded angle joins it ("S-HH-141.3deg"); one number
    of degrees in between gives one part, e.g. "S-160deg". A joint listed in ``[sleeve] angles`` is printed
    at its own angle rounded to :data:`DIHEDRAL_STEP` (:meth:`~fabpat.assembly.spec.types.SleeveSpec.listed_angle`),
    one part per rounded angle ("S-171.3deg", "S-flat" at 180°), whatever ``[sleeve] angle`` says. A slot
    thickness other than ``plates.thickness`` (:func:`joint_thickness`) is a part of its own: "S-HH-t1.1".
    """
    labels = joint_labels(skel)
    pairs: dict[str, list[float]] = {}
    for k in skel.interior_edges:
        if spec.sleeve.listed_angle(labels[int(k)]) is None:
            pairs.setdefault(_pair_name(skel, int(k)), []).append(float(skel.dihedral[k]))
    single = {pair for pair, phis in pairs.items() if max(phis) - min(phis) < 1e-9}
    one_bin = {pair for pair, phis in pairs.items()
               if len({round(math.degrees(p) / DIHEDRAL_STEP) for p in phis}) == 1}
    out = {}
    for k in skel.interior_edges:
        phi = float(skel.dihedral[k])
        listed = spec.sleeve.listed_angle(labels[int(k)])
        angle = sleeve_angle(spec, phi)
        pair = _pair_name(skel, int(k))
        if listed is not None:
            key, angle = ("flat", math.pi) if listed >= 180.0 else (f"{listed:g}deg", math.radians(listed))
        elif abs(angle - math.pi) < 1e-9:
            key = "flat"
        elif spec.sleeve.angle != "dihedral":
            key = f"{math.degrees(angle):g}deg"
        elif pair in single:
            key = pair
        else:
            step = min(DIHEDRAL_STEP * round(math.degrees(phi) / DIHEDRAL_STEP), 180.0)
            name = pair if pair in one_bin else f"{pair}-{step:.1f}deg"
            key, angle = (name, math.radians(step)) if step < 180.0 else ("flat", math.pi)
        t = joint_thickness(spec, skel, int(k))
        if t != spec.plates.thickness:
            key += f"-t{t:g}"
        out[int(k)] = (f"S-{key}", phi, angle)
    return out


def printed_angles(spec: AssemblySpec, skel: Tiling) -> dict[int, float]:
    """Interior edge k → the angle (rad) its sleeve part is printed at, as :func:`sleeve_kinds` prints it
    (for :func:`~fabpat.assembly.surface.joints.skeleton_edge`): on a mesh whose joints of one polygon pair
    differ, the dihedral rounded to :data:`DIHEDRAL_STEP`; a joint of ``[sleeve] angles``, its own angle.
    The skeleton edge must leave the web at that angle, not only at the exact one: an angle rounded down
    needs a larger setback (a cube sheared by 5 % has joints of 87.1376°, printed at 87.1°, whose web the
    exact angle's edge leaves 0.001 mm too thin)."""
    return {k: angle for k, (_, _, angle) in sleeve_kinds(spec, skel).items()}


def _setbacks(skel: Tiling, k: int, edge: float, plate: float) -> list[float]:
    """The setbacks (mm) of the two plates at edge k of a skeleton of edge ``edge``."""
    return [setback(len(skel.faces[f]), edge, plate) for f, _ in skel.edge_faces[k]]


def _sleeve_frame(skel: Tiling, k: int) -> NDArray[np.float64]:
    """(4, 4) sleeve local → world for edge k, slot A towards the edge's first face, at the skeleton's dihedral."""
    a, b = skel.edges[k]
    (fa, _), (fb, _) = skel.edge_faces[k]
    m = 0.5 * (skel.V[a] + skel.V[b])
    X = skel.V[b] - skel.V[a]
    X /= np.linalg.norm(X)
    Z = skel.normals[fa] + skel.normals[fb]
    Z -= (Z @ X) * X  # on a best-fit tiling the faces' normals are not quite square to the edge: a skewed frame
    Z /= np.linalg.norm(Z)
    into_a = skel.centroids[fa] - m
    into_a -= (into_a @ X) * X
    into_a /= np.linalg.norm(into_a)
    dA = joint_direction(float(skel.dihedral[k]), 0)
    if into_a @ np.cross(Z, X) < 0.0:
        X = -X  # the other orientation of the edge puts slot A on face fa
    Y = np.cross(Z, X)
    # on a best-fit tiling the faces only nearly meet the sleeve's slots: the closure takes up the rest
    if not skel.best_fit and np.linalg.norm(into_a - (dA[0] * Y + dA[1] * Z)) > 1e-6:
        raise AssertionError(f"cannot orient the sleeve of edge {k}")
    T = np.eye(4)
    T[:3, :3] = np.stack([X, Y, Z], axis=1)
    T[:3, 3] = m
    return T


def end_interfaces(skel: Tiling) -> list[tuple[int, int]]:
    """(face, polygon edge) of the free interfaces at both ends of a strip (first and last column)."""
    if skel.grid is None:
        return []
    last = int(skel.grid[:, 1].max())
    out = []
    for k in skel.boundary_edges:
        f, i = (int(x) for x in skel.edge_faces[k, 0])
        col = int(skel.grid[f, 1])
        # Flat-topped hexagon: edges 4, 5 face −x (left end), edges 1, 2 face +x (right end).
        if (col == 0 and i in (4, 5)) or (col == last and i in (1, 2)):
            out.append((f, i))
    return out


#: an interface segment shorter than this many STL chords (output.mesh_tolerance) is not resolved by the
#: parts' meshes (the kit's solids stop being closed manifolds, issue 15 §7)
MIN_INTERFACE_CHORDS = 10.0


def check_interface_chords(spec: AssemblySpec) -> None:
    """Refuse (SpecError naming ``plates.weight`` and its range) a weight that makes the interface segment
    2 · edge / 16 / (1 + w) (:func:`fabpat.geometry.fillet.interface_half_length`) shorter than
    :data:`MIN_INTERFACE_CHORDS` STL chords (``output.mesh_tolerance``): a part's mesh would not resolve it.
    A kit's plates and a one-piece panel alike."""
    e, w = spec.tiling.edge, spec.plates.weight
    seg_min = MIN_INTERFACE_CHORDS * spec.mesh_tolerance
    w_max = 2.0 * interface_half_length(e, weight=0.0) / seg_min - 1.0
    if w > w_max:
        raise SpecError(f"{spec.source}: plates.weight = {w:g} must be in (0, {w_max:.4g}]: a larger weight makes "
                        f"the interface segment ({2.0 * interface_half_length(e, weight=w):.3g} mm) shorter than "
                        f"{MIN_INTERFACE_CHORDS:g} × output.mesh_tolerance = {seg_min:g} mm")


def check_geometry(spec: AssemblySpec) -> None:
    """Refuse, before any work, spec values the kit's geometry cannot take; each :class:`SpecError`
    names the key and its valid range (mm), derived from the other keys:

    * ``tiling.edge`` ≥ (``sleeve.margin`` + 2 × ``sleeve.wall``) / (1 − 1 / (8 (1 + w))): a sleeve (the
      interface segment 2 · edge / 16 / (1 + w), :func:`fabpat.geometry.fillet.interface_half_length`, plus the
      margin and its two end walls) must fit on the plate's edge;
    * ``plates.weight`` ≤ edge / (8 · 10 · ``output.mesh_tolerance``) − 1: the interface segment must be
      at least :data:`MIN_INTERFACE_CHORDS` STL chords long;
    * ``sleeve.depth`` ≥ (largest − smallest plate setback over the joints sharing one sleeve part) +
      ``sleeve.wall``: the plate with the larger setback (module docstring) still enters its slot by at
      least a wall's thickness.
    """
    s, e, w, src = spec.sleeve, spec.tiling.edge, spec.plates.weight, spec.source
    e_min = min_plate_edge(s.margin, s.wall, w)
    if e < e_min:
        given = (f"tiling.radius = {spec.tiling.radius:g} mm makes the plate edge {e:.4g} mm, which"
                 if spec.tiling.radius is not None else f"tiling.edge = {e:g} mm")
        raise SpecError(f"{src}: {given} must be ≥ {e_min:.3g} mm: a sleeve (interface segment + "
                        f"sleeve.margin = {s.margin:g} + 2 × sleeve.wall = {s.wall:g}) must fit on the plate's edge")
    check_interface_chords(spec)
    unit = build_tiling(spec)
    E = skeleton_edge(unit, e, spec.plates.thickest, s.clearance, s.wall, printed_angles(spec, unit))
    lo: dict[str, float] = {}
    hi: dict[str, float] = {}
    for k, (key, _, _) in sleeve_kinds(spec, unit).items():
        g = _setbacks(unit, k, E, e)
        lo[key], hi[key] = min(lo.get(key, math.inf), *g), max(hi.get(key, 0.0), *g)
    spread = max((hi[key] - lo[key] for key in lo), default=0.0)
    d_min = spread + s.wall
    if s.depth < d_min - 1e-9:
        why = (f"the plates' setbacks differ by {spread:.3g} mm on one sleeve part, and " if spread > 0 else "")
        raise SpecError(f"{src}: sleeve.depth = {s.depth:g} mm must be ≥ {d_min:.3g} mm: {why}every plate must "
                        f"enter its slot by at least sleeve.wall = {s.wall:g} mm (the upper limit is the plate's "
                        "neck, checked next)")


def _bridge_weight(spec: AssemblySpec, face: int) -> float:
    """The spec's family member of face ``face`` (1, the paper's, when it gives none or no patterns)."""
    return spec.patterns.bridge_weight_of(face) if spec.patterns is not None else 1.0


def place(spec: AssemblySpec, face_patterns: list[str]) -> Assembly:
    """Place one plate per face (pattern ``face_patterns[f]``) and one sleeve per shared edge. A spec of shaped
    plates (``tiling.plates = "shaped"``) is placed by :func:`fabpat.assembly.place.shaped.place_assembly`,
    which shapes this placement's plates and sleeves."""
    unit = build_tiling(spec)
    if len(face_patterns) != len(unit.faces):
        raise ValueError(f"need {len(unit.faces)} pattern IDs, got {len(face_patterns)}")
    s = spec.sleeve
    e = spec.tiling.edge
    E = skeleton_edge(unit, e, spec.plates.thickest, s.clearance, s.wall, printed_angles(spec, unit))
    skel = unit.scaled(E)
    slot_length = 2.0 * interface_half_length(e, weight=spec.plates.weight) + s.margin  # segment 2d + margin

    kind_of = sleeve_kinds(spec, skel)
    g_of: dict[str, float] = {}  # one part per key, set back by the smallest setback of all its joints
    for k, (key, _, _) in kind_of.items():
        g_of[key] = min(g_of.get(key, math.inf), *_setbacks(skel, k, E, e))
    kinds: dict[str, Sleeve] = {}
    for k, (key, phi, angle) in kind_of.items():
        if key not in kinds:
            try:
                kinds[key] = Sleeve(angle, g_of[key], joint_thickness(spec, skel, k), s.clearance, slot_length,
                                    s.wall, s.depth)
            except GeometryError as err:  # the skeleton edge leaves every web: a bug if it is reached
                a, b = (int(v) + 1 for v in skel.edges[k])
                raise GeometryError(f"{spec.source}: sleeve part {key} (first at the edge between vertices {a} and "
                                    f"{b}, dihedral {math.degrees(phi):.4f}°, printed at "
                                    f"{math.degrees(angle):.4f}°): {err}") from None

    joint = joint_labels(skel)
    pins = end_interfaces(skel)
    pin_set = set(pins)
    own = bool(spec.plates.thicknesses)  # plates of their own thickness: distinct parts by thickness
    frames = skel.frames()
    plates = []
    for f, loop in enumerate(skel.faces):
        edge_labels = tuple(
            joint.get(k, "PIN" if (f, i) in pin_set else "") for i, k in enumerate(skel.face_edges[f])
        )
        t = spec.plates.thickness_of(skel.labels[f])
        shift = np.eye(4)
        shift[2, 3] = -0.5 * t  # plate solids span z ∈ [0, t]: centre the mid-surface on the face plane
        plates.append(PlacedPlate(skel.labels[f], f, PlateType(len(loop), face_patterns[f], _bridge_weight(spec, f),
                                                               t if own else None),
                                  frames[f] @ shift, edge_labels, t))
    sleeves = []
    for k in skel.interior_edges:
        key, phi, angle = kind_of[int(k)]
        (fa, ia), (fb, ib) = (tuple(int(x) for x in pair) for pair in skel.edge_faces[k])
        sleeves.append(PlacedSleeve(joint[int(k)], int(k), key, _sleeve_frame(skel, int(k)),
                                    ((fa, ia), (fb, ib)), phi, angle))
    return Assembly(spec, skel, e, tuple(plates), tuple(sleeves), kinds, tuple(pins))


def radius_line(assembly: Assembly) -> str:
    """The check line of a kit sized by ``tiling.radius``: the plate edge it chose and where the plates
    lie as placed (:meth:`Assembly.placed_radius`; straight sleeves move them as they close)."""
    spec = assembly.spec
    axis = RADIUS_KINDS[spec.tiling.kind]
    got = assembly.placed_radius(None if axis is None else np.array(axis))
    where = "the centre" if axis is None else "the axis"
    line = (f"tiling.radius = {spec.tiling.radius:g} mm: plate edge {assembly.plate_edge:.4f} mm puts the plates' "
            f"mid-surfaces {got:.4f} mm from {where} as placed")
    if spec.sleeve.angle != "dihedral":
        line += "; the sleeves bend them as they close (the prediction's radius says where they end)"
    return line

