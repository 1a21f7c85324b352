"""``fabpat design --per / --vary``: the words checked before any solve, and a closed target's tiling mapped onto
it (shapes) with its faces' irregularity measured."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fabpat.design.mapped import map_base, read_per, read_vary
from fabpat.errors import SpecError
from tests.helpers import one_line_error, open_sphere

ROOT = Path(__file__).resolve().parents[1]
SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
STRIP = ROOT / "assemblies" / "graded-strip.toml"


@pytest.fixture
def no_solve(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every design solve goes through Runner.run: reaching it fails the test (the refusal came too late)."""
    from fabpat.design.search import Runner

    def solved(*_args: Any, **_kw: Any) -> None:
        raise AssertionError("a solve was started before the refusal")

    monkeypatch.setattr(Runner, "run", solved)


def test_vary_words_and_their_defaults() -> None:
    assert read_vary(None, True) == ("shapes", "patterns")
    assert read_vary(None, False) == ("patterns", "angles")
    assert read_vary("angles, shapes", True) == ("shapes", "angles")  # in the documented order
    assert read_vary(["thickness"], False) == ("thickness",)
    for bad in ("shape", "patterns,colour", "", 3):
        with pytest.raises(SpecError, match="vary"):
            read_vary(bad, True)
    assert read_per("group") == "group"
    with pytest.raises(SpecError, match="face, group"):
        read_per("plate")


@pytest.mark.parametrize(("args", "words"), [
    (["sphere", "--spec", str(SPHERE), "--vary", "shapes,colour"], ("unknown word 'colour'", "thickness")),
    (["sphere", "--spec", str(SPHERE), "--per", "plate"], ("--per",)),
    ([str(ROOT / "tests" / "data" / "missing.csv"), "--spec", str(STRIP), "--vary", "bogus"], ("--vary",)),
])
def test_bad_per_and_vary_are_one_line_and_write_nothing(tmp_path: Path, no_solve: None, args: list[str],
                                                         words: tuple[str, ...]) -> None:
    from click.testing import CliRunner

    from fabpat.cli import cli

    out = tmp_path / "out"
    r = CliRunner().invoke(cli, ["design", *args, "--out", str(out), "--no-progress"])
    one_line_error(r, *words)
    assert not out.exists()


def test_shapes_are_refused_for_a_strip_before_any_solve(tmp_path: Path, no_solve: None) -> None:
    from fabpat.design import design

    arch = tmp_path / "arch.csv"
    arch.write_text("x,z\n0,0\n100,20\n200,0\n", encoding="utf-8")
    with pytest.raises(SpecError, match="leave shapes out"):
        design(str(arch), STRIP, vary="shapes,patterns")


def test_the_truncated_icosahedron_mapped_onto_an_ellipsoid_has_flat_nearly_regular_faces() -> None:
    """The mapped faces are planar and within the shaped plates' limit; on a sphere nothing moves."""
    from fabpat.design.base import load_base
    from fabpat.design.target import read_target
    from fabpat.geometry.shaped import MAX_IRREGULARITY

    base = load_base(SPHERE)
    m = map_base(read_target("ellipsoid:1,1,1.15"), base)
    assert m.planarity < 1e-6
    assert 0.005 < m.face_irregularity["edge"] < MAX_IRREGULARITY[0]  # stretched, but within the limit
    assert 1.0 < m.face_irregularity["angle_deg"] < math.degrees(MAX_IRREGULARITY[1])
    text = m.obj.decode()
    assert text.count("\nf ") + text.startswith("f ") == 32 and text.count("\nv ") + text.startswith("v ") == 60
    round_ = map_base(read_target("sphere"), base)
    assert round_.face_irregularity["edge"] < 1e-9 and round_.face_irregularity["angle_deg"] < 1e-9
    # the sphere's mapped corners are one sphere's: every corner at the same distance from their centre
    r = np.linalg.norm(round_.V - round_.V.mean(axis=0), axis=1)
    assert np.ptp(r) < 1e-9 * r.mean()


def test_a_target_whose_mapped_faces_are_too_irregular_is_refused_naming_the_face(tmp_path: Path,
                                                                                  no_solve: None) -> None:
    """The shipped egg (1.25 : 1, tapered) bends the truncated icosahedron's pentagons 24° out of regular, past the
    shaped plates' 20°: one line naming the face, before any solve, nothing written."""
    from click.testing import CliRunner

    from fabpat.cli import cli

    out = tmp_path / "out"
    r = CliRunner().invoke(cli, ["design", str(ROOT / "assemblies" / "egg.obj"), "--spec", str(SPHERE), "--out",
                                 str(out), "--no-progress"])
    one_line_error(r, "from regular, over the shaped plates' limit of 20 % / 20°", "face P")
    assert not out.exists()


