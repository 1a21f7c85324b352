"""Checks of an assembled kit: counts, sleeves on the interface midpoints, no part inside another.

The interference test meshes each distinct part once (0.02 mm chords), places copies with the
assembly's transforms and intersects every pair whose bounding boxes overlap with manifold3d's
exact mesh booleans. Plates must not intersect each other or any sleeve, and sleeves must not
intersect each other; the smallest plate–sleeve gap is reported (the slot clearance, 0.1 mm a side
by default).

A sleeve printed at another angle than its joint's skeleton dihedral (``[sleeve] angle = "flat"`` on
the sphere) cannot hold both plates as placed on the polyhedron: the plates bend near the joint when
the sleeves close it. Each of its two plates is therefore checked against the sleeve turned about the
joint's edge onto that plate (:func:`bent_sleeve_transform`), the joint as it is put together; the
closure solver predicts the shape after that.

On a best-fit tiling (``tiling.fit = "best"``: faces only nearly regular) no placement holds both
plates of a joint in their slots, so every joint is checked from each side in turn: the sleeve seated
on that plate (:func:`slot_frame`); :func:`placement_mismatch` says how far the placement misses, and
the prediction's grip check (:func:`fabpat.assembly.solve.predict.grip_problems`) that the closed shape puts
every plate in both of its slots.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.necks import neck_advice
from fabpat.assembly.place.parts import CHECK_TOLERANCE, PartLibrary, apply
from fabpat.assembly.place.placement import Assembly, PlacedSleeve, setback
from fabpat.assembly.surface.joints import joint_direction, joint_normal
from fabpat.errors import GeometryError
from fabpat.geometry.shaped import ShapedPattern
from fabpat.validate import SAME_POINT

if TYPE_CHECKING:
    import manifold3d

OVERLAP_VOLUME = 1e-6  # mm³: intersections below this are rounding, not material
GAP_SEARCH = 1.0  # mm: how far manifold3d looks for the smallest gap between a plate and a sleeve


@dataclass(frozen=True)
class CheckReport:
    """What :func:`check_assembly` measured. Lengths mm, volumes mm³."""

    plates: int
    sleeves: int
    vertices: int
    edges: int
    pairs_tested: int
    max_overlap: float
    min_plate_sleeve_gap: float
    midpoint_error: float
    min_insertion: float
    #: :func:`shallow_warnings`: plates that enter their slots much less than ``sleeve.depth``
    shallow: tuple[str, ...] = ()
    #: a best-fit tiling's :func:`placement_mismatch` (mm, rad); None on an exact tiling
    mismatch: tuple[float, float] | None = None

    def lines(self) -> list[str]:
        """The report as the lines `fabpat assemble` prints and the manifest stores. A kit without
        sleeves (a single face) has no gap, slot or insertion to measure: its lines say so instead of
        an infinite gap."""
        head = [f"{self.plates} plates, {self.sleeves} sleeves, {self.vertices} skeleton vertices, {self.edges} edges",
                f"{self.pairs_tested} part pairs intersected: largest overlap {self.max_overlap:.2e} mm³"]
        if self.sleeves == 0:
            return [*head, "no sleeves (one plate, no shared edge): no plate–sleeve gap, slot or insertion depth "
                           "to check"]
        lines = [*head, f"smallest plate–sleeve gap {self.min_plate_sleeve_gap:.3f} mm",
                 f"sleeves on interface midpoints within {self.midpoint_error:.1e} mm; "
                 f"plates enter their slots ≥ {self.min_insertion:.2f} mm"]
        if self.mismatch is not None:
            lines[2:4] = [f"{lines[2]}, each joint checked as put together (the sleeve seated on one plate at a "
                          "time: the plates sit at their faces' best fit)", f"{lines[3]} (seated)",
                          f"best-fit placement: slots up to {self.mismatch[0]:.3g} mm and "
                          f"{math.degrees(self.mismatch[1]):.3g}° from their plates' interfaces as placed; the "
                          "closure takes that up (the predicted shape's grip check below)"]
        return lines


def expected_counts(assembly: Assembly) -> tuple[int, int]:
    """(plates, sleeves) the tiling calls for: one plate per face, one sleeve per shared edge."""
    t = assembly.skeleton
    return len(t.faces), len(t.interior_edges)


def check_counts(assembly: Assembly) -> None:
    """Raise :class:`GeometryError` unless there is one plate per face and one sleeve per shared edge."""
    plates, sleeves = expected_counts(assembly)
    if (len(assembly.plates), len(assembly.sleeves)) != (plates, sleeves):
        raise GeometryError(f"assembly has {len(assembly.plates)} plates and {len(assembly.sleeves)} sleeves, "
                            f"the tiling needs {plates} and {sleeves}")
    if assembly.skeleton.name == "truncated-icosahedron":
        t = assembly.skeleton
        got = (len(t.V), len(t.edges), int((t.sides == 6).sum()), int((t.sides == 5).sum()))
        if got != (60, 90, 20, 12):
            raise GeometryError(f"truncated icosahedron has (V, E, hexagons, pentagons) = {got}, not (60, 90, 20, 12)")


#: a plate entering its slot less than this fraction of ``sleeve.depth`` is named in a warning
#: (:func:`shallow_warnings`); the shipped sphere's hexagons enter 2.76 of 3 mm (92 %), a hexagonal
#: prism's hexagons 1.50 of 3 mm (50 %: a hexagon's setback is 1.73 times a square's on the same part)
SHALLOW_FRACTION = 0.75


def _slot_tolerance(asm: Assembly) -> float:
    """mm: how far a plate's interface midpoint may be off its slot's centre line. An exact tiling's
    plates sit on it (:data:`fabpat.validate.SAME_POINT`, round-off); a mesh file's faces are regular only within
    ``tiling.tolerance``, which moves a plate's interface by up to about twice that, but never more
    than the slot's play across the plate (``sleeve.clearance`` / 2) lets it fit."""
    if asm.spec.tiling.kind != "mesh":
        return SAME_POINT
    return max(SAME_POINT, min(2.0 * asm.spec.tiling.tolerance, 0.5 * asm.spec.sleeve.clearance))


