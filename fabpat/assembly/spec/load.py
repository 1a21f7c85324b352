"""Assembly spec files (TOML): what to build, with every value checked before anything is built.

A spec has these tables (lengths in mm; see ``assemblies/*.toml`` for commented examples):

* ``[tiling]``  ``kind`` ("honeycomb-strip" | "truncated-icosahedron" | "mesh" | "goldberg" | "hex-tube" |
  "hex-cap" | "panel"), ``edge`` (plate polygon edge), ``rows`` and ``columns`` (strip, tube and panel); a
  ``panel`` is the strip's rows × columns hexagons (each 1 … :data:`MAX_PANEL_ROWS`) fused at their
  interfaces into ONE part, without sleeves (:mod:`fabpat.assembly.place.panel`; patterns as on a strip, no
  ``[sleeve]`` table, ``output.formats`` may add "3mf"), or instead of ``rows`` and ``columns`` the faces of
  ``file``, a flat polygon mesh (OBJ, PLY or OFF, relative to the spec; at most 144 faces), checked as a mesh
  tiling's and, within ``tolerance`` (mm, default 0.01), flat as a whole (:mod:`fabpat.assembly.surface.panel_mesh`;
  ``edge`` optional, scaling it; patterns as on a mesh tiling, by polygon or face label); a mesh tiling
  reads ``file`` (an OBJ, PLY or OFF polygon mesh, relative to the spec; its faces carry the plates,
  :mod:`fabpat.assembly.surface.mesh_tiling`), takes ``edge`` as optional (default: the mesh's mean edge; given,
  it scales the mesh), ``tolerance`` (mm, default 0.01, with ``fit = "best"`` 0.2 × edge; at most 0.5 ×
  edge: how far the faces may be from regular polygons of one edge) and ``fit`` ("exact" | "best":
  plates at their faces' best fit, the closure takes up the rest) and ``plates`` ("regular" | "shaped": each
  plate its own face's polygon, :mod:`fabpat.assembly.place.shaped`; the faces need then only be within
  ``tolerance`` mm of their planes and within 20 % / 20° of regular, and ``fit = "best"`` is refused; the
  outline is exact, rational Béziers in STEP and .3dm; what has a tolerance is the faces' planarity, the
  sleeve angles' 0.1° step and where a joint's two interfaces lie along it, which the slot's length takes
  up: docs/tilings.md); ``goldberg`` reads ``m``, ``n``,
  ``realization`` ("dual" | "planar"), ``hex-cap`` ``rings`` and ``centre`` (5 | 6)
  (:mod:`fabpat.assembly.surface.polyhedra`; plates at best fit). The closed kinds
  (:data:`RADIUS_KINDS`) take ``radius`` (mm) instead of ``edge``: the plate edge is then chosen so that
  the placed plates lie that far from the centre (a tube: its axis), :func:`_sized_by_radius`.
* ``[patterns]`` one of: ``pattern`` (every tile); ``groups`` (one ID per group of ``group_columns`` columns,
  stiff → soft) or ``tiles`` (rows × columns IDs, or a table {plate label = ID} naming every plate as the kit
  labels it, e.g. ``{T1 = "0x0488", …}``) on a strip or a panel; ``hexagon`` + ``pentagon``, or ``tiles`` = {plate label
  = ID} for every face ("H01" … "H20", "P01" … "P12", each ID of its face's polygon; ``fabpat design`` writes
  it), on the truncated icosahedron; one key per polygon of a mesh tiling, named as the polygon
  (:data:`POLYGON_KEYS`: ``triangle``, ``square``, ``pentagon``, ``hexagon``, …) or ``tiles`` by plate label
  (the polygon's letter and number, :data:`fabpat.assembly.surface.tiling.FACE_LETTERS`); or ``rule`` = "graded"
  (strip: ``count`` patterns with well-separated energies in ``scenario``) / "similar-energy" (sphere or mesh:
  one pattern per polygon, of similar energy in ``scenario``) / "roundest" (sphere: the ``candidates`` best
  similar-energy pairs, default 8, of which the closure solver keeps the roundest under the strain limit),
  read from the catalog (``catalog`` = path, default the built-in one).
* ``[plates]``  ``thickness``, ``weight`` (interface fillet weight), ``process`` ("print" | "laser"),
  ``density`` (g/cm³, for masses), ``thicknesses`` = {plate label = mm, …} (e.g. ``{H01 = 1.1, P03 = 0.9}``,
  the labels the kit gives its plates; a plate not listed keeps ``thickness``; not on a ``panel``) and
  ``thickness_range`` = [MIN, MAX] (mm, default [0.01, 100]): the range a design may choose thicknesses
  from, holding every entry of ``thicknesses``. Plates of different thickness are different parts; a
  sleeve's slots are as wide as the thicker of its two plates + ``clearance``.
* ``[sleeve]``  ``clearance`` (slot width = thickness + clearance), ``margin`` (slot length =
  interface segment + margin), ``wall``, ``depth`` (how far a plate enters its slot), ``angle``: the
  angle the sleeves are printed at — "dihedral" (each joint's dihedral angle, the plates stay flat on a
  rigid polyhedron), "flat" (180°: straight sleeves that bend the plates when they close the sphere,
  paper §5) or a number of degrees from the tiling's smallest dihedral to 180 (:func:`sleeve_angle`);
  default "flat" on a ``goldberg`` sphere, "dihedral" on every other kind (:data:`DEFAULT_SLEEVE_ANGLE`);
  ``angles`` = {joint label = degrees, …} (e.g. ``{E01 = 171.3, E02 = 165.0}``, the joints' labels in the
  kit, "E01" … :func:`fabpat.assembly.surface.joints.joint_labels`): the angle each listed joint's sleeve is
  printed at, rounded to :data:`ANGLE_STEP` (joints within it share one part); a joint not listed
  keeps ``angle``; ``angle_range`` = [MIN, MAX] (degrees in (90, 180], default [150, 180]): the range a
  design may choose angles from, holding every entry of ``angles``.
  A honeycomb strip's joints are flat, so it takes "dihedral", "flat" or 180 (and neither ``angles`` nor
  ``angle_range``).
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
are checked by :func:`fabpat.assembly.place.placement.check_geometry` before any work; see
docs/reliability.md.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from fabpat.assembly.spec.patterns import read_patterns
from fabpat.assembly.spec.tables import COLLECTED as _COLLECTED
from fabpat.assembly.spec.tables import Settled as _Settled
from fabpat.assembly.spec.tables import SpecProblems, read_spec_file
from fabpat.assembly.spec.tables import Table as _Table
from fabpat.assembly.spec.tables import key_text as _key_text
from fabpat.assembly.spec.tables import problems_of as _problems_of
from fabpat.assembly.spec.tables import show as _show
from fabpat.assembly.spec.tiling import read_tiling
from fabpat.assembly.spec.types import (  # noqa: F401 - the spec's names, read from here too
    ANGLE_STEP,
    BUILTIN_TOLERANCE,
    DEFAULT_ANGLE_RANGE,
    DEFAULT_SLEEVE_ANGLE,
    DEFAULT_THICKNESS_RANGE,
    FORMATS,
    MAX_CANDIDATES,
    MAX_CAP_RINGS,
    MAX_GOLDBERG_M,
    MAX_NAME_LENGTH,
    MAX_PANEL_COLUMNS,
    MAX_PANEL_ROWS,
    MAX_TUBE_COLUMNS,
    MAX_TUBE_ROWS,
    MESH_KINDS,
    PANEL_FORMATS,
    POLYGON_KEYS,
    PROCESSES,
    RADIUS_KINDS,
    SCENARIOS,
    SLEEVE_ANGLES,
    SPHERE_RULES,
    STRIP_KINDS,
    STRIP_RULES,
    TILINGS,
    AssemblySpec,
    EstimateSpec,
    MaterialSpec,
    PatternSpec,
    PlateSpec,
    SheetSpec,
    SleeveSpec,
    TilingSpec,
)
from fabpat.errors import SpecError
from fabpat.validate import RANGES

# -- the tables after [tiling] (read by :func:`fabpat.assembly.spec.tiling.read_tiling`) ---------------------


def _sized_by_radius(source: str, tiling: TilingSpec, plates: PlateSpec, sleeve: SleeveSpec) -> TilingSpec:
    """``tiling`` at the plate edge whose placed plates lie ``tiling.radius`` from the centre (a tube: its
    axis): :func:`fabpat.assembly.surface.tiling.edge_for_radius` with the sleeves' allowance
    (:func:`fabpat.assembly.surface.joints.skeleton_edge`). That is the kit as placed: with ``sleeve.angle =
    "dihedral"`` the closed shape; straight sleeves bend the plates as they close, and the prediction's
    ``radius`` says where they end (docs/tilings.md gives measured ratios)."""
    from fabpat.assembly.surface.joints import joint_labels, min_plate_edge, skeleton_edge
    from fabpat.assembly.surface.tiling import edge_for_radius

    assert tiling.radius is not None
    unit = replace(tiling, radius=None).skeleton()
    printed = {k: joint_angle(sleeve, label, float(unit.dihedral[k])) for k, label in joint_labels(unit).items()}
    allowance = skeleton_edge(unit, 0.0, plates.thickest, sleeve.clearance, sleeve.wall, printed)
    axis = RADIUS_KINDS[tiling.kind]
    # the smallest edge a sleeve fits on (placement.check_geometry), the largest the edge's range
    lo = max(RANGES["edge"].low, min_plate_edge(sleeve.margin, sleeve.wall, plates.weight))
    hi = RANGES["edge"].high
    try:
        edge = edge_for_radius(unit, tiling.radius, allowance, lo, hi, None if axis is None else np.array(axis))
    except ValueError as e:
        raise SpecError(f"{source}: tiling.radius = {tiling.radius:g} mm is out of reach: {e}") from None
    scale = edge / tiling.edge
    return replace(tiling, edge=edge, vertices=tuple((x * scale, y * scale, z * scale) for x, y, z in tiling.vertices))


def _load(source: str, data: object, kind: str) -> float | None:
    """``[load] end_shortening``: the strip's default end-pin travel over its length (simulate-assembly)."""
    t = _Table(source, "load", data, ("end_shortening",))
    if kind not in STRIP_KINDS and t.has("end_shortening"):
        raise t.fail("end_shortening", "applies to strips (a closed assembly is bent by its sleeves): leave "
                     "[load] out")
    return t.number("end_shortening", None, "end_shortening") if t.has("end_shortening") else None


