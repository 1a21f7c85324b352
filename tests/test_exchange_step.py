"""STEP AP214: written by OCCT's XDE writer, read back by build123d's importer."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabpat import cad
from fabpat.errors import ExportError
from fabpat.exchange.registry import ExportSettings, Part, export_part
from fabpat.exchange.step import write_step
from tests.test_cad import BOWTIE_W, SHAPES, bowtie, bowtie_area, curve_weights, edge_curves


def _import(path: Path):  # noqa: ANN202 - build123d shape
    from build123d import import_step

    return import_step(str(path))


@pytest.mark.parametrize("name", list(SHAPES))
def test_step_reimports_as_one_valid_solid_with_exact_volume(tmp_path: Path, name: str) -> None:
    make, area = SHAPES[name]
    path = write_step(cad.make_solid(make(), 2.0), tmp_path / "p.step", "fabpat test")
    shape = _import(path)
    solids = shape.solids()
    assert len(solids) == 1 and solids[0].is_valid
    assert solids[0].volume == pytest.approx(2.0 * area(), rel=1e-6)


def test_step_keeps_the_rational_weight(tmp_path: Path) -> None:
    path = write_step(cad.make_solid(bowtie(), 2.0), tmp_path / "b.step", "bow-tie")
    text = path.read_text()
    assert "RATIONAL_B_SPLINE_CURVE((1.,0.2,1.))" in text
    curves = edge_curves(_import(path))
    rational = [c for c in curves if any(w != 1.0 for w in curve_weights(c))]
    assert len(rational) >= 4  # two arcs, on the top and the bottom face
    assert all(curve_weights(c) == pytest.approx([1.0, BOWTIE_W, 1.0], abs=1e-12) for c in rational)


def test_step_header_schema_units_and_product_name(tmp_path: Path) -> None:
    name = cad.part_name("0x0488", 6, 36.0, 2.0, 0.2)
    path = write_step(cad.make_solid(bowtie()), tmp_path / "n.step", name, timestamp="2024-01-01T00:00:00")
    text = path.read_text()
    assert "AUTOMOTIVE_DESIGN" in text  # AP214
    assert "SI_UNIT(.MILLI.,.METRE.)" in text
    assert f"PRODUCT('{name}'" in " ".join(text.split())
    assert "'2024-01-01T00:00:00'" in text


def test_step_product_name_reads_back_with_xde(tmp_path: Path) -> None:
    from OCP.collections import Sequence_TDF_Label
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    path = write_step(cad.make_solid(bowtie()), tmp_path / "x.step", "fabpat 0xabcd n5 e30mm t2mm w0.2")
    reader = STEPCAFControl_Reader()
    reader.SetNameMode(True)
    reader.ReadFile(str(path))
    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    assert reader.Transfer(doc)
    labels = Sequence_TDF_Label()
    XCAFDoc_DocumentTool.ShapeTool_s(doc.Main()).GetFreeShapes(labels)
    attr = TDataStd_Name()
    assert labels.Length() == 1 and labels.Value(1).FindAttribute(TDataStd_Name.GetID_s(), attr)
    assert attr.Get().ToExtString() == "fabpat 0xabcd n5 e30mm t2mm w0.2"


def test_export_part_writes_step_atomically(tmp_path: Path) -> None:
    part = Part(bowtie(), 1.5, "fabpat bow-tie")
    (out,) = export_part(part, {"step": tmp_path / "a.step"}, ExportSettings())
    assert _import(out).solids()[0].volume == pytest.approx(1.5 * bowtie_area(), rel=1e-6)
    # An error in a later format (here an unwritable folder) leaves no STEP file either.
    with pytest.raises(ExportError):
        export_part(part, {"step": tmp_path / "b.step", "stl": tmp_path / "missing" / "b.stl"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.step"]


def test_export_parts_refuses_a_suffix_of_another_format(tmp_path: Path) -> None:
    from fabpat.exchange.registry import export_parts, filleted_part
    from fabpat.fillet import fillet_pattern
    from fabpat.library import get_pattern

    part = filleted_part(fillet_pattern(get_pattern("0x0488", 6, 2, 36.0), 0.2))
    with pytest.raises(ExportError, match=r"the DXF file must end in \.dxf, got .*out\.dwg"):
        export_parts([(part, {"dxf": tmp_path / "out.dwg"})])
    assert list(tmp_path.iterdir()) == []
