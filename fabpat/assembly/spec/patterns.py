"""Reading ``[patterns]``: which pattern (and family member) each tile of the tiling gets — one ID,
groups, per-tile tables, per-polygon IDs or a rule — checked against the tiling before any work
(the format: :mod:`fabpat.assembly.spec.load`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path

from fabpat.assembly.spec.tables import Table as _Table
from fabpat.assembly.spec.types import (
    MAX_CANDIDATES,
    POLYGON_KEYS,
    SCENARIOS,
    SPHERE_RULES,
    STRIP_RULES,
    PatternSpec,
    TilingSpec,
)
from fabpat.errors import PatternError, SpecError
from fabpat.validate import check

_DEPTH_OF_DIGITS = {1: 1, 4: 2, 16: 3}  # hex digits of an ID → subdivision depth
#: [patterns] keys that only some ways of choosing patterns read: key → the ways that read it
_GOES_WITH = {"scenario": ("rule",), "count": ("rule",), "catalog": ("rule",), "candidates": ("rule",),
              "group_columns": ("groups", "rule")}
#: [patterns] keys that only one rule reads: key → that rule
_ONLY_RULE = {"candidates": "roundest"}


def pattern_id_of(source: str, key: str, pid: object, sides: tuple[int, ...]) -> str:
    """The canonical ID if it is a library pattern for every polygon in ``sides``; SpecError otherwise."""
    from fabpat.patterns.lattice import normalize_id
    from fabpat.patterns.library import get_pattern

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

def read_patterns(source: str, data: object, tiling: TilingSpec) -> PatternSpec:
    """The ``[patterns]`` table ``data`` of the spec ``source`` for ``tiling``: exactly one way of choosing
    (:class:`PatternSpec`), every ID a library pattern of its polygon. Raises :class:`SpecError`, one line
    per problem."""
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


def _bridge_weights(source: str, value: object, tiling: TilingSpec) -> tuple[float, ...]:
    """``patterns.bridge_weight``: one number for every plate, or a table {plate label = number} (plates
    it does not name keep the paper's 1); per face, in face order. Each value in its range
    (:data:`fabpat.validate.RANGES`)."""
    labels = _labels(tiling)

    def weight(v: object, label: str) -> float:
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
    """The ``[patterns]`` table ``t`` read as the one way it chooses (``pattern``, a pattern per polygon,
    ``rule``, ``groups`` or ``tiles``) for ``tiling``; raises :class:`SpecError` naming the key.

    Which keys are allowed depends on the way chosen: a key the chosen way does not read is refused
    (:func:`_chosen_way`), against the same list of ways, rather than ignored; each way has its reader."""
    way = _chosen_way(source, t, tiling)
    sides = tiling.sides
    if way == "pattern":
        return PatternSpec(pattern=pattern_id_of(source, "patterns.pattern", t.data["pattern"], sides))
    if way in POLYGON_KEYS.values():
        names = [POLYGON_KEYS[n] for n in sides]
        for key in names:
            if not t.has(key):
                raise SpecError(f"{source}: missing key patterns.{key} (a pattern ID, e.g. \"0x0488\"): the tiling has "
                                f"{' + '.join(names)} faces, each needs its pattern")
        t.settle()
        return PatternSpec(polygons=tuple((n, pattern_id_of(source, f"patterns.{key}", t.data[key], (n,)))
                                          for n, key in zip(sides, names, strict=True)))
    if way == "rule":
        return _rule_way(source, t, tiling)
    if way == "groups":
        return _groups_way(source, t, tiling)
    return _tiles_way(source, t, tiling)


def _chosen_way(source: str, t: _Table, tiling: TilingSpec) -> str:
    """The one way ``[patterns]`` chooses (module doc); refuses two ways, none, and keys that belong to
    another tiling or another way (noted in ``t``: :meth:`_Table.note`)."""
    strip = tiling.strip
    names = [POLYGON_KEYS[n] for n in tiling.sides]
    given = [k for k in dict.fromkeys([*names, *POLYGON_KEYS.values()]) if t.has(k)]  # the tiling's own first
    ways = [k for k in ("pattern", "groups", "tiles", "rule") if t.has(k)] + given[:1]
    options = "pattern, groups, tiles or rule" if strip else f"pattern, {' + '.join(names)}, tiles or rule"
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
    return way


def _rule_way(source: str, t: _Table, tiling: TilingSpec) -> PatternSpec:
    """``[patterns] rule = …`` and the keys that go with the rule."""
    strip, sides = tiling.strip, tiling.sides
    catalog = t.string("catalog")
    if catalog and not Path(catalog).is_absolute() and Path(source).parent != Path(""):
        catalog = str(Path(source).parent / catalog)  # a relative catalog path is relative to the spec file
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
        names = [POLYGON_KEYS[n] for n in sides]
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


def _groups_way(source: str, t: _Table, tiling: TilingSpec) -> PatternSpec:
    """``[patterns] groups = [...]`` (strips: one ID per group of ``group_columns`` columns)."""
    groups = t.data["groups"]
    if not isinstance(groups, list) or not groups:
        raise t.fail("groups", "must be a non-empty list of pattern IDs (stiff → soft)")
    ids = tuple(pattern_id_of(source, f"patterns.groups[{i}]", g, tiling.sides) for i, g in enumerate(groups))
    gc = t.integer("group_columns", None)
    t.settle()
    need = math.ceil(tiling.columns / gc)
    if need != len(ids):
        raise t.fail("groups", f"has {len(ids)} IDs but tiling.columns = {tiling.columns} in groups of "
                     f"patterns.group_columns = {gc} makes {need} groups")
    return PatternSpec(groups=ids, group_columns=gc)


def _tiles_way(source: str, t: _Table, tiling: TilingSpec) -> PatternSpec:
    """``[patterns] tiles``: a table {label = ID} (closed tilings, or strips by label) or a strip's rows of IDs."""
    tiles = t.data["tiles"]
    if not tiling.strip:
        if not isinstance(tiles, Mapping):
            raise t.fail("tiles", "must be a table {plate label = pattern ID} naming every face (H01 = \"0x0488\", …)")
        return PatternSpec(tiles=(_face_table(source, tiles, tiling),))
    if isinstance(tiles, Mapping):
        return PatternSpec(tiles=_tile_table(source, tiles, tiling, tiling.sides))
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
                cache[pid] = pattern_id_of(source, f"patterns.tiles[{r}][{c}]", pid, tiling.sides)
            out.append(cache[pid])
        rows.append(tuple(out))
    return PatternSpec(tiles=tuple(rows))


def strip_labels(rows: int, columns: int) -> list[str]:
    """The kit's plate labels of a strip, in face order (column by column): "T" and the face number,
    zero-padded to the width of the largest (as :func:`fabpat.assembly.place.placement.place` labels them)."""
    n = rows * columns
    return [f"T{f + 1:0{len(str(n))}d}" for f in range(n)]


def _check_labels(source: str, table: Mapping[str, object], labels: list[str], unknown_why: str, noun: str,
                  missing_hint: str) -> None:
    """SpecError (one line) for the first key of a ``tiles`` table that is not a label, then for the first
    label it lacks."""
    unknown = [k for k in table if k not in labels]
    if unknown:
        raise SpecError(f"{source}: patterns.tiles.{unknown[0]} {unknown_why}")
    missing = [k for k in labels if k not in table]
    if missing:
        raise SpecError(f"{source}: patterns.tiles has no pattern for {noun} {missing[0]} ({missing_hint})")


def _face_table(source: str, table: Mapping[str, object], tiling: TilingSpec) -> tuple[str, ...]:
    """``tiles = {LABEL = "0x....", …}`` on a polyhedron: every face's pattern in face order, each ID checked
    for its face's polygon."""
    from fabpat.assembly.surface.tiling import FACE_LETTERS

    skel = tiling.skeleton()
    labels = list(skel.labels)
    letters = ", ".join(f"{FACE_LETTERS.get(n, 'F')} {POLYGON_KEYS[n]}s" for n in tiling.sides)
    _check_labels(source, table, labels,
                  f"is not a face of the {tiling.kind} (labels {labels[0]} … {labels[-1]} by polygon: {letters})",
                  "face", f"give every face one: {len(labels)} faces")
    return tuple(pattern_id_of(source, f"patterns.tiles.{lab}", table[lab], (int(n),))
                 for lab, n in zip(labels, skel.sides, strict=True))


def _tile_table(source: str, table: Mapping[str, object], tiling: TilingSpec,
                sides: tuple[int, ...]) -> tuple[tuple[str, ...], ...]:
    """``tiles = {LABEL = "0x....", …}``: one pattern per plate label, every label of the strip once; the
    rows × columns IDs it stands for."""
    labels = strip_labels(tiling.rows, tiling.columns)
    noun = "panel" if tiling.kind == "panel" else "strip"
    _check_labels(source, table, labels, f"is not a plate of this {noun} (labels {labels[0]} … {labels[-1]})",
                  "plate", f"give every plate {labels[0]} … {labels[-1]} one")
    grid = [[""] * tiling.columns for _ in range(tiling.rows)]
    for f, lab in enumerate(labels):  # faces run column by column (fabpat.assembly.surface.tiling.honeycomb_strip)
        grid[f % tiling.rows][f // tiling.rows] = pattern_id_of(source, f"patterns.tiles.{lab}", table[lab], sides)
    return tuple(tuple(r) for r in grid)
