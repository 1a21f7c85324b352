"""Rhino .3dm: exact rational NURBS outlines, a closed plate extrusion, assembly blocks — read back with rhino3dm."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fabpat.geometry.fillet import fillet_pattern
from fabpat.patterns.library import get_pattern
from tests.conftest import run_cli

r3 = pytest.importorskip("rhino3dm", reason="rhino3dm (PyPI) is needed to read .3dm files back")

ROOT = Path(__file__).resolve().parents[1]


def _layers(model: object) -> dict[str, int]:
    return {layer.Name: layer.Index for layer in model.Layers}  # type: ignore[attr-defined]


def _on_layer(model: object, index: int) -> list[object]:
    return [o.Geometry for o in model.Objects if o.Attributes.LayerIndex == index]  # type: ignore[attr-defined]


def _span_weights(curve: object) -> list[float]:
    """Middle weight of every Bézier span, in standard form w1 / √(w0 w2) (openNURBS reads back homogeneous)."""
    W = [curve.Points[i].W for i in range(len(curve.Points))]  # type: ignore[attr-defined]
    return [W[2 * k + 1] / math.sqrt(W[2 * k] * W[2 * k + 2]) for k in range((len(W) - 1) // 2)]


def _sampled_area(curves: list[object], n: int) -> float:
    """Signed area by the shoelace sum over n openNURBS evaluations per span (independent of fabpat)."""
    total = 0.0
    for c in curves:
        spans = c.SpanCount  # type: ignore[attr-defined]
        ts = np.concatenate([np.linspace(j, j + 1, n, endpoint=False) for j in range(spans)])
        P = np.array([(p.X, p.Y) for p in (c.PointAt(float(t)) for t in ts)])  # type: ignore[attr-defined]
        x, y = P[:, 0], P[:, 1]
        total += 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    return total


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, object]:
    path = tmp_path_factory.mktemp("rhino") / "p.3dm"
    r = run_cli("export", "0x0688", "--weight", "0.35", "--thickness", "3", "--3dm", str(path))
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == f"wrote {path}"
    model = r3.File3dm.Read(str(path))
    assert model is not None
    filleted = fillet_pattern(get_pattern("0x0688", 6, 2, 36.0), 0.35)
    return model, filleted


def test_layers_units_and_curve_count(exported: tuple[object, object]) -> None:
    model, fp = exported
    layers = _layers(model)
    assert set(layers) == {"CUT", "PLATE", "INTERFACE"}
    assert model.Settings.ModelUnitSystem == r3.UnitSystem.Millimeters  # type: ignore[attr-defined]
    cut = _on_layer(model, layers["CUT"])
    assert len(cut) == 1 + len(fp.outline.holes) == 2  # 0x0688: one outer loop, one hole
    for i, c in enumerate(cut):
        assert isinstance(c, r3.NurbsCurve)
        assert c.Degree == 2 and c.IsRational and c.IsClosed and c.IsValid
        assert c.SpanCount == len(fp.outline.loops[i].segments)
    orientation = [c.ClosedCurveOrientation() for c in cut]
    assert orientation == [r3.CurveOrientation.CounterClockwise, r3.CurveOrientation.Clockwise]


def test_interface_weight_is_kept(exported: tuple[object, object]) -> None:
    model, _ = exported
    layers = _layers(model)
    w = 0.35
    half = math.sqrt((1 + w) / 2)  # the half bow-tie arc in standard form (fabpat.geometry.fillet, split at t = ½)
    weights = [x for c in _on_layer(model, layers["CUT"]) for x in _span_weights(c)]
    interface = [x for x in weights if abs(x - 1.0) > 1e-12]
    # lines and interior arcs have weight 1; each of the 6 interfaces contributes two half arcs
    assert len(interface) == 12
    assert max(abs(x - half) for x in interface) < 1e-12
    assert all(abs(2 * x * x - 1 - w) < 1e-12 for x in interface)  # w recovered from the file's weights
    full = _on_layer(model, layers["INTERFACE"])
    assert len(full) == 12 and not model.Layers[layers["INTERFACE"]].Visible  # type: ignore[attr-defined]
    for c in full:
        assert c.Degree == 2 and c.IsRational
        assert [round(c.Points[i].W, 12) for i in range(3)] == [1.0, w, 1.0]


def test_area_from_the_nurbs_data(exported: tuple[object, object]) -> None:
    model, fp = exported
    cut = _on_layer(model, _layers(model)["CUT"])
    exact = fp.outline.area  # closed-form area of fabpat's rational outline (mm²)
    a1, a2 = _sampled_area(cut, 200), _sampled_area(cut, 400)
    # A polygon inscribed in a piecewise-smooth curve, sampled uniformly per span with the joints as
    # samples, misses the area by C/n² + O(n⁻⁴): doubling n must quarter the error, and Richardson's
    # (4·a2 − a1)/3 must remove it. A wrong weight or control point changes the area by ≫ 1e-3 mm².
    assert abs(a2 - exact) < 1e-3
    assert 3.9 < (a1 - exact) / (a2 - exact) < 4.1
    assert abs((4 * a2 - a1) / 3 - exact) < 1e-7


def test_plate_is_a_closed_extrusion(exported: tuple[object, object]) -> None:
    model, fp = exported
    (plate,) = _on_layer(model, _layers(model)["PLATE"])
    assert isinstance(plate, r3.Extrusion)
    assert plate.IsSolid and plate.IsCappedAtTop and plate.IsCappedAtBottom
    assert plate.ProfileCount == 1 + len(fp.outline.holes)
    bb = plate.GetBoundingBox()
    lo, hi = fp.outline.bbox
    assert (bb.Min.Z, bb.Max.Z) == pytest.approx((0.0, 3.0), abs=1e-12)
    assert (bb.Min.X, bb.Min.Y, bb.Max.X, bb.Max.Y) == pytest.approx((lo[0], lo[1], hi[0], hi[1]), abs=1e-6)
    brep = plate.ToBrep(True)  # what Rhino makes of it when the user explodes or booleans it
    assert brep.IsSolid and brep.IsManifold


def test_bad_path_leaves_nothing(tmp_path: Path) -> None:
    r = run_cli("export", "0x0688", "--3dm", str(tmp_path / "missing" / "p.3dm"))
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and r.stderr.startswith("fabpat: error:")
    assert not (tmp_path / "missing").exists()


def test_assembly_layers_blocks_and_instances(tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import assemble, plan
    from fabpat.assembly.spec.load import load_spec

    spec_text = (ROOT / "assemblies" / "test-small.toml").read_text() + '\n[output]\nformats = ["3dm"]\n'
    spec_path = tmp_path / "small-3dm.toml"
    spec_path.write_text(spec_text)
    result = assemble(spec_path, tmp_path / "kit", predict=False)  # the 3dm only: no predicted shape
    assert result.files == ("assembly.3dm", "manifest.json")
    model = r3.File3dm.Read(str(tmp_path / "kit" / "assembly.3dm"))

    assembly, _ = plan(load_spec(spec_path))
    placed = [(p.label, p.type.label, p.transform) for p in assembly.plates]
    placed += [(s.label, s.kind, s.transform) for s in assembly.sleeves]
    keys = [pt.label for pt in assembly.plate_types] + list(assembly.sleeve_types)
    assert len(keys) == 3 + len(assembly.sleeve_types) and len(placed) == 3 + 2  # 1 × 3 strip: 3 plates, 2 sleeves

    layers = _layers(model)
    assert set(layers) == set(keys)  # a layer per part type
    blocks = {d.Id: d for d in model.InstanceDefinitions}
    assert sorted(d.Description for d in blocks.values()) == sorted(keys)  # a block per part type
    refs = [o for o in model.Objects if isinstance(o.Geometry, r3.InstanceReference)]
    assert len(refs) == len(placed)
    by_label = {o.Attributes.Name: o for o in refs}
    for label, key, T in placed:
        o = by_label[label]
        assert o.Attributes.LayerIndex == layers[key]
        assert blocks[o.Geometry.ParentIdefId].Description == key
        X = o.Geometry.Xform
        M = np.array([[getattr(X, f"M{i}{j}") for j in range(4)] for i in range(4)])
        assert np.allclose(M, T, atol=1e-12)
    # a plate block holds the exact extrusion and its rational outline curves
    plate_key = assembly.plate_types[0].label
    block = next(d for d in blocks.values() if d.Description == plate_key)
    members = [model.Objects.FindId(i).Geometry for i in block.GetObjectIds()]
    assert sum(isinstance(g, r3.Extrusion) and g.IsSolid for g in members) == 1
    curves = [g for g in members if isinstance(g, r3.NurbsCurve)]
    assert curves and all(c.Degree == 2 and c.IsRational and c.IsClosed for c in curves)
    sleeve_key = next(iter(assembly.sleeve_types))
    block = next(d for d in blocks.values() if d.Description == sleeve_key)
    (mesh,) = [model.Objects.FindId(i).Geometry for i in block.GetObjectIds()]
    assert isinstance(mesh, r3.Mesh) and mesh.IsClosed and len(mesh.Faces) > 0
