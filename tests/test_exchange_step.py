"""STEP AP214: written by OCCT's XDE writer, read back by build123d's importer; the header's time stamp is
ISO 8601, normalised, or refused before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabpat.errors import ExportError
from fabpat.exchange import cad
from fabpat.exchange.registry import ExportSettings, Part, export_part
from fabpat.exchange.step import write_step
from tests.helpers import SMALL_SPEC, one_line_error
from tests.helpers import invoke_result as invoke
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
    from OCP.TDataStd import TDataStd_Name

    path = write_step(cad.make_solid(bowtie()), tmp_path / "x.step", "fabpat 0xabcd n5 e30mm t2mm w0.2")
    _, labels = _xde_read(path)
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
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    part = filleted_part(fillet_pattern(get_pattern("0x0488", 6, 2, 36.0), 0.2))
    with pytest.raises(ExportError, match=r"the DXF file must end in \.dxf, got .*out\.dwg"):
        export_parts([(part, {"dxf": tmp_path / "out.dwg"})])
    assert list(tmp_path.iterdir()) == []


# -- names as ISO 10303-21 strings, reproducible files ---------------------------------------------------


def _xde_read(path: Path) -> tuple[object, object]:
    """(document, free-shape labels) of a STEP file read by OCCT's XDE reader, product names kept."""
    from OCP.collections import Sequence_TDF_Label
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    reader = STEPCAFControl_Reader()
    reader.SetNameMode(True)
    reader.ReadFile(str(path))
    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    assert reader.Transfer(doc)
    labels = Sequence_TDF_Label()
    XCAFDoc_DocumentTool.ShapeTool_s(doc.Main()).GetFreeShapes(labels)
    return doc, labels


def _xde_names(path: Path) -> list[str]:
    """Every product name OCCT's XDE reader decodes from the file (the free shapes and their parts)."""
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDF import TDF_ChildIterator
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    doc, _ = _xde_read(path)
    names = []
    it = TDF_ChildIterator(XCAFDoc_DocumentTool.ShapesLabel_s(doc.Main()), True)  # type: ignore[attr-defined]
    while it.More():
        attr = TDataStd_Name()
        if it.Value().FindAttribute(TDataStd_Name.GetID_s(), attr):
            names.append(attr.Get().ToExtString())
        it.Next()
    return names


def _printable_ascii(path: Path) -> None:
    data = path.read_bytes()
    bad = sorted({b for b in data if not (0x20 <= b <= 0x7E or b == 0x0A)})
    assert bad == [], f"bytes outside printable ASCII: {bad}"


# written by hand from ISO 10303-21 §6.4.3: \X2\ + 4 hex digits per BMP character, \X4\ + 8 above U+FFFF
ENCODED = [
    ("fabpat 0x0488", "fabpat 0x0488"),
    ("Kuppel ü", "Kuppel \\X2\\00FC\\X0\\"),
    ("円円", "\\X2\\51865186\\X0\\"),
    ("a😀b", "a\\X4\\0001F600\\X0\\b"),
    ("é😀", "\\X2\\00E9\\X0\\\\X4\\0001F600\\X0\\"),
    ("back\\slash", "back\\X2\\005C\\X0\\slash"),
    ("it's", "it's"),  # OCCT's writer doubles the apostrophe
]


@pytest.mark.parametrize("text,encoded", ENCODED)
def test_step_string_encodes_per_iso_10303_21(text: str, encoded: str) -> None:
    from fabpat.exchange.step import step_string

    assert step_string(text) == encoded


@pytest.mark.parametrize("name", ["a\x00b", "tab\there", "line\nbreak", "del\x7f", "c1\x85"])
def test_a_name_with_a_control_character_is_refused(tmp_path: Path, name: str) -> None:
    from fabpat.exchange.step import dump_step

    with pytest.raises(ExportError, match=r"control character U\+00"):
        Part(bowtie(), 1.5, name)
    with pytest.raises(ExportError, match=r"control character U\+00"):
        Part(bowtie(), 1.5, "ok", label=name)
    with pytest.raises(ExportError, match=r"control character U\+00"):
        dump_step(cad.make_solid(bowtie()), tmp_path / "x.step", name)
    assert list(tmp_path.iterdir()) == []


def test_a_non_ascii_name_is_encoded_and_reads_back(tmp_path: Path) -> None:
    name = "Kuppel ü 円 😀 it's a \\X2\\0041\\X0\\ back\\slash"  # the last part is text, not a directive
    (out,) = export_part(Part(bowtie(), 1.5, name), {"step": tmp_path / "u.step"})
    _printable_ascii(out)
    text = out.read_text(encoding="ascii").replace("\n", "")  # OCCT breaks long lines, also in strings
    assert "PRODUCT('Kuppel \\X2\\00FC\\X0\\ \\X2\\5186\\X0\\ \\X4\\0001F600\\X0\\ it''s" in text
    assert _xde_names(out) == [name]


