"""``fabpat design --dry-run``: the inputs checked and the plan printed in seconds, with no solve and no file."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fabpat.design import api
from tests.helpers import invoke
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
