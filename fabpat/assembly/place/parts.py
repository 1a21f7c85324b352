"""The distinct parts of an assembly as exact solids and meshes, each built once and reused.

A sphere has 122 placed parts but only four distinct ones (two plates, two sleeves): every writer
and check asks this library for a part's ``TopoDS_Solid`` or mesh by its key (the plate type label,
e.g. ``"hex 0x0488"``, or the sleeve kind, e.g. ``"S-HH"``) and places it with a 4 × 4 transform.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.placement import Assembly, PlateType
from fabpat.exchange.threemf import triangulate

if TYPE_CHECKING:
    from OCP.gp import gp_Trsf
    from OCP.TopoDS import TopoDS_Shape

    from fabpat.geometry.fillet import FilletedPattern
    from fabpat.geometry.outline import Outline, RationalQuad

CHECK_TOLERANCE = 0.02  # mm: chord height of the meshes used for the checks and the GLB preview
PICTURE_TOLERANCE = 0.1  # mm: coarse meshes for the PNG (60 k triangles for a sphere)


@dataclass(eq=False)
class PartLibrary:
    """Solids and meshes of ``assembly``'s distinct parts; ``filleted`` maps plate type → FilletedPattern."""

    assembly: Assembly
    filleted: dict[PlateType, FilletedPattern]
    _solids: dict[str, TopoDS_Shape] = field(default_factory=dict)
    _meshes: dict[tuple[str, float], tuple[NDArray[np.float64], NDArray[np.int64]]] = field(default_factory=dict)

    @property
    def keys(self) -> list[str]:
        """Distinct part keys: plate types first (order of use), then sleeve kinds."""
        return [pt.label for pt in self.assembly.plate_types] + list(self.assembly.sleeve_types)

    def plate_type(self, key: str) -> PlateType | None:
        """The plate type whose label is ``key``, or None for a sleeve key."""
        return next((pt for pt in self.assembly.plate_types if pt.label == key), None)

    def is_plate(self, key: str) -> bool:
        """True when ``key`` names a plate type (not a sleeve kind)."""
        return self.plate_type(key) is not None

    def name(self, key: str) -> str:
        """Product name with every parameter that changes the part's geometry."""
        from fabpat.exchange.cad import part_name

        pt = self.plate_type(key)
        if pt is None:
            return self.assembly.sleeve_types[key].name
        spec = self.assembly.spec
        name = part_name(pt.pattern_id, pt.sides, self.assembly.plate_edge, self.assembly.type_thickness(pt),
                         spec.plates.weight, pt.variation.label())
        face = getattr(pt, "face_label", "")  # a shaped plate: its own part, named by its face
        return f"{name} shaped {face}" if face else name

    def support(self, pt: PlateType) -> tuple[RationalQuad, ...]:
        """The whole interface arcs whose halves the plate outline keeps (exact STEP weights)."""
        return tuple(arc for pair in self.filleted[pt].interface_arcs for arc in pair)

    def solid(self, key: str) -> TopoDS_Shape:
        """``TopoDS_Solid`` of the part in its own frame: plates z ∈ [0, t]; sleeves in the joint frame."""
        if key not in self._solids:
            from fabpat.exchange.cad import make_solid

            pt = self.plate_type(key)
            if pt is None:
                self._solids[key] = self.assembly.sleeve_types[key].solid()
            else:
                self._solids[key] = make_solid(self.filleted[pt].outline, self.assembly.type_thickness(pt),
                                               self.support(pt))
        return self._solids[key]

    def mesh(self, key: str, tolerance: float = CHECK_TOLERANCE) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """``V`` (n, 3) mm, ``F`` (m, 3) of the part in its own frame (closed, outward)."""
        if (key, tolerance) not in self._meshes:
            from fabpat.exchange.cad import make_solid

            # Mesh a fresh copy: BRepMesh stores its triangulation in the shape, and the exact solid
            # is also written to STEP and STL at other tolerances.
            pt = self.plate_type(key)
            if pt is not None:
                check_plate_mesh(self.filleted[pt].outline, self.assembly.type_thickness(pt), tolerance)
            shape = (self.assembly.sleeve_types[key].solid() if pt is None else
                     make_solid(self.filleted[pt].outline, self.assembly.type_thickness(pt), self.support(pt)))
            self._meshes[key, tolerance] = triangulate(shape, tolerance)
        return self._meshes[key, tolerance]

    def placed(self) -> list[tuple[str, str, NDArray[np.float64]]]:
        """(instance label, part key, 4 × 4 transform) of every placed part: plates, then sleeves."""
        out = [(p.label, p.type.label, p.transform) for p in self.assembly.plates]
        out += [(s.label, s.kind, s.transform) for s in self.assembly.sleeves]
        return out


def check_plate_mesh(outline: Outline, thickness: float, tolerance: float) -> None:
    """Refuse (ExportError) a plate mesh estimated above the export limit, before OCCT starts on it."""
    from fabpat.errors import ExportError
    from fabpat.exchange.registry import DEFAULT_MAX_EXPORT_ELEMENTS, estimate_triangles
    from fabpat.validate import check_size

    check_size(estimate_triangles(outline, thickness, tolerance), DEFAULT_MAX_EXPORT_ELEMENTS,
               f"mesh triangles of a plate at a {tolerance:g} mm chord", "the export limit",
               "use a larger output.mesh_tolerance", error=ExportError)


def transformed(shape: TopoDS_Shape, T: NDArray[np.float64]) -> TopoDS_Shape:
    """A copy of ``shape`` moved by the rigid 4 × 4 transform ``T``."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform

    return BRepBuilderAPI_Transform(shape, gp_trsf(T), True).Shape()


def gp_trsf(T: NDArray[np.float64]) -> gp_Trsf:
    """OCCT ``gp_Trsf`` of a rigid 4 × 4 transform."""
    from OCP.gp import gp_Trsf

    trsf = gp_Trsf()
    trsf.SetValues(*(float(v) for v in T[:3, :4].ravel()))
    return trsf


def apply(T: NDArray[np.float64], V: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, 3) points moved by the 4 × 4 transform ``T``."""
    return V @ T[:3, :3].T + T[:3, 3]
