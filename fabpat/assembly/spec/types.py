"""The plain data of an assembly spec: every table as a frozen dataclass, and the names and kinds they
allow. :mod:`fabpat.assembly.spec.load` reads a TOML spec into them (its docstring is the format)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fabpat.assembly.surface.tiling import Tiling, honeycomb_strip, truncated_icosahedron
from fabpat.validate import RANGES

TILINGS = ("honeycomb-strip", "truncated-icosahedron", "mesh", "goldberg", "hex-tube", "hex-cap", "panel")
#: the flat kinds of rows × columns hexagons, pushed into an arch by ``simulate-assembly``; their patterns are
#: chosen as a strip's (pattern, groups, tiles, rule = "graded")
STRIP_KINDS = ("honeycomb-strip", "panel")
#: largest panel (rows, columns): building and checking the one fused solid grows faster than its tiles
#: (BRepCheck compares the outline's loops pairwise: docs/tilings.md)
MAX_PANEL_ROWS, MAX_PANEL_COLUMNS = 12, 12
#: the kinds whose faces are a polygon mesh kept in the spec (:attr:`TilingSpec.vertices`): a file's, or
#: a built-in surface's (:mod:`fabpat.assembly.surface.polyhedra`, only nearly regular: plates at best fit)
MESH_KINDS = ("mesh", "goldberg", "hex-tube", "hex-cap")
#: the closed built-in kinds that take ``radius`` instead of ``edge``, and the axis their radius is
#: measured from (None: from the centre, a sphere; the tube's axis is x, fabpat.assembly.surface.polyhedra)
RADIUS_KINDS: dict[str, tuple[float, float, float] | None] = {
    "truncated-icosahedron": None, "goldberg": None, "hex-tube": (1.0, 0.0, 0.0)}
#: largest built-in surfaces: GP(6, 0) has 362 plates (a closure of 10 minutes at h = 3), a tube or
#: cap beyond these sizes as many
MAX_GOLDBERG_M, MAX_TUBE_ROWS, MAX_TUBE_COLUMNS, MAX_CAP_RINGS = 6, 30, 30, 8
#: how far a built-in surface's faces may be from regular (× the edge) before its closure is refused
BUILTIN_TOLERANCE = 0.5
#: ``[patterns]`` key of each polygon of a polyhedral tiling (a mesh's faces have 3 … 12 sides)
POLYGON_KEYS = {3: "triangle", 4: "square", 5: "pentagon", 6: "hexagon", 7: "heptagon", 8: "octagon", 9: "nonagon",
                10: "decagon", 11: "hendecagon", 12: "dodecagon"}
PROCESSES = ("print", "laser")
FORMATS = ("step", "stl", "glb", "3dm", "dxf", "svg", "bom", "png")
#: a panel's formats: a kit's and the 3MF of its one part (a kit's many parts are STL files)
PANEL_FORMATS = (*FORMATS, "3mf")
STRIP_RULES = ("graded",)
SPHERE_RULES = ("similar-energy", "roundest")
SCENARIOS = ("cantilever", "cylinder", "dome")
SLEEVE_ANGLES = ("dihedral", "flat")  # the named values of [sleeve] angle; a number of degrees is the third way
#: ``[sleeve] angle`` when the spec gives none, by tiling kind (else "dihedral"): a Goldberg sphere is made to bend
#: like the shipped sphere (straight sleeves, paper §5); at its dihedral angles it is a nearly rigid polyhedron
#: whose patterns barely matter. The truncated icosahedron keeps "dihedral": both shipped specs name their angle
DEFAULT_SLEEVE_ANGLE = {"goldberg": "flat"}
#: ``[sleeve] angle_range`` when the spec gives none (degrees): the printed angles a design may choose joints from
DEFAULT_ANGLE_RANGE = (150.0, 180.0)
#: degrees: the angles of ``[sleeve] angles`` are printed rounded to this step, so that joints within it share
#: one sleeve part (as a mesh's dihedral angles are, fabpat.assembly.place.placement.DIHEDRAL_STEP)
ANGLE_STEP = 0.1
#: ``[plates] thickness_range`` when the spec gives none (mm): the range every plate thickness must lie in
#: (fabpat.validate's "thickness")
DEFAULT_THICKNESS_RANGE = (RANGES["thickness"].low, RANGES["thickness"].high)
#: largest ``patterns.candidates``: each candidate pair is one closure of the sphere (8 took 4 min 49 s at
#: h = 3 on the shared 2-core machine, docs/fabrication-files.md), so 20 bound the choice to about
#: 12 minutes; the similar-energy ranking puts the likely winners first anyway
MAX_CANDIDATES = 20
#: longest ``name`` (characters): it titles pictures, the STEP product and the net
MAX_NAME_LENGTH = 80


@dataclass(frozen=True)
class TilingSpec:
    """``[tiling]``: the tiling ``kind``, plate polygon ``edge`` (mm) and, for strips, rows and columns.

    A mesh tiling also keeps its ``file`` (the path as resolved from the spec), ``tolerance`` (mm) and
    the checked mesh itself, scaled to ``edge``: ``vertices`` (mm) and ``faces`` (vertex loops, CCW seen
    from outside; :func:`fabpat.assembly.surface.mesh_tiling.mesh_tiling`), so that the spec is plain data. A panel
    from a mesh file (``kind = "panel"`` with ``file``) keeps the exact flat tiling its faces make, in the
    panel's plane z = 0 (:func:`fabpat.assembly.surface.panel_mesh.regular_tiling`; CCW seen from +z).
    """
    kind: str
    edge: float  # mm: plate polygon edge
    rows: int = 1
    columns: int = 1
    file: str | None = None
    tolerance: float = 0.01  # mm (fabpat.assembly.surface.mesh_tiling.DEFAULT_TOLERANCE)
    vertices: tuple[tuple[float, float, float], ...] = ()
    faces: tuple[tuple[int, ...], ...] = ()
    #: "exact" (plates on the faces) or "best" (at their faces' best fit: built-in surfaces, or a mesh's
    #: ``fit = "best"``); the closure ramps the rest of the mismatch to zero
    fit: str = "exact"
    m: int = 1  # goldberg GP(m, n)
    n: int = 0
    realization: str = "dual"  # goldberg: fabpat.assembly.surface.polyhedra.REALIZATIONS
    rings: int = 1  # hex-cap
    centre: int = 5  # hex-cap: sides of the central face
    #: mm: the size asked for instead of ``edge`` (closed kinds, :data:`RADIUS_KINDS`); ``edge`` is then
    #: the plate edge that puts the placed plates at this mean distance from the centre (the axis)
    radius: float | None = None
    #: a mesh's plates: "regular" (the regular polygon of ``edge``) or "shaped" (each its own face's polygon,
    #: :mod:`fabpat.assembly.place.shaped`; the faces' mean edge is ``edge``)
    plates: str = "regular"

    @property
    def strip(self) -> bool:
        """A honeycomb strip or a panel of rows × columns hexagons (patterns chosen by rows and columns), not a
        polyhedral tiling nor a panel from a mesh file (patterns chosen by polygon or face label)."""
        return self.kind in STRIP_KINDS and self.file is None

    @property
    def panel(self) -> bool:
        """A one-piece panel: the plates fused into one part, no sleeves (:mod:`fabpat.assembly.place.panel`)."""
        return self.kind == "panel"

    @property
    def pushed(self) -> bool:
        """Flat and pushed into an arch by ``simulate-assembly`` (a strip or any panel), not closed by sleeves."""
        return self.kind in STRIP_KINDS

    def skeleton(self) -> Tiling:
        """The tiling of unit edge (:mod:`fabpat.assembly.surface.tiling`; scaled once the sleeves fix the skeleton
        edge)."""
        if self.kind == "truncated-icosahedron":
            return truncated_icosahedron(1.0)
        if self.kind in MESH_KINDS:
            # every mesh's plates sit at their faces' best fit: a file's faces are regular only within
            # tiling.tolerance, and the sleeve frames must not demand more of them
            if self.plates == "shaped":  # its edge is the faces' mean edge (fabpat.assembly.surface.shaped)
                from fabpat.assembly.surface.shaped import ShapedTiling

                return ShapedTiling(self.kind, np.array(self.vertices) / self.edge, self.faces, best_fit=True)
            return Tiling(self.kind, np.array(self.vertices) / self.edge, self.faces, best_fit=True)
        # a mesh panel's vertices are an exact tiling already (fabpat.assembly.surface.panel_mesh)
        if self.file is not None:
            return Tiling(self.kind, np.array(self.vertices) / self.edge, self.faces)
        return honeycomb_strip(self.rows, self.columns, 1.0)

    @property
    def sides(self) -> tuple[int, ...]:
        """Polygons of the tiling's faces, largest first (6 for strips; 6 and 5 for the truncated icosahedron)."""
        if self.faces:
            return tuple(sorted({len(f) for f in self.faces}, reverse=True))
        return (6,) if self.strip else (6, 5)


