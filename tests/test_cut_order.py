"""Cut order: laser software cuts in file order, so every part's holes come before its outline.

Each file is read back in order (ezdxf for DXF, the path data's ``M`` commands for SVG) and every
loop is told apart by where it starts: on the pattern's outer loop or on a hole. Nothing here uses
fabpat to read.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import fabpat
from fabpat.exchange.dxf import write_dxf
from fabpat.exchange.svg import svg_document

ezdxf = pytest.importorskip("ezdxf")


@pytest.fixture(scope="module")
def outline():  # noqa: ANN201
    o = fabpat.pattern("0x0488").fillet(weight=0.2).outline
    assert len(o.holes) == 1  # one hole and one outline: the order is the question
    return o


def on_outer(outline, p: np.ndarray) -> bool:  # noqa: ANN001
    """True when ``p`` (2,) mm lies on the outer loop, False on a hole (none lies on both)."""
    d = [float(np.min(np.linalg.norm(P - p, axis=1))) for P in outline.flatten(0.001)]
    assert min(d) < 0.5, f"{p} is on no loop"  # kerf offsets and arc ends: within 0.5 mm
    return int(np.argmin(d)) == 0


def dxf_starts(path: Path) -> list[np.ndarray]:
    """The first point of every CUT entity, in file order."""
    out = []
    for e in ezdxf.readfile(path).modelspace().query("*[layer=='CUT']"):
        kind = e.dxftype()
        if kind == "LWPOLYLINE":
            out.append(np.array(e.get_points("xy")[0]))
        elif kind == "LINE":
            out.append(np.array(e.dxf.start)[:2])
        elif kind == "ARC":
            out.append(np.array(e.start_point)[:2])
        elif kind == "SPLINE":
            out.append(np.array(e.control_points[0])[:2])
    return out


def assert_holes_then_outline(flags: list[bool]) -> None:
    """Every entity of the holes before every entity of the outline."""
    assert flags and not flags[0] and flags[-1], flags
    first_outer = flags.index(True)
    assert all(flags[first_outer:]) and not any(flags[:first_outer]), flags


@pytest.mark.parametrize("options", [{}, {"entities": "segments"}, {"curves": "spline"}, {"curves": "lines"}])
def test_dxf_cuts_the_hole_before_the_outline(outline, tmp_path: Path, options: dict) -> None:  # noqa: ANN001
    path = write_dxf(outline, tmp_path / "p.dxf", None, origin="centre", **options)
    assert_holes_then_outline([on_outer(outline, p) for p in dxf_starts(path)])


@pytest.mark.parametrize("options", [{}, {"curves": "exact"}, {"kerf": 0.2}])
def test_svg_cuts_the_hole_before_the_outline(outline, options: dict) -> None:  # noqa: ANN001
    text = svg_document(outline, None, origin="centre", **options)
    d = re.search(r' d="([^"]*)"', text).group(1)
    starts = [np.array([float(x), -float(y)]) for x, y in re.findall(r"M ([-\d.e]+)[ ,]([-\d.e]+)", d)]
    assert len(starts) == 2
    assert [on_outer(outline, p) for p in starts] == [False, True]


def test_kit_sheet_cuts_each_plates_holes_before_its_outline() -> None:
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.kit.sheets import nest_plates, sheet_document
    from fabpat.assembly.place.parts import PartLibrary
    from fabpat.assembly.spec.load import parse_spec

    spec = parse_spec({"tiling": {"kind": "honeycomb-strip", "columns": 2, "rows": 1, "edge": 36.0},
                       "patterns": {"groups": ["0x0488"], "group_columns": 2}, "plates": {"process": "laser"},
                       "sheet": {"width": 300.0, "height": 200.0}})
    lib = PartLibrary(*plan(spec))
    nesting = nest_plates(lib.assembly)
    doc = sheet_document(lib.assembly, nesting, 0, lib.filleted)
    areas = []
    for e in doc.modelspace().query("LWPOLYLINE[layer=='CUT']"):
        P = np.array(e.get_points("xy"))
        areas.append(abs(0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - P[:, 1] * np.roll(P[:, 0], -1)))))
    big = [a > 1500.0 for a in areas]  # the chord polygons: outline ≈ 1950 mm², hole ≈ 1245 mm²
    plates = len(lib.assembly.plates)
    assert len(areas) == 2 * plates and big == [False, True] * plates, areas
