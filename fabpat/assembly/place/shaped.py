"""Shaped plates placed: on a mesh with ``[tiling] plates = "shaped"`` every plate is its own face's polygon.

**The plate**: in its face's plane (the frame of :meth:`~fabpat.assembly.surface.tiling.Tiling.frames`, as a
regular plate's), the face polygon of the skeleton with every edge moved inward by the plate's setback
``g_n = (E − e) / (2 tan(π/n))`` (:func:`~fabpat.assembly.surface.joints.setback`: on a regular face, exactly
the regular plate), so that each sleeve's web and slots fit as on a regular kit: the skeleton edge ``E``, the
setbacks and the sleeve parts are computed as there (:mod:`fabpat.assembly.place.placement`, the faces' mean
edge standing for the edge, :class:`~fabpat.assembly.surface.shaped.ShapedTiling`). The pattern is mapped
into that polygon by :func:`~fabpat.geometry.shaped.shape_pattern` (exact: rational Béziers). Every shaped
plate is its own part type, :class:`ShapedPlateType`, named by its face label ("H07 0x0488").

**The sleeve**: moving the edges of a face whose corner angles differ moves its edge midpoints along the
edge too, by ``g/2 (cot(α_i/2) − cot(α_{i+1}/2))`` for corner angles α, and a plate's interface is
centred on its own edge's midpoint with its own half-length ``interface_half_length(L_i)``. The two
plates of a joint therefore put their interfaces at slightly different places along the joint. Each
sleeve is centred on the middle of the two interfaces' union (along the edge), and each sleeve part's
slot is that union's longest length over its joints plus ``sleeve.margin``: every interface lies in its
slot with at least ``margin / 2`` to spare at each end, as on a regular kit (where the union is the
segment itself and nothing moves). The slot being longer, the sleeve must still fit on both plates'
edges: :func:`shaped_assembly` refuses (SpecError, naming the joint and the plate) a sleeve that reaches
past either end of one of its plates' edges. Measured on planar Goldberg polyhedra GP(2, 0) … GP(4, 0)
and :func:`fabpat.design.remesh.relax` outputs (``docs/tilings.md``): the midpoints of a joint's two
interfaces lie at most a few tenths of a millimetre apart at a 36 mm edge.

A regular plate keeps :class:`~fabpat.assembly.place.placement.PlateType` and its behaviour.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.placement import Assembly, PlacedSleeve, PlateType, place
from fabpat.assembly.spec.types import AssemblySpec
from fabpat.assembly.surface.joints import setback
from fabpat.assembly.surface.shaped import inset
from fabpat.errors import GeometryError, SpecError
from fabpat.geometry.fillet import interface_half_length


@dataclass(frozen=True)
class ShapedPlateType(PlateType):
    """A plate of its own face's polygon: ``face_label`` ("H07") and ``corners`` ((n, 2) mm, the plate
    polygon in its frame, counter-clockwise, corner i on the skeleton's face corner i); label like
    "H07 0x0488" (and the family member's tag)."""

    face_label: str = ""
    corners: tuple[tuple[float, float], ...] = ()

    @property
    def label(self) -> str:
        """Part key: the face label, the pattern ID and, for a family member, its tag: ``"H07 0x0488"``."""
        tag = self.variation.tag()
        return f"{self.face_label} {self.pattern_id}" + (f" {tag}" if tag else "")

    @property
    def polygon(self) -> NDArray[np.float64]:
        """(n, 2) mm: the plate polygon in its frame."""
        return np.array(self.corners, dtype=np.float64)


def is_shaped(pt: PlateType) -> bool:
    """True for a :class:`ShapedPlateType`."""
    return isinstance(pt, ShapedPlateType)


def plate_corners(pt: PlateType, edge: float) -> NDArray[np.float64]:
    """(n, 2) mm: the plate's polygon in its frame, a shaped plate's own or the regular n-gon of ``edge`` mm
    (:func:`~fabpat.patterns.lattice.polygon_vertices`)."""
    if isinstance(pt, ShapedPlateType):
        return pt.polygon
    from fabpat.patterns.lattice import polygon_vertices

    return polygon_vertices(pt.sides, edge)


def plate_outline(pt: PlateType, edge: float, weight: float, source: str = "") -> Any:
    """The exact outline of plate type ``pt``: its pattern filleted in the regular n-gon of ``edge`` mm
    (:func:`~fabpat.geometry.fillet.fillet_pattern`) or, shaped, in its own polygon
    (:func:`~fabpat.geometry.shaped.shape_pattern`), with interface weight ``weight``. Raises
    :class:`SpecError` (one line naming ``source`` and the face) when a shaped polygon is refused."""
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.geometry.shaped import shape_pattern
    from fabpat.patterns.library import get_pattern

    pattern = get_pattern(pt.pattern_id, pt.sides, pt.depth, edge)
    if not isinstance(pt, ShapedPlateType):
        return fillet_pattern(pattern, weight, pt.variation)
    try:
        return shape_pattern(pattern, pt.polygon, weight, pt.variation)
    except GeometryError as e:
        raise SpecError(f"{source}: plate {pt.label} (its face's polygon moved in by the setback): {e}") from None


def _interfaces(asm: Assembly, s: PlacedSleeve, types: list[ShapedPlateType]
                ) -> list[tuple[float, float, float, float]]:
    """Per slot of sleeve ``s`` (A, B): (its plate's interface midpoint, its half-length, the plate edge's two
    ends) along the sleeve's X axis from the sleeve's origin, mm."""
    X, origin = s.transform[:3, 0], s.transform[:3, 3]
    w, half_t = asm.spec.plates.weight, 0.5 * asm.spec.plates.thickness
    out = []
    for p, i in s.plates:
        pt = types[p]
        C = pt.polygon
        a, b = C[i], C[(i + 1) % len(C)]
        T = asm.plates[p].transform
        x = [float((T[:3, :3] @ np.array([*q, half_t]) + T[:3, 3] - origin) @ X) for q in (0.5 * (a + b), a, b)]
        out.append((x[0], interface_half_length(float(np.linalg.norm(b - a)), pt.depth, w), x[1], x[2]))
    return out


def place_assembly(spec: AssemblySpec, face_patterns: list[str]) -> Assembly:
    """:func:`~fabpat.assembly.place.placement.place`, with the plates and sleeves of a spec of shaped plates
    (``tiling.plates = "shaped"``) shaped by :func:`shaped_assembly`: every kit and closure places through
    here. Raises as those two."""
    placed = place(spec, face_patterns)
    return shaped_assembly(placed) if spec.tiling.plates == "shaped" else placed


def shaped_assembly(asm: Assembly) -> Assembly:
    """``asm`` (placed on a :class:`~fabpat.assembly.surface.shaped.ShapedTiling`) with every plate its face's
    polygon moved in by its setback (:class:`ShapedPlateType`), every sleeve centred on its two interfaces and
    every sleeve part's slot as long as its longest union of two interfaces plus ``sleeve.margin`` (module
    docstring). Raises :class:`SpecError` naming the joint and the plate when a sleeve reaches past the end
    of a plate's edge, or a face whose edges moved in leave no polygon."""
    spec, skel, e = asm.spec, asm.skeleton, asm.plate_edge
    E = skel.edge_length()
    frames = skel.frames()
    types = []
    for p in asm.plates:
        loop = skel.faces[p.face]
        Q = ((skel.V[list(loop)] - frames[p.face][:3, 3]) @ frames[p.face][:3, :2])
        try:
            corners = inset(Q, setback(len(loop), E, e))
        except GeometryError as err:
            raise SpecError(f"{spec.source}: face {skel.labels[p.face]}: {err}") from None
        types.append(ShapedPlateType(p.type.sides, p.type.pattern_id, p.type.bridge_weight, p.type.thickness,
                                     face_label=skel.labels[p.face],
                                     corners=tuple((float(x), float(y)) for x, y in corners)))
    plates = tuple(replace(p, type=t) for p, t in zip(asm.plates, types, strict=True))
    spans = [_interfaces(asm, s, types) for s in asm.sleeves]
    need: dict[str, float] = {}
    centres = []
    for s, sides in zip(asm.sleeves, spans, strict=True):
        lo, hi = min(m - d for m, d, _, _ in sides), max(m + d for m, d, _, _ in sides)
        centres.append(0.5 * (lo + hi))
        need[s.kind] = max(need.get(s.kind, 0.0), hi - lo)
    kinds = {k: replace(sl, slot_length=need.get(k, sl.slot_length - spec.sleeve.margin) + spec.sleeve.margin)
             for k, sl in asm.sleeve_types.items()}
    sleeves = []
    for s, sides, c in zip(asm.sleeves, spans, centres, strict=True):
        half = 0.5 * kinds[s.kind].length
        for (q, _), (_, _, xa, xb) in zip(s.plates, sides, strict=True):
            if c - half < min(xa, xb) - 1e-9 or c + half > max(xa, xb) + 1e-9:
                raise SpecError(f"{spec.source}: sleeve {s.label} ({s.kind}, {2 * half:.2f} mm long) reaches past the "
                                f"edge of plate {plates[q].label} ({abs(xb - xa):.2f} mm long): give a larger "
                                "tiling.edge, a smaller sleeve.margin or sleeve.wall, or a more regular face")
        T = s.transform.copy()
        T[:3, 3] += c * T[:3, 0]
        sleeves.append(replace(s, transform=T))
    return replace(asm, plates=plates, sleeves=tuple(sleeves), sleeve_types=kinds)


def joint_offsets(asm: Assembly) -> list[tuple[str, float, float]]:
    """Per sleeve of a shaped ``asm``: (its label, how far apart its two plates' interface midpoints lie along
    the joint, how much longer the union of its two interfaces is than the regular plate's interface 2d(e)), mm
    (what the module docstring measures)."""
    types = [p.type for p in asm.plates]
    if not all(isinstance(t, ShapedPlateType) for t in types):
        raise GeometryError("joint_offsets measures an assembly of shaped plates")
    shaped = [t for t in types if isinstance(t, ShapedPlateType)]
    d0 = 2.0 * interface_half_length(asm.plate_edge, weight=asm.spec.plates.weight)
    out = []
    for s in asm.sleeves:
        (ma, da, _, _), (mb, db, _, _) = _interfaces(asm, s, shaped)
        out.append((s.label, abs(ma - mb), max(ma + da, mb + db) - min(ma - da, mb - db) - d0))
    return out


def slot_excess(asm: Assembly, s: PlacedSleeve, side: int, along: float, half: float) -> float:
    """How far (mm) an interface of half-length ``half`` whose midpoint lies ``along`` mm from the centre of
    sleeve ``s``'s slot reaches into the ``sleeve.margin / 2`` kept free at the slot's ends (0 when it
    does not; :mod:`fabpat.assembly.place.checks` refuses more than its tolerance)."""
    sleeve = asm.sleeve_types[s.kind]
    return max(0.0, abs(along) + half - 0.5 * (sleeve.slot_length - asm.spec.sleeve.margin))


def shaped_kerf(P: NDArray[np.float64], kerf: float) -> NDArray[np.float64]:
    """A shaped plate's polygon P (n, 2) mm with its edges moved out by ``kerf / 2`` mm (the cut path)."""
    return inset(P, -0.5 * kerf) if kerf > 0 else P


__all__ = ["ShapedPlateType", "is_shaped", "joint_offsets", "place_assembly", "plate_corners", "plate_outline",
           "shaped_assembly", "shaped_kerf", "slot_excess"]