def _off_slot(asm: Assembly, s: PlacedSleeve, plate_index: int, off: float, along: float) -> GeometryError:
    """The error of a plate whose interface is ``off`` mm from sleeve ``s``'s slot (``along`` mm from the
    edge): on a mesh file it names the face, the edge and the regularity check that would refuse it."""
    plate = asm.plates[plate_index]
    spec = asm.spec
    if spec.tiling.kind != "mesh":
        return GeometryError(f"sleeve {s.label} is not on the interface midpoint of plate {plate.label} "
                             f"(off by {off:.3g} mm, {along:.3f} mm from the edge)")
    from fabpat.assembly.surface.mesh_tiling import regular_deviation

    unit = spec.tiling.skeleton()
    loop = unit.faces[plate.face]
    plane, _, corner, _ = regular_deviation(unit.V[list(loop)] * spec.tiling.edge, spec.tiling.edge)
    worst = max(plane, corner)
    a, b = (int(v) + 1 for v in unit.edges[s.edge])
    tol = _slot_tolerance(asm)
    takes = (f"sleeve.clearance / 2 = {tol:.3g} mm" if tol >= 0.5 * spec.sleeve.clearance else
             f"{tol:.3g} mm, 2 × tiling.tolerance")
    return GeometryError(
        f"{spec.tiling.file}: face {plate.face + 1} (plate {plate.label}) sits {off:.3g} mm off the slot of sleeve "
        f"{s.label} at the edge between vertices {a} and {b}, more than the slot takes ({takes}): its corners are "
        f"{worst:.3g} mm from a regular {len(loop)}-gon of edge {spec.tiling.edge:.4g} mm, which tiling.tolerance = "
        f"{spec.tiling.tolerance:g} mm let through; the mesh check refuses the face at tiling.tolerance < {worst:.3g} "
        "mm (or give fit = \"best\" and let `fabpat simulate-assembly` close the mismatch)")


def _slot_midpoints(lib: PartLibrary) -> Iterator[tuple[PlacedSleeve, int, int, NDArray[np.float64]]]:
    """Every (sleeve, side, plate index, the plate's interface midpoint in the sleeve's frame (3,) mm), in
    the sleeves' order: what the slot checks measure. On a best-fit tiling the frame is the sleeve seated
    on that plate (:func:`slot_frame`)."""
    asm = lib.assembly
    for s in asm.sleeves:
        for side, (p, _) in enumerate(s.plates):
            inv = np.linalg.inv(slot_frame(lib, s, side))
            yield s, side, p, apply(inv, _interface_frame(lib, s, side)[0][None])[0]


