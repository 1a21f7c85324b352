"""Assembly spec files (TOML): what to build, with every value checked before anything is built.

A spec has these tables (lengths in mm; see ``assemblies/*.toml`` for commented examples):

* ``[tiling]``  ``kind`` ("honeycomb-strip" | "truncated-icosahedron" | "mesh" | "goldberg" | "hex-tube" |
  "hex-cap" | "panel"), ``edge`` (plate polygon edge), ``rows`` and ``columns`` (strip, tube and panel); a
  ``panel`` is the strip's rows × columns hexagons (each 1 … :data:`MAX_PANEL_ROWS`) fused at their
  interfaces into ONE part, without sleeves (:mod:`fabpat.assembly.panel`; patterns as on a strip, no
  ``[sleeve]`` table, ``output.formats`` may add "3mf"); a mesh tiling
  reads ``file`` (an OBJ, PLY or OFF polygon mesh, relative to the spec; its faces carry the plates,
  :mod:`fabpat.assembly.mesh_tiling`), takes ``edge`` as optional (default: the mesh's mean edge; given,
  it scales the mesh), ``tolerance`` (mm, default 0.01, with ``fit = "best"`` 0.2 × edge; at most 0.5 ×
  edge: how far the faces may be from regular polygons of one edge) and ``fit`` ("exact" | "best":
  plates at their faces' best fit, the closure takes up the rest); ``goldberg`` reads ``m``, ``n``,
  ``realization`` ("dual" | "planar"), ``hex-cap`` ``rings`` and ``centre`` (5 | 6)
  (:mod:`fabpat.assembly.polyhedra`; plates at best fit). The closed kinds
  (:data:`RADIUS_KINDS`) take ``radius`` (mm) instead of ``edge``: the plate edge is then chosen so that
  the placed plates lie that far from the centre (a tube: its axis), :func:`_sized_by_radius`.
* ``[patterns]`` one of: ``pattern`` (every tile); ``groups`` (one ID per group of ``group_columns`` columns,
  stiff → soft) or ``tiles`` (rows × columns IDs, or a table {plate label = ID} naming every plate as the kit
  labels it, e.g. ``{T1 = "0x0488", …}``) on a strip or a panel; ``hexagon`` + ``pentagon``, or ``tiles`` = {plate label
  = ID} for every face ("H01" … "H20", "P01" … "P12", each ID of its face's polygon; ``fabpat design`` writes
  it), on the truncated icosahedron; one key per polygon of a mesh tiling, named as the polygon
  (:data:`POLYGON_KEYS`: ``triangle``, ``square``, ``pentagon``, ``hexagon``, …) or ``tiles`` by plate label
  (the polygon's letter and number, :data:`fabpat.assembly.tiling.FACE_LETTERS`); or ``rule`` = "graded"
  (strip: ``count`` patterns with well-separated energies in ``scenario``) / "similar-energy" (sphere or mesh:
  one pattern per polygon, of similar energy in ``scenario``) / "roundest" (sphere: the ``candidates`` best
  similar-energy pairs, default 8, of which the closure solver keeps the roundest under the strain limit),
  read from the catalog (``catalog`` = path, default the built-in one).
* ``[plates]``  ``thickness``, ``weight`` (interface fillet weight), ``process`` ("print" | "laser"),
  ``density`` (g/cm³, for masses).
* ``[sleeve]``  ``clearance`` (slot width = thickness + clearance), ``margin`` (slot length =
  interface segment + margin), ``wall``, ``depth`` (how far a plate enters its slot), ``angle``: the
  angle the sleeves are printed at — "dihedral" (default: each joint's dihedral angle, the plates stay
  flat on a rigid polyhedron), "flat" (180°: straight sleeves that bend the plates when they close the
  sphere, paper §5) or a number of degrees from the tiling's smallest dihedral to 180
  (:func:`sleeve_angle`). A honeycomb strip's joints are flat, so it takes "dihedral", "flat" or 180.
* ``[material]`` the plates' material for the closure solver: ``youngs_modulus`` (N/mm², default
  1000), ``poisson`` (default 0.35), ``strain_limit`` (largest allowed principal strain, default
  0.02: see :class:`MaterialSpec`).
* ``[sheet]``  ``width``, ``height`` (laser sheet or print bed), ``margin``, ``spacing``, ``kerf``,
  ``border`` (true | false, default true: the bed outline on the sheets' non-plotting layer SHEET),
  ``dxf_entities`` ("polyline" | "segments", default "polyline": closed LWPOLYLINEs with bulges for
  laser fills, or one LINE / ARC per piece for OpenSCAD; as ``fabpat export --dxf-entities``).
* ``[estimates]`` ``cut_speed`` (mm/s), ``print_rate`` (mm³/s).
* ``[load]``  ``end_shortening`` (strips and panels): the end-pin travel over the strip length that
  ``simulate-assembly`` uses when ``--end-shortening`` is not given (default 0.1).
* ``[output]``  ``formats``: any of step, stl, glb, 3dm, dxf, svg, bom, png (a panel also
  3mf); ``mesh_tolerance`` (STL chord of the parts and of the sleeves in the .3dm, default 0.005),
  ``curve_tolerance`` (largest deviation of the sheets' DXF arcs from the exact outlines, default 0.01).

Every error is a :class:`~fabpat.errors.SpecError` whose one line names the file, the key and what
is allowed. A key the chosen way of picking patterns does not read (``count`` beside ``hexagon``,
``candidates`` beside any rule but "roundest"), or one the process does not use (``sheet.kerf``,
``estimates.cut_speed`` with ``plates.process = "print"``), is an error, never ignored; so is a format
listed twice. Ranges that depend on the geometry (``tiling.edge``, ``plates.weight``, ``sleeve.depth``)
are checked by :func:`fabpat.assembly.placement.check_geometry` before any work; see
docs/reliability.md.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from fabpat.assembly.spec_tables import COLLECTED as _COLLECTED
from fabpat.assembly.spec_tables import Settled as _Settled
from fabpat.assembly.spec_tables import SpecProblems, read_spec_file
from fabpat.assembly.spec_tables import Table as _Table
from fabpat.assembly.spec_tables import key_text as _key_text
from fabpat.assembly.spec_tables import problems_of as _problems_of
from fabpat.assembly.spec_tables import show as _show
from fabpat.assembly.tiling import Tiling, honeycomb_strip, truncated_icosahedron
from fabpat.errors import PatternError, SpecError
from fabpat.validate import RANGES, check

TILINGS = ("honeycomb-strip", "truncated-icosahedron", "mesh", "goldberg", "hex-tube", "hex-cap", "panel")
#: the flat kinds of rows × columns hexagons, pushed into an arch by ``simulate-assembly``; their patterns are
#: chosen as a strip's (pattern, groups, tiles, rule = "graded")
STRIP_KINDS = ("honeycomb-strip", "panel")
#: largest panel (rows, columns): building and checking the one fused solid grows faster than its tiles
#: (BRepCheck compares the outline's loops pairwise: docs/tilings.md)
MAX_PANEL_ROWS, MAX_PANEL_COLUMNS = 12, 12
#: the kinds whose faces are a polygon mesh kept in the spec (:attr:`TilingSpec.vertices`): a file's, or
#: a built-in surface's (:mod:`fabpat.assembly.polyhedra`, only nearly regular: plates at best fit)
MESH_KINDS = ("mesh", "goldberg", "hex-tube", "hex-cap")
#: the closed built-in kinds that take ``radius`` instead of ``edge``, and the axis their radius is
#: measured from (None: from the centre, a sphere; the tube's axis is x, fabpat.assembly.polyhedra)
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
_DEPTH_OF_DIGITS = {1: 1, 4: 2, 16: 3}  # hex digits of an ID → subdivision depth
#: [patterns] keys that only some ways of choosing patterns read: key → the ways that read it
_GOES_WITH = {"scenario": ("rule",), "count": ("rule",), "catalog": ("rule",), "candidates": ("rule",),
              "group_columns": ("groups", "rule")}
#: [patterns] keys that only one rule reads: key → that rule
_ONLY_RULE = {"candidates": "roundest"}
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
    from outside; :func:`fabpat.assembly.mesh_tiling.mesh_tiling`), so that the spec is plain data.
    """
    kind: str
    edge: float  # mm: plate polygon edge
    rows: int = 1
    columns: int = 1
    file: str | None = None
    tolerance: float = 0.01  # mm (fabpat.assembly.mesh_tiling.DEFAULT_TOLERANCE)
    vertices: tuple[tuple[float, float, float], ...] = ()
    faces: tuple[tuple[int, ...], ...] = ()
    #: "exact" (plates on the faces) or "best" (at their faces' best fit: built-in surfaces, or a mesh's
    #: ``fit = "best"``); the closure ramps the rest of the mismatch to zero
    fit: str = "exact"
    m: int = 1  # goldberg GP(m, n)
    n: int = 0
    realization: str = "dual"  # goldberg: fabpat.assembly.polyhedra.REALIZATIONS
    rings: int = 1  # hex-cap
    centre: int = 5  # hex-cap: sides of the central face
    #: mm: the size asked for instead of ``edge`` (closed kinds, :data:`RADIUS_KINDS`); ``edge`` is then
    #: the plate edge that puts the placed plates at this mean distance from the centre (the axis)
    radius: float | None = None

    @property
    def strip(self) -> bool:
        """A honeycomb strip or a panel (rows × columns of hexagons, pushed into an arch), not a polyhedral
        tiling (closed by its sleeves)."""
        return self.kind in STRIP_KINDS

    @property
    def panel(self) -> bool:
        """A one-piece panel: the strip's hexagons fused into one part, no sleeves (:mod:`fabpat.assembly.panel`)."""
        return self.kind == "panel"

    def skeleton(self) -> Tiling:
        """The tiling of unit edge (:mod:`fabpat.assembly.tiling`; scaled once the sleeves fix the skeleton edge)."""
        if self.kind == "truncated-icosahedron":
            return truncated_icosahedron(1.0)
        if self.kind in MESH_KINDS:
            # every mesh's plates sit at their faces' best fit: a file's faces are regular only within
            # tiling.tolerance, and the sleeve frames must not demand more of them
            return Tiling(self.kind, np.array(self.vertices) / self.edge, self.faces, best_fit=True)
        return honeycomb_strip(self.rows, self.columns, 1.0)

    @property
    def sides(self) -> tuple[int, ...]:
        """Polygons of the tiling's faces, largest first (6 for strips; 6 and 5 for the truncated icosahedron)."""
        if self.kind in MESH_KINDS:
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
    #: per face (in face order) the family member's bridge_weight (fabpat.variation); () = the paper's
    #: fillets on every plate
    bridge_weights: tuple[float, ...] = ()
    #: ``bridge_weight = "rule"``: the rule also picks every pattern's family member, to hit its target
    #: energy (:func:`fabpat.assembly.build.with_members` fills ``bridge_weights``; ``rule = "roundest"``: its
    #: candidate pairs include the catalog's swept members, :func:`fabpat.assembly.build.candidate_pairs`)
    member_rule: bool = False

    def polygon_pattern(self, sides: int) -> str:
        """The pattern the spec names for every face of ``sides`` sides (``polygons``)."""
        return dict(self.polygons)[sides]

    def bridge_weight_of(self, face: int) -> float:
        """The bridge_weight of face ``face``'s plate (1, the paper's, unless the spec gives one)."""
        return self.bridge_weights[face] if self.bridge_weights else 1.0