@dataclass(frozen=True)
class PatternSpec:
    """How patterns are chosen; exactly one way is set (see the module docstring)."""

    pattern: str | None = None
    groups: tuple[str, ...] = ()
    group_columns: int = 1
    tiles: tuple[tuple[str, ...], ...] = ()
    #: (sides, ID) of every polygon of a polyhedral tiling (``hexagon = …``, ``pentagon = …``, …)
    polygons: tuple[tuple[int, str], ...] = ()
    rule: str | None = None
    scenario: str = "cylinder"
    count: int = 5
    catalog: str | None = None
    candidates: int = 8  # rule = "roundest": similar-energy pairs the closure solver tries
    #: per face (in face order) the family member's bridge_weight (fabpat.patterns.variation); () = the paper's
    #: fillets on every plate
    bridge_weights: tuple[float, ...] = ()
    #: ``bridge_weight = "rule"``: the rule also picks every pattern's family member, to hit its target
    #: energy (:func:`fabpat.assembly.kit.build.with_members` fills ``bridge_weights``; ``rule = "roundest"``: its
    #: candidate pairs include the catalog's swept members, :func:`fabpat.assembly.kit.build.candidate_pairs`)
    member_rule: bool = False

    def polygon_pattern(self, sides: int) -> str:
        """The pattern the spec names for every face of ``sides`` sides (``polygons``)."""
        return dict(self.polygons)[sides]

    def bridge_weight_of(self, face: int) -> float:
        """The bridge_weight of face ``face``'s plate (1, the paper's, unless the spec gives one)."""
        return self.bridge_weights[face] if self.bridge_weights else 1.0


