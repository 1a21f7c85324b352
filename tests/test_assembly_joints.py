"""An angle per joint and a thickness per plate, as spec keys: ``[sleeve] angles``/``angle_range`` and
``[plates] thicknesses``/``thickness_range``.

Specs are tiny: a cube read from an OBJ (12 joints of 90°), a one-ring hexagon cap (12 flat joints), the
1 × 3 test strip and, for the labels, the truncated icosahedron (parsed only). Expected angles are the
listed ones (rounded to 0.1°), expected rotations the listed angle minus the cube's 90°.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from fabpat.assembly.place.placement import place
from fabpat.assembly.solve.closure import ClosureRun, closure_setup, run_closure
from fabpat.assembly.solve.strip import strip_setup
from fabpat.assembly.spec.load import parse_spec
from fabpat.assembly.surface.joints import required_setback
from fabpat.errors import SpecError
from fabpat.shell.rotations import expmap
from tests.helpers import invoke, one_line_error

CUBE_V = [(0, 0, 0), (36, 0, 0), (36, 36, 0), (0, 36, 0), (0, 0, 36), (36, 0, 36), (36, 36, 36), (0, 36, 36)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]  # outward
#: the cube's joints E01 and E05 listed within 0.1° of each other (one part), E07 at another angle
ANGLES = {"E01": 95.0, "E05": 95.04, "E07": 97.3}


def cube(tmp_path: Path, sleeve: dict | None = None, plates: dict | None = None) -> dict:
    (tmp_path / "m.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in CUBE_V) + "".join(
        "f " + " ".join(str(i + 1) for i in f) + "\n" for f in CUBE_F), encoding="utf-8")
    return {"name": "cube", "tiling": {"kind": "mesh", "file": "m.obj"}, "patterns": {"square": "0x0488"},
            "sleeve": {"margin": 2.8, "angle_range": [91.0, 100.0], **(sleeve or {})}, "plates": plates or {},
            "sheet": {"width": 600.0, "height": 400.0}, "output": {"formats": ["bom"]}}


def sphere(**tables: dict) -> dict:
    data: dict = {"tiling": {"kind": "truncated-icosahedron", "edge": 36.0},
                  "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"}}
    data.update(tables)
    return data


def strip(**tables: dict) -> dict:
    data: dict = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
                  "patterns": {"pattern": "0x0488"}}
    data.update(tables)
    return data


def toml(data: dict) -> str:
    """A spec dict as TOML text (tables of numbers, strings and lists: all these tests write)."""
    def value(v: object) -> str:
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return f'"{v}"' if isinstance(v, str) else repr(v)

    head = [f"{k} = {value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    tables = [f"[{k}]\n" + "\n".join(f"{key} = {value(x)}" for key, x in v.items())
              for k, v in data.items() if isinstance(v, dict)]
    return "\n".join(head + tables) + "\n"


# -- the keys as read -------------------------------------------------------------------------------


def test_the_keys_are_read_in_label_order_with_their_ranges(tmp_path: Path) -> None:
    spec = parse_spec(cube(tmp_path, {"angles": {"E07": 97.3, "E01": 95.0}},
                           {"thicknesses": {"Q2": 2.5, "Q1": 1.5}, "thickness_range": [1.0, 3.0]}),
                      str(tmp_path / "spec.toml"))
    assert spec.sleeve.angles == (("E01", 95.0), ("E07", 97.3))
    assert spec.sleeve.angle_range == (91.0, 100.0)
    assert spec.plates.thicknesses == (("Q1", 1.5), ("Q2", 2.5))
    assert spec.plates.thickness_range == (1.0, 3.0)
    assert (spec.plates.thickness_of("Q1"), spec.plates.thickness_of("Q3")) == (1.5, 2.0)
    assert spec.plates.thickest == 2.5 and not spec.plates.uniform
    # printed at the listed angle rounded to 0.1°; an unlisted joint follows [sleeve] angle
    assert spec.sleeve.listed_angle("E07") == 97.3 and spec.sleeve.listed_angle("E02") is None


def test_defaults_leave_every_joint_and_plate_as_before() -> None:
    spec = parse_spec(sphere(), "s.toml")
    assert spec.sleeve.angles == () and spec.sleeve.angle_range == (150.0, 180.0)
    assert spec.plates.thicknesses == () and spec.plates.uniform


# -- refusals: one line each, naming the key ----------------------------------------------------------


def _one_line(data: dict, *words: str) -> None:
    with pytest.raises(SpecError) as err:
        parse_spec(data, "s.toml")
    msg = str(err.value)
    assert "\n" not in msg, msg
    for w in words:
        assert w in msg, msg


@pytest.mark.parametrize(("sleeve", "words"), [
    ({"angle_range": [90.0, 170.0]}, ("sleeve.angle_range = [90.0, 170.0]", "90 < MIN ≤ MAX ≤ 180")),
    ({"angle_range": [170.0, 160.0]}, ("sleeve.angle_range = [170.0, 160.0]", "MIN ≤ MAX")),
    ({"angle_range": [150.0, 181.0]}, ("sleeve.angle_range",)),
    ({"angle_range": [150.0]}, ("sleeve.angle_range",)),
    ({"angle_range": [150.0, float("nan")]}, ("sleeve.angle_range",)),
    ({"angles": {"E01": 140.0}}, ("sleeve.angles.E01 = 140° is outside sleeve.angle_range = [150, 180]",)),
    ({"angles": {"E01": 160.0}, "angle_range": [165.0, 175.0]}, ("sleeve.angles.E01 = 160°", "[165, 175]")),
    ({"angles": {"E91": 170.0}}, ("sleeve.angles names 'E91'", "its 90 joints are E01 … E90")),
    ({"angles": {"E1": 170.0}}, ("sleeve.angles names 'E1'", "E01 … E90")),
    ({"angles": {"E01": "flat"}}, ("sleeve.angles", "must be a table {joint label = number")),
    ({"angles": [170.0]}, ("sleeve.angles", "must be a table")),
])
def test_bad_joint_angles_are_one_line(sleeve: dict, words: tuple[str, ...]) -> None:
    _one_line(sphere(sleeve=sleeve), *words)


@pytest.mark.parametrize(("plates", "words"), [
    ({"thickness_range": [0.0, 2.0]}, ("plates.thickness_range = [0.0, 2.0]", "0.01 ≤ MIN ≤ MAX ≤ 100")),
    ({"thickness_range": [-1.0, 2.0]}, ("plates.thickness_range",)),
    ({"thickness_range": [2.0, 1.0]}, ("plates.thickness_range = [2.0, 1.0]", "MIN ≤ MAX")),
    ({"thicknesses": {"H01": 2.5}, "thickness_range": [1.0, 2.0]},
     ("plates.thicknesses.H01 = 2.5 mm is outside plates.thickness_range = [1, 2]",)),
    ({"thicknesses": {"H01": 0.0}}, ("plates.thicknesses.H01 = 0 mm is outside plates.thickness_range = [0.01, 100]",)),
    ({"thicknesses": {"X01": 1.0}}, ("plates.thicknesses names 'X01'", "its 32 plates are H01 … H20, P01 … P12")),
    ({"thicknesses": {"H01": True}}, ("plates.thicknesses", "must be a table {plate label = number")),
    ({"thicknesses": {"H01": 1.2, "P03": 0.9}, "thickness": 1.0, "process": "laser"},
     ("plates.thicknesses gives plates of 0.9, 1, 1.2 mm", "same sheets", "plates.process = \"print\"")),
])
def test_bad_plate_thicknesses_are_one_line(plates: dict, words: tuple[str, ...]) -> None:
    _one_line(sphere(plates=plates), *words)


def test_a_wrong_range_is_not_blamed_on_the_values_it_would_hold() -> None:
    with pytest.raises(SpecError) as err:
        parse_spec(sphere(sleeve={"angle_range": [170.0, 160.0], "angles": {"E01": 165.0}}), "s.toml")
    assert "angle_range" in str(err.value) and "angles.E01" not in str(err.value)


def test_a_strip_takes_no_joint_angles_and_a_panel_no_thicknesses() -> None:
    _one_line(strip(sleeve={"angles": {"E1": 170.0}}), "sleeve.angles applies to closed tilings")
    _one_line(strip(sleeve={"angle_range": [150.0, 170.0]}), "sleeve.angle_range applies to closed tilings")
    panel = strip(plates={"thicknesses": {"T1": 1.0}})
    panel["tiling"] = {**panel["tiling"], "kind": "panel"}
    _one_line(panel, "plates.thicknesses applies to kits of plates joined by sleeves")


def test_a_strip_takes_plate_thicknesses_by_its_labels() -> None:
    spec = parse_spec(strip(plates={"thicknesses": {"T2": 1.2}}), "s.toml")
    assert spec.plates.thicknesses == (("T2", 1.2),)
    _one_line(strip(plates={"thicknesses": {"T4": 1.2}}), "plates.thicknesses names 'T4'", "its 3 plates are T1 … T3")


@pytest.mark.parametrize("command", ["assemble", "simulate-assembly"])
def test_the_cli_refuses_a_bad_angle_in_one_line_and_writes_nothing(tmp_path: Path, command: str) -> None:
    spec = tmp_path / "spec.toml"
    spec.write_text(toml(cube(tmp_path, {"angles": {"E13": 95.0}})), encoding="utf-8")
    out = tmp_path / "out"
    args = ["--out", str(out), "--no-predict"] if command == "assemble" else ["--json", "--vtu", str(out / "m.vtu")]
    one_line_error(invoke(command, str(spec), *args), "sleeve.angles names 'E13'", "its 12 joints are E01 … E12")
    assert not out.exists()


# -- placement and the kit --------------------------------------------------------------------------


def test_listed_angles_reach_the_placed_sleeves(tmp_path: Path) -> None:
    spec = parse_spec(cube(tmp_path, {"angles": ANGLES}), str(tmp_path / "spec.toml"))
    asm = place(spec, ["0x0488"] * 6)
    by_label = {s.label: s for s in asm.sleeves}
    assert len(by_label) == 12
    for label, s in by_label.items():
        assert s.dihedral == pytest.approx(math.pi / 2, abs=1e-12)
        want = {"E01": 95.0, "E05": 95.0, "E07": 97.3}.get(label, 90.0)  # 95.04 rounds to 95.0
        assert math.degrees(s.angle) == pytest.approx(want, abs=1e-9), label
    # one part per printed angle: E01 and E05 share one, E07 has its own, the rest the cube's joint
    assert by_label["E01"].kind == by_label["E05"].kind == "S-95deg"
    assert by_label["E07"].kind == "S-97.3deg"
    assert {by_label[k].kind for k in by_label if k not in ANGLES} == {"S-QQ"}
    for key, sleeve in asm.sleeve_types.items():
        printed = {s.angle for s in asm.sleeves if s.kind == key}
        assert len(printed) == 1 and sleeve.dihedral == pytest.approx(printed.pop(), abs=1e-12)


def test_the_skeleton_leaves_the_web_at_a_listed_angle_below_the_dihedral() -> None:
    # a one-ring cap is flat (12 joints of 180°); a joint printed at 150° needs a larger setback
    data: dict = {"tiling": {"kind": "hex-cap", "rings": 1, "centre": 6, "edge": 36.0},
                  "patterns": {"hexagon": "0x0488"}}
    plain = place(parse_spec(data, "c.toml"), ["0x0488"] * 7)
    listed = place(parse_spec({**data, "sleeve": {"angles": {"E01": 150.0}}}, "c.toml"), ["0x0488"] * 7)
    assert listed.skeleton.edge_length() > plain.skeleton.edge_length()
    bent = listed.sleeve_types["S-150deg"]
    s = listed.spec.sleeve
    assert bent.setback >= required_setback(math.radians(150.0), 2.0, s.clearance, s.wall) - 1e-12
    for sleeve in listed.sleeve_types.values():
        assert sleeve.web() >= s.wall - 1e-9


def test_plates_of_their_own_thickness_are_their_own_parts(tmp_path: Path) -> None:
    spec = parse_spec(cube(tmp_path, {"angles": ANGLES}, {"thicknesses": {"Q1": 1.5, "Q2": 2.5}}),
                      str(tmp_path / "spec.toml"))
    asm = place(spec, ["0x0488"] * 6)
    plates = {p.label: p for p in asm.plates}
    assert (plates["Q1"].thickness, plates["Q2"].thickness, plates["Q3"].thickness) == (1.5, 2.5, 2.0)
    assert plates["Q1"].type.label == "quad 0x0488 t1.5" and plates["Q3"].type.label == "quad 0x0488 t2"
    # the mid-surface stays on the face plane: the solid's z = t/2 maps onto it whatever t
    for p in asm.plates:
        mid = p.transform @ np.array([0.0, 0.0, 0.5 * p.thickness, 1.0])
        normal, centre = asm.skeleton.normals[p.face], asm.skeleton.centroids[p.face]
        assert abs((mid[:3] - centre) @ normal) < 1e-9
    # a sleeve's slots take the thicker of its plates
    for s in asm.sleeves:
        thick = max(asm.plates[p].thickness for p, _ in s.plates)
        assert asm.sleeve_types[s.kind].slot_width == pytest.approx(thick + spec.sleeve.clearance)


def test_the_kit_lists_each_sleeve_part_with_its_angle(tmp_path: Path) -> None:
    spec = tmp_path / "spec.toml"
    spec.write_text(toml(cube(tmp_path, {"angles": ANGLES}, {"thicknesses": {"Q1": 1.5}})), encoding="utf-8")
    r = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-predict", "--no-progress")
    assert r.returncode == 0, r.stderr
    rows = {row["part"]: row for row in csv.DictReader((tmp_path / "kit" / "bom.csv").open(encoding="utf-8"))}
    counts = {k: int(v["count"]) for k, v in rows.items() if v["kind"] != "sheet"}
    # Q1 (1.5 mm) meets only 2 mm plates: every slot stays 2.2 mm wide, so the sleeves are the angles' parts
    assert counts == {"quad 0x0488 t1.5": 1, "quad 0x0488 t2": 5, "S-95deg": 2, "S-97.3deg": 1, "S-QQ": 9}
    assert float(rows["quad 0x0488 t1.5"]["unit_volume_mm3"]) == pytest.approx(
        0.75 * float(rows["quad 0x0488 t2"]["unit_volume_mm3"]), rel=1e-3)
    md = (tmp_path / "kit" / "bom.md").read_text(encoding="utf-8")
    assert "| S-95deg | 95.00 | 2.2 | 2 |" in md and "| S-97.3deg | 97.30 | 2.2 | 1 |" in md
    assert "| S-QQ | 90.00 | 2.2 | 9 |" in md


# -- the solver ---------------------------------------------------------------------------------------


def _slot_turn(run: ClosureRun, label: str) -> float:
    """The angle (°) between the final rotations of a sleeve's slot A and slot B nodes (rigidly linked)."""
    m = run.setup.model
    j = next(i for i, s in enumerate(m.sleeves) if s.label == label)
    (pa, ia), (pb, ib) = m.sleeves[j].slots
    rot = run.result.final.rotation
    Ra, Rb = expmap(rot[m.nodes(pa, ia)[:1]])[0], expmap(rot[m.nodes(pb, ib)[:1]])[0]
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))