@dataclass(frozen=True)
class PlateSpec:
    """``[plates]``: thickness (mm), interface fillet weight, process and density (g/cm³)."""
    thickness: float = 2.0  # mm
    weight: float = 0.2  # interface fillet weight (paper §3.3)
    process: str = "print"
    density: float = 1.24  # g/cm³: PLA (notes, §4.1)


@dataclass(frozen=True)
class SleeveSpec:
    """``[sleeve]``: clearance, margin, wall and depth of the sleeve connectors (mm) and the angle they
    are printed at: ``"dihedral"``, ``"flat"`` or a number of degrees (see :func:`sleeve_angle`)."""
    clearance: float = 0.2  # mm: slot width − plate thickness
    margin: float = 1.0  # mm: slot length − interface segment length
    wall: float = 1.2  # mm: three 0.4 mm perimeters
    depth: float = 3.0  # mm: how far a plate enters the slot
    angle: str | float = "dihedral"  # "dihedral" | "flat" | degrees


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
    mesh_tolerance: float = 0.005  # mm: STL chord of the parts (fabpat.cad.DEFAULT_CHORD)
    curve_tolerance: float = 0.01  # mm: DXF sheets' arcs from the exact outlines
    material: MaterialSpec = MaterialSpec()
    end_shortening: float | None = None  # [load]: strips' default end-pin travel / strip length

    @property
    def polygon_sides(self) -> tuple[int, ...]:
        """Polygons used by the tiling, largest first (:attr:`TilingSpec.sides`)."""
        return self.tiling.sides


