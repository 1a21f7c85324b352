"""SVG read back by svgpathtools (area of the path's subpaths) and the standard XML parser.

The default SVG is read the way cutter software and svgpathtools read it: no transform on the
path, only lines and cubic Béziers (no rotated elliptical arcs), coordinates already in the page's
y-down frame with the part 1 mm from the page's left and bottom edges.
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

from fabpat.exchange.svg import write_svg
from fabpat.geometry.outline import Line
from tests.test_cad import SHAPES, bowtie, hexagon_with_hole

svgpathtools = pytest.importorskip("svgpathtools")
SVG = "{http://www.w3.org/2000/svg}"


def _cross(a: complex, b: complex) -> float:
    return (a.conjugate() * b).imag


def subpath_area(sub) -> float:  # noqa: ANN001 - svgpathtools.Path
    """Exact signed area ∮ (x dy − y dx)/2 of a closed svgpathtools subpath (lines, C, Q, elliptic A).

    A piece of the ellipse c + rot·(rx cos φ, ry sin φ) contributes ½ [c × (end − start) + rx ry Δφ];
    a quadratic Bézier its chord term plus 2/3 of its signed control triangle.
    """
    total = 0.0
    for seg in sub:
        total += 0.5 * _cross(seg.start, seg.end)
        if isinstance(seg, svgpathtools.CubicBezier):
            # x y' − y x' is a polynomial of degree 5: 4-point Gauss–Legendre integrates it exactly.
            x, wq = np.polynomial.legendre.leggauss(4)
            t = 0.5 * (x + 1.0)
            total += 0.25 * sum(w * _cross(seg.point(tt), seg.derivative(tt)) for tt, w in zip(t, wq, strict=True))
            total -= 0.5 * _cross(seg.start, seg.end)
        elif isinstance(seg, svgpathtools.QuadraticBezier):
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


def page_points(outline, n: int = 400) -> list[np.ndarray]:  # noqa: ANN001
    """Exact outline points (rational Bézier formula evaluated here), one polyline per loop, mapped
    to the default SVG page: x' = x − xmin + 1, y' = ymax + 1 − y (1 mm margin, y down)."""
    (lo, hi) = outline.bbox
    out = []
    for lp in outline.loops:
        pts = []
        for seg in lp.segments:
            t = np.linspace(0.0, 1.0, n)[:, None]
            if isinstance(seg, Line):
                pts.append(seg.p0 + t * (seg.p1 - seg.p0))
                continue
            b = np.hstack([(1 - t) ** 2, 2 * t * (1 - t) * seg.w, t**2])
            pts.append(b @ seg.control_points / b.sum(axis=1, keepdims=True))
        P = np.vstack(pts)
        out.append(np.column_stack([P[:, 0] - lo[0] + 1.0, hi[1] + 1.0 - P[:, 1]]))
    return out


def distance_to(samples: np.ndarray, loops: list[np.ndarray]) -> np.ndarray:
    """(m,) distances from complex points to the nearest of the polylines (dense enough to be the curve)."""
    X = np.column_stack([samples.real, samples.imag])
    out = np.full(len(X), np.inf)
    for P in loops:
        A, D = P[:-1], np.diff(P, axis=0)
        L2 = np.maximum((D * D).sum(axis=1), 1e-300)
        for i, x in enumerate(X):
            t = np.clip(((x - A) * D).sum(axis=1) / L2, 0.0, 1.0)
            out[i] = min(out[i], float(np.hypot(*(x - A - t[:, None] * D).T).min()))
    return out


@pytest.mark.parametrize("name", list(SHAPES))
def test_default_svg_is_cubic_without_transform_within_tolerance(tmp_path: Path, name: str) -> None:
    make, area = SHAPES[name]
    outline, tol = make(), 0.01
    root = ElementTree.parse(write_svg(outline, tmp_path / "p.svg", "0x0488", title="fabpat test")).getroot()
    assert not [e for e in root.iter() if e.get("transform")]  # no transform anywhere
    (path,) = root.iter(f"{SVG}path")
    parsed = svgpathtools.parse_path(path.get("d", ""))
    kinds = {type(seg).__name__ for seg in parsed}
    assert kinds <= {"Line", "CubicBezier"}  # no (rotated) elliptical arcs, no quadratics
    assert path_area(path.get("d", "")) == pytest.approx(area(), abs=outline.perimeter * tol)
    # Every point of the written path lies within tol of the exact outline (placed on the page).
    exact = page_points(outline)
    samples = np.array([seg.point(t) for seg in parsed for t in np.linspace(0, 1, 21)])
    assert distance_to(samples, exact).max() <= tol
    # Page: viewBox 0 0 W H in mm, the part 1 mm from the left and bottom edges.
    x0, y0, w, h = (float(v) for v in root.get("viewBox", "").split())
    (lo, hi) = outline.bbox
    assert (x0, y0) == (0.0, 0.0) and w == pytest.approx(hi[0] - lo[0] + 2) and h == pytest.approx(hi[1] - lo[1] + 2)
    assert float(root.get("width", "")[:-2]) == pytest.approx(w) and root.get("height", "").endswith("mm")
    xmin, xmax, ymin, ymax = parsed.bbox()
    assert (xmin, h - ymax) == pytest.approx((1.0, 1.0), abs=tol)
    assert root.find(f"{SVG}title").text == "fabpat test"  # type: ignore[union-attr]


@pytest.mark.parametrize("name", list(SHAPES))
def test_exact_svg_encloses_the_exact_area(tmp_path: Path, name: str) -> None:
    make, area = SHAPES[name]
    outline = make()
    root = ElementTree.parse(write_svg(outline, tmp_path / "p.svg", curves="exact", origin="centre")).getroot()
    x0, y0, w, h = (float(v) for v in root.get("viewBox", "").split())
    (bbox_lo, bbox_hi) = outline.bbox
    assert x0 == pytest.approx(bbox_lo[0] - 1.0) and w == pytest.approx(bbox_hi[0] - bbox_lo[0] + 2.0)
    assert y0 == pytest.approx(-bbox_hi[1] - 1.0)  # centre: the pattern's frame with y negated
    (path,) = root.iter(f"{SVG}path")
    assert path.get("transform") is None and path.get("fill-rule") == "evenodd"
    assert path_area(path.get("d", "")) == pytest.approx(area(), rel=1e-6)


def test_cubic_tolerance_is_honoured(tmp_path: Path) -> None:
    outline = bowtie()
    for tol in (0.01, 0.0001):
        root = ElementTree.parse(write_svg(outline, tmp_path / "b.svg", tolerance=tol)).getroot()
        parsed = svgpathtools.parse_path(next(root.iter(f"{SVG}path")).get("d", ""))
        samples = np.array([seg.point(t) for seg in parsed for t in np.linspace(0, 1, 21)])
        assert distance_to(samples, page_points(outline)).max() <= tol


@pytest.mark.parametrize("curves", ["cubic", "exact"])
def test_svg_with_kerf_and_label(tmp_path: Path, curves: str) -> None:
    outline = hexagon_with_hole()
    root = ElementTree.parse(write_svg(outline, tmp_path / "k.svg", "0x0488", kerf=0.2, curves=curves)).getroot()
    (path,) = root.iter(f"{SVG}path")
    d = 0.1
    exact = outline.area + outline.perimeter * d + (math.pi - 4) * d * d  # see the DXF kerf test
    bound = outline.perimeter * (1e-6 if curves == "exact" else 0.01)  # 1e-6 mm digits / cubic tolerance
    assert path_area(path.get("d", "")) == pytest.approx(exact, abs=bound)
    if curves == "cubic":
        assert {type(s).__name__ for s in svgpathtools.parse_path(path.get("d", ""))} <= {"Line", "CubicBezier"}
    (text,) = root.iter(f"{SVG}text")
    assert text.text == "0x0488" and text.get("text-anchor") in (None, "start")