def _plates(source: str, data: object, tiling: TilingSpec | None) -> PlateSpec:
    """``[plates]``; ``thicknesses`` are checked against the ``tiling``'s plate labels (None: the tiling is
    wrong, they are checked on the next run)."""
    t = _Table(source, "plates", data, ("thickness", "weight", "process", "density", "thicknesses",
                                        "thickness_range"))
    low, high = DEFAULT_THICKNESS_RANGE  # fabpat.validate's plate thickness
    before = len(t.problems)
    lo, hi = t.pair("thickness_range", DEFAULT_THICKNESS_RANGE,
                    f"two thicknesses [MIN, MAX] in mm with {low:g} ≤ MIN ≤ MAX ≤ {high:g}",
                    lambda a, b: low <= a <= b <= high)
    thicknesses: tuple[tuple[str, float], ...] = ()
    if t.has("thicknesses") and tiling is not None:
        if tiling.panel:
            t.note(t.fail("thicknesses", "applies to kits of plates joined by sleeves; tiling.kind = \"panel\" is "
                          "one part of one thickness: give plates.thickness"), None)
        else:
            labels = tiling.skeleton().labels
            given = t.labelled("thicknesses", "plate")
            for label, v in given.items():
                if label not in labels:
                    t.note(t.fail("thicknesses", f"names {_show(label)}, a plate this tiling lacks: its "
                                  f"{len(labels)} plates are {_span(labels)}"), None)
                elif len(t.problems) == before and not lo <= v <= hi:  # a wrong range says nothing of v
                    t.note(t.fail(f"thicknesses.{label}", f"= {v:g} mm is outside plates.thickness_range = "
                                  f"[{lo:g}, {hi:g}]"), None)
            thicknesses = tuple((label, given[label]) for label in labels if label in given)
    thickness, process = t.number("thickness", 2.0, "thickness"), t.choice("process", PROCESSES, "print")
    several = sorted({thickness, *(v for _, v in thicknesses)}) if thickness is not None else []
    if process == "laser" and len(several) > 1:  # one sheet is one thickness: the kit nests every plate on one
        t.note(t.fail("thicknesses", f"gives plates of {', '.join(f'{v:g}' for v in several)} mm, and "
                      "plates.process = \"laser\" cuts every plate from the same sheets: give each thickness its "
                      "own spec, or print the plates (plates.process = \"print\")"), None)
    return PlateSpec(thickness, t.number("weight", 0.2, "weight"), process,
                     t.number("density", 1.24, "density"), thicknesses, (lo, hi))