# -- small typed readers ----------------------------------------------------------------------------


def _pattern_id(source: str, key: str, pid: Any, sides: tuple[int, ...]) -> str:
    """The canonical ID if it is a library pattern for every polygon in ``sides``; SpecError otherwise."""
    from fabpat.lattice import normalize_id
    from fabpat.library import get_pattern

    if not isinstance(pid, str):
        raise SpecError(f"{source}: {key} = {pid!r} must be a pattern ID string such as \"0x0488\"")
    digits = pid.strip().lower().removeprefix("0x")
    depth = _DEPTH_OF_DIGITS.get(len(digits))
    if depth is None:
        raise SpecError(f"{source}: {key} = {pid!r} is not a pattern ID (0x + 1, 4 or 16 hex digits)")
    try:
        for n in sides:
            get_pattern(pid, n, depth)
        return normalize_id(pid, depth)
    except PatternError as e:
        raise SpecError(f"{source}: {key} = {pid!r}: unknown pattern — {e}") from e


# -- the tables -------------------------------------------------------------------------------------


#: [tiling] keys that only some kinds read: key → those kinds
_KIND_KEYS = {"rows": ("honeycomb-strip", "hex-tube", "panel"), "columns": ("honeycomb-strip", "hex-tube", "panel"),
              "file": ("mesh",), "tolerance": ("mesh",), "fit": ("mesh",), "m": ("goldberg",), "n": ("goldberg",),
              "realization": ("goldberg",), "rings": ("hex-cap",), "centre": ("hex-cap",),
              "radius": tuple(RADIUS_KINDS)}


def _tiling(source: str, data: Any) -> TilingSpec:
    t = _Table(source, "tiling", data, ("kind", "edge", *_KIND_KEYS))
    before = len(t.problems)
    kind = t.choice("kind", TILINGS, None)
    unknown_kind = len(t.problems) > before
    if unknown_kind:  # which keys apply depends on the kind
        t.settle()
    for key, kinds in _KIND_KEYS.items():
        if t.has(key) and kind not in kinds:
            t.note(t.fail(key, f"is only for kind = {' or '.join(repr(k) for k in kinds)}".replace("'", '"')), None)
    if kind == "mesh":
        return _mesh_tiling(source, t)
    radius = None
    if t.has("radius") and kind in RADIUS_KINDS:
        if t.has("edge"):
            raise t.fail("radius", "and tiling.edge both size the tiling: give one of them")
        # sized once [plates] and [sleeve] are read (:func:`_sized_by_radius`); unit edge until then
        radius, edge = t.number("radius", None, "edge"), 1.0  # the edge's range, [1, 1000] mm
    else:
        edge = t.number("edge", None, "edge")
    if kind == "honeycomb-strip":
        return TilingSpec(kind, edge, t.integer("rows", None), t.integer("columns", None))
    if kind == "panel":
        return TilingSpec(kind, edge, t.integer("rows", None, 1, MAX_PANEL_ROWS),
                          t.integer("columns", None, 1, MAX_PANEL_COLUMNS))
    if kind in MESH_KINDS:
        return replace(_builtin_tiling(source, t, kind, edge), radius=radius)
    return TilingSpec(kind, edge, radius=radius)


def _sized_by_radius(source: str, tiling: TilingSpec, plates: PlateSpec, sleeve: SleeveSpec) -> TilingSpec:
    """``tiling`` at the plate edge whose placed plates lie ``tiling.radius`` from the centre (a tube: its
    axis): :func:`fabpat.assembly.tiling.edge_for_radius` with the sleeves' allowance
    (:func:`fabpat.assembly.sleeve.skeleton_edge`). That is the kit as placed: with ``sleeve.angle =
    "dihedral"`` the closed shape; straight sleeves bend the plates as they close, and the prediction's
    ``radius`` says where they end (docs/tilings.md gives measured ratios)."""
    from fabpat.assembly.sleeve import skeleton_edge
    from fabpat.assembly.tiling import edge_for_radius

    assert tiling.radius is not None
    unit = replace(tiling, radius=None).skeleton()
    allowance = skeleton_edge(unit, 0.0, plates.thickness, sleeve.clearance, sleeve.wall,
                              lambda phi: printed_angle(sleeve.angle, phi))
    axis = RADIUS_KINDS[tiling.kind]
    lo, hi = RANGES["edge"].low, RANGES["edge"].high
    try:
        edge = edge_for_radius(unit, tiling.radius, allowance, lo, hi, None if axis is None else np.array(axis))
    except ValueError as e:
        raise SpecError(f"{source}: tiling.radius = {tiling.radius:g} mm is out of reach: {e}") from None
    scale = edge / tiling.edge
    return replace(tiling, edge=edge, vertices=tuple((x * scale, y * scale, z * scale) for x, y, z in tiling.vertices))


