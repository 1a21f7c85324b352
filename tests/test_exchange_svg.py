"""SVG read back by svgpathtools (area of the path's subpaths) and the standard XML parser."""

from __future__ import annotations

import math
from pathlib import Path
from xml.etree import ElementTree

import pytest

from fabpat.exchange.svg import write_svg
from tests.test_cad import SHAPES, hexagon_with_hole

svgpathtools = pytest.importorskip("svgpathtools")
SVG = "{http://www.w3.org/2000/svg}"


def _cross(a: complex, b: complex) -> float:
    return (a.conjugate() * b).imag


def subpath_area(sub) -> float:  # noqa: ANN001 - svgpathtools.Path
    """Exact signed area ∮ (x dy − y dx)/2 of a closed svgpathtools subpath (lines, Q, elliptic A).

    A piece of the ellipse c + rot·(rx cos φ, ry sin φ) contributes ½ [c × (end − start) + rx ry Δφ];
    a quadratic Bézier its chord term plus 2/3 of its signed control triangle.
    """
    total = 0.0
    for seg in sub:
        total += 0.5 * _cross(seg.start, seg.end)
        if isinstance(seg, svgpathtools.QuadraticBezier):
            total += _cross(seg.control - seg.start, seg.end - seg.start) / 3.0
        elif isinstance(seg, svgpathtools.Arc):
            chord_term = 0.5 * _cross(seg.start, seg.end)
            total += 0.5 * (_cross(seg.center, seg.end - seg.start) + seg.radius.real * seg.radius.imag
                            * math.radians(seg.delta)) - chord_term
        else:
            assert isinstance(seg, svgpathtools.Line)
    return total


def path_area(d: str) -> float:
    """Solid area of an even-odd path: |outer| − Σ |holes| (largest subpath is the outer loop)."""
    subs = svgpathtools.parse_path(d).continuous_subpaths()
    areas = sorted((abs(subpath_area(sub)) for sub in subs), reverse=True)
    return areas[0] - sum(areas[1:])


@pytest.mark.parametrize("name", list(SHAPES))
def test_svg_path_encloses_the_exact_area(tmp_path: Path, name: str) -> None:
    make, area = SHAPES[name]
    outline = make()
    root = ElementTree.parse(write_svg(outline, tmp_path / "p.svg", title="fabpat test")).getroot()
    assert root.get("width", "").endswith("mm") and root.get("height", "").endswith("mm")
    x0, y0, w, h = (float(v) for v in root.get("viewBox", "").split())
    assert float(root.get("width", "")[:-2]) == pytest.approx(w)  # 1 user unit = 1 mm
    (bbox_lo, bbox_hi) = outline.bbox
    assert x0 == pytest.approx(bbox_lo[0] - 1.0) and w == pytest.approx(bbox_hi[0] - bbox_lo[0] + 2.0)
    (path,) = root.iter(f"{SVG}path")
    assert path.get("transform") == "scale(1,-1)" and path.get("fill-rule") == "evenodd"
    assert path_area(path.get("d", "")) == pytest.approx(area(), rel=1e-6)
    assert root.find(f"{SVG}title").text == "fabpat test"  # type: ignore[union-attr]


def test_svg_with_kerf_and_label(tmp_path: Path) -> None:
    outline = hexagon_with_hole()
    root = ElementTree.parse(write_svg(outline, tmp_path / "k.svg", "0x0488", kerf=0.2)).getroot()
    (path,) = root.iter(f"{SVG}path")
    d = 0.1
    exact = outline.area + outline.perimeter * d + (math.pi - 4) * d * d  # see the DXF kerf test
    assert path_area(path.get("d", "")) == pytest.approx(exact, abs=outline.perimeter * 1e-6)  # 1e-6 mm digits
    (text,) = root.iter(f"{SVG}text")
    assert text.text == "0x0488"