def _span(labels: tuple[str, ...] | list[str]) -> str:
    """Labels in a message, first … last of each letter: "H01 … H20, P01 … P12", "E01 … E90"."""
    runs: dict[str, list[str]] = {}
    for label in labels:
        runs.setdefault(label.rstrip("0123456789"), []).append(label)
    return ", ".join(r[0] if len(r) == 1 else f"{r[0]} … {r[-1]}" for r in runs.values())


def smallest_dihedral(tiling: TilingSpec) -> float:
    """Smallest interior dihedral angle (rad) of the joints of ``tiling``: the lowest ``[sleeve] angle``.

    Truncated icosahedron: the hexagon–hexagon angle arccos(−√5/3) ≈ 138.19°
    (:data:`fabpat.assembly.surface.tiling.HEX_HEX_DIHEDRAL`); a mesh: its sharpest fold; a honeycomb strip is flat (π).
    """
    from fabpat.assembly.surface.tiling import HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL

    if tiling.kind == "truncated-icosahedron":
        return min(HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL)
    if tiling.kind in MESH_KINDS:
        skel = tiling.skeleton()
        return float(skel.dihedral[skel.interior_edges].min(initial=math.pi))
    return math.pi


def _sleeve_angle(t: _Table, tiling: TilingSpec) -> str | float:
    """``[sleeve] angle``: "dihedral", "flat" or degrees in [smallest dihedral of the tiling, 180]; without
    it the kind's default (:data:`DEFAULT_SLEEVE_ANGLE`, else "dihedral")."""
    kind = tiling.kind
    v = t.data.get("angle", DEFAULT_SLEEVE_ANGLE.get(kind, "dihedral"))
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


