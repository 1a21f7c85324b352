"""The base spec of a design: an assembly spec whose pattern choice is left open, and its candidates.

The spec file is read as every spec is (a regular file of at most 1 MiB; a FIFO or device is refused unread),
and its tiling must be a honeycomb strip or one of :data:`CLOSED_KINDS` or :data:`OPEN_KINDS` (:func:`check_kind`),
before any solve.

``[patterns]`` of the base may hold, besides (optionally) one of the spec's ways of choosing patterns
(a ``rule`` there is the design's second baseline), the design keys:

* ``allowed``: a list of pattern IDs, the only candidates;
* ``min_width``: mm, drop candidates whose narrowest feature (the catalog's ``min_width``) is smaller;
* ``max_distinct``: the largest number of distinct patterns in the design (each is one more part type).
* ``variations``: ``true`` (default) or ``false``: whether the candidates include the family members
  (:mod:`fabpat.patterns.variation`) the catalog's ``family`` table holds (``fabpat sweep --family``), a strip's
  and a closed tiling's alike (:mod:`fabpat.assembly.choose.members`).
* ``depth``: ``2`` (default) or ``3``: a strip's candidates also include the depth-3 patterns the catalog
  (``catalog`` key, else the built-in one, which ships depth-3 hexagons) has simulated — ``fabpat sweep --depth 3
  --learn N --db mine.sqlite`` makes more such rows; the depth-2 candidates then come from that catalog if it has
  them, else from the built-in one.

Candidates of a strip are the hexagon patterns with a converged Cylinder energy in the catalog
(``catalog`` key or the built-in one), at the base's plate set-up when the catalog has it, else at the
default one (energies only rank patterns, as for ``rule = "graded"``). Candidates of a closed tiling
are, per polygon of its faces, the catalog rows of that polygon with all three energies converged
(:func:`closed_rows`), narrowed alike.

A candidate that is a family member is written ``"ID bW"`` (``"0x0488 b0.63"``: pattern 0x0488 at
``bridge_weight`` 0.63, as the kit labels it; :func:`fabpat.assembly.choose.members.member_token`,
:func:`~fabpat.assembly.choose.members.split_member`): the swept members themselves, whose energies are solves,
not interpolations. A closed tiling's member is a row like its pattern's
(:func:`fabpat.assembly.choose.members.member_rows`); a polygon the catalog has no family rows for keeps the
paper's members, and :attr:`DesignBase.notes` says so (design.json ``notes``). design.toml gives such a
plate its pattern in ``tiles`` and its member in ``[patterns] bridge_weight``.

A base that names its patterns (``pattern``, ``hexagon`` + ``pentagon``, ``groups``, ``tiles``) or a
``rule`` gives the design a baseline, ``spec`` or ``rule`` in design.json, solved with the rest.
"""

from __future__ import annotations

import copy
import itertools
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fabpat.assembly.choose.members import member_energies, member_rows, member_token, split_member
from fabpat.assembly.spec.load import TILINGS, AssemblySpec, parse_spec
from fabpat.errors import FabpatError, SpecError
from fabpat.validate import as_float

__all__ = ["DesignBase", "load_base", "closed_rows", "candidates", "base_faces", "member_token", "split_member"]

#: the [patterns] keys that only ``fabpat design`` reads
DESIGN_KEYS = ("allowed", "min_width", "max_distinct", "variations", "depth")
#: the ways of choosing patterns an assembly spec has (fabpat.assembly.spec.load)
_WAYS = ("pattern", "groups", "tiles", "hexagon", "pentagon", "rule")
#: the scenario whose energy gives a pattern's bending stiffness (two end moments bend the plate)
SCENARIO = "cylinder"
#: the tiling kind whose design target is an arch (a strip's mid-line)
STRIP_KIND = "honeycomb-strip"
#: the closed tilings a design takes (a target surface): spheres of hexagons and pentagons, whose closure has a
#: least-squares sphere and whose polygons both catalogs hold. A panel or a mesh file is refused before any solve:
#: a flat panel has no sleeves to bend it, and a mesh file's faces may be any polygon (docs/design.md, "Which
#: tilings")
CLOSED_KINDS = ("truncated-icosahedron", "goldberg")
#: the open tilings a design takes: a dome (``cap:H``) on a hex-cap, a surface of revolution
#: (``revolution:…``) on a hex-tube (:mod:`fabpat.design.revolution`); designed as the closed ones are
OPEN_KINDS = ("hex-cap", "hex-tube")


