"""``fabpat design --dry-run``: the inputs checked and the plan printed in seconds, with no solve and no file."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fabpat.design import api
from tests.helpers import invoke, open_sphere
from tests.test_design import _base

#: the truncated icosahedron's circumradius over its edge, sqrt(58 + 18 √5) / 4 (its 60 vertices lie on it)
CIRCUMRADIUS = math.sqrt(58.0 + 18.0 * math.sqrt(5.0)) / 4.0


@pytest.fixture(autouse=True)
def no_solves(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a dry run started the solves")

    monkeypatch.setattr(api, "Runner", refuse)


def test_a_strip_plan_predicts_the_sine_arch_curvature(tmp_path: Path) -> None:
    """A shallow sine arch is the uniform elastica's own shape: its peak curvature a π² / s² (amplitude a,
    span s, after the scaling to the strip's length) is what the fitted elastica bends to."""
    x = np.linspace(0.0, 200.0, 81)
    target = tmp_path / "sine.csv"
    target.write_text("x,z\n" + "".join(f"{a:.6f},{20.0 * math.sin(math.pi * a / 200.0):.6f}\n" for a in x))
    spec, out = _base(tmp_path, "variations = false"), tmp_path / "d"
    r = invoke("design", str(target), "--spec", str(spec), "--out", str(out), "--h", "6", "--scale-target",
               "--dry-run")
    assert r.returncode == 0, r.stderr
    plan = json.loads(r.stdout)
    arc = float(np.hypot(np.diff(x), np.diff(20.0 * np.sin(np.pi * x / 200.0))).sum())
    assert plan["scale"] == pytest.approx(plan["pin_length"] / arc, rel=1e-9)
    assert plan["span"] == pytest.approx(200.0 * plan["scale"], rel=1e-9)
    assert plan["end_shortening"] == pytest.approx(1.0 - plan["span"] / plan["pin_length"], rel=1e-9)
    a, s = 20.0 * plan["scale"], plan["span"]
    assert plan["elastica"] == "fitted" and plan["thickness"] == 0.8 and plan["columns"] == 4  # test-small.toml
    assert plan["elastica_peak_strain"] == pytest.approx(0.5 * plan["thickness"] * a * math.pi**2 / s**2, rel=0.1)
    assert not out.exists()


def test_a_closed_plan_fits_the_target_to_the_polyhedron(tmp_path: Path) -> None:
    spec = Path(__file__).resolve().parents[1] / "assemblies" / "truncated-icosahedron.toml"
    r = invoke("design", "sphere", "--spec", str(spec), "--out", str(tmp_path / "d"), "--dry-run")
    assert r.returncode == 0, r.stderr
    plan = json.loads(r.stdout)
    assert plan["relative_rms"] < 1e-9 and plan["groups"] == 2 and plan["faces"] == 32
    edge = plan["radius"] / CIRCUMRADIUS  # the skeleton's edge: the plates' 36 mm and the sleeves' allowance
    assert 36.0 < edge < 42.0
    assert set(plan["candidates"]) == {"hexagon", "pentagon"}
    assert not (tmp_path / "d").exists()


def test_a_dry_run_refuses_what_the_design_would(tmp_path: Path) -> None:
    x = np.linspace(0.0, 100.0, 21)
    target = tmp_path / "short.csv"
    target.write_text("x,z\n" + "".join(f"{a:.6f},{10.0 * math.sin(math.pi * a / 100.0):.6f}\n" for a in x))
    r = invoke("design", str(target), "--spec", str(_base(tmp_path, "variations = false")), "--out",
               str(tmp_path / "d"), "--h", "6", "--dry-run")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--scale-target" in r.stderr, r.stderr
    assert r.stdout == ""


SPHERE = Path(__file__).resolve().parents[1] / "assemblies" / "truncated-icosahedron.toml"
STRIP = Path(__file__).resolve().parents[1] / "assemblies" / "graded-strip.toml"