def test_the_closure_turns_each_listed_joint_by_its_own_angle(tmp_path: Path) -> None:
    spec = parse_spec(cube(tmp_path, {"angles": ANGLES}, {"thicknesses": {"Q1": 1.5}}), str(tmp_path / "spec.toml"))
    setup = closure_setup(spec, ["0x0488"] * 6, h=7.5)
    t = setup.model.element_thickness
    assert t is not None
    for p, plate in enumerate(setup.model.plates):
        assert np.all(t[setup.model.plate_slices(p)[1]] == (1.5 if plate.label == "Q1" else 2.0))
    run = run_closure(setup, steps=1)
    # each slot's nodes turn rigidly with the sleeve: A against B by the joint's dihedral − printed angle
    assert _slot_turn(run, "E01") == pytest.approx(5.0, abs=1e-6)
    assert _slot_turn(run, "E05") == pytest.approx(5.0, abs=1e-6)
    assert _slot_turn(run, "E07") == pytest.approx(7.3, abs=1e-6)
    assert _slot_turn(run, "E02") == pytest.approx(0.0, abs=1e-6)
    assert run.energy > 0.0


def test_a_uniform_spec_gives_the_solver_one_thickness() -> None:
    base = parse_spec(strip(plates={"thickness": 0.8}), "s.toml")
    assert strip_setup(base, ["0x0488"] * 3, h=7.5).model.element_thickness is None
    same = parse_spec(strip(plates={"thickness": 0.8, "thicknesses": {"T2": 0.8}}), "s.toml")
    assert strip_setup(same, ["0x0488"] * 3, h=7.5).model.element_thickness is None
    own = parse_spec(strip(plates={"thickness": 0.8, "thicknesses": {"T2": 1.2}}), "s.toml")
    setup = strip_setup(own, ["0x0488"] * 3, h=7.5)
    t = setup.model.element_thickness
    assert t is not None and set(np.unique(t)) == {0.8, 1.2}
    assert np.all(t[setup.model.plate_slices(1)[1]] == 1.2)