def _builtin_tiling(source: str, t: _Table, kind: str, edge: float) -> TilingSpec:
    """A built-in surface of nearly regular faces (:mod:`fabpat.assembly.polyhedra`) at plate edge ``edge``."""
    from fabpat.assembly import polyhedra
    from fabpat.assembly.mesh_tiling import mesh_tiling

    if kind == "goldberg":
        m = t.integer("m", None, 1, MAX_GOLDBERG_M)
        n = t.integer("n", 0, 0, MAX_GOLDBERG_M)
        realization = t.choice("realization", polyhedra.REALIZATIONS, "dual")
        t.settle()
        if n > m:
            raise t.fail("n", f"= {n} must be at most tiling.m = {m} (GP(n, m) is the mirror image of GP(m, n))")
        if m * m + m * n + n * n > MAX_GOLDBERG_M ** 2:
            plates = 10 * (m * m + m * n + n * n) + 2
            raise t.fail("n", f"= {n} with tiling.m = {m} makes GP({m}, {n}) of {plates} plates: at most m² + mn + "
                         f"n² = {MAX_GOLDBERG_M ** 2} (GP({MAX_GOLDBERG_M}, 0), {10 * MAX_GOLDBERG_M ** 2 + 2} plates)")
        V, faces = polyhedra.goldberg(m, n, realization)
        extra: dict[str, Any] = {"m": m, "n": n, "realization": realization}
    elif kind == "hex-tube":
        rows, columns = t.integer("rows", None, 3, MAX_TUBE_ROWS), t.integer("columns", None, 1, MAX_TUBE_COLUMNS)
        t.settle()
        V, faces = polyhedra.hex_tube(rows, columns)
        extra = {"rows": rows, "columns": columns}
    else:
        rings = t.integer("rings", None, 1, MAX_CAP_RINGS)
        centre = t.integer("centre", 5, 5, 6)
        t.settle()
        V, faces = polyhedra.hex_cap(rings, centre)
        extra = {"rings": rings, "centre": centre}
    # our own surfaces are near-regular by construction: the bound only guards the closure's start (the
    # roughest, hex-cap rings = 8 and GP(6, 0) planar, need 0.3 and 0.4 of the edge)
    skel = mesh_tiling(V, faces, edge=edge, fit="best", name=kind, tolerance=BUILTIN_TOLERANCE * edge,
                       source=f"{source}: tiling.kind = {kind!r}")
    return TilingSpec(kind, edge, vertices=tuple((float(x), float(y), float(z)) for x, y, z in skel.V),
                      faces=skel.faces, fit="best", **extra)


def _mesh_tiling(source: str, t: _Table) -> TilingSpec:
    """``kind = "mesh"``: read and check ``file`` (relative to the spec's folder) at ``edge`` and ``tolerance``."""
    from fabpat.assembly.mesh_tiling import BEST_FIT_TOLERANCE, DEFAULT_TOLERANCE, FITS, mesh_tiling, read_polygon_mesh

    name = t.string("file")
    edge = t.number("edge", None, "edge") if t.has("edge") else None
    fit = t.choice("fit", FITS, "exact")
    # any positive length here; mesh_tiling bounds it by the edge (MAX_TOLERANCE × edge, as its default)
    tolerance = t.number("tolerance", DEFAULT_TOLERANCE, "sleeve_length") if t.has("tolerance") else None
    if name is None or not name.strip():
        raise t.fail("file", f"is {'missing' if name is None else 'empty'}: the polygon mesh (OBJ, PLY or OFF) "
                     "whose faces carry the plates")
    t.settle()
    path = Path(name) if Path(name).is_absolute() else Path(source).parent / name
    try:
        V, faces = read_polygon_mesh(path)
        skel = mesh_tiling(V, faces, tolerance=tolerance, edge=edge, source=str(path), fit=fit)
    except SpecError as e:
        raise SpecError(f"{source}: tiling.file: {e}") from None
    if edge is None:  # the plates take the mesh's own (mean) edge
        edge = float(np.linalg.norm(skel.V[skel.edges[:, 1]] - skel.V[skel.edges[:, 0]], axis=1).mean())
        try:
            check("edge", edge, "the mesh's mean edge (tiling.edge)", error=SpecError)
        except SpecError as err:
            raise SpecError(f"{source}: tiling.file: {err}; give tiling.edge to scale the mesh") from None
    if tolerance is None:
        tolerance = DEFAULT_TOLERANCE if fit == "exact" else BEST_FIT_TOLERANCE * edge
    return TilingSpec("mesh", edge, file=str(path), tolerance=tolerance, fit=fit,
                      vertices=tuple((float(x), float(y), float(z)) for x, y, z in skel.V), faces=skel.faces)


def _patterns(source: str, data: Any, tiling: TilingSpec) -> PatternSpec:
    allowed = ("pattern", "groups", "group_columns", "tiles", *POLYGON_KEYS.values(), "rule", "scenario",
               "count", "catalog", "candidates", "bridge_weight")
    t = _Table(source, "patterns", data, allowed)
    value = t.data.get("bridge_weight")
    if value == "rule":
        chosen = _pattern_way(source, t, tiling)
        if chosen.rule not in MEMBER_RULES:
            raise SpecError(f"{source}: patterns.bridge_weight = \"rule\" goes with patterns.rule = "
                            f"{' or '.join(repr(r) for r in MEMBER_RULES)} (the rule picks each pattern's member "
                            "to hit its target energy): give numbers instead")
        if not tiling.strip and tiling.sides != (6, 5):
            raise SpecError(f"{source}: patterns.bridge_weight = \"rule\" matches a pentagon's family member to its "
                            "hexagon's energy; this tiling has other faces: give numbers instead")
        return dataclasses.replace(chosen, member_rule=True)
    members = _bridge_weights(source, value, tiling) if t.has("bridge_weight") else ()
    return dataclasses.replace(_pattern_way(source, t, tiling), bridge_weights=members)


#: the rules that can also choose each pattern's family member (``bridge_weight = "rule"``)
MEMBER_RULES = ("graded", "similar-energy", "roundest")


def _bridge_weights(source: str, value: Any, tiling: TilingSpec) -> tuple[float, ...]:
    """``patterns.bridge_weight``: one number for every plate, or a table {plate label = number} (plates
    it does not name keep the paper's 1); per face, in face order. Each value in its range
    (:data:`fabpat.validate.RANGES`)."""
    labels = _labels(tiling)

    def weight(v: Any, label: str) -> float:
        try:
            return check("bridge_weight", v, label, error=SpecError)
        except SpecError as e:
            raise SpecError(f"{source}: {e}") from None

    if isinstance(value, Mapping):
        unknown = [k for k in value if k not in labels]
        if unknown:
            raise SpecError(f"{source}: patterns.bridge_weight.{unknown[0]} is not a plate of this "
                            f"{tiling.kind} (labels {labels[0]} … {labels[-1]})")
        return tuple(weight(value[lab], f"patterns.bridge_weight.{lab}") if lab in value else 1.0 for lab in labels)
    if value in MEMBER_RULES:  # the rule's name where "rule" belongs: say how the two keys go together
        raise SpecError(f"{source}: patterns.bridge_weight = {value!r}: a rule is named by patterns.rule; "
                        f"write patterns.rule = {value!r} and patterns.bridge_weight = \"rule\" for the rule "
                        "to pick each pattern's member")
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SpecError(f"{source}: patterns.bridge_weight must be a number (every plate), a table "
                        f"{{plate label = number}}, e.g. {{{labels[0]} = 0.5}}, or \"rule\"; got {value!r}")
    return (weight(value, "patterns.bridge_weight"),) * len(labels)


