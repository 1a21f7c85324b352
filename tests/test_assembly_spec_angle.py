"""Issue 12, the kit side: ``[sleeve] angle``, ``[material]``, ``rule = "roundest"`` and the sleeves
placed for a bent sphere (straight sleeves on the polyhedron's joints)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from fabpat.assembly.choose.rules import similar_pair, similar_pairs
from fabpat.assembly.place.placement import build_tiling, check_geometry, place, setback
from fabpat.assembly.place.sleeve import Sleeve
from fabpat.assembly.spec.load import MaterialSpec, load_spec, parse_spec, sleeve_angle
from fabpat.assembly.surface.joints import joint_direction, required_setback
from fabpat.assembly.surface.tiling import HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL
from fabpat.errors import SpecError

ROOT = Path(__file__).resolve().parents[1]
FLAT = ROOT / "assemblies" / "truncated-icosahedron.toml"
RIGID = ROOT / "assemblies" / "truncated-icosahedron-rigid.toml"


def sphere(**tables: object) -> dict:
    data: dict = {"tiling": {"kind": "truncated-icosahedron", "edge": 36.0},
                  "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"},
                  "sheet": {"width": 600.0, "height": 400.0}}
    data.update(tables)
    return data


def strip(**tables: object) -> dict:
    data: dict = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
                  "patterns": {"pattern": "0x0488"}, "sheet": {"width": 600.0, "height": 400.0}}
    data.update(tables)
    return data


def refused(data: dict, *words: str) -> str:
    with pytest.raises(SpecError) as err:
        parse_spec(data, "s.toml")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("s.toml: "), msg
    for w in words:
        assert w in msg, (w, msg)
    return msg


# -- [sleeve] angle -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("value", "parsed"), [
    (None, "dihedral"), ("dihedral", "dihedral"), ("flat", "flat"), (160, 160.0), (160.5, 160.5),
    (180, 180.0), (138.19, 138.19),
])
def test_sphere_angles_parse(value: object, parsed: object) -> None:
    spec = parse_spec(sphere(sleeve={} if value is None else {"angle": value}))
    assert spec.sleeve.angle == parsed and type(spec.sleeve.angle) is type(parsed)


@pytest.mark.parametrize("value", [None, "dihedral", "flat", 180, 180.0])
def test_strip_angles_parse(value: object) -> None:
    spec = parse_spec(strip(sleeve={} if value is None else {"angle": value}))
    assert spec.sleeve.angle == ("dihedral" if value is None else 180.0 if value == 180 else value)


@pytest.mark.parametrize("value", [138.18, 100, 0, -5, 181, 1e308, math.nan, math.inf, 10**400])
def test_sphere_angle_out_of_range_is_refused(value: object) -> None:
    refused(sphere(sleeve={"angle": value}), "sleeve.angle", '"dihedral"', '"flat"', "[138.19, 180]", "138.19°")


@pytest.mark.parametrize("value", ["straight", "Flat", "", True, False, [180], {"deg": 180}])
def test_sphere_angle_of_another_type_is_refused(value: object) -> None:
    refused(sphere(sleeve={"angle": value}), "sleeve.angle", '"dihedral"', '"flat"', "180")


@pytest.mark.parametrize("value", [179.9, 160, 138.19, "bent", True])
def test_strip_takes_only_flat_angles(value: object) -> None:
    msg = refused(strip(sleeve={"angle": value}), "sleeve.angle", '"dihedral"', '"flat"', "180")
    assert "flat joints" in msg


def test_sleeve_angle_in_radians() -> None:
    phi = HEX_PENT_DIHEDRAL
    assert sleeve_angle(parse_spec(sphere()), phi) == phi
    assert sleeve_angle(parse_spec(sphere(sleeve={"angle": "dihedral"})), HEX_HEX_DIHEDRAL) == HEX_HEX_DIHEDRAL
    assert sleeve_angle(parse_spec(sphere(sleeve={"angle": "flat"})), phi) == math.pi
    assert sleeve_angle(parse_spec(sphere(sleeve={"angle": 160})), phi) == pytest.approx(160 * math.pi / 180, abs=1e-15)
    assert sleeve_angle(parse_spec(strip(sleeve={"angle": 180})), math.pi) == pytest.approx(math.pi, abs=1e-15)


def test_straight_sleeve_is_a_valid_part() -> None:
    g = required_setback(math.pi, 2.0, 0.2, 1.2)
    assert g == pytest.approx(0.1 + 0.6, abs=1e-12)  # c/2 + wall/2: the slots are coplanar
    s = Sleeve(math.pi, g, 2.0, 0.2, 4.75, 1.2, 3.0)
    assert s.web() == pytest.approx(1.2, abs=1e-9)
    assert np.allclose(s.direction(0), [1.0, 0.0], atol=1e-15) and np.allclose(s.direction(1), [-1.0, 0.0], atol=1e-15)


# -- [material] ---------------------------------------------------------------------------------------


def test_material_defaults_and_values() -> None:
    assert parse_spec(sphere()).material == MaterialSpec(1000.0, 0.35, 0.02)
    m = parse_spec(strip(material={"youngs_modulus": 3500, "poisson": 0.3, "strain_limit": 0.017})).material
    assert (m.youngs_modulus, m.poisson, m.strain_limit) == (3500.0, 0.3, 0.017)
    assert parse_spec(sphere(material={"strain_limit": 0.5})).material.strain_limit == 0.5


@pytest.mark.parametrize(("table", "words"), [
    ({"strain_limit": 0}, ("material.strain_limit", "(0, 0.5]")),
    ({"strain_limit": 0.6}, ("material.strain_limit", "(0, 0.5]")),
    ({"strain_limit": "2%"}, ("material.strain_limit", "number")),
    ({"poisson": 0.5}, ("material.poisson", "(-1, 0.5)")),
    ({"youngs_modulus": -1.0}, ("material.youngs_modulus", "N/mm²")),
    ({"youngs_modulus": True}, ("material.youngs_modulus", "number")),
    ({"yield_strain": 0.02}, ("unknown key material.yield_strain", "youngs_modulus, poisson, strain_limit")),
])
def test_material_refusals_name_the_key(table: dict, words: tuple[str, ...]) -> None:
    refused(sphere(material=table), *words)
    assert "[material] must be a table" in refused(sphere(material=3))


# -- rule = "roundest" --------------------------------------------------------------------------------


def test_roundest_rule_parses() -> None:
    p = parse_spec(sphere(patterns={"rule": "roundest"})).patterns
    assert (p.rule, p.candidates, p.scenario) == ("roundest", 8, "dome")
    p = parse_spec(sphere(patterns={"rule": "roundest", "candidates": 3, "scenario": "cylinder"})).patterns
    assert (p.rule, p.candidates, p.scenario) == ("roundest", 3, "cylinder")
    assert parse_spec(sphere(patterns={"rule": "similar-energy"})).patterns.candidates == 8  # the unread default


@pytest.mark.parametrize(("patterns", "words"), [
    ({"hexagon": "0x0488", "pentagon": "0x0508", "candidates": 4},
     ("patterns.candidates does not apply to patterns.hexagon", "patterns.rule = 'roundest'")),
    ({"pattern": "0x0488", "candidates": 4}, ("patterns.candidates does not apply to patterns.pattern", "roundest")),
    ({"rule": "similar-energy", "candidates": 4},
     ("patterns.candidates does not apply to patterns.rule = 'similar-energy'", "roundest")),
    ({"rule": "roundest", "candidates": 0}, ("patterns.candidates", "integer in [1, 20]")),
    ({"rule": "roundest", "candidates": True}, ("patterns.candidates", "integer")),
    ({"rule": "roundest", "count": 2}, ("patterns.count does not apply to rule = 'roundest'", "candidates")),
    ({"rule": "round"}, ("patterns.rule", "similar-energy, roundest")),
])
def test_roundest_refusals(patterns: dict, words: tuple[str, ...]) -> None:
    refused(sphere(patterns=patterns), *words)


def test_candidates_on_a_strip_is_refused() -> None:
    refused(strip(patterns={"rule": "graded", "count": 3, "candidates": 2}), "patterns.candidates does not apply",
            "roundest")
    refused(strip(patterns={"rule": "roundest"}), "patterns.rule", "graded")


HEX = {"a": 1.0, "b": 2.0, "c": 4.0, "d": 8.0, "e": 16.0}
PENT = {"p": 3.9, "q": 2.2, "r": 9.0, "s": 1.01}


def test_similar_pairs_by_hand() -> None:
    # median hexagon energy 4 (c), nearest pentagon 3.9 (p): similar_pair's answer comes first.
    # Near the median: c, then b and d (both a factor 2 away; b first by ID), then a and e (a factor 4).
    # Their nearest pentagons and log ratios: a–s 0.00995, c–p 0.0253, b–q 0.0953, d–r 0.118, e–r 0.575.
    assert similar_pair(HEX, PENT) == ("c", "p")
    assert similar_pairs(HEX, PENT, 1) == [("c", "p")]
    assert similar_pairs(HEX, PENT, 2) == [("c", "p"), ("a", "s")]  # 4 candidates: c, b, d, a
    assert similar_pairs(HEX, PENT, 3) == [("c", "p"), ("a", "s"), ("b", "q")]
    assert similar_pairs(HEX, PENT, 10) == [("c", "p"), ("a", "s"), ("b", "q"), ("d", "r"), ("e", "r")]


def test_similar_pairs_in_one_scenario_never_pair_a_pattern_with_itself() -> None:
    energies = {"a": 1.0, "b": 1.05, "c": 4.0, "d": 4.1, "e": 16.0, "f": 17.0, "g": 33.0}
    pairs = similar_pairs(energies, energies, 3)  # the same energies for both polygons
    assert pairs[0] == similar_pair(energies, energies) == ("d", "c")  # median 4.1 (d), nearest other 4.0 (c)
    # the 6 nearest 4.1: d, c, e (×3.90), b (×3.905), a, f; their log ratios: d–c and c–d 0.0247,
    # b–a and a–b 0.0488, e–f and f–e 0.0606; ties go to the smaller hexagon ID
    assert pairs == [("d", "c"), ("c", "d"), ("a", "b")]
    assert all(h != p for h, p in pairs)


def test_similar_pairs_on_random_catalogs() -> None:
    rng = np.random.default_rng(12)
    for _ in range(20):
        hexagon = {f"0x{i:04x}": float(e) for i, e in enumerate(rng.lognormal(0, 1, 40))}
        pentagon = {f"0x{i + 20:04x}": float(e) for i, e in enumerate(rng.lognormal(0, 1, 30))}
        pairs = similar_pairs(hexagon, pentagon, 8)
        assert pairs[0] == similar_pair(hexagon, pentagon)
        assert len(pairs) == len(set(pairs)) == 8
        ratios = [abs(math.log(hexagon[h] / pentagon[p])) for h, p in pairs[1:]]
        assert ratios == sorted(ratios)
        assert all(h != p for h, p in pairs)


def test_similar_pairs_count_must_be_positive() -> None:
    with pytest.raises(SpecError, match="at least 1"):
        similar_pairs(HEX, PENT, 0)


# -- placement ----------------------------------------------------------------------------------------


def placed(data: dict):  # noqa: ANN201
    spec = parse_spec(data)
    check_geometry(spec)
    ids = ["0x0488" if len(f) == 6 else "0x0508" for f in build_tiling(spec).faces]
    return place(spec, ids)


def test_flat_sphere_has_one_straight_sleeve_part_on_the_polyhedron() -> None:
    flat, rigid = placed(sphere(sleeve={"angle": "flat"})), placed(sphere())
    assert flat.counts() == {"hex 0x0488": 20, "pent 0x0508": 12, "S-flat": 90}
    assert list(flat.sleeve_types) == ["S-flat"] and flat.sleeve_types["S-flat"].dihedral == math.pi
    E = flat.skeleton.edge_length()
    assert E == rigid.skeleton.edge_length()  # the printed angle does not move the plates
    assert flat.sleeve_types["S-flat"].setback == pytest.approx(setback(5, E, 36.0), abs=1e-12)  # the smallest
    kinds = {}
    for s, r in zip(flat.sleeves, rigid.sleeves, strict=True):
        assert s.angle == math.pi and s.dihedral == pytest.approx(r.angle, abs=1e-12)
        assert np.allclose(s.transform, r.transform, atol=1e-12)  # frames come from the skeleton
        kinds.setdefault(r.kind, set()).add(round(math.degrees(s.dihedral), 6))
    assert kinds == {"S-HH": {round(math.degrees(HEX_HEX_DIHEDRAL), 6)},
                     "S-HP": {round(math.degrees(HEX_PENT_DIHEDRAL), 6)}}
    for p, q in zip(flat.plates, rigid.plates, strict=True):
        assert np.array_equal(p.transform, q.transform)


def test_rigid_sphere_keeps_two_sleeve_parts_at_the_dihedrals() -> None:
    asm = placed(sphere(sleeve={"angle": "dihedral"}))
    assert asm.counts() == {"hex 0x0488": 20, "pent 0x0508": 12, "S-HH": 30, "S-HP": 60}
    types = asm.sleeve_types
    assert math.degrees(types["S-HH"].dihedral) == pytest.approx(138.19, abs=0.005)
    assert math.degrees(types["S-HP"].dihedral) == pytest.approx(142.62, abs=0.005)
    for s in asm.sleeves:
        assert s.angle == s.dihedral == pytest.approx(types[s.kind].dihedral, abs=1e-12)


def test_a_numeric_angle_is_one_part_and_may_widen_the_skeleton() -> None:
    asm = placed(sphere(sleeve={"angle": 160}))
    assert list(asm.sleeve_types) == ["S-160deg"] and len(asm.sleeves) == 90
    assert all(s.angle == pytest.approx(math.radians(160), abs=1e-15) for s in asm.sleeves)
    rigid_E = placed(sphere()).skeleton.edge_length()
    assert asm.skeleton.edge_length() == rigid_E
    # printed at 138.19°, below the hex–pent dihedral, the sleeve's web needs a larger pentagon setback
    low = placed(sphere(sleeve={"angle": 138.19}))
    sl = low.sleeve_types["S-138.19deg"]
    assert low.skeleton.edge_length() > rigid_E
    assert sl.setback == pytest.approx(required_setback(math.radians(138.19), 2.0, 0.2, 1.2), abs=1e-9)
    assert sl.web() >= 1.2 - 1e-9


def test_strip_sleeves_are_unchanged_by_a_flat_angle() -> None:
    a, b = placed(strip()), placed(strip(sleeve={"angle": "flat"}))
    assert list(a.sleeve_types) == list(b.sleeve_types) == ["S-flat"]
    sa, sb = a.sleeve_types["S-flat"], b.sleeve_types["S-flat"]
    assert sa.setback == sb.setback == pytest.approx(0.7, abs=1e-12)
    assert sa.dihedral == pytest.approx(sb.dihedral, abs=1e-12)
    for s in a.sleeves:
        assert s.angle == s.dihedral == pytest.approx(math.pi, abs=1e-12)


def test_depth_bound_spans_the_joints_of_one_part() -> None:
    # hexagon setback − pentagon setback on the shared S-flat part, plus a wall: 0.286 + 1.2 mm
    with pytest.raises(SpecError, match=r"sleeve.depth = 1.4 mm must be ≥ 1.49 mm: .* on one sleeve part"):
        check_geometry(parse_spec(sphere(sleeve={"angle": "flat", "depth": 1.4})))
    check_geometry(parse_spec(sphere(sleeve={"angle": "flat", "depth": 1.49})))


def test_bent_sleeve_transform_turns_each_slot_onto_its_plate() -> None:
    from fabpat.assembly.place.checks import bent_sleeve_transform

    asm = placed(sphere(sleeve={"angle": "flat"}))
    for s in asm.sleeves[:5]:
        for side in (0, 1):
            T = bent_sleeve_transform(s, side)
            slot = T[:3, :3] @ [0.0, *joint_direction(s.angle, side)]
            plate = s.transform[:3, :3] @ [0.0, *joint_direction(s.dihedral, side)]
            assert np.allclose(slot, plate, atol=1e-12)
            assert np.allclose(T[:3, 3], s.transform[:3, 3]) and np.allclose(T[:3, 0], s.transform[:3, 0])
    rigid = placed(sphere())
    assert np.array_equal(bent_sleeve_transform(rigid.sleeves[0], 1), rigid.sleeves[0].transform)


# -- the shipped specs --------------------------------------------------------------------------------


def test_shipped_sphere_specs() -> None:
    flat, rigid = load_spec(FLAT), load_spec(RIGID)
    assert flat.sleeve.angle == "flat" and rigid.sleeve.angle == "dihedral"
    assert flat.material == rigid.material == MaterialSpec()
    assert (flat.name, rigid.name) == ("truncated-icosahedron", "truncated-icosahedron-rigid")
    for field in ("tiling", "patterns", "plates", "sheet", "estimates", "formats", "mesh_tolerance", "curve_tolerance"):
        assert getattr(flat, field) == getattr(rigid, field), field
    assert flat.sleeve.__dict__ | {"angle": None} == rigid.sleeve.__dict__ | {"angle": None}


def test_the_flat_kit_passes_the_checks_only_with_the_sleeves_turned(monkeypatch: pytest.MonkeyPatch) -> None:
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.place import checks
    from fabpat.assembly.place.parts import PartLibrary
    from fabpat.errors import GeometryError

    lib = PartLibrary(*plan(parse_spec(sphere(sleeve={"angle": "flat"}))))
    err, depth = checks.interface_midpoints(lib)
    assert err < 1e-9 and 2.5 < depth <= 3.0 + 1e-9
    tested, worst, gap = checks.intersections(lib)
    assert worst <= 1e-6 and gap == pytest.approx(0.1, abs=0.02)  # clearance / 2, as on the rigid sphere
    # a straight sleeve left as placed on a folded joint cuts into its plates: the turn is what passes
    monkeypatch.setattr(checks, "bent_sleeve_transform", lambda s, side: s.transform)
    with pytest.raises(GeometryError, match="intersect"):
        checks.intersections(lib)


def test_assemble_writes_the_flat_sphere_kit(tmp_path: Path) -> None:
    import dataclasses

    from fabpat.assembly.kit.build import assemble

    out = tmp_path / "kit"
    # predict=False: the kit's parts without the closure (tests/test_assembly_predict.py has the prediction and
    # every format, from the command line); in-process, and only the formats whose files are checked here
    spec = dataclasses.replace(load_spec(FLAT), formats=("step", "stl", "bom"))
    assemble(spec, out, predict=False)
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["counts"] == {"hex 0x0488": 20, "pent 0x0508": 12, "S-flat": 90}
    # bent sleeves: the exact flat parts side by side (parts.step), not placed on the polyhedron
    assert (out / "parts" / "sleeve-S-flat.stl").is_file() and (out / "parts.step").is_file()


def test_a_goldberg_sphere_bends_by_default_as_the_shipped_sphere_does() -> None:
    """Without [sleeve] angle a Goldberg sphere was a nearly rigid polyhedron ("dihedral") while the shipped
    sphere is bent by straight sleeves: its default is now "flat"; the other kinds keep "dihedral"."""
    gp = {"kind": "goldberg", "m": 1, "n": 1, "edge": 36.0}  # the smallest with hexagons: a fast parse
    assert parse_spec(sphere(tiling=gp), "g.toml").sleeve.angle == "flat"
    assert parse_spec(sphere(), "s.toml").sleeve.angle == "dihedral"
    tube = {"kind": "hex-tube", "rows": 6, "columns": 2, "edge": 36.0}
    assert parse_spec(sphere(tiling=tube, patterns={"hexagon": "0x0488"}), "t.toml").sleeve.angle == "dihedral"
