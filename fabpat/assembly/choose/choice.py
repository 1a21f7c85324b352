"""Choosing a kit's patterns: one pattern ID (and family member) per face of the tiling, by the spec's
``[patterns]`` table — named patterns, groups, per-tile tables, or a rule over the catalog's energies
(:mod:`fabpat.assembly.choose.rules`; family members through :mod:`fabpat.assembly.choose.members`).

Both front doors use it — the kit (:func:`fabpat.assembly.kit.build.assemble`) and the solver
(:func:`fabpat.assembly.solve.simulation.simulate_assembly`) — as do panels and inverse design, so the choice
lives here and nobody reaches into another front door for it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from fabpat.assembly.place.placement import build_tiling
from fabpat.assembly.spec.load import POLYGON_KEYS, AssemblySpec
from fabpat.errors import FabpatError, SpecError

if TYPE_CHECKING:
    from fabpat.assembly.choose.rules import MemberCurve
    from fabpat.catalog.family import FamilyCurve


def _energies(spec: AssemblySpec, sides: int) -> dict[str, float]:
    """Energies of the spec's scenario for the faces of ``sides``, from that polygon's own catalog rows
    (:func:`fabpat.catalog.polygon_energies`; imported only here: the catalog is optional)."""
    try:
        from fabpat import catalog as cat
    except ImportError as e:
        raise SpecError(
            f"{spec.source}: patterns.rule = {spec.patterns.rule!r} needs the pattern catalog (fabpat.catalog), "
            f"which cannot be imported ({e}); name the patterns instead (patterns.pattern, groups, tiles or "
            "hexagon + pentagon)"
        ) from e
    pl = spec.plates
    named = "patterns.groups" if spec.tiling.strip else " + ".join(f"patterns.{POLYGON_KEYS[n]}"
                                                                  for n in spec.polygon_sides)
    try:
        return cat.polygon_energies(spec.patterns.catalog, spec.patterns.scenario, sides, edge=spec.tiling.edge,
                                    thickness=pl.thickness, weight=pl.weight)
    except FabpatError as e:
        raise SpecError(f"{spec.source}: patterns.rule = {spec.patterns.rule!r} needs catalog energies, but {e} "
                        f"(or name the patterns instead: {named})") from e


def _pair_energies(get: Callable[[int], dict[str, float]]) -> tuple[dict[str, float], dict[str, float]]:
    """Hexagon and pentagon energies for a sphere rule, each polygon's own (a catalog without pentagons
    is refused by ``get``, never answered with hexagon energies)."""
    return get(6), get(5)


def candidate_pairs(spec: AssemblySpec, energies: Callable[[int], dict[str, float]] | None = None,
                    notes: list[str] | None = None) -> list[tuple[str, str]]:
    """``rule = "roundest"``: the ``patterns.candidates`` (hexagon, pentagon) pairs of similar energy to try,
    best first (:func:`fabpat.assembly.choose.rules.similar_pairs`). With ``bridge_weight = "rule"`` each polygon's
    pool also holds the catalog's swept family members of its patterns (:func:`_with_members`), and a pair's
    entries are candidate names (``"0x0488 b0.63"``, :func:`fabpat.assembly.choose.members.with_candidates`); a
    polygon the
    catalog has no family rows for keeps its paper's members and appends a line to ``notes``. Raises
    :class:`SpecError`."""
    from fabpat.assembly.choose import rules

    p = spec.patterns
    get = energies or (lambda n: _energies(spec, n))
    try:
        pools = _pair_energies(get)
        if p.member_rule:
            pools = (_with_members(spec, 6, pools[0], notes), _with_members(spec, 5, pools[1], notes))
        return rules.similar_pairs(*pools, p.candidates)
    except SpecError as e:
        if str(e).startswith(spec.source):
            raise
        raise SpecError(f"{spec.source}: patterns.rule = {p.rule!r}, scenario {p.scenario!r}: {e}") from e


def _with_members(spec: AssemblySpec, sides: int, pool: dict[str, float], notes: list[str] | None
                  ) -> dict[str, float]:
    """``pool`` ({ID: energy N·mm} of the spec's scenario on ``sides``-gons) and the converged swept family
    members of its patterns (:func:`fabpat.assembly.choose.members.member_rows` at the spec's plate set-up, else the
    default
    one, as the energies; the same candidates as ``fabpat design``'s)."""
    from fabpat.assembly.choose.members import member_energies, member_rows

    pl, p = spec.plates, spec.patterns
    try:
        rows, note = member_rows(p.catalog, sides, pool, edge=spec.tiling.edge, thickness=pl.thickness,
                                 weight=pl.weight)
    except FabpatError as e:
        raise SpecError(f"{spec.source}: patterns.bridge_weight = \"rule\" needs the catalog's family rows: {e}") from e
    if note is not None and notes is not None:
        notes.append(f"patterns.rule = 'roundest', bridge_weight = \"rule\": {note}")
    return {**pool, **member_energies(rows, p.scenario)}


def face_patterns(spec: AssemblySpec, energies: Callable[[int], dict[str, float]] | None = None) -> list[str]:
    """Pattern ID of every face of the spec's tiling (face order of :func:`build_tiling`).

    ``energies(sides)`` supplies ``{ID: energy}`` for the spec's scenario when a rule is used
    (default: the catalog). Graded strips go stiff (small energy) at column 0 → soft at the end.
    ``rule = "roundest"`` gives its first candidate, the similar-energy pair (no solver here:
    :func:`assemble` closes the sphere with each candidate, :func:`candidate_pairs`).
    """
    from fabpat.assembly.choose import rules

    p = spec.patterns
    tiling = build_tiling(spec)
    get = energies or (lambda n: _energies(spec, n))
    try:
        if p.rule == "graded" and not p.groups:  # groups set: chosen already (with_members)
            groups = rules.graded(get(6), p.count)
        elif p.rule in ("similar-energy", "roundest"):
            chosen = rules.similar_set({n: get(n) for n in spec.polygon_sides})
            return [chosen[len(f)] for f in tiling.faces]
        else:
            groups = list(p.groups)
    except SpecError as e:
        if str(e).startswith(spec.source):
            raise
        raise SpecError(f"{spec.source}: patterns.rule = {p.rule!r}, scenario {p.scenario!r}: {e}") from e
    out = []
    for f, loop in enumerate(tiling.faces):
        if p.pattern:
            out.append(p.pattern)
        elif p.tiles and tiling.grid is None:  # a polyhedron's tiles: one pattern per face, in face order
            out.append(p.tiles[0][f])
        elif p.polygons:
            out.append(p.polygon_pattern(len(loop)))
        else:
            assert tiling.grid is not None
            r, c = (int(x) for x in tiling.grid[f])
            out.append(p.tiles[r][c] if p.tiles else groups[c // p.group_columns])
    return out


def _family_curves(spec: AssemblySpec, sides: int) -> dict[str, FamilyCurve]:
    """Every pattern's family curve in the spec's scenario (:func:`fabpat.catalog.family.family_curves`) at the
    spec's plate set-up, else the catalog's default one (a pattern without family rows: a one-member
    curve, the paper's). Raises SpecError when the catalog holds neither set-up."""
    from fabpat.assembly.choose.provenance import CATALOG_SETUP
    from fabpat.catalog.family import family_curves

    pl, p = spec.plates, spec.patterns
    problem: FabpatError | None = None
    for setup in ({"edge": spec.tiling.edge, "thickness": pl.thickness, "weight": pl.weight}, CATALOG_SETUP):
        try:
            return family_curves(p.scenario, sides=sides, db=p.catalog, edge=setup["edge"],
                                 thickness=setup["thickness"], weight=setup["weight"])
        except FabpatError as e:
            problem = e
    raise SpecError(f"{spec.source}: patterns.bridge_weight = \"rule\" needs the catalog's {p.scenario} energies: "
                    f"{problem}")


def with_members(spec: AssemblySpec, energies: Callable[[int], dict[str, float]] | None = None,
                 curves: Callable[[int], Mapping[str, MemberCurve]] | None = None) -> AssemblySpec:
    """The spec with ``bridge_weight = "rule"`` resolved into every face's pattern and family member; any
    other spec unchanged (:mod:`fabpat.assembly.choose.rules`):

    * ``graded``: for each target energy of :func:`~fabpat.assembly.choose.rules.graded_targets` (stiff → soft),
      the unused pattern whose family reaches the target exactly with the member closest to the
      paper's (smallest |ln w|, :func:`~fabpat.assembly.choose.rules.graded_members`), where the rule alone
      takes the pattern of nearest catalog energy; the groups are written into the spec;
    * ``similar-energy``: its pair of patterns, with the pentagon's member whose pentagon energy is the
      hexagon's (or, when the catalog has no pentagon family, the hexagon's member whose energy is the
      pentagon's).

    ``curves(sides)`` supplies {ID: family curve} (default: the catalog's, :mod:`fabpat.catalog.family`).
    Raises :class:`SpecError` as :func:`face_patterns`.
    """
    from fabpat.assembly.choose import rules

    p = spec.patterns
    if p is None or not p.member_rule or p.bridge_weights or p.rule == "roundest":  # roundest: in the solver
        return spec
    get = energies or (lambda n: _energies(spec, n))
    get_curves = curves or (lambda n: _family_curves(spec, n))
    tiling = build_tiling(spec)
    if p.rule == "graded":
        try:
            picks = rules.graded_members(get(6), get_curves(6), p.count)
        except SpecError as e:
            raise SpecError(f"{spec.source}: patterns.rule = {p.rule!r}, scenario {p.scenario!r}: {e}") from e
        chosen = dataclasses.replace(p, rule=None, groups=tuple(pid for pid, _ in picks))
        member = dict(picks)
        ids = face_patterns(dataclasses.replace(spec, patterns=chosen))
        return dataclasses.replace(spec, patterns=dataclasses.replace(
            p, groups=chosen.groups, bridge_weights=tuple(member[pid] for pid in ids)))
    ids = face_patterns(spec, get)
    hid, pid = (next(i for i, f in zip(ids, tiling.faces, strict=True) if len(f) == n) for n in (6, 5))
    pent = get_curves(5).get(pid)
    if pent is not None and pent.range != (1.0, 1.0):
        w = {6: 1.0, 5: rules.nearest_member(pent, get(6)[hid])}
    else:
        w = {6: rules.nearest_member(get_curves(6)[hid], get(5)[pid]), 5: 1.0}
    return dataclasses.replace(spec, patterns=dataclasses.replace(
        p, bridge_weights=tuple(w[len(f)] for f in tiling.faces)))