def joint_angle(sleeve: SleeveSpec, label: str, dihedral: float) -> float:
    """The angle (rad) joint ``label``'s sleeve is printed at, its skeleton dihedral angle being
    ``dihedral`` (rad): its entry of ``[sleeve] angles``, rounded to :data:`ANGLE_STEP`
    (:meth:`SleeveSpec.listed_angle`), else :func:`printed_angle` of ``[sleeve] angle``."""
    listed = sleeve.listed_angle(label)
    return printed_angle(sleeve.angle, dihedral) if listed is None else math.radians(listed)


def _sleeve(source: str, data: object, tiling: TilingSpec | None) -> SleeveSpec:
    """``[sleeve]``; its angles are checked against the ``tiling`` (None: the tiling is wrong, the angles
    are checked on the next run)."""
    t = _Table(source, "sleeve", data, ("clearance", "margin", "wall", "depth", "angle", "angles", "angle_range"))
    return SleeveSpec(t.number("clearance", 0.2, "clearance"), t.number("margin", 1.0, "gap"),
                      t.number("wall", 1.2, "sleeve_length"), t.number("depth", 3.0, "sleeve_length"),
                      _sleeve_angle(t, tiling) if tiling is not None else "dihedral",
                      *_joint_angles(t, tiling))


def _joint_angles(t: _Table, tiling: TilingSpec | None) -> tuple[tuple[tuple[str, float], ...], tuple[float, float]]:
    """``[sleeve] angles`` (joint label → degrees, in joint order) and ``angle_range`` (degrees): the range
    in (90, 180] each listed angle must lie in; the labels are the ``tiling``'s joints'
    (:func:`fabpat.assembly.surface.joints.joint_labels`)."""
    from fabpat.assembly.surface.joints import joint_labels

    if tiling is not None and tiling.pushed:
        for key in ("angles", "angle_range"):
            if t.has(key):
                t.note(t.fail(key, "applies to closed tilings (a strip's joints are flat and straight): leave it "
                              "out"), None)
        return (), DEFAULT_ANGLE_RANGE
    before = len(t.problems)
    lo, hi = t.pair("angle_range", DEFAULT_ANGLE_RANGE, "two angles [MIN, MAX] in degrees with 90 < MIN ≤ MAX ≤ 180",
                    lambda a, b: 90.0 < a <= b <= 180.0)
    if not t.has("angles") or tiling is None:
        return (), (lo, hi)
    labels = list(joint_labels(tiling.skeleton()).values())
    given = t.labelled("angles", "joint")
    for label, v in given.items():
        if label not in labels:
            have = f"its {len(labels)} joints are {_span(labels)}" if labels else "it has no joints"
            t.note(t.fail("angles", f"names {_show(label)}, a joint this tiling lacks: {have}"), None)
        elif len(t.problems) == before and not lo <= v <= hi:  # a wrong range says nothing of the angles
            t.note(t.fail(f"angles.{label}", f"= {v:g}° is outside sleeve.angle_range = [{lo:g}, {hi:g}]"), None)
    return tuple((label, given[label]) for label in labels if label in given), (lo, hi)