@dataclass(frozen=True, eq=False)
class DesignBase:
    """The parsed base: ``spec`` (its patterns a placeholder unless the base names a way), the decoded
    TOML ``data`` without the design keys, ``energies`` {candidate ID: Cylinder energy N·mm} and the
    design keys' values (``max_distinct`` None: no cap)."""

    spec: AssemblySpec
    data: dict[str, Any]
    energies: dict[str, float]
    max_distinct: int | None
    has_rule: bool
    way: str | None = None
    rows: dict[int, list[dict[str, Any]]] | None = None
    #: what the candidates lack, one line each (a polygon without family rows in the catalog)
    notes: tuple[str, ...] = ()


def _read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The decoded TOML of the base spec file, read as every spec is
    (:func:`fabpat.assembly.spec.tables.read_spec_file`: a regular file of at most
    :data:`~fabpat.assembly.spec.tables.MAX_SPEC_BYTES`, a FIFO or device refused unread)."""
    from fabpat.assembly.spec.tables import read_spec_file

    return read_spec_file(path)[1]


def load_base(path: str | os.PathLike[str]) -> DesignBase:
    """Read the base spec and its candidate patterns. Raises SpecError (one line): a bad spec, a bad
    design key, or no candidate left."""
    source = str(path)
    data = _read_toml(path)
    tiling = data.get("tiling")
    kind = tiling.get("kind") if isinstance(tiling, dict) else None
    if isinstance(kind, str) and kind in TILINGS:  # first: the [patterns] a kind takes differ (an unknown kind:
        check_kind(source, kind)                   # the spec reader's line)
    pats = data.get("patterns", {})
    if not isinstance(pats, dict):
        raise SpecError(f"{source}: [patterns] must be a table")
    keys = {k: pats[k] for k in DESIGN_KEYS if k in pats}
    rest = {k: v for k, v in pats.items() if k not in DESIGN_KEYS}
    has_way = any(k in rest for k in _WAYS)
    way = next((k for k in _WAYS if k in rest), None)
    catalog = rest.pop("catalog", None) if "rule" not in rest else rest.get("catalog")
    if not has_way:
        for k in rest:  # a rule's own keys without the rule: the spec reader would name them; so do we
            raise SpecError(f"{source}: patterns.{k} does not apply without a way of choosing patterns (the design "
                            f"reads only {', '.join(DESIGN_KEYS)} and catalog)")
        rest = {"pattern": "0x0488"}  # a placeholder: every design names each tile's pattern itself
    parsed = dict(data, patterns=rest)
    spec = parse_spec(parsed, source)
    clean = copy.deepcopy(data)
    clean["patterns"] = {k: v for k, v in pats.items() if k not in DESIGN_KEYS}
    if catalog is not None and not isinstance(catalog, str):
        raise SpecError(f"{source}: patterns.catalog = {catalog!r} must be a file name")
    if catalog and not Path(catalog).is_absolute():
        catalog = str(Path(source).parent / catalog)
    k = keys.get("max_distinct")
    if k is not None and (isinstance(k, bool) or not isinstance(k, int) or k < 1):
        raise SpecError(f"{source}: patterns.max_distinct = {k!r} must be an integer ≥ 1 (distinct patterns allowed)")
    if spec.tiling.kind != STRIP_KIND:
        if keys.get("depth", 2) != 2:
            raise SpecError(f"{source}: patterns.depth = {keys['depth']!r}: depth-3 candidates are for strip designs "
                            "(a closed tiling's design chooses among the depth-2 patterns); leave it out")
        notes: list[str] = []
        rows = closed_rows(spec, source, catalog, keys, notes)
        return DesignBase(spec, clean, {}, k, spec.patterns.rule is not None, way, rows, tuple(notes))
    energies = candidates(spec, source, catalog, keys)
    return DesignBase(spec, clean, energies, k, spec.patterns.rule is not None, way)


def check_kind(source: str, kind: str) -> None:
    """:class:`SpecError` (one line) unless a design takes the tiling ``kind``: :data:`STRIP_KIND` or one of
    :data:`CLOSED_KINDS` or :data:`OPEN_KINDS`."""
    if kind != STRIP_KIND and kind not in CLOSED_KINDS + OPEN_KINDS:
        closed = " or ".join(f'"{k}"' for k in CLOSED_KINDS)
        raise SpecError(f'{source}: tiling.kind = "{kind}" cannot be designed: fabpat design takes a "{STRIP_KIND}" '
                        f'(a target arch), a closed tiling of kind {closed} (a target surface), a "hex-cap" '
                        f'(cap:H) or a "hex-tube" (revolution:R0,…,Rk)')


def _catalog_energies(spec: AssemblySpec, catalog: str | None, depth: int = 2) -> dict[str, float]:
    from fabpat import catalog as cat

    pl = spec.plates
    try:
        found = cat.energies(catalog, SCENARIO, sides=6, depth=depth, edge=spec.tiling.edge, thickness=pl.thickness,
                             weight=pl.weight)
        found = found or cat.energies(catalog, SCENARIO, sides=6, depth=depth)
        if depth == 2 and not found and catalog is not None:  # a catalog of deeper patterns only
            return _catalog_energies(spec, None)
        return found
    except FabpatError as e:
        raise SpecError(f"{spec.source}: the design needs the catalog's {SCENARIO} energies, but {e}") from e


def _depth3_energies(spec: AssemblySpec, source: str, catalog: str | None, keys: dict[str, Any]) -> dict[str, float]:
    """The depth-3 candidates ``[patterns] depth = 3`` adds (module doc): {ID: Cylinder energy}; SpecError for
    another depth or a catalog without depth-3 rows."""
    depth = keys.get("depth", 2)
    if isinstance(depth, bool) or depth not in (2, 3):
        raise SpecError(f"{source}: patterns.depth = {depth!r} must be 2 (the paper's library) or 3 (adds the "
                        "catalog's depth-3 patterns)")
    if depth == 2:
        return {}
    found = _catalog_energies(spec, catalog, 3)  # None: the built-in catalog's shipped depth-3 rows
    if not found:
        raise SpecError(f"{source}: patterns.depth = 3 adds the depth-3 patterns a catalog has simulated, but "
                        f"{'the built-in catalog has' if catalog is None else catalog + ' has'} none: run fabpat "
                        "sweep --depth 3 --learn N --db mine.sqlite and give patterns.catalog = \"mine.sqlite\"")
    return found


def closed_rows(spec: AssemblySpec, source: str, catalog: str | None, keys: dict[str, Any],
                notes: list[str] | None = None) -> dict[int, list[dict[str, Any]]]:
    """{polygon sides: catalog rows} of a closed tiling's candidates (module doc), at the base's plate
    set-up when the catalog has it, with the family members of its patterns unless ``variations = false``
    (:func:`fabpat.assembly.choose.members.member_rows`, all three energies converged); SpecError (one line) if a
    polygon
    has none left. A polygon without family rows in the catalog appends a line to ``notes``."""
    from fabpat import catalog as cat
    from fabpat.assembly.place.placement import build_tiling
    from fabpat.assembly.spec.patterns import pattern_id_of

    pl = spec.plates
    allowed = None
    if "allowed" in keys:
        a = keys["allowed"]
        if not isinstance(a, list) or not a:
            raise SpecError(f"{source}: patterns.allowed must be a non-empty list of pattern IDs")
        allowed = {pattern_id_of(source, f"patterns.allowed[{i}]", x, (5, 6)) for i, x in enumerate(a)}
    w = keys.get("min_width", 0.0)
    if isinstance(w, bool) or not isinstance(w, int | float) or not math.isfinite(w) or w < 0:
        raise SpecError(f"{source}: patterns.min_width = {w!r} must be a number of mm ≥ 0")
    out: dict[int, list[dict[str, Any]]] = {}
    for sides in sorted({len(f) for f in build_tiling(spec).faces}, reverse=True):
        rows: list[dict[str, object]]
        try:
            try:
                rows = cat.catalog(catalog, sides=sides, edge=spec.tiling.edge, thickness=pl.thickness,
                                   weight=pl.weight)
            except FabpatError:  # not at this set-up: the default one (the features only rank patterns)
                rows = []
            rows = rows or cat.catalog(catalog, sides=sides)
        except FabpatError as e:
            raise SpecError(f"{source}: the design needs the catalog of {sides}-sided plates, but {e}") from e
        rows = [dict(r) for r in rows if all(r.get(f"converged_{s}") for s in ("dome", "cylinder", "cantilever"))]
        n = len(rows)
        rows = [r for r in rows if (allowed is None or r["id"] in allowed) and as_float(r.get("min_width") or 0.0) >= w]
        if not rows:
            raise SpecError(f"{source}: no candidate pattern is left for the {sides}-sided faces after the catalog's "
                            f"{n} converged patterns, patterns.allowed and patterns.min_width: widen the choice")
        if use_variations(source, keys):
            members, note = _members(spec, catalog, sides, {r["id"] for r in rows}, w)
            rows += [m for m in members if m.get("filleted_ratio") is not None
                     and all(m.get(f"converged_{s}") for s in ("dome", "cylinder", "cantilever"))]
            if note is not None and notes is not None:
                notes.append(note)
        out[sides] = rows
    return out


def use_variations(source: str, keys: dict[str, Any]) -> bool:
    """The ``variations`` key: whether family members are candidates (default true); SpecError otherwise."""
    use = keys.get("variations", True)
    if not isinstance(use, bool):
        raise SpecError(f"{source}: patterns.variations = {use!r} must be true or false (family members as candidates)")
    return use


def _min_widths(spec: AssemblySpec, catalog: str | None) -> dict[str, float]:
    from fabpat import catalog as cat

    pl = spec.plates
    widths: dict[str, float] = {}
    for where, depth in itertools.product(dict.fromkeys([None, catalog]), (2, 3)):  # the built-in's, the catalog's
        try:
            rows = cat.catalog(where, sides=6, depth=depth, edge=spec.tiling.edge, thickness=pl.thickness,
                               weight=pl.weight)
        except FabpatError:
            try:
                rows = cat.catalog(where, sides=6, depth=depth)
            except FabpatError:
                continue
        widths.update({str(r["id"]): float(str(r["min_width"])) for r in rows if r.get("min_width") is not None})
    return widths


def candidates(spec: AssemblySpec, source: str, catalog: str | None, keys: dict[str, Any]) -> dict[str, float]:
    """{candidate: Cylinder energy} of the candidates that ``allowed`` and ``min_width`` leave, with their
    family members unless ``variations = false`` (module doc); SpecError if none."""
    from fabpat.assembly.spec.patterns import pattern_id_of

    deeper = _depth3_energies(spec, source, catalog, keys)
    energies = {k: v for k, v in {**_catalog_energies(spec, catalog), **deeper}.items() if math.isfinite(v) and v > 0}
    why = [f"the catalog's {len(energies)} hexagon patterns with a {SCENARIO} energy"]
    if "allowed" in keys:
        allowed = keys["allowed"]
        if not isinstance(allowed, list) or not allowed:
            raise SpecError(f"{source}: patterns.allowed must be a non-empty list of pattern IDs")
        ids = {pattern_id_of(source, f"patterns.allowed[{i}]", a, (6,)) for i, a in enumerate(allowed)}
        energies = {k: v for k, v in energies.items() if k in ids}
        why.append(f"patterns.allowed ({len(ids)} IDs)")
    if "min_width" in keys:
        w = keys["min_width"]
        if isinstance(w, bool) or not isinstance(w, int | float) or not math.isfinite(w) or w < 0:
            raise SpecError(f"{source}: patterns.min_width = {w!r} must be a number of mm ≥ 0")
        widths = _min_widths(spec, catalog)
        energies = {k: v for k, v in energies.items() if widths.get(k, -1.0) >= w}
        why.append(f"patterns.min_width = {w:g} mm")
    if not energies:
        raise SpecError(f"{source}: no candidate pattern is left after {' and '.join(why)}: widen the choice")
    if use_variations(source, keys):
        energies = {**energies, **_member_candidates(spec, catalog, energies, float(keys.get("min_width", 0.0)))}
    return energies


def _member_candidates(spec: AssemblySpec, catalog: str | None, energies: dict[str, float],
                       min_width: float) -> dict[str, float]:
    """{member name: Cylinder energy} of the catalog's converged family rows of the candidate patterns
    (:func:`fabpat.assembly.choose.members.member_rows`: at the base's set-up, else the default one), each member's own
    min_width at least ``min_width``."""
    rows, _ = _members(spec, catalog, 6, energies, min_width)
    return member_energies(rows, SCENARIO)


def _members(spec: AssemblySpec, catalog: str | None, sides: int, ids: Any,
             min_width: float) -> tuple[list[dict[str, Any]], str | None]:
    """:func:`fabpat.assembly.choose.members.member_rows` of the candidate patterns ``ids`` at the base's plate set-up;
    SpecError (one line) for a catalog that cannot be read."""
    pl = spec.plates
    try:
        return member_rows(catalog, sides, ids, min_width=min_width, edge=spec.tiling.edge, thickness=pl.thickness,
                           weight=pl.weight)
    except FabpatError as e:
        raise SpecError(f"{spec.source}: the design needs the catalog's family members, but {e}") from e


def base_faces(base: DesignBase) -> tuple[str, list[str]] | None:
    """The base spec's own choice as a baseline: ("rule", its rule's face patterns) or ("spec", the
    patterns it names), or None when the base leaves the choice open."""
    if base.way is None:
        return None
    from fabpat.assembly.choose.choice import face_patterns

    return ("rule" if base.has_rule else "spec"), face_patterns(base.spec)