@dataclass(frozen=True)
class PlateSpec:
    """``[plates]``: thickness (mm), interface fillet weight, process and density (g/cm³); ``thicknesses``
    the (plate label, thickness mm) of each plate given its own thickness, ``thickness_range`` (mm) the
    range they lie in (a design chooses from it)."""
    thickness: float = 2.0  # mm
    weight: float = 0.2  # interface fillet weight (paper §3.3)
    process: str = "print"
    density: float = 1.24  # g/cm³: PLA (notes, §4.1)
    thicknesses: tuple[tuple[str, float], ...] = ()
    thickness_range: tuple[float, float] = DEFAULT_THICKNESS_RANGE

    def thickness_of(self, label: str) -> float:
        """Plate ``label``'s thickness (mm): its entry of ``thicknesses``, else ``thickness``."""
        return dict(self.thicknesses).get(label, self.thickness)

    @property
    def thickest(self) -> float:
        """The largest plate thickness (mm): ``thickness`` or an entry of ``thicknesses``."""
        return max([self.thickness, *(t for _, t in self.thicknesses)])

    @property
    def uniform(self) -> bool:
        """Every plate has the one ``thickness`` (no entry of ``thicknesses`` differs from it)."""
        return all(t == self.thickness for _, t in self.thicknesses)


