"""Byte-reproducible files with a time stamp: each writer (3MF, DXF, 3DM) in-process, and whole kits of
``fabpat assemble --timestamp`` (a strip, the sphere, a panel) built once in this process and once in a
fresh one, then compared file by file; third-party readers open the stamped files."""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
import uuid
import zipfile
from datetime import datetime
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import rhino3dm as r3

from fabpat.exchange.registry import ExportSettings, Part, export_parts
from tests.conftest import run_cli
from tests.test_cad import rounded_square

ROOT = Path(__file__).resolve().parents[1]
STAMP = "2025-01-31T12:00:00Z"
#: a small closed mesh: a tetrahedron (mm), outward triangles
TETRA_V = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 10.0]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _part() -> Part:
    return Part(rounded_square(), 2.0, "fabpat test part", "T1")


def _files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` by its path relative to it."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _header(data: bytes, name: str) -> str:
    """The value of header variable ``name`` as the DXF file holds it (ezdxf's reader sets $TDCREATE anew)."""
    lines = data.decode("utf-8").splitlines()
    at = next(i for i in range(0, len(lines) - 1, 2) if lines[i].strip() == "9" and lines[i + 1] == name)
    return lines[at + 3].strip()


# --- the stamp itself ------------------------------------------------------------------------------------


def test_zip_dates_and_ids_follow_the_stamp() -> None:
    from fabpat.errors import ExportError
    from fabpat.exchange.stamp import stamp_uuid, zip_date_time

    assert zip_date_time(STAMP) == (2025, 1, 31, 12, 0, 0)
    assert zip_date_time("2025-01-31T13:00:00+01:00") == (2025, 1, 31, 12, 0, 0)  # one instant, one date (UTC)
    assert zip_date_time("1970-01-01") == (1980, 1, 1, 0, 0, 0)  # ZIP dates start in 1980: clamped
    assert zip_date_time("2200-01-01") == (2107, 12, 31, 23, 59, 58)
    assert stamp_uuid(STAMP, "a") == stamp_uuid("2025-01-31 12:00:00Z", "a")  # spellings of one instant
    assert stamp_uuid(STAMP, "a") != stamp_uuid(STAMP, "b") != stamp_uuid("2025-02-01", "b")
    assert stamp_uuid(STAMP, "a", "b") != stamp_uuid(STAMP, "a b")
    with pytest.raises(ExportError, match="not an ISO 8601"):
        zip_date_time("yesterday")


# --- one writer at a time, in this process ---------------------------------------------------------------


def _coloured(parts: list[tuple[int, str]]) -> bytes:
    """A STEP data section ending in OCCT-style colour blocks, one per (target entity, colour) in order; a
    colour is written once, in the first block that uses it, and later blocks refer to it (as OCCT does)."""
    lines = ["ISO-10303-21;", "HEADER;", "ENDSEC;", "DATA;", "#1 = SHAPE_REPRESENTATION('',(#2,#3,#4),#5);",
             "#2 = X();", "#3 = X();", "#4 = X();", "#5 = Y();"]
    n, defined = 10, {}
    for target, rgb in parts:
        lines += [f"#{n} = MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION('',(#{n + 1}),#5);",
                  f"#{n + 1} = STYLED_ITEM('color',(#{n + 2}),#{target});"]
        if rgb in defined:
            lines.append(f"#{n + 2} = FILL_AREA_STYLE_COLOUR('',#{defined[rgb]});")
            n += 3
        else:
            defined[rgb] = n + 3
            lines += [f"#{n + 2} = FILL_AREA_STYLE_COLOUR('',#{n + 3});", f"#{n + 3} = COLOUR_RGB('',{rgb});"]
            n += 4
    return ("\n".join([*lines, "ENDSEC;", "END-ISO-10303-21;", ""])).encode()


def _colour_of(data: bytes) -> dict[str, str]:
    """target entity → its colour, following the references of the colour blocks."""
    import re

    ents = dict(re.findall(rb"(?m)^#(\d+) = (.*);$", data))
    out = {}
    for text in ents.values():
        if text.startswith(b"STYLED_ITEM"):
            style, target = re.findall(rb"#(\d+)", text)
            colour = re.search(rb"#(\d+)", ents[style])[1]  # type: ignore[index]
            out[target.decode()] = ents[colour].decode()
    return out


def test_step_colour_blocks_with_a_shared_colour_get_one_order(tmp_path: Path) -> None:
    """OCCT writes a colour once and refers to it from later blocks (the rigid sphere's two sleeve kinds share
    their grey), so its blocks differ in length; they are put in one order all the same."""
    from fabpat.exchange.step_order import sort_trailing_styles

    grey, red = "0.1,0.1,0.1", "0.9,0.1,0.1"
    one, two = tmp_path / "1.step", tmp_path / "2.step"
    one.write_bytes(_coloured([(2, grey), (3, grey), (4, red)]))
    two.write_bytes(_coloured([(4, red), (3, grey), (2, grey)]))
    before = _colour_of(one.read_bytes())
    assert before == _colour_of(two.read_bytes()) and one.read_bytes() != two.read_bytes()
    assert [sort_trailing_styles(one), sort_trailing_styles(two)] == [False, True]  # one was in order already
    assert one.read_bytes() == two.read_bytes()
    assert _colour_of(one.read_bytes()) == before  # every part keeps its colour
    assert one.read_text().count("COLOUR_RGB") == 2  # the shared colour still written once


def test_step_occurrence_ids_start_at_one(tmp_path: Path) -> None:
    """OCCT numbers assembly occurrences per process: a second assembly written by one process got '11', …"""
    from fabpat.exchange.step_order import renumber_occurrences

    def file(first: int) -> bytes:
        return (f"DATA;\n#5 = NEXT_ASSEMBLY_USAGE_OCCURRENCE('{first + 1}','2x','',#1,#2,$);\n"
                f"#9 = NEXT_ASSEMBLY_USAGE_OCCURRENCE('{first}','1x','',#2,#3,$);\nENDSEC;\n").encode()

    warm, fresh = tmp_path / "warm.step", tmp_path / "fresh.step"
    warm.write_bytes(file(11))
    fresh.write_bytes(file(1))
    assert renumber_occurrences(warm) is True and renumber_occurrences(fresh) is False
    assert warm.read_bytes() == fresh.read_bytes() == file(1)


def test_3mf_with_a_timestamp_is_the_same_bytes_and_dated_by_it(tmp_path: Path) -> None:
    from fabpat.exchange.threemf import dump_3mf

    paths = [tmp_path / f"{k}.3mf" for k in "abc"]
    dump_3mf(TETRA_V, TETRA_F, paths[0], "tetra", STAMP)
    dump_3mf(TETRA_V, TETRA_F, paths[1], "tetra", "2025-01-31T13:00:00+01:00")  # the same instant
    dump_3mf(TETRA_V, TETRA_F, paths[2], "tetra")  # no stamp: dated now
    assert paths[0].read_bytes() == paths[1].read_bytes()
    with zipfile.ZipFile(paths[0]) as z:
        assert [i.date_time for i in z.infolist()] == [(2025, 1, 31, 12, 0, 0)] * 3
        assert z.testzip() is None
    with zipfile.ZipFile(paths[2]) as z:
        assert {i.date_time[0] for i in z.infolist()} == {datetime.now().year}
    import trimesh
    mesh = trimesh.load(paths[0], file_type="3mf", force="mesh")
    assert len(mesh.faces) == 4 and mesh.is_watertight


def test_dxf_with_a_timestamp_is_the_same_bytes(tmp_path: Path) -> None:
    from ezdxf.tools.juliandate import juliandate

    from fabpat.exchange.dxf import write_dxf

    a, b, c, other = (tmp_path / f"{k}.dxf" for k in ("a", "b", "c", "other"))
    for path in (a, b):
        write_dxf(rounded_square(), path, "T1", timestamp=STAMP, name="part")
    write_dxf(rounded_square(), c, "T1")
    write_dxf(rounded_square(), other, "T1", timestamp=STAMP, name="another part")
    assert a.read_bytes() == b.read_bytes()
    assert not ezdxf.options.write_fixed_meta_data_for_testing  # no global switched
    data = a.read_bytes()
    day = juliandate(datetime(2025, 1, 31, 12, 0, 0))
    for name in ("$TDCREATE", "$TDUPDATE", "$TDUCREATE", "$TDUUPDATE"):
        assert float(_header(data, name)) == pytest.approx(day, abs=1e-9), name
    assert float(_header(data, "$TDINDWG")) == float(_header(data, "$TDUSRTIMER")) == 0.0
    guids = (_header(data, "$FINGERPRINTGUID"), _header(data, "$VERSIONGUID"))
    assert all(uuid.UUID(g.strip("{}")).version == 5 for g in guids) and guids[0] != guids[1]
    assert _header(other.read_bytes(), "$FINGERPRINTGUID") != guids[0]  # names give distinct GUIDs
    assert f"{ezdxf.__version__} @ {STAMP}" in a.read_text()  # ezdxf's marker, dated by the stamp
    doc = ezdxf.readfile(a)
    names = [e.dxf.name for e in doc.classes]
    assert names == sorted(names)  # not in the order of a set of strings (hash randomisation)
    undated = c.read_bytes()
    assert abs(float(_header(undated, "$TDCREATE")) - juliandate(datetime.now())) < 1.0  # today's behaviour
    assert _header(undated, "$FINGERPRINTGUID") not in guids
    from ezdxf import recover

    recovered, auditor = recover.readfile(a)
    assert not auditor.has_errors and len(recovered.modelspace()) == len(doc.modelspace())


def test_3dm_with_a_timestamp_is_the_same_bytes(tmp_path: Path) -> None:
    from fabpat.exchange.rhino import encode, part_model

    part = _part()
    one, two = (encode(part_model(part, timestamp=STAMP), STAMP) for _ in range(2))
    assert one == two
    assert encode(part_model(part)) != encode(part_model(part))  # fresh ids without a stamp
    path = tmp_path / "p.3dm"
    path.write_bytes(one)
    model = r3.File3dm.Read(str(path))
    assert model is not None and str(model.Created) == str(model.LastEdited) == "2025-01-31 12:00:00"
    assert len({str(o.Attributes.Id) for o in model.Objects}) == len(model.Objects) == len(part.outline.loops) + 1
    assert [layer.Name for layer in model.Layers] == ["CUT", "PLATE", "INTERFACE"]
    assert all(uuid.UUID(str(layer.Id)).version == 5 for layer in model.Layers)
    assert str(path) not in one.decode("latin-1")  # the path written to is not in the file


def test_3dm_blocks_get_fixed_ids_and_valid_crcs(tmp_path: Path) -> None:
    """rhino3dm draws block and block-geometry ids at random; :func:`reproducible` replaces them in the encoded
    file and redoes the CRCs: openNURBS reads the result, every CRC still checks."""
    from fabpat.exchange.rhino import encode
    from fabpat.exchange.rhino_stamp import crc_chunks, reproducible

    def model() -> tuple[object, dict[uuid.UUID, uuid.UUID]]:
        m = r3.File3dm()
        layer = r3.Layer()
        layer.Name = "A"
        layer.Id = uuid.UUID(int=1)
        index = m.Layers.Add(layer)
        att = r3.ObjectAttributes()
        att.LayerIndex = index
        line = r3.LineCurve(r3.Point3d(0, 0, 0), r3.Point3d(1, 0, 0))
        block = m.InstanceDefinitions.FindIndex(m.InstanceDefinitions.Add("b", "", "", "", r3.Point3d(0, 0, 0),
                                                                          (line, line), (att, att)))
        ref = r3.ObjectAttributes()
        ref.LayerIndex = index
        ref.Id = uuid.UUID(int=2)
        m.Objects.AddInstanceObject(r3.InstanceReference(block.Id, r3.Transform(1.0)), ref)
        drawn = [block.Id, *block.GetObjectIds()]
        return m, {u: uuid.UUID(int=100 + k) for k, u in enumerate(drawn)}

    (m1, ids1), (m2, ids2) = model(), model()
    assert set(ids1).isdisjoint(ids2)  # drawn at random
    raw = encode(m1)
    one, two = reproducible(raw, STAMP, ids1), reproducible(encode(m2), STAMP, ids2)
    assert one == two
    assert crc_chunks(one) == crc_chunks(raw)  # a stale CRC would drop its chunk from the list
    path = tmp_path / "b.3dm"
    path.write_bytes(one)
    back = r3.File3dm.Read(str(path))
    assert back is not None
    (block,) = back.InstanceDefinitions
    assert str(block.Id) == str(uuid.UUID(int=100))
    assert [str(u) for u in block.GetObjectIds()] == [str(uuid.UUID(int=k)) for k in (101, 102)]
    assert len(back.Objects) == 3 and str(back.Created) == "2025-01-31 12:00:00"


def test_export_parts_with_a_timestamp_give_the_same_bytes(tmp_path: Path) -> None:
    """The registry passes ``ExportSettings.timestamp`` to every writer (as a panel kit's part files use it)."""
    formats = ("step", "stl", "3mf", "3dm", "dxf", "svg")
    runs = []
    for k in ("1", "2"):
        (tmp_path / k).mkdir()
        export_parts([(_part(), {f: tmp_path / k / f"p.{f}" for f in formats})], ExportSettings(timestamp=STAMP))
        runs.append(_files(tmp_path / k))
    assert sorted(runs[0]) == [f"p.{f}" for f in sorted(formats)]
    assert [f for f in runs[0] if runs[0][f] != runs[1][f]] == []


def test_librecad_reads_a_stamped_sheet(tmp_path: Path) -> None:
    """LibreCAD 2 (headless, ``dxf2pdf``) converts a stamped DXF: the header values are ones it accepts."""
    librecad = shutil.which("librecad")
    if librecad is None:
        pytest.skip("LibreCAD is not installed")
    from fabpat.exchange.dxf import write_dxf

    dxf = tmp_path / "p.dxf"
    write_dxf(rounded_square(), dxf, "T1", timestamp=STAMP, name="part")
    env = {"QT_QPA_PLATFORM": "offscreen", "HOME": str(tmp_path), "PATH": "/usr/bin:/bin"}
    r = subprocess.run([librecad, "dxf2pdf", "-o", str(tmp_path), str(dxf)], capture_output=True,
                       text=True, env=env, timeout=120)
    assert r.returncode == 0 and "DONE" in r.stdout + r.stderr, r.stderr
    assert (tmp_path / "p.pdf").read_bytes().startswith(b"%PDF")


# --- whole kits: one run here, one in a fresh process ----------------------------------------------------

#: a panel of two hexagons (assemblies/panel.toml cut to 1 × 2): the panel's writers, at a fifth of the fusing
PANEL = "panel-1x2.toml"
#: every file of each kit (the manifest's ``files`` and the manifest): a missing or extra file fails the test
KITS = {
    "strip": ("test-small.toml", True, [
        "assembly.3dm", "assembly.glb", "assembly.png", "assembly.step", "bom.csv", "bom.md", "manifest.json",
        "net.svg", "parts/plate-hex-0x0488.stl", "parts/plate-hex-0x0508.stl", "parts/plate-hex-0x0588.stl",
        "parts/sleeve-S-flat.stl", "predicted.glb", "predicted.png", "predicted.stl", "prediction.json",
        "sheets/sheet-01.dxf", "sheets/sheet-02.dxf"]),
    # the bent-sleeve sphere's parts.step / parts.3dm are the same writers over the flat layout: not repeated
    "rigid-sphere": ("truncated-icosahedron-rigid.toml", False, [
        "assembly.3dm", "assembly.glb", "assembly.png", "assembly.step", "bom.csv", "bom.md", "manifest.json",
        "net.svg", "parts/plate-hex-0x0488.stl", "parts/plate-pent-0x0508.stl", "parts/sleeve-S-HH.stl",
        "parts/sleeve-S-HP.stl", "sheets/sheet-01.dxf"]),
    "panel": (PANEL, False, [
        "bom.csv", "bom.md", "manifest.json", "panel.3dm", "panel.3mf", "panel.dxf", "panel.glb", "panel.png",
        "panel.step", "panel.stl", "panel.svg", "sheets/sheet-01.dxf"]),
}


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(KITS))
def test_assemble_with_a_timestamp_gives_byte_identical_kits(kind: str, tmp_path: Path) -> None:
    """Two runs with one ``--timestamp``, each in a new process (the CLI), so that what changes between
    processes changes too (OCCT's memory addresses, Python's string hashes, which order
    ezdxf's CLASSES). The strip predicts (``prediction.json``, ``predicted.*``); the sphere and the panel
    run without the prediction (``--no-predict``; a panel has none). A third run of the strip without a time
    stamp and with DXF only shows that the comparison can fail: its sheets' header dates and GUIDs differ."""
    from fabpat.assembly.kit.build import assemble
    from fabpat.assembly.spec.load import load_spec

    name, predict, expected = KITS[kind]
    spec = ROOT / "assemblies" / name
    if name == PANEL:
        text = (ROOT / "assemblies" / "panel.toml").read_text()
        text = re.sub(r"rows = 3\ncolumns = 4", "rows = 1\ncolumns = 2", text)
        text = re.sub(r"tiles = \[\[.*?\]\]", 'tiles = [["0x0488", "0x0588"]]', text, flags=re.S)
        spec = tmp_path / name
        spec.write_text(text)
    for run in ("1", "2"):  # two fresh processes: a test worker's earlier tests may have left state behind
        cli = ["assemble", str(spec), "--out", str(tmp_path / run), "--timestamp", STAMP, "--no-progress"]
        r = run_cli(*cli, *([] if predict or kind == "panel" else ["--no-predict"]))
        assert r.returncode == 0, r.stderr
    one, two = _files(tmp_path / "1"), _files(tmp_path / "2")
    assert sorted(one) == sorted(two) == expected
    assert [f for f in expected if one[f] != two[f]] == []
    if predict:
        assert "seconds" not in one["prediction.json"].decode()  # a duration: not in a reproducible kit
    if kind == "strip":
        step = one["assembly.step"].decode()
        assert f"'{STAMP}'" in step  # the header's time is the stamp
        assert step.count("COLOUR_RGB") == 4  # three plate colours and the sleeves' grey

    if kind != "strip":  # that the comparison can fail is shown once, on the cheapest kit
        return
    plain = dataclasses.replace(load_spec(spec, need_sheet=True), formats=("dxf",))
    assemble(plain, tmp_path / "3", predict=False)
    sheet = "sheets/sheet-01.dxf"
    three = (tmp_path / "3" / sheet).read_bytes()
    assert three != one[sheet]
    for var in ("$TDCREATE", "$FINGERPRINTGUID", "$VERSIONGUID"):
        assert _header(three, var) != _header(one[sheet], var), var
