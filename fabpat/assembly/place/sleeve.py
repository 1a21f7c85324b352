"""The sleeve connector: a printed part with two slots that grip two plates' interface necks (paper §5).

Local frame (mm): X runs along the joint's edge, the origin is the skeleton edge's midpoint, and the
cross-section lies in the (Y, Z) plane, symmetric about Y = 0, convex side towards +Z. Plate A enters
along ``a = (sin φ/2, −cos φ/2)`` and plate B along ``b = (−sin φ/2, −cos φ/2)``, where φ is the
interior dihedral angle (π on a flat strip: a = +Y, b = −Y).

Each plate's edge sits ``setback`` from the edge line (the plates never touch each other: a web of at
least ``wall`` separates the two slot bottoms). A slot is ``thickness + clearance`` wide, ``slot_length``
long along X (the interface segment 2d = 3.75 mm plus a margin) and open at the arm's end, ``depth``
beyond the setback; walls of ``wall`` close it on both faces of the plate and at both X ends, so the
sleeve restrains the plate in every direction. The body is the convex hull of the two arms, extruded
along X: its X ends are flat faces of the full cross-section, so it prints standing on one of them with
the slots vertical (the only bridge is the slot roof, ``thickness + clearance`` ≈ 2.2 mm wide).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.surface.joints import joint_direction, joint_normal, required_setback
from fabpat.errors import GeometryError
from fabpat.geometry.polygons import signed_area

if TYPE_CHECKING:
    from OCP.TopoDS import TopoDS_Shape, TopoDS_Solid

SLOT_OVERSHOOT = 1.0  # mm: the slot cutter runs past the arm's end so the mouth is cleanly open



def _hull(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Convex hull of 2D points, counter-clockwise, no collinear points (monotone chain)."""
    P = sorted({(round(float(x), 12), round(float(y), 12)) for x, y in points})

    def half(pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for p in pts:
            while len(out) >= 2:
                (ax, ay), (bx, by) = out[-2], out[-1]
                if (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax) > 1e-12:
                    break
                out.pop()
            out.append(p)
        return out

    lower, upper = half(P), half(P[::-1])
    return np.array(lower[:-1] + upper[:-1], dtype=np.float64)


@dataclass(frozen=True)
class Sleeve:
    """One sleeve type: all lengths in mm, ``dihedral`` in rad (the angle it is printed at, ≤ π: π is straight)."""

    dihedral: float
    setback: float
    thickness: float = 2.0
    clearance: float = 0.2
    slot_length: float = 4.75
    wall: float = 1.2
    depth: float = 3.0

    def __post_init__(self) -> None:
        if not 0.0 < self.dihedral <= math.pi:
            raise GeometryError(f"sleeve dihedral must be in (0°, 180°], got {math.degrees(self.dihedral):g}°")
        need = required_setback(self.dihedral, self.thickness, self.clearance, self.wall)
        if self.setback < need - 1e-9:
            raise GeometryError(f"sleeve setback {self.setback:.3f} mm leaves a web thinner than the wall "
                                f"({self.wall:g} mm): it needs ≥ {need:.3f} mm")

    @property
    def slot_width(self) -> float:
        """Plate thickness + clearance (mm)."""
        return self.thickness + self.clearance

    @property
    def length(self) -> float:
        """Length along the edge (mm): the slot plus a wall at each end."""
        return self.slot_length + 2.0 * self.wall

    @property
    def arm_end(self) -> float:
        """Distance (mm) from the edge line to the slot mouths, along each plate."""
        return self.setback + self.depth

    @property
    def name(self) -> str:
        """Product name with every parameter that changes the geometry."""
        return (f"fabpat sleeve {math.degrees(self.dihedral):.2f}deg g{self.setback:.3f} t{self.thickness:g} "
                f"c{self.clearance:g} L{self.slot_length:g} w{self.wall:g} d{self.depth:g}")

    def direction(self, side: int) -> NDArray[np.float64]:
        """(2,) unit vector (Y, Z) from the edge into plate A (side 0) or B (side 1)."""
        return joint_direction(self.dihedral, side)

    def plate_normal(self, side: int) -> NDArray[np.float64]:
        """(2,) unit normal of plate A / B pointing to the convex (+Z) side."""
        return joint_normal(self.dihedral, side)

    def _rect(self, side: int, s0: float, s1: float, half: float) -> NDArray[np.float64]:
        d, n = self.direction(side), self.plate_normal(side)
        return np.array([s * d + r * n for s, r in ((s0, -half), (s1, -half), (s1, half), (s0, half))])

    def arm(self, side: int) -> NDArray[np.float64]:
        """(4, 2) corners of arm A / B: from the edge line to the mouth, slot plus two walls thick."""
        return self._rect(side, 0.0, self.arm_end, 0.5 * self.slot_width + self.wall)

    def slot(self, side: int, overshoot: float = 0.0) -> NDArray[np.float64]:
        """(4, 2) corners of slot A / B: from ``clearance/2`` before the plate's edge to the mouth."""
        return self._rect(side, self.setback - 0.5 * self.clearance, self.arm_end + overshoot, 0.5 * self.slot_width)

    @cached_property
    def section(self) -> NDArray[np.float64]:
        """(k, 2) cross-section of the body (convex hull of the two arms), counter-clockwise."""
        return _hull(np.vstack([self.arm(0), self.arm(1)]))

    def section_area(self) -> float:
        """Area of the body's cross-section (mm²), slots not removed."""
        P = self.section
        return signed_area(P)

    def volume(self) -> float:
        """Exact volume (mm³): hull prism minus the two slot pockets (each lies inside its arm)."""
        pocket = self.slot_width * self.slot_length * (self.depth + 0.5 * self.clearance)
        return self.section_area() * self.length - 2.0 * pocket

    def web(self) -> float:
        """Smallest material thickness between the two slots (mm)."""
        A, B = self.slot(0), self.slot(1)

        def seg_dist(p: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
            t = float(np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
            return float(np.linalg.norm(p - a - t * (b - a)))

        return min(
            seg_dist(p, Q[i], Q[(i + 1) % 4]) for P, Q in ((A, B), (B, A)) for p in P for i in range(4)
        )

    def slot_centre(self, side: int) -> NDArray[np.float64]:
        """(3,) local point (X, Y, Z) where plate A / B's interface midpoint must sit."""
        return np.array([0.0, *(self.setback * self.direction(side))])

    def solid(self) -> TopoDS_Solid:
        """The sleeve as a BRepCheck-valid ``TopoDS_Solid`` in the local frame."""
        from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut

        from fabpat.exchange.cad import check_valid

        x0 = -0.5 * self.length
        body = _prism(self.section, x0, self.length)
        for side in (0, 1):
            cutter = _prism(self.slot(side, SLOT_OVERSHOOT), -0.5 * self.slot_length, self.slot_length)
            op = BRepAlgoAPI_Cut(body, cutter)
            if not op.IsDone():
                raise GeometryError("OCCT could not cut the sleeve's slot")
            body = op.Shape()
        solid = _single_solid(body)
        check_valid(solid, "sleeve")
        return solid

    def print_transform(self) -> NDArray[np.float64]:
        """(4, 4) local → print frame: X (the edge) becomes +Z, the end face X = −length/2 lies on z = 0."""
        T = np.zeros((4, 4))
        T[0, 1] = T[1, 2] = T[2, 0] = T[3, 3] = 1.0  # (X, Y, Z) → (Y, Z, X): a proper rotation
        T[2, 3] = 0.5 * self.length
        return T


def _prism(polygon: NDArray[np.float64], x0: float, length: float) -> TopoDS_Shape:
    """Polygon in the (Y, Z) plane at X = x0, extruded along +X by ``length`` (TopoDS_Shape)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Pnt, gp_Vec

    poly = BRepBuilderAPI_MakePolygon()
    for y, z in polygon:
        poly.Add(gp_Pnt(x0, float(y), float(z)))
    poly.Close()
    face = BRepBuilderAPI_MakeFace(poly.Wire(), True)
    if not face.IsDone():
        raise GeometryError("cannot build the sleeve cross-section face")
    return BRepPrimAPI_MakePrism(face.Face(), gp_Vec(float(length), 0.0, 0.0)).Shape()


def _single_solid(shape: TopoDS_Shape) -> TopoDS_Solid:
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    solids = []
    ex = TopExp_Explorer(shape, TopAbs_SOLID)
    while ex.More():
        solids.append(TopoDS.Solid(ex.Current()))
        ex.Next()
    if len(solids) != 1:
        raise GeometryError(f"the sleeve came out as {len(solids)} solids, expected 1")
    return solids[0]
