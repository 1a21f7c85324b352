"""Kit sheets of the truncated icosahedron read the way a maker's programs read them.

TEXT is placed by its first point (readers that ignore alignment codes), so each label's first
point and its box (ezdxf's own text measurement) must lie on its plate's material, found here
from the CUT loops alone (inside an odd number of loops). The bed outline is on a non-plotting
layer, and ``[sheet] border = false`` leaves it out (OpenSCAD imports every layer as geometry).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fabpat.assembly.build import plan
from fabpat.assembly.parts import PartLibrary
from fabpat.assembly.sheets import nest_plates, sheet_document
from fabpat.assembly.spec import parse_spec

SPHERE = {
    "tiling": {"kind": "truncated-icosahedron", "edge": 36.0},
    "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"},
    "plates": {"process": "laser"},
    "sheet": {"width": 600.0, "height": 400.0},
}


@pytest.fixture(scope="module")
def sheet():  # noqa: ANN201
    lib = PartLibrary(*plan(parse_spec(SPHERE)))
    asm = lib.assembly
    nesting = nest_plates(asm)
    assert nesting.n_sheets == 1
    return lib, nesting, sheet_document(asm, nesting, 0, lib.filleted)


def cut_polygons(doc) -> list[np.ndarray]:  # noqa: ANN001
    from ezdxf import path as dxfpath

    return [np.array([(v.x, v.y) for v in dxfpath.make_path(e).flattening(0.005)])
            for e in doc.modelspace().query('LWPOLYLINE[layer=="CUT"]')]


def on_material(polys: list[np.ndarray], X: np.ndarray) -> np.ndarray:
    from matplotlib.path import Path as MPath

    count = np.zeros(len(X), dtype=int)
    for P in polys:
        count += MPath(P).contains_points(X)
    return count % 2 == 1


def test_every_label_starts_on_its_plate(sheet) -> None:  # noqa: ANN001
    from ezdxf.tools.text_size import text_size

    _, _, doc = sheet
    polys = cut_polygons(doc)
    texts = doc.modelspace().query("TEXT")
    assert len(texts) == 360  # 180 plate edges × (joint label + plate label)
    for e in texts:
        assert e.dxf.layer == "ENGRAVE" and e.dxf.halign == 0 and e.dxf.valign == 0
        assert e.dxf.height >= 1.0  # fabpat's own minimum (pentagon labels were 0.991 mm)
        s, a, size = np.array(e.dxf.insert)[:2], math.radians(e.dxf.rotation), text_size(e)
        u, v = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        box = np.array([s, s + size.width * u, s + size.width * u + size.cap_height * v, s + size.cap_height * v])
        assert on_material(polys, box).all(), e.dxf.text


def test_bed_outline_is_not_plotted_and_extents_are_set(sheet) -> None:  # noqa: ANN001
    lib, nesting, doc = sheet
    assert doc.layers.get("SHEET").dxf.plot == 0
    (border,) = doc.modelspace().query('LWPOLYLINE[layer=="SHEET"]')
    assert [tuple(p) for p in border.get_points("xy")] == [(0, 0), (600, 0), (600, 400), (0, 400)]
    assert np.array(doc.header["$EXTMIN"])[:2] == pytest.approx([0, 0])
    assert np.array(doc.header["$EXTMAX"])[:2] == pytest.approx([600, 400])
    spec = lib.assembly.spec
    bare = dataclasses.replace(spec, sheet=dataclasses.replace(spec.sheet, border=False))
    doc = sheet_document(dataclasses.replace(lib.assembly, spec=bare), nesting, 0, lib.filleted)
    assert "SHEET" not in doc.layers and not doc.modelspace().query('*[layer=="SHEET"]')
    P = np.vstack(cut_polygons(doc))
    lo, hi = np.array(doc.header["$EXTMIN"])[:2], np.array(doc.header["$EXTMAX"])[:2]
    assert P.min(axis=0) == pytest.approx(lo, abs=0.01) and P.max(axis=0) == pytest.approx(hi, abs=0.01)