def test_an_earlier_design_with_its_mapped_mesh_may_be_replaced(tmp_path: Path) -> None:
    """mapped.obj is a design's own output: a re-run into the folder replaces it; a user's file still stops it."""
    import json

    from fabpat.design.outputs import GENERATOR, design_in_the_way

    (tmp_path / "design.json").write_text(json.dumps({"generator": GENERATOR}), encoding="utf-8")
    for name in ("design.toml", "design.png", "mapped.obj"):
        (tmp_path / name).write_text("x", encoding="utf-8")
    assert design_in_the_way(tmp_path) is None
    (tmp_path / "notes.txt").write_text("mine", encoding="utf-8")
    assert design_in_the_way(tmp_path) == "it holds notes.txt, which fabpat design did not write"


def _own(record: dict[str, Any]) -> None:
    """The design's patterns are the shipped spec's pair: 0x0488 on every hexagon, 0x0508 on every pentagon."""
    pats = record["patterns"]
    assert len(pats) == 32
    assert {p for k, p in pats.items() if k.startswith("H")} == {"0x0488"}
    assert {p for k, p in pats.items() if k.startswith("P")} == {"0x0508"}


def test_vary_without_patterns_keeps_the_base_patterns_and_gives_the_angles_the_budget(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``--per group --vary angles --max-solves 4`` solved 4 pattern designs (the single baseline among them)
    while design.json said variables.patterns = 0. Now the spec's own pair is solved alone and the angle phase
    starts from it with the whole budget (the closure and the angle phase replaced: no real solve)."""
    from fabpat.design import design
    from tests.test_design_inputs import _fake_closure

    monkeypatch.setattr("fabpat.design.closed_api.solve_closed", _fake_closure)
    seen: dict[str, Any] = {}

    def angles(phase: Any, tgt: Any, spec: Any, best: Any, h: float, budget: int, *_a: Any) -> None:
        seen.update(faces=list(best.data["faces"]), budget=budget)

    monkeypatch.setattr("fabpat.design.closed_angles.vary_angles", angles)
    rec = design("sphere", SPHERE, h=7.5, max_solves=4, per="group", vary="angles").record
    _own(rec)
    assert set(rec["baselines"]) == {"spec"} and rec["solves"] == 1 and len(rec["history"]) == 1
    assert rec["variables"]["patterns"] == 0 and rec["vary"] == ["angles"]
    assert seen["budget"] == 4 and seen["faces"] == list(rec["patterns"].values())


def test_vary_shapes_without_patterns_keeps_the_base_patterns_on_the_mapped_faces(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The mapped tiling's spec carries a placeholder pattern: the kept patterns are the base's, read before the
    mapping (0x0508 on the pentagons, not the placeholder's 0x0488)."""
    from fabpat.design import design
    from tests.test_design_inputs import _fake_closure

    monkeypatch.setattr("fabpat.design.closed_api.solve_closed", _fake_closure)
    res = design("ellipsoid:1,1,1.15", SPHERE, h=7.5, max_solves=4, vary="shapes")
    _own(res.record)
    assert set(res.record["baselines"]) == {"spec"} and res.record["solves"] == 1
    assert res.record["variables"]["patterns"] == 0 and res.record["variables"]["shapes"] == 3 * 60
    assert "mapped.obj" in res.files


def test_vary_without_patterns_on_a_base_that_names_none_is_refused(tmp_path: Path, no_solve: None) -> None:
    from click.testing import CliRunner

    from fabpat.cli import cli
    from fabpat.design import design

    spec = open_sphere(tmp_path)
    with pytest.raises(SpecError, match="--vary without patterns keeps the base spec's patterns") as e:
        design("sphere", spec, vary="angles")
    assert "\n" not in str(e.value)
    out = tmp_path / "out"
    r = CliRunner().invoke(cli, ["design", "ellipsoid:1,1,1.15", "--spec", str(spec), "--out", str(out),
                                 "--vary", "shapes,angles", "--no-progress"])
    one_line_error(r, "name them in its [patterns]")
    assert not out.exists()