def _labels(tiling: TilingSpec) -> list[str]:
    """The kit's plate labels in face order."""
    if tiling.strip:
        return strip_labels(tiling.rows, tiling.columns)
    return list(tiling.skeleton().labels)


def _pattern_way(source: str, t: _Table, tiling: TilingSpec) -> PatternSpec:
    strip = tiling.strip
    sides = tiling.sides
    names = [POLYGON_KEYS[n] for n in sides]
    by_polygon = " + ".join(names)
    given = [k for k in dict.fromkeys([*names, *POLYGON_KEYS.values()]) if t.has(k)]  # the tiling's own first
    ways = [k for k in ("pattern", "groups", "tiles", "rule") if t.has(k)] + given[:1]
    options = "pattern, groups, tiles or rule" if strip else f"pattern, {by_polygon}, tiles or rule"
    if not ways:
        raise SpecError(f"{source}: [patterns] needs one of: {options}")
    if len(ways) > 1:
        raise SpecError(f"{source}: [patterns] sets both {ways[0]} and {ways[1]}: use one of {options}")
    way = ways[0]
    only_strip = {"groups", "group_columns"}
    for key in t.data:
        if (strip and key in POLYGON_KEYS.values()) or (not strip and key in only_strip):
            t.note(t.fail(key, f"does not apply to tiling.kind = {tiling.kind!r}"), None)
        elif not strip and key in POLYGON_KEYS.values() and key not in names:
            t.note(t.fail(key, f"names no face of this {tiling.kind}: its faces are {', '.join(names)}"), None)
    # a key that the chosen way does not read is an error, as a key of the other tiling is (never ignored)
    for key in t.data:
        if key in _GOES_WITH and way not in _GOES_WITH[key]:
            with_ = " or ".join(f"patterns.{w}" for w in _GOES_WITH[key])
            with_ += f" = {_ONLY_RULE[key]!r}" if key in _ONLY_RULE else ""
            t.note(t.fail(key, f"does not apply to patterns.{way} (it goes with {with_})"), None)
    catalog = t.string("catalog")
    if catalog and not Path(catalog).is_absolute() and Path(source).parent != Path(""):
        catalog = str(Path(source).parent / catalog)  # a relative catalog path is relative to the spec file
    if way == "pattern":
        return PatternSpec(pattern=_pattern_id(source, "patterns.pattern", t.data["pattern"], sides))
    if way in POLYGON_KEYS.values():
        for key in names:
            if not t.has(key):
                raise SpecError(f"{source}: missing key patterns.{key} (a pattern ID, e.g. \"0x0488\"): the tiling has "
                                f"{by_polygon} faces, each needs its pattern")
        t.settle()
        return PatternSpec(polygons=tuple((n, _pattern_id(source, f"patterns.{key}", t.data[key], (n,)))
                                          for n, key in zip(sides, names, strict=True)))
    if way == "rule":
        rules = STRIP_RULES if strip else SPHERE_RULES
        before = len(t.problems)
        rule = t.choice("rule", rules, None)
        if len(t.problems) > before:  # what else is allowed depends on the rule
            t.settle()
        scenario = t.choice("scenario", SCENARIOS, "cylinder" if strip else "dome")
        count = t.integer("count", 5, 2) if strip else 2
        if not strip and t.has("count"):
            raise t.fail("count", f"does not apply to rule = {rule!r} (it picks two patterns; rule = \"roundest\" "
                         "tries patterns.candidates pairs)")
        if not strip and sides != (6, 5) and rule == "roundest":
            raise t.fail("rule", f"= \"roundest\" tries hexagon–pentagon pairs, but this tiling's faces are "
                         f"{', '.join(names)}: use rule = \"similar-energy\" or name the patterns")
        if t.has("candidates") and rule != _ONLY_RULE["candidates"]:
            raise t.fail("candidates", f"does not apply to patterns.rule = {rule!r} (it goes with patterns.rule = "
                         f"{_ONLY_RULE['candidates']!r})")
        candidates = t.integer("candidates", PatternSpec.candidates, 1, MAX_CANDIDATES)
        group_columns = t.integer("group_columns", max(1, tiling.columns // count)) if strip else 1
        t.settle()  # the group count below reads count and group_columns
        if strip and math.ceil(tiling.columns / group_columns) != count:
            raise t.fail("group_columns", f"= {group_columns} makes {math.ceil(tiling.columns / group_columns)} "
                         f"groups of tiling.columns = {tiling.columns}, but patterns.count = {count}")
        return PatternSpec(rule=rule, scenario=scenario, count=count, group_columns=group_columns, catalog=catalog,
                           candidates=candidates)
    if way == "groups":
        groups = t.data["groups"]
        if not isinstance(groups, list) or not groups:
            raise t.fail("groups", "must be a non-empty list of pattern IDs (stiff → soft)")
        ids = tuple(_pattern_id(source, f"patterns.groups[{i}]", g, sides) for i, g in enumerate(groups))
        gc = t.integer("group_columns", None)
        t.settle()
        need = math.ceil(tiling.columns / gc)
        if need != len(ids):
            raise t.fail("groups", f"has {len(ids)} IDs but tiling.columns = {tiling.columns} in groups of "
                         f"patterns.group_columns = {gc} makes {need} groups")
        return PatternSpec(groups=ids, group_columns=gc)
    tiles = t.data["tiles"]
    if not strip:
        if not isinstance(tiles, Mapping):
            raise t.fail("tiles", "must be a table {plate label = pattern ID} naming every face (H01 = \"0x0488\", …)")
        return PatternSpec(tiles=(_face_table(source, tiles, tiling),))
    if isinstance(tiles, Mapping):
        return PatternSpec(tiles=_tile_table(source, tiles, tiling, sides))
    if (not isinstance(tiles, list) or len(tiles) != tiling.rows
            or any(not isinstance(r, list) or len(r) != tiling.columns for r in tiles)):
        raise t.fail("tiles", f"must be {tiling.rows} rows (tiling.rows) of {tiling.columns} IDs (tiling.columns)")
    cache: dict[str, str] = {}
    rows = []
    for r, row in enumerate(tiles):
        out = []
        for c, pid in enumerate(row):
            if not isinstance(pid, str):  # a list or table cell: unhashable, and not an ID anyway
                raise SpecError(f"{source}: patterns.tiles[{r}][{c}] = {pid!r} must be a pattern ID string")
            if pid not in cache:
                cache[pid] = _pattern_id(source, f"patterns.tiles[{r}][{c}]", pid, sides)
            out.append(cache[pid])
        rows.append(tuple(out))
    return PatternSpec(tiles=tuple(rows))


def strip_labels(rows: int, columns: int) -> list[str]:
    """The kit's plate labels of a strip, in face order (column by column): "T" and the face number,
    zero-padded to the width of the largest (as :func:`fabpat.assembly.placement.place` labels them)."""
    n = rows * columns
    return [f"T{f + 1:0{len(str(n))}d}" for f in range(n)]


def _check_labels(source: str, table: Mapping[str, Any], labels: list[str], unknown_why: str, noun: str,
                  missing_hint: str) -> None:
    """SpecError (one line) for the first key of a ``tiles`` table that is not a label, then for the first
    label it lacks."""
    unknown = [k for k in table if k not in labels]
    if unknown:
        raise SpecError(f"{source}: patterns.tiles.{unknown[0]} {unknown_why}")
    missing = [k for k in labels if k not in table]
    if missing:
        raise SpecError(f"{source}: patterns.tiles has no pattern for {noun} {missing[0]} ({missing_hint})")


def _face_table(source: str, table: Mapping[str, Any], tiling: TilingSpec) -> tuple[str, ...]:
    """``tiles = {LABEL = "0x....", …}`` on a polyhedron: every face's pattern in face order, each ID checked
    for its face's polygon."""
    from fabpat.assembly.tiling import FACE_LETTERS

    skel = tiling.skeleton()
    labels = list(skel.labels)
    letters = ", ".join(f"{FACE_LETTERS.get(n, 'F')} {POLYGON_KEYS[n]}s" for n in tiling.sides)
    _check_labels(source, table, labels,
                  f"is not a face of the {tiling.kind} (labels {labels[0]} … {labels[-1]} by polygon: {letters})",
                  "face", f"give every face one: {len(labels)} faces")
    return tuple(_pattern_id(source, f"patterns.tiles.{lab}", table[lab], (int(n),))
                 for lab, n in zip(labels, skel.sides, strict=True))


def _tile_table(source: str, table: Mapping[str, Any], tiling: TilingSpec,
                sides: tuple[int, ...]) -> tuple[tuple[str, ...], ...]:
    """``tiles = {LABEL = "0x....", …}``: one pattern per plate label, every label of the strip once; the
    rows × columns IDs it stands for."""
    labels = strip_labels(tiling.rows, tiling.columns)
    _check_labels(source, table, labels, f"is not a plate of this strip (labels {labels[0]} … {labels[-1]})",
                  "plate", f"give every plate {labels[0]} … {labels[-1]} one")
    grid = [[""] * tiling.columns for _ in range(tiling.rows)]
    for f, lab in enumerate(labels):  # faces run column by column (fabpat.assembly.tiling.honeycomb_strip)
        grid[f % tiling.rows][f // tiling.rows] = _pattern_id(source, f"patterns.tiles.{lab}", table[lab], sides)
    return tuple(tuple(r) for r in grid)


def _load(source: str, data: Any, kind: str) -> float | None:
    """``[load] end_shortening``: the strip's default end-pin travel over its length (simulate-assembly)."""
    t = _Table(source, "load", data, ("end_shortening",))
    if kind not in STRIP_KINDS and t.has("end_shortening"):
        raise t.fail("end_shortening", "applies to strips (a closed assembly is bent by its sleeves): leave "
                     "[load] out")
    return t.number("end_shortening", None, "end_shortening") if t.has("end_shortening") else None


def _plates(source: str, data: Any) -> PlateSpec:
    t = _Table(source, "plates", data, ("thickness", "weight", "process", "density"))
    return PlateSpec(t.number("thickness", 2.0, "thickness"), t.number("weight", 0.2, "weight"),
                     t.choice("process", PROCESSES, "print"),
                     t.number("density", 1.24, "density"))


def smallest_dihedral(tiling: TilingSpec) -> float:
    """Smallest interior dihedral angle (rad) of the joints of ``tiling``: the lowest ``[sleeve] angle``.

    Truncated icosahedron: the hexagon–hexagon angle arccos(−√5/3) ≈ 138.19°
    (:data:`fabpat.assembly.tiling.HEX_HEX_DIHEDRAL`); a mesh: its sharpest fold; a honeycomb strip is flat (π).
    """
    from fabpat.assembly.tiling import HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL

    if tiling.kind == "truncated-icosahedron":
        return min(HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL)
    if tiling.kind in MESH_KINDS:
        skel = tiling.skeleton()
        return float(skel.dihedral[skel.interior_edges].min(initial=math.pi))
    return math.pi


def _sleeve_angle(t: _Table, tiling: TilingSpec) -> str | float:
    """``[sleeve] angle``: "dihedral", "flat" or degrees in [smallest dihedral of the tiling, 180]."""
    v = t.data.get("angle", "dihedral")
    kind = tiling.kind
    if isinstance(v, str):
        if v not in SLEEVE_ANGLES:
            raise t.fail("angle", f"= {v!r} is not allowed: choose \"dihedral\", \"flat\" or a number of degrees"
                         + (f" in [{math.degrees(smallest_dihedral(tiling)):.2f}, 180]" if not tiling.strip
                            else " (180: a strip has flat joints)"))
        return v
    if tiling.strip:
        if isinstance(v, bool) or not isinstance(v, int | float) or v != 180:
            raise t.fail("angle", f"= {v!r} is not allowed on a honeycomb strip: a strip has flat joints, so choose "
                         "\"dihedral\", \"flat\" or 180")
        return 180.0
    low = math.degrees(smallest_dihedral(tiling))
    ok = not isinstance(v, bool) and isinstance(v, int | float) and low <= v <= 180.0  # NaN fails the comparison
    if not ok:
        raise t.fail("angle", f"= {v!r} is not allowed: choose \"dihedral\", \"flat\" or a number of degrees in "
                     f"[{low:.2f}, 180] (a {kind} has dihedral angles from {low:.2f}°; 180° is straight)")
    return float(v)


def sleeve_angle(spec: AssemblySpec, dihedral: float) -> float:
    """The angle (rad) a sleeve is printed at, for a joint whose skeleton dihedral angle is ``dihedral`` (rad).

    ``[sleeve] angle`` = "dihedral" → ``dihedral`` (the plates stay flat on the polyhedron); "flat" → π
    (straight sleeves: the plates bend when the sleeves close the sphere, paper §5); a number of
    degrees → that angle in radians. The joint's change of angle on closing is ``dihedral − angle``.
    """
    return printed_angle(spec.sleeve.angle, dihedral)


def printed_angle(angle: str | float, dihedral: float) -> float:
    """:func:`sleeve_angle` for the ``[sleeve] angle`` value ``angle`` itself."""
    if angle == "dihedral":
        return float(dihedral)
    if angle == "flat":
        return math.pi
    return math.radians(float(angle))


def _sleeve(source: str, data: Any, tiling: TilingSpec | None) -> SleeveSpec:
    """``[sleeve]``; its angle is checked against the ``tiling`` (None: the tiling is wrong, the angle
    is checked on the next run)."""
    t = _Table(source, "sleeve", data, ("clearance", "margin", "wall", "depth", "angle"))
    return SleeveSpec(t.number("clearance", 0.2, "clearance"), t.number("margin", 1.0, "gap"),
                      t.number("wall", 1.2, "sleeve_length"), t.number("depth", 3.0, "sleeve_length"),
                      _sleeve_angle(t, tiling) if tiling is not None else "dihedral")


def _material(source: str, data: Any) -> MaterialSpec:
    t = _Table(source, "material", data, ("youngs_modulus", "poisson", "strain_limit"))
    d = MaterialSpec()
    return MaterialSpec(t.number("youngs_modulus", d.youngs_modulus, "youngs_modulus"),
                        t.number("poisson", d.poisson, "poisson"),
                        t.number("strain_limit", d.strain_limit, "strain_limit"))


def _sheet(source: str, data: Any, process: str | None) -> SheetSpec:
    from fabpat.exchange.dxf import ENTITY_MODES

    t = _Table(source, "sheet", data, ("width", "height", "margin", "spacing", "kerf", "border", "dxf_entities"))
    t.only_for("kerf", process, "laser")  # printed plates are not cut: a kerf would only move their outlines
    kerf = t.number("kerf", 0.15 if process == "laser" else 0.0, "kerf")
    return SheetSpec(t.number("width", None, "sheet_size"), t.number("height", None, "sheet_size"),
                     t.number("margin", 5.0, "gap"), t.number("spacing", 3.0, "gap"), kerf,
                     t.boolean("border", True), t.choice("dxf_entities", ENTITY_MODES, "polyline"))


def _estimates(source: str, data: Any, process: str | None) -> EstimateSpec:
    t = _Table(source, "estimates", data, ("cut_speed", "print_rate"))
    t.only_for("cut_speed", process, "laser")  # print_rate applies to both: sleeves are always printed
    return EstimateSpec(t.number("cut_speed", 15.0, "rate"), t.number("print_rate", 3.0, "rate"))


def _output(source: str, data: Any, kind: str | None = None) -> tuple[tuple[str, ...], float, float]:
    """Formats (a panel's: :data:`PANEL_FORMATS`), STL chord (mm) and DXF arc tolerance (mm) of ``[output]``."""
    t = _Table(source, "output", data, ("formats", "mesh_tolerance", "curve_tolerance"))
    tolerances = (t.number("mesh_tolerance", AssemblySpec.mesh_tolerance, "mesh_tolerance"),
                  t.number("curve_tolerance", AssemblySpec.curve_tolerance, "curve_tolerance"))
    return (_formats(t, PANEL_FORMATS if kind == "panel" else FORMATS), *tolerances)


def _formats(t: _Table, allowed: tuple[str, ...] = FORMATS) -> tuple[str, ...]:
    formats = t.data.get("formats", list(allowed))
    if not isinstance(formats, list) or not formats:
        raise t.fail("formats", f"must be a non-empty list of: {', '.join(allowed)}")
    for f in formats:
        if f == "3mf" and f not in allowed:  # a kit of many parts writes them as STL files
            raise t.fail("formats", "contains '3mf', which is for tiling.kind = \"panel\" (one part): a kit's parts "
                         f"are written as STL; allowed values are {', '.join(allowed)}")
        if f not in allowed:
            raise t.fail("formats", f"contains {f!r}: allowed values are {', '.join(allowed)}")
    twice = [f for i, f in enumerate(formats) if f in formats[:i]]
    if twice:  # a typo or a merge slip: say so rather than pick one silently
        raise t.fail("formats", f"lists {twice[0]!r} twice: give each format once")
    return tuple(formats)


def check_sheet_fits(spec: AssemblySpec) -> None:
    """Raise SpecError if a plate (plus kerf, the sheet margin and one nesting step) cannot lie on the sheet.

    Tries the two turns the nesting uses (0 and π/n); the 1 mm slack is the nesting grid's step.
    """
    from fabpat.assembly.nesting import DEFAULT_RESOLUTION
    from fabpat.lattice import polygon_vertices

    if spec.tiling.panel:
        from fabpat.assembly.panel_sheet import check_panel_fits

        return check_panel_fits(spec)
    s = spec.sheet
    room = (s.width - 2 * s.margin - DEFAULT_RESOLUTION, s.height - 2 * s.margin - DEFAULT_RESOLUTION)
    for n in spec.polygon_sides:
        P = polygon_vertices(n, spec.tiling.edge)
        sizes = []
        for a in (0.0, math.pi / n):
            Q = P @ [[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]
            sizes.append(Q.max(axis=0) - Q.min(axis=0) + s.kerf)
        if not any(w <= room[0] + 1e-9 and h <= room[1] + 1e-9 for w, h in sizes):
            name = POLYGON_KEYS[n]
            w, h = min(sizes, key=lambda v: max(v[0] - room[0], v[1] - room[1]))
            raise SpecError(
                f"{spec.source}: sheet.width × sheet.height = {s.width:g} × {s.height:g} mm is smaller than a "
                f"{name} plate ({w:.1f} × {h:.1f} mm plus sheet.margin = {s.margin:g} mm on each side)"
            )


def _name(source: str, data: Mapping[str, Any]) -> str:
    """``name``: printable characters (letters, digits, punctuation and spaces of any script; no control
    characters such as NUL, tab or newline), at most :data:`MAX_NAME_LENGTH` after stripping spaces. It
    titles the pictures, the STEP product and the net, so it must be text every format can hold."""
    name = data.get("name", Path(source).stem)
    if not isinstance(name, str) or not name.strip():
        raise SpecError(f"{source}: name = {_show(name)} must be a non-empty string")
    name = name.strip()
    bad = next((c for c in name if not c.isprintable()), None)
    if bad is not None:
        raise SpecError(f"{source}: name = {_show(name)} holds the control character {bad!r}: use printable "
                        "characters only (letters, digits, punctuation, spaces)")
    if len(name) > MAX_NAME_LENGTH:
        raise SpecError(f"{source}: name is {len(name)} characters long: use at most {MAX_NAME_LENGTH}")
    return name


def parse_spec(data: Mapping[str, Any], source: str = "<spec>", *, need_sheet: bool = False) -> AssemblySpec:
    """Validate a decoded TOML document (a mapping of tables) and return the spec.

    ``[sheet]`` may be left out (``sheet`` is then None) unless ``need_sheet`` (``fabpat assemble``
    nests the plates on it). Every problem found is reported at once: a :class:`SpecProblems` (a
    :class:`SpecError`) with one line per problem naming the key and the allowed values; ``[patterns]``
    is checked once ``[tiling]`` is valid, since what it allows depends on the tiling.
    """
    if not isinstance(source, str):
        source = str(source)
    if not isinstance(data, Mapping):
        raise SpecError(f"{source}: a spec must be a table of TOML tables ([tiling], [patterns], …), got "
                        f"{type(data).__name__}")
    problems: list[str] = []
    token = _COLLECTED.set(problems)
    try:
        spec = _read_tables(data, source, need_sheet, problems)
    except RecursionError as e:  # a value nested thousands deep: not a spec
        raise SpecError(f"{source}: a value is nested too deep to be a spec") from e
    finally:
        _COLLECTED.reset(token)
    if problems:
        raise SpecProblems(problems, source)
    assert spec is not None
    if spec.sheet is not None:
        check_sheet_fits(spec)
    return spec


def _read_tables(data: Mapping[str, Any], source: str, need_sheet: bool, problems: list[str]) -> AssemblySpec | None:
    """Every table of :func:`parse_spec`, each read on after another's problems (collected in ``problems``)."""
    def read(f: Callable[[], Any]) -> Any:  # a table with a problem gives None: nothing reads its fallbacks
        before = len(problems)
        try:
            value = f()
        except _Settled:
            return None
        except SpecError as e:
            problems.extend(_problems_of(e))
            return None
        return value if len(problems) == before else None

    top = ("name", "tiling", "patterns", "plates", "sleeve", "material", "sheet", "estimates", "output", "load")
    for key in data:
        if key not in top:
            problems.append(f"{source}: unknown key {_key_text(key)} (allowed: {', '.join(top)})")
    for key in ("tiling", "patterns", "sheet") if need_sheet else ("tiling", "patterns"):
        if key not in data:
            problems.append(f"{source}: missing table [{key}]" + (
                " (fabpat assemble nests the plates on this laser sheet or print bed: give its width and height)"
                if key == "sheet" else ""))
    name = read(lambda: _name(source, data))
    tiling = read(lambda: _tiling(source, data["tiling"])) if "tiling" in data else None
    plates = read(lambda: _plates(source, data.get("plates", {})))
    process = plates.process if plates is not None else None
    kind = tiling.kind if tiling is not None else None
    if kind == "panel" and "sleeve" in data:
        problems.append(f"{source}: [sleeve] applies to assemblies joined by sleeves; tiling.kind = \"panel\" is one "
                        "part with its plates fused: leave [sleeve] out")
    sleeve = read(lambda: _sleeve(source, data.get("sleeve", {}), tiling))
    if tiling is not None and tiling.radius is not None and plates is not None and sleeve is not None:
        tiling = read(lambda: _sized_by_radius(source, tiling, plates, sleeve))
    material = read(lambda: _material(source, data.get("material", {})))
    sheet = read(lambda: _sheet(source, data["sheet"], process)) if "sheet" in data else None
    estimates = read(lambda: _estimates(source, data.get("estimates", {}), process))
    output = read(lambda: _output(source, data.get("output", {}), kind))
    patterns = read(lambda: _patterns(source, data["patterns"], tiling)) if tiling and "patterns" in data else None
    load = read(lambda: (_load(source, data.get("load", {}), kind),)) if kind is not None else (None,)
    if problems:
        return None
    return AssemblySpec(name, source, tiling, patterns, plates, sleeve, sheet, estimates, *output, material=material,
                        end_shortening=load[0])


def load_spec(path: str | os.PathLike[str], *, need_sheet: bool = False) -> AssemblySpec:
    """Read and validate a spec file (:func:`parse_spec`; ``need_sheet`` as there).

    Raises :class:`SpecError` (one line per problem) if ``path`` is not a path, not a regular file (a
    folder, FIFO or device such as /dev/zero is refused before it is read), larger than
    :data:`~fabpat.assembly.spec_tables.MAX_SPEC_BYTES`, not UTF-8 TOML, or not a valid spec
    (:func:`fabpat.assembly.spec_tables.read_spec_file`).
    """
    p, data = read_spec_file(path)
    return parse_spec(data, str(p), need_sheet=need_sheet)