@pytest.mark.parametrize(("case", "words"), [
    ("bogus", ("unknown word 'bogus'", "thickness")),
    ("empty", ("--vary", "shapes, patterns, angles, thickness")),
    ("per", ("--per",)),
    ("strip-shapes", ("--vary shapes", "leave shapes out")),
    ("irregular", ("face P09", "24.1°", "over the shaped plates' limit")),
    ("no-patterns", ("--vary without patterns keeps the base spec's patterns: name them in its [patterns]",)),
])
def test_a_dry_run_refuses_per_vary_and_mapped_faces_as_the_design_does(tmp_path: Path, case: str,
                                                                       words: tuple[str, ...]) -> None:
    """Each of these was a plan and exit 0 from --dry-run while the design refused it before its first solve:
    the words of --vary and --per, shapes with a strip target, a closed target whose mapped faces are too
    irregular (the shipped egg bends pentagon P09 24.1° out of regular, past the shaped plates' 20°) and a
    design without patterns on a base that names none. One line, exit 2, nothing written."""
    from click.testing import CliRunner

    from fabpat.cli import cli
    from tests.helpers import one_line_error

    arch = tmp_path / "arch.csv"
    arch.write_text("x,z\n0,0\n100,20\n200,0\n", encoding="utf-8")
    args = {"bogus": ["sphere", "--spec", str(SPHERE), "--vary", "bogus"],
            "empty": ["sphere", "--spec", str(SPHERE), "--vary", ""],
            "per": ["sphere", "--spec", str(SPHERE), "--per", "plate"],
            "strip-shapes": [str(arch), "--spec", str(STRIP), "--vary", "shapes"],
            "irregular": [str(SPHERE.parent / "egg.obj"), "--spec", str(SPHERE)],
            "no-patterns": ["sphere", "--spec", str(open_sphere(tmp_path)), "--vary", "angles"]}[case]
    out = tmp_path / "out"
    r = CliRunner().invoke(cli, ["design", *args, "--out", str(out), "--dry-run"])
    one_line_error(r, *words)
    assert r.stdout == "" and not out.exists()


def test_dry_run_checks_per_from_python() -> None:
    from fabpat.design.dry_run import dry_run
    from fabpat.errors import SpecError

    with pytest.raises(SpecError, match="--per must be one of face, group"):
        dry_run("sphere", SPHERE, per="plate")


def test_a_closed_plan_gives_per_vary_and_the_mapped_faces(tmp_path: Path) -> None:
    """With shapes the plan measures the tiling mapped onto the target as the design would (flat faces, within
    the shaped plates' limit, stretched by the 1.15 : 1 ellipsoid); a sphere keeps its base tiling (shapes
    dropped, nothing mapped); per and vary are the design's."""
    from fabpat.geometry.shaped import MAX_IRREGULARITY

    out = tmp_path / "d"
    r = invoke("design", "ellipsoid:1,1,1.15", "--spec", str(SPHERE), "--out", str(out), "--per", "group",
               "--vary", "angles,shapes", "--dry-run")
    assert r.returncode == 0, r.stderr
    plan = json.loads(r.stdout)
    assert plan["per"] == "group" and plan["vary"] == ["shapes", "angles"]
    assert plan["planarity"] < 1e-6
    assert 0.005 < plan["face_irregularity"]["edge"] < MAX_IRREGULARITY[0]
    assert 1.0 < plan["face_irregularity"]["angle_deg"] < math.degrees(MAX_IRREGULARITY[1])
    r = invoke("design", "sphere", "--spec", str(SPHERE), "--out", str(out), "--dry-run")
    assert r.returncode == 0, r.stderr
    plan = json.loads(r.stdout)
    assert plan["per"] == "face" and plan["vary"] == ["patterns"] and "face_irregularity" not in plan
    assert not out.exists()


def test_a_strip_plan_says_which_asked_words_the_search_keeps_fixed(tmp_path: Path) -> None:
    # the plan listed "angles" among the words a strip's design would vary, and only the real run's design.json
    # said they are not varied
    x = np.linspace(0.0, 200.0, 41)
    target = tmp_path / "sine.csv"
    target.write_text("x,z\n" + "".join(f"{a:.6f},{20.0 * math.sin(math.pi * a / 200.0):.6f}\n" for a in x))
    spec = _base(tmp_path, "variations = false")
    r = invoke("design", str(target), "--spec", str(spec), "--out", str(tmp_path / "d"), "--scale-target",
               "--vary", "patterns,angles", "--dry-run")
    assert r.returncode == 0, r.stderr
    plan = json.loads(r.stdout)
    assert plan["notes"] == [api.unvaried_note(object(), ["angles"])]
    assert plan["notes"][0].startswith("angles: not varied by this search")
    plain = json.loads(invoke("design", str(target), "--spec", str(spec), "--out", str(tmp_path / "d"),
                              "--scale-target", "--dry-run").stdout)
    assert "notes" not in plain and plain["vary"] == ["patterns"]  # a strip's search varies its patterns
    assert "per" not in plain  # a strip has no faces to group
    assert "give [sleeve]" not in plan["notes"][0]  # a strip's spec cannot set sleeve angles: no such advice
    # without patterns a strip's search would vary nothing (it used to search the patterns all the same)
    for words in ("angles", "thickness", "angles,thickness"):
        r = invoke("design", str(target), "--spec", str(spec), "--out", str(tmp_path / "d"), "--scale-target",
                   "--vary", words, "--dry-run")
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
        assert "must include patterns" in r.stderr
