"""Reading ``[tiling]``: which surface the plates tile — a honeycomb strip or panel by rows × columns,
a polygon mesh read from a file, a built-in polyhedron or tube (:mod:`fabpat.assembly.surface.polyhedra`) —
checked key by key for its kind before any work (the format: :mod:`fabpat.assembly.spec.load`, which
sizes a tiling given by ``radius`` once the plates and sleeves are read)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from fabpat.assembly.spec.tables import Table as _Table
from fabpat.assembly.spec.types import (
    BUILTIN_TOLERANCE,
    MAX_CAP_RINGS,
    MAX_GOLDBERG_M,
    MAX_PANEL_COLUMNS,
    MAX_PANEL_ROWS,
    MAX_TUBE_COLUMNS,
    MAX_TUBE_ROWS,
    MESH_KINDS,
    RADIUS_KINDS,
    TILINGS,
    TilingSpec,
)
from fabpat.errors import SpecError
from fabpat.validate import check

_KIND_KEYS = {"rows": ("honeycomb-strip", "hex-tube", "panel"), "columns": ("honeycomb-strip", "hex-tube", "panel"),
              "file": ("mesh", "panel"), "tolerance": ("mesh", "panel"), "fit": ("mesh",), "plates": ("mesh",),
              "m": ("goldberg",), "n": ("goldberg",), "realization": ("goldberg",), "rings": ("hex-cap",),
              "centre": ("hex-cap",), "radius": tuple(RADIUS_KINDS)}


def read_tiling(source: str, data: object) -> TilingSpec:
    """The ``[tiling]`` table ``data`` of the spec file ``source`` as a :class:`TilingSpec` (lengths in mm).

    Which keys apply depends on ``kind`` (:data:`_KIND_KEYS`; the format: :mod:`fabpat.assembly.spec.load`): a
    strip or panel by rows × columns, a mesh read from ``file``, a built-in surface, or sized by ``radius``
    (unit edge here, sized once ``[plates]`` and ``[sleeve]`` are read). Raises :class:`SpecError` (one
    line naming the key and what is allowed), or notes the problem inside :func:`fabpat.assembly.spec.load.parse_spec`.
    """
    t = _Table(source, "tiling", data, ("kind", "edge", *_KIND_KEYS))
    before = len(t.problems)
    kind = t.choice("kind", TILINGS, None)
    unknown_kind = len(t.problems) > before
    if unknown_kind:  # which keys apply depends on the kind
        t.settle()
    for key, kinds in _KIND_KEYS.items():
        if t.has(key) and kind not in kinds:
            t.note(t.fail(key, f"is only for kind = {' or '.join(repr(k) for k in kinds)}".replace("'", '"')), None)
    if t.has("radius") and kind not in RADIUS_KINDS:
        t.settle()  # that one line: not also "missing key tiling.edge" for a spec that sized it otherwise
    if kind == "mesh":
        return _mesh_tiling(source, t)
    if kind == "panel" and (t.has("file") or not (t.has("rows") or t.has("columns"))):
        return panel_tiling_spec(source, t)
    radius = None
    if t.has("radius") and kind in RADIUS_KINDS:
        if t.has("edge"):
            raise t.fail("radius", "and tiling.edge both size the tiling: give one of them")
        # sized once [plates] and [sleeve] are read (:func:`_sized_by_radius`); unit edge until then. A
        # positive length up to a sheet's 10 m here; which radii the plate edges reach is checked there
        radius, edge = t.number("radius", None, "sheet_size"), 1.0
    elif kind in RADIUS_KINDS and not t.has("edge"):
        raise t.fail("edge", "is missing: give tiling.edge (the plate edge, mm) or tiling.radius (the size the "
                     "plates lie at, mm)")
    else:
        edge = t.number("edge", None, "edge")
    if kind == "honeycomb-strip":
        return TilingSpec(kind, edge, t.integer("rows", None), t.integer("columns", None))
    if kind == "panel":
        if t.has("tolerance"):  # read only from a mesh file: never ignored
            raise t.fail("tolerance", "applies to a panel from tiling.file (how far its mesh may be from flat regular "
                         "polygons); rows × columns hexagons are exact")
        return TilingSpec(kind, edge, t.integer("rows", None, 1, MAX_PANEL_ROWS),
                          t.integer("columns", None, 1, MAX_PANEL_COLUMNS))
    if kind in MESH_KINDS:
        return replace(_builtin_tiling(source, t, kind, edge), radius=radius)
    return TilingSpec(kind, edge, radius=radius)


def _builtin_tiling(source: str, t: _Table, kind: str, edge: float) -> TilingSpec:
    """A built-in surface of nearly regular faces (:mod:`fabpat.assembly.surface.polyhedra`) at plate edge ``edge``."""
    from fabpat.assembly.surface import polyhedra
    from fabpat.assembly.surface.mesh_tiling import mesh_tiling

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
        shape = TilingSpec(kind, edge, m=m, n=n, realization=realization)
    elif kind == "hex-tube":
        rows, columns = t.integer("rows", None, 3, MAX_TUBE_ROWS), t.integer("columns", None, 1, MAX_TUBE_COLUMNS)
        t.settle()
        V, faces = polyhedra.hex_tube(rows, columns)
        shape = TilingSpec(kind, edge, rows=rows, columns=columns)
    else:
        rings = t.integer("rings", None, 1, MAX_CAP_RINGS)
        centre = t.integer("centre", 5, 5, 6)
        t.settle()
        V, faces = polyhedra.hex_cap(rings, centre)
        shape = TilingSpec(kind, edge, rings=rings, centre=centre)
    # our own surfaces are near-regular by construction: the bound only guards the closure's start (the
    # roughest, hex-cap rings = 8 and GP(6, 0) planar, need 0.3 and 0.4 of the edge)
    skel = mesh_tiling(V, faces, edge=edge, fit="best", name=kind, tolerance=BUILTIN_TOLERANCE * edge,
                       source=f"{source}: tiling.kind = {kind!r}")
    return replace(shape, vertices=tuple((float(x), float(y), float(z)) for x, y, z in skel.V),
                   faces=skel.faces, fit="best")


def _mesh_tiling(source: str, t: _Table) -> TilingSpec:
    """``kind = "mesh"``: read and check ``file`` (relative to the spec's folder) at ``edge`` and ``tolerance``."""
    from fabpat.assembly.surface.mesh_tiling import (
        BEST_FIT_TOLERANCE,
        DEFAULT_TOLERANCE,
        FITS,
        mesh_tiling,
        read_polygon_mesh,
    )
    from fabpat.assembly.surface.shaped import PLATE_KINDS

    name = t.string("file")
    edge = t.number("edge", None, "edge") if t.has("edge") else None
    fit = t.choice("fit", FITS, "exact")
    plates = t.choice("plates", PLATE_KINDS, "regular")
    # any positive length here; mesh_tiling bounds it by the edge (MAX_TOLERANCE × edge, as its default)
    tolerance = t.number("tolerance", DEFAULT_TOLERANCE, "sleeve_length") if t.has("tolerance") else None
    if name is None and t.has("file"):
        t.settle()  # a file that is not a string is that one problem, not also "missing"
    if name is None or not name.strip():
        raise t.fail("file", f"is {'missing' if name is None else 'empty'}: the polygon mesh (OBJ, PLY or OFF) "
                     "whose faces carry the plates")
    t.settle()
    if plates == "shaped" and fit == "best":  # a shaped plate is its face: nothing to fit
        raise t.fail("fit", "= \"best\" places regular plates at their faces' best fit; tiling.plates = \"shaped\" "
                     "makes each plate its own face's polygon: leave fit out")
    path = Path(name) if Path(name).is_absolute() else Path(source).parent / name
    try:
        V, faces = read_polygon_mesh(path)
        skel = mesh_tiling(V, faces, tolerance=tolerance, edge=edge, source=str(path), fit=fit, plates=plates)
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
    return TilingSpec("mesh", edge, file=str(path), tolerance=tolerance, fit=fit, plates=plates,
                      vertices=tuple((float(x), float(y), float(z)) for x, y, z in skel.V), faces=skel.faces)


def panel_tiling_spec(source: str, t: _Table) -> TilingSpec:
    """The ``TilingSpec`` of ``kind = "panel"`` with ``file``: the flat mesh (relative to the spec's folder)
    read, checked and laid on its exact tiling of regular polygons at ``edge`` and ``tolerance`` (module
    docstring). ``file`` and ``rows``/``columns`` are two ways to give the panel: exactly one of them. ``t`` is the
    ``[tiling]`` table's reader (:class:`fabpat.assembly.spec.tables.Table`); SpecError, one line."""
    from fabpat.assembly.surface.mesh_tiling import DEFAULT_TOLERANCE
    from fabpat.assembly.surface.panel_mesh import read_panel_mesh

    grid = [k for k in ("rows", "columns") if t.has(k)]
    if grid or not t.has("file"):
        what = f"tiling.file and tiling.{grid[0]} both give" if grid else "neither tiling.file nor tiling.rows gives"
        raise SpecError(f"{source}: {what} the panel's tiles: give tiling.rows and tiling.columns (hexagons) or "
                        "tiling.file (a flat OBJ, PLY or OFF mesh), not both")
    name = t.string("file")
    edge = t.number("edge", None, "edge") if t.has("edge") else None
    tolerance = t.number("tolerance", DEFAULT_TOLERANCE, "sleeve_length")
    if name is None:
        t.settle()  # a file that is not a string is that one problem (tiling.file is there: checked above)
    if name is None or not name.strip():
        raise t.fail("file", "is empty: the flat polygon mesh (OBJ, PLY or OFF) whose faces are the panel's tiles")
    t.settle()
    path = Path(name) if Path(name).is_absolute() else Path(source).parent / name
    try:
        skel = read_panel_mesh(path, edge=edge, tolerance=tolerance, source=str(path))
    except SpecError as e:
        raise SpecError(f"{source}: tiling.file: {e}") from None
    mean_edge = skel.edge_length()
    try:
        check("edge", mean_edge, "the mesh's mean edge (tiling.edge)" if edge is None else "tiling.edge",
              error=SpecError)
    except SpecError as err:
        raise SpecError(f"{source}: tiling.file: {err}; give tiling.edge to scale the mesh") from None
    if len(skel.faces) > MAX_PANEL_ROWS * MAX_PANEL_COLUMNS:
        raise SpecError(f"{source}: tiling.file has {len(skel.faces)} faces: a panel has at most "
                        f"{MAX_PANEL_ROWS * MAX_PANEL_COLUMNS} tiles (checking its fused solid grows faster than its "
                        "tiles)")
    return TilingSpec("panel", mean_edge if edge is None else edge, file=str(path), tolerance=tolerance,
                      vertices=tuple((float(x), float(y), float(z)) for x, y, z in skel.V), faces=skel.faces)
