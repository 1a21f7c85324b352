"""Designing open surfaces: a dome (cap:H) on a hex-cap, a surface of revolution (revolution:…) on a hex-tube.

References outside the code under test: points placed on a sphere of known radius (their distance from a
spherical cap is known in closed form), central differences of the refitted squared distances for the fit's
gradient, and central differences of full closure solves for the adjoint angle gradient.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fabpat.design.target import ClosedTarget, TargetError, read_target, require_match

ROOT = Path(__file__).resolve().parents[1]
CAP = ROOT / "assemblies" / "hex-cap-dome.toml"
TUBE = ROOT / "assemblies" / "hex-tube-revolution.toml"


def _target(text: str) -> ClosedTarget:
    tgt = read_target(text)
    assert isinstance(tgt, ClosedTarget)
    return tgt


def test_cap_and_revolution_targets_are_read() -> None:
    cap = read_target("cap:0.5")
    assert isinstance(cap, ClosedTarget) and cap.kind == "cap" and cap.profile == (0.5,) and cap.open
    rev = read_target("revolution:0.4,0.5,0.4")
    assert isinstance(rev, ClosedTarget) and rev.kind == "revolution" and rev.profile == (0.4, 0.5, 0.4)
    assert rev.bands == 3 and not _target("sphere").open


@pytest.mark.parametrize("text", ["cap:0", "cap:1.5", "cap:a", "cap:0.5,0.6", "cap", "revolution:0.5",
                                  "revolution:0.5,x", "revolution:0.5,0.001", "revolution:" + ",".join(["0.5"] * 51)])
def test_bad_open_targets_are_one_line(text: str) -> None:
    with pytest.raises(TargetError) as e:
        read_target(text)
    assert "\n" not in str(e.value) and text.split(":")[0] in str(e.value)


@pytest.mark.parametrize(("target", "kind"), [("cap:0.5", "hex-tube"), ("sphere", "hex-cap"),
                                              ("revolution:0.5,0.5", "hex-cap"), ("cap:0.5", "goldberg"),
                                              ("revolution:0.5,0.5", "honeycomb-strip")])
def test_a_target_that_does_not_fit_the_tiling_is_refused(target: str, kind: str) -> None:
    with pytest.raises(TargetError, match="cap|revolution"):
        require_match(read_target(target), "spec.toml", kind)


def test_the_open_kinds_are_designed() -> None:
    from fabpat.design.base import check_kind

    for kind in ("hex-cap", "hex-tube"):
        check_kind("spec.toml", kind)  # no refusal
    from fabpat.errors import SpecError

    with pytest.raises(SpecError, match="hex-cap"):
        check_kind("spec.toml", "panel")


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-m", "fabpat", *args], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=120)


def test_cli_refuses_a_target_in_one_line_and_writes_nothing(tmp_path: Path) -> None:
    r = _run("design", "cap:0.5", "--spec", str(TUBE), "--out", str(tmp_path / "d"), cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr.startswith("fabpat: error: ") and r.stderr.count("\n") == 1, r.stderr
    assert "revolution:R0" in r.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("target", "spec"), [("revolution:0.4,0.5", CAP), ("cap:2", CAP), ("sphere", TUBE)])
def test_design_refuses_a_target_before_any_solve_and_writes_nothing(tmp_path: Path, target: str, spec: Path) -> None:
    from fabpat.design import design

    with pytest.raises(TargetError) as e:
        design(target, spec, out=tmp_path / "d", h=6.0)
    assert "\n" not in str(e.value) and ("cap:H" in str(e.value) or "revolution:R0" in str(e.value))
    assert list(tmp_path.iterdir()) == []


def test_a_mesh_edge_too_coarse_for_the_interfaces_is_said_as_such_not_as_a_failed_search(tmp_path: Path) -> None:
    """h = 8 mm on the cap's 3.75 mm interface segments: every solve is refused before it starts, and the design
    says which h to use (as simulate-assembly does), not that no candidate converged in some number of solves."""
    from fabpat.design import design
    from fabpat.errors import GeometryError

    with pytest.raises(GeometryError) as e:
        design("cap:0.75", CAP, out=tmp_path / "d", h=8.0, max_solves=3)
    msg = str(e.value)
    assert "\n" not in msg and "use h ≤ 7.5 mm" in msg and "converged" not in msg
    assert list(tmp_path.iterdir()) == []


def test_design_axis_of_a_tube_and_of_a_hexagon_cap() -> None:
    from fabpat.assembly.surface.polyhedra import hex_cap, hex_tube
    from fabpat.design.closed import design_axis

    V, F = hex_tube(6, 2)  # the tube's axis is x (hex_tube)
    assert np.allclose(design_axis(V, F), [1.0, 0.0, 0.0], atol=1e-9)
    V, F = hex_cap(1, 6)  # a flat disc, its normal +z
    assert np.allclose(design_axis(V, F), [0.0, 0.0, 1.0], atol=1e-9)


def _turned(P: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return P @ Rotation.from_rotvec([0.3, -0.2, 0.1]).as_matrix().T + np.array([5.0, -3.0, 2.0])


def test_points_on_a_cap_fit_it_and_an_offset_is_measured() -> None:
    # points spread evenly by area (a Fibonacci spiral) over a spherical cap of rim radius 100 mm and height 50 mm
    # (H = 0.5), then moved off it radially by δ: their distance from the cap is δ, whatever the fit does
    H, rim = 0.5, 100.0
    R = rim * (1.0 + H * H) / (2.0 * H)
    rng = np.random.default_rng(0)
    k = np.arange(1500) + 0.5  # even in z: even in area on a sphere (Archimedes); a golden-angle spiral around
    z = R - H * rim * k / 1500
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(R * R - z * z)
    U = np.column_stack([r * np.cos(phi), r * np.sin(phi), z]) / R
    tgt = _target("cap:0.5")
    on = tgt.fit(_turned(R * U), np.array([0.0, 0.0, 1.0]))
    assert on.rms < 2e-3 * rim and abs(on.scale - rim) < 2e-3 * rim
    delta = 0.01 * rim * np.sign(rng.normal(size=1500))
    off = tgt.fit(_turned((R + delta)[:, None] * U), np.array([0.0, 0.0, 1.0]))
    assert np.isclose(off.rms, 0.01 * rim, rtol=0.05)


@pytest.mark.parametrize("target", ["cap:0.6", "revolution:0.4,0.5,0.45"])
def test_open_fit_gradient_is_the_derivative_of_the_refitted_squared_distances(target: str) -> None:
    rng = np.random.default_rng(3)
    tube = target.startswith("revolution")
    n = 800
    if tube:  # a tube of radius 45 and length 100 along z, bulged
        a = rng.uniform(0.0, 100.0, n)
        t = rng.uniform(0.0, 2.0 * math.pi, n)
        rad = 45.0 + 3.0 * np.sin(math.pi * a / 100.0)
        P = np.column_stack([rad * np.cos(t), rad * np.sin(t), a])
    else:  # a dome over a disc of radius 100
        r = 100.0 * np.sqrt(rng.uniform(0.0, 1.0, n))
        t = rng.uniform(0.0, 2.0 * math.pi, n)
        P = np.column_stack([r * np.cos(t), r * np.sin(t), 55.0 * (1.0 - (r / 100.0) ** 2)])
    P = _turned(P + rng.normal(0.0, 0.5, P.shape))
    axis = np.array([0.0, 0.0, 1.0])
    tgt = _target(target)
    fit = tgt.fit(P, axis)
    V = rng.normal(size=P.shape)
    step = 1e-4
    Jp, Jm = (float(np.sum(tgt.fit(P + s * step * V, axis).signed ** 2)) for s in (1.0, -1.0))
    assert np.isclose(float(np.sum(fit.error_gradient * V)), (Jp - Jm) / (2.0 * step), rtol=1e-3)


@pytest.mark.slow
def test_open_design_angle_gradient_matches_full_solves() -> None:
    # the smallest dome: a pentagon and one ring of five hexagons (10 sleeves), meshed at the coarsest h
    from fabpat.assembly.spec.load import parse_spec
    from fabpat.design.angles import angle_gradient, angle_model, design_error, solve_angles

    spec = parse_spec({"tiling": {"kind": "hex-cap", "rings": 1, "centre": 5, "edge": 36.0},
                       "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"}, "plates": {"thickness": 1.0},
                       "sleeve": {"angle": "flat"}}, str(CAP))
    model = angle_model(spec, ["0x0508"] + ["0x0488"] * 5, 7.5)
    tgt, axis = _target("cap:0.6"), np.array([0.0, 0.0, 1.0])
    a = model.angle0 - np.radians(np.linspace(2.0, 6.0, len(model.labels)))  # folded a few degrees more
    run = solve_angles(model, a)
    J, fit = design_error(run, tgt, axis)
    g = angle_gradient(model, a, run, fit)
    v = np.random.default_rng(4).normal(size=len(a))
    v /= np.linalg.norm(v)
    step = 1e-3
    Jp, Jm = (design_error(solve_angles(model, a + s * step * v, run), tgt, axis)[0] for s in (1.0, -1.0))
    fd = (Jp - Jm) / (2.0 * step)
    assert J > 0.0 and abs(fd) > 1e-3 * np.linalg.norm(g)  # a direction the error depends on
    assert abs(g @ v - fd) < 1e-3 * abs(fd), (g @ v, fd)


@pytest.mark.parametrize(("target", "spec", "groups"), [("cap:0.6", CAP, 3), ("revolution:0.45,0.5,0.45", TUBE, 2)])
def test_the_shipped_open_specs_are_planned_with_patterns_and_angles(target: str, spec: Path, groups: int) -> None:
    from fabpat.design.dry_run import dry_run

    plan = dry_run(target, spec, h=6.0)
    # the cap: a pentagon and two rings of hexagons; the tube: its middle column and its two ends (bands about x)
    assert plan["groups"] == groups and plan["vary"] == ["patterns", "angles"]
    assert 0.0 < plan["relative_rms"] < 0.2  # the placed tiling against its fitted target