def _material(source: str, data: object) -> MaterialSpec:
    t = _Table(source, "material", data, ("youngs_modulus", "poisson", "strain_limit"))
    d = MaterialSpec()
    return MaterialSpec(t.number("youngs_modulus", d.youngs_modulus, "youngs_modulus"),
                        t.number("poisson", d.poisson, "poisson"),
                        t.number("strain_limit", d.strain_limit, "strain_limit"))


def _sheet(source: str, data: object, process: str | None) -> SheetSpec:
    from fabpat.exchange.dxf import ENTITY_MODES

    t = _Table(source, "sheet", data, ("width", "height", "margin", "spacing", "kerf", "border", "dxf_entities"))
    t.only_for("kerf", process, "laser")  # printed plates are not cut: a kerf would only move their outlines
    kerf = t.number("kerf", 0.15 if process == "laser" else 0.0, "kerf")
    return SheetSpec(t.number("width", None, "sheet_size"), t.number("height", None, "sheet_size"),
                     t.number("margin", 5.0, "gap"), t.number("spacing", 3.0, "gap"), kerf,
                     t.boolean("border", True), t.choice("dxf_entities", ENTITY_MODES, "polyline"))


def _estimates(source: str, data: object, process: str | None) -> EstimateSpec:
    t = _Table(source, "estimates", data, ("cut_speed", "print_rate"))
    t.only_for("cut_speed", process, "laser")  # print_rate applies to both: sleeves are always printed
    return EstimateSpec(t.number("cut_speed", 15.0, "rate"), t.number("print_rate", 3.0, "rate"))


def _output(source: str, data: object, kind: str | None = None) -> tuple[tuple[str, ...], float, float]:
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
    from fabpat.assembly.spec.sheet import DEFAULT_RESOLUTION
    from fabpat.patterns.lattice import polygon_vertices

    if spec.tiling.panel:
        from fabpat.assembly.spec.sheet import check_panel_fits

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


def _name(source: str, data: Mapping[str, object]) -> str:
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


def parse_spec(data: Mapping[str, object], source: str = "<spec>", *, need_sheet: bool = False) -> AssemblySpec:
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


def _read_tables(data: Mapping[str, object], source: str, need_sheet: bool, problems: list[str]) -> AssemblySpec | None:
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
    tiling = read(lambda: read_tiling(source, data["tiling"])) if "tiling" in data else None
    plates = read(lambda: _plates(source, data.get("plates", {}), tiling))
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
    patterns = read(lambda: read_patterns(source, data["patterns"], tiling)) if tiling and "patterns" in data else None
    load = read(lambda: (_load(source, data.get("load", {}), kind),)) if kind is not None else (None,)
    if problems:
        return None
    return AssemblySpec(name, source, tiling, patterns, plates, sleeve, sheet, estimates, *output, material=material,
                        end_shortening=load[0])


def load_spec(path: str | os.PathLike[str], *, need_sheet: bool = False) -> AssemblySpec:
    """Read and validate a spec file (:func:`parse_spec`; ``need_sheet`` as there).

    Raises :class:`SpecError` (one line per problem) if ``path`` is not a path, not a regular file (a
    folder, FIFO or device such as /dev/zero is refused before it is read), larger than
    :data:`~fabpat.assembly.spec.tables.MAX_SPEC_BYTES`, not UTF-8 TOML, or not a valid spec
    (:func:`fabpat.assembly.spec.tables.read_spec_file`).
    """
    p, data = read_spec_file(path)
    return parse_spec(data, str(p), need_sheet=need_sheet)