def test_an_assembly_name_is_encoded_too(tmp_path: Path) -> None:
    """Names set by another writer (the assembly, through OCP's str constructor that keeps UTF-8
    bytes) reach the file encoded, and the caller's document keeps its names."""
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    from fabpat.exchange.step import write_document

    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, 0.001)
    label = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main()).AddShape(cad.make_solid(bowtie()), False)
    TDataStd_Name.Set_s(label, TCollection_ExtendedString("Kugel ß"))  # no multi-byte flag: UTF-8 bytes
    write_document(doc, tmp_path / "a.step", "Kugel ß")
    _printable_ascii(tmp_path / "a.step")
    assert "Kugel \\X2\\00DF\\X0\\" in (tmp_path / "a.step").read_text(encoding="ascii")
    assert _xde_names(tmp_path / "a.step") == ["Kugel ß"]
    attr = TDataStd_Name()
    assert label.FindAttribute(TDataStd_Name.GetID_s(), attr) and attr.Get().ToExtString() == "Kugel Ã\x9f"


def _style_block(first: int, target: int, rgb: str) -> str:
    return (f"#{first} = MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION('',(\n    #{first + 1}),#1);\n"
            f"#{first + 1} = STYLED_ITEM('color',(#{first + 2}),#{target});\n"
            f"#{first + 2} = COLOUR_RGB('',{rgb});\n")


def test_trailing_colour_blocks_get_one_order(tmp_path: Path) -> None:
    from fabpat.exchange.step_order import sort_trailing_styles

    def file(blocks: list[tuple[int, str]]) -> str:
        body = "".join(_style_block(10 + 3 * k, target, rgb) for k, (target, rgb) in enumerate(blocks))
        return ("ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1 = SHAPE_REPRESENTATION('',(#2),#3);\n#2 = X();\n"
                f"#3 = Y();\n{body}ENDSEC;\nEND-ISO-10303-21;\n")

    blocks = [(2, "0.1,0.2,0.3"), (3, "0.9,0.8,0.7")]
    a, b = tmp_path / "a.step", tmp_path / "b.step"
    a.write_text(file(blocks))
    b.write_text(file(blocks[::-1]))  # the same colours, written in the other order
    assert a.read_bytes() != b.read_bytes()
    sort_trailing_styles(a)
    sort_trailing_styles(b)
    assert a.read_bytes() == b.read_bytes()
    text = a.read_text()
    assert "#11 = STYLED_ITEM('color',(#12),#2);\n#12 = COLOUR_RGB('',0.1,0.2,0.3);" in text  # renumbered in place
    assert "#14 = STYLED_ITEM('color',(#15),#3);\n#15 = COLOUR_RGB('',0.9,0.8,0.7);" in text
    referred = tmp_path / "c.step"  # an earlier entity refers into the blocks: left as it is
    referred.write_text(file(blocks).replace("#2 = X();", "#2 = X(#14);"))
    before = referred.read_bytes()
    assert sort_trailing_styles(referred) is False and referred.read_bytes() == before


@pytest.mark.parametrize("given, header", [
    ("2025-01-31 12:00", "2025-01-31T12:00:00"),
    ("20250131", "2025-01-31T00:00:00"),
    ("2025-01-31", "2025-01-31T00:00:00"),
    ("2025-01-31T12:00:00.75+00:00", "2025-01-31T12:00:00Z"),
    ("2025-01-31T12:00-05:30", "2025-01-31T12:00:00-05:30"),
])
def test_step_timestamp_is_normalised(tmp_path: Path, given: str, header: str) -> None:
    from fabpat.exchange import cad
    from fabpat.exchange.step import check_timestamp, write_step
    from tests.test_cad import bowtie

    assert check_timestamp(given) == header
    path = write_step(cad.make_solid(bowtie()), tmp_path / "t.step", "t", timestamp=given)
    text = path.read_text(encoding="utf-8")
    assert f"'{header}'" in text and (given == header or f"'{given}'" not in text)


def test_timestamp_must_be_iso8601(tmp_path: Path) -> None:
    from fabpat.exchange.registry import ExportSettings
    from fabpat.exchange.step import check_timestamp

    res = invoke("assemble", str(SMALL_SPEC), "--out", str(tmp_path / "kit"), "--timestamp", "garbage")
    one_line_error(res, "--timestamp", "ISO 8601")
    assert list(tmp_path.iterdir()) == []
    for bad in ("garbage", "2025-13-01", "", "2025-01-31T25:00", "2025-01-31 \u00e9"):
        with pytest.raises(ExportError, match="ISO 8601"):
            check_timestamp(bad)
        with pytest.raises(ExportError, match="ISO 8601"):
            ExportSettings(timestamp=bad).check()
    for good in ("2025-01-31T12:00:00", "2025-01-31T12:00:00Z", "2025-01-31T12:00:00+01:00"):
        assert check_timestamp(good) == good  # already normal: unchanged


def test_step_header_gets_a_valid_timestamp_only(tmp_path: Path) -> None:
    from fabpat.exchange.step import dump_step

    with pytest.raises(ExportError, match="ISO 8601"):
        dump_step(object(), tmp_path / "x.step", "x", "not a time")  # refused before OCCT sees the shape
    assert list(tmp_path.iterdir()) == []
