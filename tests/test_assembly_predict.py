"""`fabpat assemble` with bent sleeves: the kit predicts the closed sphere and shows it (issue 12, items 3–4).

The closures here run at a coarse mesh (``PREDICT_H``): the point is the kit's files and checks, not
accuracy (the mesh study is in the closure's own tests and benchmarks). The in-process read-outs use the
sphere closure the sphere-closure tests share (tests.helpers.flat_sphere, at the same h).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.helpers import SPHERE_H, flat_sphere, invoke

ROOT = Path(__file__).resolve().parents[1]
SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
RIGID = ROOT / "assemblies" / "truncated-icosahedron-rigid.toml"
PREDICT_H = "6"  # mm: coarse (the interface segment is 3.75 mm; ≤ 7.5 mm is allowed)
assert float(PREDICT_H) == SPHERE_H  # the closed fixture is the shared closure at this h
FIELDS = ["converged", "plates", "sleeves", "nodes", "dofs", "iterations", "seconds", "energy", "plate_energies",
          "sleeve_moments", "reaction", "max_deflection", "radius", "sphericity_rms", "sphericity_max",
          "peak_strain", "peak_strain_plate", "strain_limit", "over_limit", "h", "path"]


def variant(tmp: Path, name: str, formats: list[str] | None = None, strain_limit: float | None = None) -> Path:
    """A copy of the shipped sphere spec with other output formats and/or material.strain_limit."""
    text = SPHERE.read_text()
    if formats is not None:
        text = re.sub(r"(?m)^formats = .*$", "formats = " + json.dumps(formats), text)
    if strain_limit is not None:
        if re.search(r"(?m)^strain_limit\s*=", text):
            text = re.sub(r"(?m)^strain_limit\s*=.*$", f"strain_limit = {strain_limit!r}", text)
        elif "[material]" in text:
            text = text.replace("[material]\n", f"[material]\nstrain_limit = {strain_limit!r}\n")
        else:
            text += f"\n[material]\nstrain_limit = {strain_limit!r}\n"
    path = tmp / name
    path.write_text(text)
    return path


#: the kit's files are tested under a limit far from the shipped plates' peak strain (≈ 1.5 % at 1 mm, the
#: shipped 2 % limit), so the kit tests do not depend on it; the refusal has its own test below
LOOSE = 0.05


@pytest.fixture(scope="module")
def kit(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("sphere")
    out = tmp / "kit"
    spec = variant(tmp, "sphere.toml", strain_limit=LOOSE)
    r = invoke("assemble", str(spec), "--out", str(out), "--no-progress", "--predict-h", PREDICT_H)
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="module")
def closed():  # type: ignore[no-untyped-def]
    """The shipped sphere's plan and its closure at PREDICT_H, in-process: the ClosureRun of the shared
    simulate_assembly closure (closure_setup and run_closure of the plan's face patterns, in one report step: the
    read-outs here are of the final state)."""
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.spec.load import load_spec

    spec = load_spec(SPHERE)
    asm, filleted = plan(spec)  # the shipped strain limit: the read-outs here do not depend on it
    run = flat_sphere().run
    assert [p.label for p in asm.plates] == [p.label for p in run.setup.model.plates]  # the plan's plates
    return spec, asm, filleted, run


@pytest.mark.slow
def test_prediction_json(kit: Path) -> None:
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.spec.load import load_spec

    rec = json.loads((kit / "prediction.json").read_text())
    assert set(FIELDS) <= set(rec) and rec["peak"] is None and rec["half_ratio"] is None  # simulate-assembly's
    assert rec["converged"] is True and rec["plates"] == 32 and rec["sleeves"] == 90 and rec["h"] == float(PREDICT_H)
    skel = plan(load_spec(SPHERE))[0].skeleton
    c = skel.V.mean(axis=0)
    circum = float(np.linalg.norm(skel.V - c, axis=1).max())
    inr = min(float(abs((skel.centroids[f] - c) @ skel.normals[f])) for f in range(len(skel.faces)))
    assert inr < rec["radius"] < circum, (inr, rec["radius"], circum)
    assert 0 < rec["sphericity_rms"] <= rec["sphericity_max"] < 0.05
    assert rec["energy"] > 0 and math.isclose(sum(rec["plate_energies"].values()), rec["energy"], rel_tol=1e-9)
    assert len(rec["sleeve_moments"]) == 90 and min(rec["sleeve_moments"].values()) > 0
    assert 0 < rec["peak_strain"] <= rec["strain_limit"] == LOOSE and rec["over_limit"] == []
    assert rec["path"][-1]["angle_fraction"] == pytest.approx(1.0)
    manifest = json.loads((kit / "manifest.json").read_text())
    assert manifest["prediction"] == "prediction.json"
    assert {"prediction.json", "predicted.stl", "parts.step", "parts.3dm", "assembly.glb", "assembly.png"} <= set(
        manifest["files"])
    assert "assembly.step" not in manifest["files"] and "assembly.3dm" not in manifest["files"]
    assert any("sleeves grip the deformed plates" in line for line in manifest["checks"])


def test_glb_shows_the_predicted_sphere(kit: Path) -> None:
    import trimesh

    sc = trimesh.load(kit / "assembly.glb")
    nodes = sc.graph.nodes_geometry
    plates = [n for n in nodes if re.fullmatch(r"[HP]\d+", n)]
    sleeves = [n for n in nodes if re.fullmatch(r"E\d+", n)]
    assert len(plates) == 32 and len(sleeves) == 90 and len(nodes) == 122
    lo, hi = sc.metadata["density_range"]
    assert lo == 0 and hi > 0 and sc.metadata["density_unit"] == "N·mm/mm²"
    rec = json.loads((kit / "prediction.json").read_text())
    # the plates' vertices (metres) lie on the predicted sphere within its largest radial deviation (+ t/2)
    P = np.vstack([sc.dump()[i].vertices for i, n in enumerate(nodes) if n in plates]) * 1000.0
    from fabpat.assembly.solve.closure import fit_sphere

    _, r = fit_sphere(P)
    assert r == pytest.approx(rec["radius"], rel=0.02)
    colours = np.vstack([g.visual.vertex_colors for name, g in sc.geometry.items() if re.fullmatch(r"[HP]\d+", name)])
    assert len(np.unique(colours[:, :3], axis=0)) > 20  # a colour map, not one colour


def test_png_of_the_prediction(kit: Path) -> None:
    import matplotlib.image as mpimg

    img = mpimg.imread(kit / "assembly.png")
    assert img.shape[0] > 400 and img.shape[1] > 400 and np.ptp(img[..., :3]) > 0.5


def test_predicted_stl_is_closed(kit: Path) -> None:
    import trimesh

    m = trimesh.load(kit / "predicted.stl")
    parts = m.split(only_watertight=False)
    assert len(parts) == 122 and all(p.is_watertight for p in parts)
    if shutil.which("admesh"):
        out = subprocess.run(["admesh", str(kit / "predicted.stl")], capture_output=True, text=True, timeout=120)
        text = out.stdout
        assert re.search(r"Number of parts\s*:\s*122", text), text
        for what in ("Edges fixed", "Facets removed", "Facets added", "Facets reversed", "Backwards edges"):
            assert re.search(rf"{what}\s*:\s*0\b", text), (what, text)


def test_parts_step_holds_the_flat_parts(kit: Path) -> None:
    from fabpat.assembly.show.export import read_step_tree

    _, rows, solids = read_step_tree(kit / "parts.step")
    assert solids == len(rows) == len(json.loads((kit / "manifest.json").read_text())["counts"])
    names = {row[1] for row in rows}
    assert "20x hex 0x0488" in names and "12x pent 0x0508" in names and "90x S-flat" in names
    assert "RATIONAL_B_SPLINE_CURVE" in (kit / "parts.step").read_text(errors="replace")


def test_parts_3dm_lays_the_flat_parts_out(kit: Path) -> None:
    r3 = pytest.importorskip("rhino3dm", reason="rhino3dm (PyPI) is needed to read .3dm files back")
    model = r3.File3dm.Read(str(kit / "parts.3dm"))
    refs = [o for o in model.Objects if isinstance(o.Geometry, r3.InstanceReference)]
    counts = json.loads((kit / "manifest.json").read_text())["counts"]
    assert sorted(o.Attributes.Name for o in refs) == sorted(f"{n}x" for n in counts.values())
    xs = sorted(o.Geometry.Xform.M03 for o in refs)  # side by side along x, at least 10 mm apart
    assert all(b - a > 10.0 for a, b in zip(xs, xs[1:], strict=False))


def test_bom_lists_the_straight_sleeves(kit: Path) -> None:
    import csv

    rows = list(csv.DictReader((kit / "bom.csv").open()))
    sleeves = [r for r in rows if r["kind"] == "sleeve"]
    assert [(r["part"], r["count"]) for r in sleeves] == [("S-flat", "90")]


@pytest.mark.slow
def test_sleeves_sit_on_the_deformed_joints(closed) -> None:  # type: ignore[no-untyped-def]
    """The printed (straight) sleeve placed by its master node's pose holds both plates' deformed
    interface nodes on its slots' mid-planes; the sleeve at the joint's dihedral does not."""
    from fabpat.assembly.solve.preview import joint_fit, sleeve_poses

    spec, asm, _, run = closed
    kinds = [s.kind for s in asm.sleeves]
    assert {asm.sleeve_types[k].dihedral for k in kinds} == {math.pi}
    plane, outside = joint_fit(run, asm.sleeve_types, kinds)
    assert plane < 1e-9 and outside == 0.0
    # control: a sleeve printed at each joint's dihedral angle does not fit the bent joint
    from fabpat.assembly.surface.joints import required_setback

    flat = asm.sleeve_types[kinds[0]]
    need = max(required_setback(s.dihedral, flat.thickness, flat.clearance, flat.wall) for s in asm.sleeves)
    wrong = {s.label: replace(flat, dihedral=s.dihedral, setback=max(flat.setback, need)) for s in asm.sleeves}
    plane_wrong, _ = joint_fit(run, wrong, [s.label for s in asm.sleeves])
    assert plane_wrong > 0.3
    # the pose is a rotation, and the sleeves moved with the sphere (not left on the polyhedron)
    poses = sleeve_poses(run)
    for T in poses:
        assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)
    moved = max(float(np.linalg.norm(T[:3, 3] - s.transform[:3, 3])) for T, s in zip(poses, asm.sleeves, strict=True))
    assert moved > 0.5


def test_energy_density_colours(closed) -> None:  # type: ignore[no-untyped-def]
    from fabpat.assembly.solve.preview import predicted_shape

    _, asm, _, run = closed
    shape = predicted_shape(run, asm)
    m = run.setup.model
    P = m.X[m.F]
    area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    dens = np.concatenate([pl.density for pl in shape.plates])
    assert float((dens * area).sum()) == pytest.approx(run.energy, rel=1e-9)
    assert shape.density_range[1] == pytest.approx(max(float(pl.vertex_density.max()) for pl in shape.plates))
    for pl in shape.plates:
        assert np.allclose(np.linalg.norm(pl.N, axis=1), 1.0)


def test_thickened_mid_surface_is_a_closed_solid() -> None:
    import trimesh

    from fabpat.assembly.solve.preview import thickened

    V = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0], [1, 0.5, 0]], dtype=float)
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    N = np.tile([0.0, 0.0, 1.0], (5, 1))
    W, G = thickened(V, F, N, 0.5)
    m = trimesh.Trimesh(W, G, process=False)
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(2.0 * 0.5)  # outward: positive volume = area × t


@pytest.mark.slow
def test_refuses_a_kit_over_the_strain_limit(tmp_path: Path) -> None:
    spec = variant(tmp_path, "tight.toml", formats=["bom"], strain_limit=1e-4)
    out = tmp_path / "kit"
    r = run_cli("assemble", str(spec), "--out", str(out), "--no-progress", "--predict-h", PREDICT_H)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fabpat: error: "), r.stderr
    assert "strain_limit = 0.0001" in lines[0] and "--force" in lines[0] and re.search(r"plate [HP]\d+", lines[0])
    assert not out.exists() and sorted(os.listdir(tmp_path)) == ["tight.toml"]

    # the refusal above is the real process's exit code and stderr; the forced build's output is the same
    # command's logic, run in-process (no second interpreter start)
    from click.testing import CliRunner

    from fabpat.cli import cli

    res = CliRunner().invoke(cli, ["assemble", str(spec), "--out", str(out), "--no-progress", "--predict-h",
                                   PREDICT_H, "--force"])
    assert res.exit_code == 0, res.stderr
    warnings = [line for line in res.stderr.splitlines() if line.startswith("fabpat: warning: plate ")]
    manifest = json.loads((out / "manifest.json").read_text())
    rec = json.loads((out / "prediction.json").read_text())
    assert len(warnings) == len(rec["over_limit"]) == len(manifest["warnings"]) > 0
    assert all("exceeds material.strain_limit = 0.0001" in w for w in manifest["warnings"])


def test_no_predict(tmp_path: Path) -> None:
    """predict = False (--no-predict): no shape file, and the kit says the strain limit was not checked
    (in-process: the option's logic; the flag itself is given in the CLI kits of test_assembly_mesh and others)."""
    from fabpat.assembly.kit.build import assemble

    spec = variant(tmp_path, "quick.toml", formats=["step", "glb", "png", "bom"])
    out = tmp_path / "kit"
    res = assemble(spec, out, predict=False)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["prediction"] == "skipped (--no-predict)"
    assert "no file shows the assembled shape" in manifest["shape"]
    assert not (out / "prediction.json").exists() and not (out / "assembly.glb").exists()
    assert sorted(manifest["files"]) == ["bom.csv", "bom.md", "parts.step"]
    # the strain limit was not checked, and the kit says so (merged: this was its own test on a second build)
    assert any("strain_limit" in w and "not checked" in w for w in res.warnings)
    assert any("not checked" in w for w in manifest["warnings"])


def test_rigid_spec_needs_no_prediction(tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import assemble

    out = tmp_path / "kit"
    text = re.sub(r"(?m)^formats = .*$", 'formats = ["glb", "bom"]', RIGID.read_text())
    spec = tmp_path / "rigid.toml"
    spec.write_text(text)
    assemble(spec, out)  # in-process: the kit's logic (the CLI runs the same function)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["prediction"].startswith("not needed: the sleeves are at the dihedral angles")
    assert not (out / "prediction.json").exists() and "shape" not in manifest
    assert sorted(manifest["files"]) == ["assembly.glb", "bom.csv", "bom.md"]


def test_steps_name_the_prediction() -> None:
    from fabpat.assembly.kit.build import steps
    from fabpat.assembly.spec.load import load_spec

    assert "prediction" in steps(load_spec(SPHERE))
    assert "prediction" not in steps(load_spec(SPHERE), predict=False)
    assert "prediction" not in steps(load_spec(RIGID))
    strip = load_spec(ROOT / "assemblies" / "graded-strip.toml")  # pushed together by its pins: predicted too
    assert "prediction" in steps(strip) and "prediction" not in steps(strip, predict=False)


# -- rule = "roundest" -----------------------------------------------------------------------------------

ENERGIES = {6: {"0x0488": 1.0, "0x0508": 1.2, "0x0588": 5.0}, 5: {"0x0508": 1.05, "0x0488": 1.3}}


def roundest_spec(strain_limit: float, angle: str = "flat"):  # type: ignore[no-untyped-def]
    import tomllib

    from fabpat.assembly.spec.load import parse_spec

    data = tomllib.loads(SPHERE.read_text())
    data["patterns"] = {"rule": "roundest", "candidates": 2}
    data["plates"]["thickness"] = 2.0  # the paper's plates: their peak strains (≈ 2.4 %, 3.0 %) straddle 2.7 %
    data["material"]["strain_limit"] = strain_limit
    data["sleeve"]["angle"] = angle
    data["output"]["formats"] = ["bom"]
    return parse_spec(data, "round.toml")


@pytest.mark.slow
def test_roundest_keeps_the_roundest_pair_under_the_strain_limit(tmp_path: Path) -> None:
    """Two candidate pairs closed; the limit (2.7 %) lies between their peak strains (≈ 2.4 % and ≈ 3.0 % at
    this h), so the rounder pair is refused for its strain and the other one is built."""
    from fabpat.assembly.kit.build import assemble, steps

    spec = roundest_spec(0.027)
    seen: list[str] = []
    res = assemble(spec, tmp_path / "kit", progress=seen.append, energies=lambda n: ENERGIES[n],
                   predict_h=float(PREDICT_H))
    assert seen == steps(spec)[:len(seen)] and seen[:2] == ["patterns", "prediction"]
    manifest = json.loads((tmp_path / "kit" / "manifest.json").read_text())
    tried = manifest["candidates"]
    assert len(tried) == 2 and sum(c["chosen"] for c in tried) == 1
    kept = next(c for c in tried if c["chosen"])
    under = [c for c in tried if c["plates_over_limit"] == 0]
    assert kept == min(under, key=lambda c: c["sphericity_rms"])
    assert any(c["plates_over_limit"] > 0 and c["sphericity_rms"] < kept["sphericity_rms"] for c in tried)
    assert manifest["counts"] == {f"hex {kept['hexagon']}": 20, f"pent {kept['pentagon']}": 12, "S-flat": 90}
    rec = json.loads((tmp_path / "kit" / "prediction.json").read_text())
    assert rec["radius"] == kept["radius"] and res.prediction is not None and res.prediction["over_limit"] == []
    assert "## Pattern pairs tried (rule = roundest)" in (tmp_path / "kit" / "bom.md").read_text()


@pytest.mark.parametrize("case", ["no-predict", "dihedral"])
def test_roundest_needs_the_prediction(case: str, tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import assemble
    from fabpat.errors import SpecError

    spec = roundest_spec(0.05, "dihedral" if case == "dihedral" else "flat")
    with pytest.raises(SpecError, match="roundest") as e:
        assemble(spec, tmp_path / "kit", energies=lambda n: ENERGIES[n], predict=case != "no-predict")
    assert "\n" not in str(e.value) and not (tmp_path / "kit").exists()


def test_simulation_png_fields(closed, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """``fabpat simulate-assembly --png`` on a closed spec (AssemblySimulation.to_png): every field draws,
    and an unknown one is refused."""
    import matplotlib.image as mpimg

    from fabpat.assembly.solve.simulation import PNG_FIELDS, AssemblySimulation
    from fabpat.errors import SpecError
    from fabpat.shell.curvature import curvature_fields

    spec, _, _, run = closed
    m = run.setup.model
    n = len(m.X)
    curv = curvature_fields(run.x[:n], m.F, m.plate_of_node[:n], center=run.centre)
    sim = AssemblySimulation(spec.tiling.kind, spec.name, m, run, 1.0, run.element_strain, curv, 0.02,
                             float(PREDICT_H))
    images = {}
    for field in PNG_FIELDS:
        sim.to_png(tmp_path / f"{field}.png", field)
        images[field] = mpimg.imread(tmp_path / f"{field}.png")[..., :3]
        assert np.ptp(images[field]) > 0.5
    assert not np.array_equal(images["energy"], images["mean_curvature"])  # the field changes the colours
    with pytest.raises(SpecError, match="png field"):
        sim.to_png(tmp_path / "x.png", "pressure")


def test_too_coarse_predict_h_is_refused_up_front(tmp_path: Path) -> None:
    out = tmp_path / "kit"
    r = invoke("assemble", str(SPHERE), "--out", str(out), "--no-progress", "--predict-h", "8")
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "--predict-h" in lines[0] and "h ≤ 7.5 mm" in lines[0], r.stderr
    assert not out.exists()


def test_default_predict_h_fits_the_interfaces() -> None:
    """3 mm on the shipped 36 mm plates; on 12 mm plates the interface segment is 2·12/16/1.2 = 1.25 mm, so
    the default drops to the largest h the mesher allows there, 2 × 1.25 mm."""
    from fabpat.assembly.kit.build import default_predict_h
    from fabpat.assembly.spec.load import load_spec

    spec = load_spec(SPHERE)
    assert default_predict_h(spec) == 3.0
    assert default_predict_h(replace(spec, tiling=replace(spec.tiling, edge=12.0))) == pytest.approx(2.5)


# -- found by a hostile pass: arguments, the whole-assembly mesh bound, the unchecked strain limit ------


@pytest.mark.parametrize("kwargs", [{"predict": "yes"}, {"predict": None}, {"force": "no"}, {"force": 1},
                                    {"predict": False, "predict_h": 2.0}, {"predict_h": float("nan")}])
def test_assemble_arguments_are_checked_first(kwargs: dict, tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import assemble
    from fabpat.errors import FabpatError

    spec = Path(__file__).resolve().parents[1] / "assemblies" / "truncated-icosahedron.toml"
    with pytest.raises(FabpatError) as err:
        assemble(spec, tmp_path / "kit", **kwargs)
    assert "\n" not in str(err.value) and not (tmp_path / "kit").exists()


@pytest.mark.parametrize("spec, out", [(123, "kit"), (None, "kit"), ("SPEC", None), ("SPEC", 123)])
def test_assemble_spec_and_out_types(spec: object, out: object, tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import assemble
    from fabpat.errors import SpecError

    path = str(Path(__file__).resolve().parents[1] / "assemblies" / "truncated-icosahedron.toml")
    with pytest.raises(SpecError):
        assemble(path if spec == "SPEC" else spec, tmp_path / out if isinstance(out, str) else out)


@pytest.mark.slow
def test_a_fine_prediction_mesh_is_refused_before_it_fills_memory(tmp_path: Path) -> None:
    """--predict-h 0.5 meshed the 32 plates into ~210 000 triangles and reached 7.5 GB before it was
    killed; it is refused with the h that passes, naming --predict-h, and no folder is written."""
    spec = Path(__file__).resolve().parents[1] / "assemblies" / "truncated-icosahedron.toml"
    r = run_cli("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress", "--predict-h", "0.5")
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "--predict-h ≥" in r.stderr and "whole assembly" in r.stderr and not (tmp_path / "kit").exists()


def test_a_closed_simulation_reprs_in_one_line(closed) -> None:  # type: ignore[no-untyped-def]
    """The sphere's AssemblySimulation printed over 25 000 lines (every array); now one short line."""
    from fabpat.assembly.solve.simulation import AssemblySimulation

    spec, _, _, run = closed
    sim = AssemblySimulation("truncated-icosahedron", spec.name, run.setup.model, run, 1.0, run.element_strain, {},
                             spec.material.strain_limit, float(PREDICT_H))
    text = repr(sim)
    assert "\n" not in text and len(text) < 300, text
    assert "plates=32, sleeves=90" in text and f"radius={run.radius:.2f} mm" in text
    assert f"sphericity_rms={100 * run.sphericity_rms:.3f} %" in text
    html = sim._repr_html_()
    assert html.count("<tr>") == sum(not isinstance(v, dict | list) for v in sim.fields().values()) < 40