@dataclass(frozen=True)
class SleeveSpec:
    """``[sleeve]``: clearance, margin, wall and depth of the sleeve connectors (mm) and the angle they
    are printed at: ``"dihedral"``, ``"flat"`` or a number of degrees (see :func:`sleeve_angle`);
    ``angles`` the (joint label, degrees) of each joint printed at its own angle, ``angle_range``
    (degrees) the range they lie in (a design chooses from it)."""
    clearance: float = 0.2  # mm: slot width − plate thickness
    margin: float = 1.0  # mm: slot length − interface segment length
    wall: float = 1.2  # mm: three 0.4 mm perimeters
    depth: float = 3.0  # mm: how far a plate enters the slot
    angle: str | float = "dihedral"  # "dihedral" | "flat" | degrees
    angles: tuple[tuple[str, float], ...] = ()
    angle_range: tuple[float, float] = DEFAULT_ANGLE_RANGE

    def listed_angle(self, label: str) -> float | None:
        """The angle (degrees) joint ``label`` is printed at if ``angles`` lists it, rounded to
        :data:`ANGLE_STEP` (at most 180), else None (the joint follows ``angle``)."""
        value = dict(self.angles).get(label)
        if value is None:
            return None
        return min(round(ANGLE_STEP * round(value / ANGLE_STEP), 6), 180.0)


@dataclass(frozen=True)
class MaterialSpec:
    """``[material]``: the plates' material, read by the closure solver.

    ``youngs_modulus`` (N/mm²) and ``poisson`` are the defaults of the pattern scenarios (1000 N/mm²,
    0.35). ``strain_limit`` is the largest principal strain (membrane plus bending, on either plate
    surface) a plate may reach. The default 0.02 is the yield strain of PLA: tensile yield strength
    ≈ 60 MPa over tensile modulus ≈ 3.5 GPa ≈ 1.7 % (NatureWorks Ingeo 4043D technical data sheet:
    60 MPa and 3.6 GPa), rounded to 2 %. A printed or laser-cut part may crack below it at notches
    and layer lines, so it is an upper bound to design below, not a safe value.
    """
    youngs_modulus: float = 1000.0  # N/mm²
    poisson: float = 0.35
    strain_limit: float = 0.02  # PLA yield strain, rounded up from 1.7 % (see above)


@dataclass(frozen=True)
class SheetSpec:
    """``[sheet]``: laser sheet or print bed size, margin, spacing and kerf (mm)."""
    width: float = 600.0  # mm
    height: float = 400.0  # mm
    margin: float = 5.0  # mm: border kept free on every side
    spacing: float = 3.0  # mm: minimum gap between two plates' polygons
    kerf: float = 0.0  # mm: laser kerf (cut loops move out by kerf/2)
    border: bool = True  # draw the bed outline on the sheets' non-plotting layer SHEET
    dxf_entities: str = "polyline"  # "polyline" (closed LWPOLYLINEs) | "segments" (LINE + ARC)


@dataclass(frozen=True)
class EstimateSpec:
    """``[estimates]``: laser cut speed (mm/s) and print rate (mm³/s) for the BOM's times."""
    cut_speed: float = 15.0  # mm/s: 2 mm acrylic or plywood on a 40–60 W CO2 laser
    print_rate: float = 3.0  # mm³/s: effective rate of a 0.4 mm nozzle at 0.2 mm layers, travel included


@dataclass(frozen=True)
class AssemblySpec:
    """A validated spec; ``source`` is the file it came from (for messages). ``sheet`` is None when the
    spec has no ``[sheet]`` (a simulation needs none; ``fabpat assemble`` refuses it)."""

    name: str
    source: str
    tiling: TilingSpec
    patterns: PatternSpec
    plates: PlateSpec
    sleeve: SleeveSpec
    sheet: SheetSpec | None
    estimates: EstimateSpec
    formats: tuple[str, ...]
    mesh_tolerance: float = 0.005  # mm: STL chord of the parts (fabpat.exchange.cad.DEFAULT_CHORD)
    curve_tolerance: float = 0.01  # mm: DXF sheets' arcs from the exact outlines
    material: MaterialSpec = MaterialSpec()
    end_shortening: float | None = None  # [load]: strips' default end-pin travel / strip length

    @property
    def polygon_sides(self) -> tuple[int, ...]:
        """Polygons used by the tiling, largest first (:attr:`TilingSpec.sides`)."""
        return self.tiling.sides
