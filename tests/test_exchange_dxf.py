"""DXF read back with ezdxf: audit, layers, units, closed loops and enclosed areas.

Areas of bulge polylines are computed here from the bulges (chord polygon + exact circular
segments); splines are evaluated by ezdxf's own NURBS code. Nothing below uses fabpat to read.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fabpat.errors import ExportError
from fabpat.exchange.dxf import write_dxf
from tests.test_cad import BOWTIE_W, SHAPES, bowtie, bowtie_area, hexagon_with_hole, rounded_square

ezdxf = pytest.importorskip("ezdxf")
TOL = 0.01


def bulge_area(points: list[tuple[float, float, float]]) -> float:
    """Signed area of a closed polyline with bulges: shoelace + Σ sign(b) R²/2 (θ − sin θ)."""
    P = np.array([(x, y) for x, y, _ in points])
    b = np.array([bb for _, _, bb in points])
    E = np.roll(P, -1, axis=0)
    area = 0.5 * float(np.sum(P[:, 0] * E[:, 1] - P[:, 1] * E[:, 0]))
    for (s, e, bulge) in zip(P, E, b, strict=True):
        if bulge == 0:
            continue
        theta = 4 * math.atan(abs(bulge))
        R = math.dist(s, e) / (2 * math.sin(theta / 2))
        area += math.copysign(0.5 * R * R * (theta - math.sin(theta)), bulge)
    return area


def cut_loops(doc) -> list[list[tuple[float, float, float]]]:  # noqa: ANN001
    """(x, y, bulge) of every closed polyline on layer CUT (LWPOLYLINE or R12 POLYLINE)."""
    loops = []
    for e in doc.modelspace().query("LWPOLYLINE POLYLINE"):
        assert e.dxf.layer == "CUT" and (e.closed if e.dxftype() == "LWPOLYLINE" else e.is_closed)
        if e.dxftype() == "LWPOLYLINE":
            loops.append([tuple(p) for p in e.get_points("xyb")])
        else:
            loops.append([(v.dxf.location.x, v.dxf.location.y, v.dxf.bulge) for v in e.vertices])
    return loops


def read(path: Path):  # noqa: ANN201
    doc = ezdxf.readfile(path)
    auditor = doc.audit()
    assert not auditor.has_errors, [str(e) for e in auditor.errors]
    assert {"CUT", "ENGRAVE"} <= {layer.dxf.name for layer in doc.layers}
    return doc


@pytest.mark.parametrize("version", ["R2010", "R12"])
@pytest.mark.parametrize("curves", ["arcs", "lines"])
@pytest.mark.parametrize("name", list(SHAPES))
def test_polyline_modes_enclose_the_outline_area(tmp_path: Path, name: str, curves: str, version: str) -> None:
    make, area = SHAPES[name]
    outline = make()
    path = write_dxf(outline, tmp_path / "p.dxf", "0x0488", curves=curves, tolerance=TOL, dxf_version=version)
    doc = read(path)
    assert doc.dxfversion == ("AC1009" if version == "R12" else "AC1024")
    if version == "R2010":
        assert doc.header["$INSUNITS"] == 4  # millimetres
    loops = cut_loops(doc)
    assert len(loops) == len(outline.loops)
    if curves == "lines":
        assert all(b == 0 for lp in loops for _, _, b in lp)
    areas = [bulge_area(lp) for lp in loops]
    assert areas[0] > 0 and all(a < 0 for a in areas[1:])  # outer CCW, holes CW
    # Every point of the written curves lies within TOL of the outline: |ΔA| ≤ perimeter × TOL.
    assert abs(sum(areas) - area()) <= outline.perimeter * TOL
    (text,) = doc.modelspace().query("TEXT")
    assert text.dxf.text == "0x0488" and text.dxf.layer == "ENGRAVE"


def test_circular_corners_are_written_as_exact_arcs(tmp_path: Path) -> None:
    doc = read(write_dxf(rounded_square(), tmp_path / "r.dxf"))
    (loop,) = cut_loops(doc)
    assert len(loop) == 8 and sorted(b for *_, b in loop)[-4:] == pytest.approx([math.tan(math.pi / 8)] * 4)
    assert bulge_area(loop) == pytest.approx(400 - (4 - math.pi) * 9, rel=1e-12)


def test_spline_mode_keeps_control_points_and_weights(tmp_path: Path) -> None:
    outline = bowtie()
    doc = read(write_dxf(outline, tmp_path / "s.dxf", "id", curves="spline"))
    (spline,) = doc.modelspace().query("SPLINE")
    assert spline.dxf.layer == "CUT" and spline.dxf.degree == 2
    ctrl = np.array(spline.control_points)[:, :2]
    weights = np.array(spline.weights)
    assert np.allclose(ctrl[0], ctrl[-1])  # closed loop
    for k, seg in enumerate(outline.outer.segments):  # piece k: control points 2k, 2k+1, 2k+2
        assert np.allclose(ctrl[2 * k], seg.start) and np.allclose(ctrl[2 * k + 2], seg.end)
        assert weights[2 * k + 1] == (seg.w if hasattr(seg, "w") else 1.0)
    assert sorted(set(weights.tolist())) == [BOWTIE_W, 1.0]
    # ezdxf's own NURBS evaluation encloses the exact area.
    pts = np.array([(p.x, p.y) for p in spline.construction_tool().flattening(0.001)])
    x, y = pts.T
    assert 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) == pytest.approx(
        bowtie_area(), abs=outline.perimeter * 0.001
    )


@pytest.mark.parametrize("curves", ["arcs", "lines", "spline"])
def test_kerf_grows_area_by_perimeter_times_half_kerf(tmp_path: Path, curves: str) -> None:
    kerf = 0.2
    outline = hexagon_with_hole()
    doc = read(write_dxf(outline, tmp_path / "k.dxf", curves=curves, kerf=kerf))
    if curves == "spline":
        areas = []
        for s in doc.modelspace().query("SPLINE"):
            x, y = np.array([(p.x, p.y) for p in s.construction_tool().flattening(0.001)]).T
            areas.append(0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
        total = abs(areas[0]) - sum(abs(a) for a in areas[1:])
    else:
        total = sum(bulge_area(lp) for lp in cut_loops(doc))
    d = kerf / 2
    # Outer hexagon: + P_out·d + π d² (six arc joins of radius d); square hole (10 mm) shrinks to
    # (10 − 2d)²: together A + P·d + (π − 4) d², exactly.
    exact = outline.area + outline.perimeter * d + (math.pi - 4) * d * d
    bound = {"arcs": 1e-9, "lines": outline.perimeter * TOL, "spline": outline.perimeter * 0.001}[curves]
    assert total == pytest.approx(exact, abs=bound)


def test_kerf_on_curved_outline(tmp_path: Path) -> None:
    d = 0.05
    doc = read(write_dxf(bowtie(), tmp_path / "b.dxf", kerf=2 * d))
    (loop,) = cut_loops(doc)
    P = bowtie().perimeter
    # ≈ P·d; corners add or remove O(d²) and the arc fit at most P·TOL.
    assert bulge_area(loop) - bowtie_area() == pytest.approx(P * d, abs=P * TOL + 8 * d * d)


def test_label_lies_on_the_material_when_it_fits(tmp_path: Path) -> None:
    from matplotlib.path import Path as MPath

    doc = read(write_dxf(hexagon_with_hole(), tmp_path / "t.dxf", "0x0488"))
    (text,) = doc.modelspace().query("TEXT")
    p = text.dxf.align_point
    P = [(36 * math.cos(k * math.pi / 3), 36 * math.sin(k * math.pi / 3)) for k in range(6)]
    assert MPath(P).contains_point((p.x, p.y)) and max(abs(p.x), abs(p.y)) > 5 + text.dxf.height
    assert 1.0 <= text.dxf.height <= 3.0


@pytest.mark.parametrize(
    "options, words",
    [({"curves": "spline", "dxf_version": "R12"}, "R12"), ({"curves": "bezier"}, "curve mode"),
     ({"kerf": -0.1}, "kerf"), ({"tolerance": 0.0}, "tolerance"), ({"dxf_version": "R13"}, "version")],
)
def test_bad_options_raise_and_write_nothing(tmp_path: Path, options: dict[str, object], words: str) -> None:
    with pytest.raises(ExportError, match=words):
        write_dxf(bowtie(), tmp_path / "x.dxf", **options)
    assert list(tmp_path.iterdir()) == []