def _interface_frame(lib: PartLibrary, s: PlacedSleeve, side: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(midpoint (3,) mm, axes (3, 3) as columns: along the edge, into the plate, its normal) of the interface
    of sleeve ``s``'s plate ``side`` at mid-thickness, in the world as placed; the axes' signs follow the
    sleeve's frame (edge line X, the slot's direction and its normal at the joint's dihedral)."""
    asm = lib.assembly
    p, i = s.plates[side]
    plate = asm.plates[p]
    seg = lib.filleted[plate.type].interface_segments[i]
    mid = apply(plate.transform, np.array([[*seg.mean(axis=0), 0.5 * plate.thickness]]))[0]
    R, T = plate.transform[:3, :3], s.transform[:3, :3]
    d, n = joint_direction(s.dihedral, side), joint_normal(s.dihedral, side)
    along = R @ np.array([*(seg[-1] - seg[0]), 0.0])
    along /= np.linalg.norm(along)
    normal = R[:, 2]
    along *= np.sign(along @ T[:, 0])
    normal *= np.sign(normal @ (T[:, 1:] @ n))
    into = np.cross(normal, along)
    into *= np.sign(into @ (T[:, 1:] @ d))
    return mid, np.stack([along, into, normal], axis=1)


def _seat(lib: PartLibrary, s: PlacedSleeve, side: int) -> NDArray[np.float64]:
    """(4, 4) the rigid motion that takes slot ``side`` of sleeve ``s`` as placed onto its plate's interface:
    the slot's centre line through the interface midpoint, its direction into the plate and its plane the
    plate's mid-plane. The identity (to round-off) on an exact tiling; on a best-fit tiling the placement's
    mismatch at that slot, which the closure takes up."""
    asm = lib.assembly
    plate = asm.plates[s.plates[side][0]]
    d, n = joint_direction(s.dihedral, side), joint_normal(s.dihedral, side)
    expect = setback(plate.type.sides, asm.skeleton.edge_length(), asm.plate_edge)
    T = s.transform
    slot_origin = apply(T, np.array([[0.0, *(expect * d)]]))[0]
    slot_axes = np.stack([T[:3, 0], T[:3, 1:3] @ d, T[:3, 1:3] @ n], axis=1)
    mid, axes = _interface_frame(lib, s, side)
    C = np.eye(4)
    C[:3, :3] = axes @ slot_axes.T
    C[:3, 3] = mid - C[:3, :3] @ slot_origin
    return C


def seated(asm: Assembly) -> bool:
    """Whether the kit is checked joint by joint with each sleeve seated on one plate at a time
    (:func:`slot_frame`): a tiling placed at its faces' best fit (``tiling.fit = "best"``). A mesh file
    with ``fit = "exact"`` is placed the same way but must sit in its slots as placed (its plates may be
    off by ``tiling.tolerance`` at most, :func:`_slot_tolerance`)."""
    return asm.spec.tiling.fit == "best"


def slot_frame(lib: PartLibrary, s: PlacedSleeve, side: int) -> NDArray[np.float64]:
    """(4, 4) sleeve local → world at the joint's dihedral, as slot ``side`` meets its plate.

    On an exact tiling this is ``s.transform``: both plates sit on the sleeve's slots as placed. On a
    best-fit tiling (``tiling.fit = "best"``, Goldberg spheres) the plates sit only near their faces and
    the sleeve cannot meet both as placed; the kit is checked joint by joint as it is put together — the
    sleeve seated on each of its plates in turn (:func:`_seat`) — and the closure predicts the shape that
    puts both sides in their slots at once (the prediction's grip check)."""
    if not seated(lib.assembly):
        return s.transform
    return _seat(lib, s, side) @ s.transform


def placement_mismatch(lib: PartLibrary) -> tuple[float, float]:
    """(largest distance mm, largest angle rad) between a slot as placed and its plate's interface (the
    :func:`_seat` motions): zero to round-off on an exact tiling; on a best-fit tiling what the closure
    closes."""
    dist, angle = 0.0, 0.0
    for s in lib.assembly.sleeves:
        for side in (0, 1):
            C = _seat(lib, s, side)
            cos = float(np.clip(0.5 * (np.trace(C[:3, :3]) - 1.0), -1.0, 1.0))
            mid = _interface_frame(lib, s, side)[0]
            # C takes the slot's point on the centre line as placed to the midpoint: C⁻¹ gives it back
            dist = max(dist, float(np.linalg.norm(apply(np.linalg.inv(C), mid[None])[0] - mid)))
            angle = max(angle, math.acos(cos))
    return dist, angle


def insertion_depths(lib: PartLibrary) -> list[tuple[float, str, str, str]]:
    """How deep (mm) each plate enters each of its slots: (depth, plate label, sleeve label, sleeve part),
    one per plate and sleeve, in the sleeves' order."""
    asm = lib.assembly
    return [(asm.sleeve_types[s.kind].arm_end - float(local[1:] @ joint_direction(s.dihedral, side)),
             asm.plates[p].label, s.label, s.kind) for s, side, p, local in _slot_midpoints(lib)]


def shallow_warnings(lib: PartLibrary) -> list[str]:
    """One line per sleeve part on which a plate enters its slot less than :data:`SHALLOW_FRACTION` ×
    ``sleeve.depth``: the shallowest plate and sleeve, the depth reached, how many slots are that
    shallow, and the ``sleeve.depth`` that would seat that plate as deep as asked (neck check
    permitting). A sleeve part is symmetric and set back by its joints' smallest setback
    (:mod:`fabpat.assembly.place.placement`): a polygon with a larger setback (a hexagon beside a square)
    enters less deep."""
    depth = lib.assembly.spec.sleeve.depth
    by_part: dict[str, list[tuple[float, str, str, str]]] = {}
    for rec in insertion_depths(lib):
        if rec[0] < SHALLOW_FRACTION * depth - 1e-9:
            by_part.setdefault(rec[3], []).append(rec)
    out = []
    for part, recs in by_part.items():
        d, plate, sleeve, _ = min(recs)
        out.append(f"plate {plate} enters its slot in sleeve {sleeve} ({part}) only {d:.2f} mm of sleeve.depth = "
                   f"{depth:g} mm ({len(recs)} slot(s) of {part} less than {100 * SHALLOW_FRACTION:g} %): its "
                   f"setback is larger than that part's; sleeve.depth = {2 * depth - d:.2f} would seat it "
                   f"{depth:g} mm (if the necks allow)")
    return out


def interface_midpoints(lib: PartLibrary) -> tuple[float, float]:
    """(largest offset of an interface midpoint from its slot's centre line, smallest insertion depth), mm.

    In the sleeve's frame, a plate's interface midpoint must lie on the slot's centre line (X = 0 and on
    the slot's mid-plane) between the slot bottom and its mouth; its distance to the mouth is how deep
    the plate enters. Raises :class:`GeometryError` if a midpoint is off the line (by more than
    :func:`_slot_tolerance`; on a mesh file naming the face, the edge and the tolerance that would
    refuse the face) or outside the slot. A shaped plate's interface need not be centred in its slot
    (:mod:`fabpat.assembly.place.shaped`): it must lie inside it with ``sleeve.margin / 2`` to spare at each
    end (:func:`~fabpat.assembly.place.shaped.slot_excess` counts as the offset). The slot lines are taken
    at the joint's skeleton dihedral (where the plates are placed): a sleeve printed at another angle turns
    about the edge line onto each plate, which keeps those distances.
    """
    from fabpat.assembly.place.shaped import is_shaped, slot_excess

    asm = lib.assembly
    tol = _slot_tolerance(asm)
    worst, shallow = 0.0, math.inf
    for s, side, p, local in _slot_midpoints(lib):
        sleeve, plate = asm.sleeve_types[s.kind], asm.plates[p]
        d, n = joint_direction(s.dihedral, side), joint_normal(s.dihedral, side)
        along = float(local[1:] @ d)
        x = abs(local[0])
        if is_shaped(plate.type):  # off-centre by design: inside the slot with the margin to spare
            shaped = lib.filleted[plate.type]
            assert isinstance(shaped, ShapedPattern)  # a shaped plate type is filleted in its own polygon
            half = float(shaped.interface_half_lengths[s.plates[side][1]])
            x = slot_excess(asm, s, side, float(local[0]), half)
        off = max(x, abs(float(local[1:] @ n)))
        expect = setback(plate.type.sides, asm.skeleton.edge_length(), asm.plate_edge)
        off = max(off, abs(along - expect))
        worst = max(worst, off)
        if off > tol:
            raise _off_slot(asm, s, p, off, along)
        if not (sleeve.setback - tol <= along < sleeve.arm_end):
            raise GeometryError(f"sleeve {s.label} is not on the interface midpoint of plate {plate.label} "
                                f"(off by {off:.3g} mm, {along:.3f} mm from the edge)")
        shallow = min(shallow, sleeve.arm_end - along)
    return worst, shallow


def _manifold(V: NDArray[np.float64], F: NDArray[np.int64]) -> manifold3d.Manifold:
    import manifold3d

    m = manifold3d.Manifold(manifold3d.Mesh64(vert_properties=np.ascontiguousarray(V, dtype=np.float64),
                                              tri_verts=np.ascontiguousarray(F, dtype=np.uint64)))
    if m.status() != manifold3d.Error.NoError:
        raise GeometryError(f"a part's mesh is not a closed 2-manifold ({m.status()})")
    return m


def bent_sleeve_transform(sleeve: PlacedSleeve, side: int) -> NDArray[np.float64]:
    """(4, 4) sleeve local → world with the sleeve turned about its edge line (local X) so that slot
    ``side``, printed at ``sleeve.angle``, points along plate ``side`` as placed at ``sleeve.dihedral``.

    Equal to ``sleeve.transform`` when the two angles agree.
    """
    a, b = joint_direction(sleeve.angle, side), joint_direction(sleeve.dihedral, side)
    beta = math.atan2(a[0] * b[1] - a[1] * b[0], a @ b)  # signed angle from a to b in the (Y, Z) plane
    R = np.eye(4)
    R[1:3, 1:3] = [[math.cos(beta), -math.sin(beta)], [math.sin(beta), math.cos(beta)]]
    return sleeve.transform @ R


def intersections(lib: PartLibrary, tolerance: float = CHECK_TOLERANCE) -> tuple[int, float, float]:
    """(pairs tested, largest overlap volume mm³, smallest plate–sleeve gap mm) over all placed parts.

    A sleeve printed at another angle than its joint's dihedral meets each of its own two plates
    turned onto it (:func:`bent_sleeve_transform`); every other pair is tested as placed.
    Raises :class:`GeometryError` naming the first pair of parts that overlap by more than
    :data:`OVERLAP_VOLUME`.
    """
    base = {key: lib.mesh(key, tolerance) for key in lib.keys}
    protos = {key: _manifold(*vf) for key, vf in base.items()}
    asm = lib.assembly
    turned = {}  # (sleeve label, plate label) → the sleeve turned onto that plate, for bent joints only
    for s in asm.sleeves:
        if abs(s.angle - s.dihedral) > 1e-12 or seated(asm):
            for side, (p, _) in enumerate(s.plates):
                T = slot_frame(lib, s, side) @ np.linalg.inv(s.transform) @ bent_sleeve_transform(s, side)
                turned[s.label, asm.plates[p].label] = protos[s.kind].transform(T[:3, :4])
    items = []
    for label, key, T in lib.placed():
        W = apply(T, base[key][0])
        items.append((label, lib.is_plate(key), protos[key].transform(T[:3, :4]), W.min(axis=0), W.max(axis=0)))
    tested, worst, gap = 0, 0.0, math.inf
    for a in range(len(items)):
        la, pa, ma, loa, hia = items[a]
        for b in range(a + 1, len(items)):
            lb, pb, mb, lob, hib = items[b]
            if np.any(loa > hib + GAP_SEARCH) or np.any(lob > hia + GAP_SEARCH):
                continue
            tested += 1
            if (lb, la) in turned:  # plates come first in lib.placed(): a is the plate, b the sleeve
                mb = turned[lb, la]
            vol = (ma ^ mb).volume()
            worst = max(worst, vol)
            if vol > OVERLAP_VOLUME:
                hint = (": the plate's neck reaches the sleeve's end wall at the slot's mouth — "
                        f"{neck_advice(asm, lib.filleted)}" if pa != pb else "")
                raise GeometryError(f"parts {la} and {lb} intersect ({vol:.3g} mm³){hint}")
            if pa != pb:
                gap = min(gap, ma.min_gap(mb, GAP_SEARCH))
    return tested, worst, gap


def check_assembly(lib: PartLibrary) -> CheckReport:
    """Every check above; raises :class:`GeometryError` on the first failure."""
    asm = lib.assembly
    check_counts(asm)
    err, depth = interface_midpoints(lib) if asm.sleeves else (0.0, math.inf)
    tested, worst, gap = intersections(lib)
    t = asm.skeleton
    mismatch = placement_mismatch(lib) if seated(asm) else None
    return CheckReport(len(asm.plates), len(asm.sleeves), len(t.V), len(t.edges), tested, worst, gap, err, depth,
                       tuple(shallow_warnings(lib)), mismatch)
