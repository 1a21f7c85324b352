"""Where a kit's patterns come from: the rule (or the spec's explicit choice) and their catalog energies.

Every kit records, per distinct plate, how its pattern was chosen (``chosen_by``: the spec's
``patterns.rule`` and scenario, or "explicit" with the key that names it) and the pattern's strain
energy in each of the paper's three scenarios (N·mm, lower = stiffer) from the catalog the spec reads
(``patterns.catalog``, default the built-in one), in the manifest (``patterns``) and the BOM. The
energies are looked up at the kit's own plate set-up (edge, thickness, weight) and, when the catalog
has none there, at the catalog's default set-up (36 mm edge, 2 mm plates, weight 0.2), as the rules
rank patterns (:func:`fabpat.assembly.kit.build.face_patterns`); ``catalog_setup`` says which. A pattern
or polygon the catalog does not hold has ``null`` energies.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from fabpat.assembly.place.placement import PlateType
from fabpat.assembly.spec.load import POLYGON_KEYS, SCENARIOS, AssemblySpec
from fabpat.errors import FabpatError

#: the catalog's default plate set-up (fabpat.catalog.energies' defaults): edge mm, thickness mm, weight
CATALOG_SETUP = {"edge": 36.0, "thickness": 2.0, "weight": 0.2}


@dataclass(frozen=True)
class PatternRecord:
    """One distinct plate's pattern: ``part`` ("hex 0x0488"), ``pattern`` ID, polygon ``sides``,
    ``chosen_by`` (see the module docstring), ``energies`` {scenario: N·mm or None}, the ``catalog``
    read ("built-in" or its path) and the ``catalog_setup`` {edge, thickness, weight} of the energies
    (None when the catalog gave none, ``note`` then says why); ``bridge_weight`` the family member
    (:mod:`fabpat.patterns.variation`; 1 = the paper's, whose energies are the catalog's own; another member's
    are interpolated over the catalog's family, :mod:`fabpat.catalog.family`)."""

    part: str
    pattern: str
    sides: int
    chosen_by: str
    energies: dict[str, float | None]
    catalog: str
    catalog_setup: dict[str, float] | None
    note: str = ""
    bridge_weight: float = 1.0

    def as_dict(self) -> dict[str, object]:
        """The manifest's record (plain JSON types)."""
        return {"part": self.part, "pattern": self.pattern, "sides": self.sides, "bridge_weight": self.bridge_weight,
                "chosen_by": self.chosen_by,
                "energies_Nmm": self.energies, "catalog": self.catalog, "catalog_setup": self.catalog_setup,
                **({"note": self.note} if self.note else {})}


def chosen_by(spec: AssemblySpec) -> str:
    """How the spec chooses its patterns, e.g. ``rule = 'graded' (cylinder energies)`` or ``explicit
    (patterns.groups)``."""
    p = spec.patterns
    if p.rule:
        return f"rule = {p.rule!r} ({p.scenario} energies)"
    by_polygon = ", ".join(f"patterns.{POLYGON_KEYS[n]}" for n, _ in p.polygons)
    way = next(k for k, v in (("patterns.pattern", p.pattern), ("patterns.groups", p.groups),
                              ("patterns.tiles", p.tiles), (by_polygon, p.polygons)) if v)
    return f"explicit ({way})"


def _lookup(spec: AssemblySpec, sides: int, depth: int) -> tuple[dict[str, dict[str, float]], dict[str, float] | None,
                                                                 str]:
    """{scenario: {ID: energy}} of the spec's catalog for one polygon, the set-up they are at, and a note."""
    try:
        from fabpat import catalog as cat
    except ImportError as e:  # the catalog is optional
        return {}, None, f"the catalog cannot be imported ({e})"
    pl = spec.plates
    own = {"edge": spec.tiling.edge, "thickness": pl.thickness, "weight": pl.weight}
    try:
        for setup in (own, CATALOG_SETUP):
            found = {sc: cat.energies(spec.patterns.catalog, sc, sides=sides, depth=depth, **setup) for sc in SCENARIOS}
            if any(found.values()):
                return found, dict(setup), ""
    except (FabpatError, ValueError, OSError) as e:
        return {}, None, f"the catalog cannot be read: {e}"
    return {}, None, f"the catalog has no energies for {sides}-gons at depth {depth}"


def _member_energies(spec: AssemblySpec, pt: PlateType, setup: dict[str, float]) -> tuple[dict[str, float | None], str]:
    """A family member's energies interpolated from the catalog's family rows (:mod:`fabpat.catalog.family`),
    None where its curve does not reach the member, with a note saying so."""
    from fabpat.catalog.family import family_curves

    out: dict[str, float | None] = {}
    missing = []
    unswept = False  # a scenario without family rows (a sweep adds them), not one whose members buckle
    for sc in SCENARIOS:
        try:
            curve = family_curves(sc, sides=pt.sides, depth=pt.depth, db=spec.patterns.catalog, **setup).get(
                pt.pattern_id)
        except (FabpatError, ValueError, OSError):
            curve = None
        lo, hi = curve.range if curve is not None else (1.0, 1.0)
        out[sc] = curve.energy(pt.bridge_weight) if curve is not None and lo <= pt.bridge_weight <= hi else None
        if out[sc] is None:
            if curve is None or len(curve.weights) == 1:
                unswept = True
                missing.append(f"{sc}: no family rows")
            else:  # swept: the members beyond the converged run buckle (or lie past the swept ends)
                missing.append(f"{sc}: converged only over {lo:g} … {hi:g}")
    note = (f"bridge_weight {pt.bridge_weight:g}: energies interpolated over the catalog's family" if not missing
            else f"bridge_weight {pt.bridge_weight:g} is outside the catalog's family ({'; '.join(missing)}"
                 + ("; `fabpat sweep --family` adds family rows)" if unswept else ")"))
    return out, note


def pattern_records(spec: AssemblySpec, plate_types: Sequence[PlateType]) -> list[PatternRecord]:
    """One :class:`PatternRecord` per distinct plate type (a :class:`~fabpat.assembly.place.placement.PlateType`,
    in the order given); never raises for a catalog that cannot be read (the note says so)."""
    name = spec.patterns.catalog or "built-in"
    how = chosen_by(spec)
    cache: dict[tuple[int, int], tuple[dict[str, dict[str, float]], dict[str, float] | None, str]] = {}
    out = []
    for pt in plate_types:
        key = (pt.sides, pt.depth)
        if key not in cache:
            cache[key] = _lookup(spec, *key)
        found, setup, note = cache[key]
        energies = {sc: found.get(sc, {}).get(pt.pattern_id) for sc in SCENARIOS}
        if setup is not None and all(v is None for v in energies.values()):
            note = f"pattern {pt.pattern_id} is not in the catalog"
        elif setup is not None and pt.bridge_weight != 1.0:
            energies, note = _member_energies(spec, pt, setup)
        out.append(PatternRecord(pt.label, pt.pattern_id, pt.sides, how, energies, name, setup, note,
                                 pt.bridge_weight))
    return out
