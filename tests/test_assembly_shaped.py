"""Shaped plates in assemblies (``[tiling] kind = "mesh"``, ``plates = "shaped"``): each plate is its own
face's polygon moved in by its setback.

Meshes are typed in: a box sheared and stretched (faces planar parallelograms and rectangles whose
angles and edges are known), a box too long, a box sheared too far, a cube with one corner raised.
Expected values come from that geometry (the shear angle atan(s), the edge ratio, the raised corner's
δ/4 off the best plane), from the exact outlines (areas × thickness against OCCT's volumes of the STEP,
OpenSCAD's of the DXF), or from the input mesh itself (the closed shape).
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fabpat.assembly.place.shaped import ShapedPlateType, joint_offsets
from fabpat.assembly.place.shaped import place_assembly as place
from fabpat.assembly.spec.load import load_spec
from fabpat.assembly.surface.shaped import inset
from fabpat.errors import SpecError

CUBE_V = [(0, 0, 0), (36, 0, 0), (36, 36, 0), (0, 36, 0), (0, 0, 36), (36, 0, 36), (36, 36, 36), (0, 36, 36)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]  # outward
#: the kit's box: x sheared by 0.15 z (its front and back faces parallelograms of 81.5° and 98.5°), y stretched
SHEAR, STRETCH = 0.15, 1.1


def box(shear: float = SHEAR, stretch: float = STRETCH, height: float = 1.0) -> list[tuple[float, float, float]]:
    return [(x + shear * z * height, y * stretch, z * height) for x, y, z in CUBE_V]


def write_spec(folder: Path, V: list, plates: str = 'plates = "shaped"', tiling: str = "", sheet: str = "",
               formats: str = '["step", "stl", "dxf", "svg", "bom"]') -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "m.obj").write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in V)
                                  + "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in CUBE_F),
                                  encoding="utf-8")
    spec = folder / "spec.toml"
    spec.write_text(f'name = "shaped box"\n[tiling]\nkind = "mesh"\nfile = "m.obj"\n{plates}\n{tiling}\n'
                    '[patterns]\nsquare = "0x0488"\n[sleeve]\nangle = "dihedral"\nmargin = 3.5\n'
                    f'[sheet]\nwidth = 600.0\nheight = 400.0\n{sheet}\n[output]\nformats = {formats}\n',
                    encoding="utf-8")
    return spec


# -- the spec ---------------------------------------------------------------------------------------


def test_a_face_sheared_past_the_limit_is_named_with_its_angle(tmp_path: Path) -> None:
    with pytest.raises(SpecError) as err:
        load_spec(write_spec(tmp_path, box(0.45, 1.0)))
    line = str(err.value)
    assert "\n" not in line
    # face 3 (0, 1, 5, 4) is the first sheared one: a parallelogram whose corners are atan(0.45) off 90°
    assert "face Q3 (face 3 of the file) is too irregular for a shaped plate" in line
    assert f"{math.degrees(math.atan(0.45)):.1f}°" in line and "limit 20 % / 20°" in line


def test_a_face_stretched_past_the_limit_is_named_with_its_edge_deviation(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"face Q3 \(face 3 of the file\) is too irregular.* edges deviate up to "
                                        r"25\.0 % from their mean"):  # 36 × 60: (60 − 48) / 48
        load_spec(write_spec(tmp_path, box(0.0, 1.0, 60.0 / 36.0)))


def test_a_face_off_its_plane_is_named_with_the_distance(tmp_path: Path) -> None:
    V = [list(v) for v in CUBE_V]
    V[6][2] += 0.5  # one corner of the top face (face 2, the first that holds it) raised 0.5 mm
    with pytest.raises(SpecError, match=r"face Q2 \(face 2 of the file\) is not planar: its corner \d is 0\.125 mm "
                                        r"off the face's best-fit plane \(tiling\.tolerance = 0\.01 mm\)"):
        load_spec(write_spec(tmp_path, V))  # four corners, one raised by δ: each δ/4 from the best plane
    assert load_spec(write_spec(tmp_path, V, tiling="tolerance = 0.13")).tiling.plates == "shaped"


@pytest.mark.parametrize(("plates", "tiling", "message"), [
    ('plates = "bent"', "", r"tiling\.plates = 'bent' is not allowed: choose one of regular, shaped"),
    ('plates = "shaped"', 'fit = "best"', r"tiling\.fit = \"best\" places regular plates"),
])
def test_bad_plates_values_are_one_line(tmp_path: Path, plates: str, tiling: str, message: str) -> None:
    with pytest.raises(SpecError, match=message) as err:
        load_spec(write_spec(tmp_path, box(), plates, tiling))
    assert "\n" not in str(err.value)


def test_plates_on_another_kind_names_the_kind_that_takes_it(tmp_path: Path) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text('[tiling]\nkind = "truncated-icosahedron"\nedge = 36.0\nplates = "shaped"\n'
                    '[patterns]\nhexagon = "0x0488"\npentagon = "0x0508"\n', encoding="utf-8")
    with pytest.raises(SpecError, match=r'tiling\.plates is only for kind = "mesh"') as err:
        load_spec(spec)
    assert "\n" not in str(err.value)


# -- placement --------------------------------------------------------------------------------------


def test_inset_of_a_regular_hexagon_is_the_smaller_regular_hexagon() -> None:
    from fabpat.patterns.lattice import polygon_vertices

    g = 1.7
    got = inset(polygon_vertices(6, 36.0), g)
    want = polygon_vertices(6, 36.0 - 2.0 * g * math.tan(math.pi / 6))  # the apothem shrinks by g
    assert np.abs(got - want).max() < 1e-12


def test_each_plate_is_its_face_moved_in_and_its_own_part(tmp_path: Path) -> None:
    spec = load_spec(write_spec(tmp_path, box()))
    asm = place(spec, ["0x0488"] * 6)
    assert [p.type.label for p in asm.plates] == [f"Q{i} 0x0488" for i in range(1, 7)]
    assert len(asm.plate_types) == 6
    E, e = asm.skeleton.edge_length(), asm.plate_edge
    g = (E - e) / 2.0  # a square's setback: (E − e) / (2 tan 45°)
    for p in asm.plates:
        pt = p.type
        assert isinstance(pt, ShapedPlateType)
        C = np.column_stack([pt.polygon, np.full(4, 0.5 * spec.plates.thickness), np.ones(4)]) @ p.transform.T
        face = asm.skeleton.V[list(asm.skeleton.faces[p.face])]
        normal = asm.skeleton.normals[p.face]
        for i in range(4):  # every plate edge parallel to its face's edge, g inside it, in the face's plane
            a, b = face[i], face[(i + 1) % 4]
            t = (b - a) / np.linalg.norm(b - a)
            for q in (C[i, :3], C[(i + 1) % 4, :3]):
                r = q - a - ((q - a) @ t) * t
                assert abs(r @ normal) < 1e-9 and abs(np.linalg.norm(r) - g) < 1e-9
    # the sheared faces' corners of 81.5° and 98.5° move the midpoints of a joint's two interfaces apart
    shifts = [shift for _, shift, _ in joint_offsets(asm)]
    assert max(shifts) > 0.1 and min(shifts) < 1e-9  # the rectangles' joints (edges along y) do not shift


# -- the kit ----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def kit(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    from fabpat.assembly.kit.build import assemble

    folder = tmp_path_factory.mktemp("shaped")
    spec = write_spec(folder, box())
    assemble(spec, folder / "kit", timestamp="2026-01-01T00:00:00Z", predict=False)
    return spec, folder / "kit"


def _outlines(spec_path: Path) -> dict[str, Any]:
    from fabpat.assembly.kit.build import plan

    asm, filleted = plan(load_spec(spec_path, need_sheet=True), ids=["0x0488"] * 6)
    return {pt.label: fp for pt, fp in filleted.items()}


def test_kit_step_solids_are_valid_with_the_exact_volumes(kit: tuple[Path, Path]) -> None:
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    spec_path, folder = kit
    step = folder / "parts.step"  # the sleeves are printed at angles rounded to 0.1°: the flat parts' file
    reader = STEPControl_Reader()
    assert reader.ReadFile(str(step)) == IFSelect_RetDone
    reader.TransferRoots()
    shape = reader.OneShape()
    volumes = []
    ex = TopExp_Explorer(shape, TopAbs_SOLID)
    while ex.More():
        assert BRepCheck_Analyzer(ex.Current()).IsValid()
        props = GProp_GProps()
        BRepGProp.VolumeProperties_s(ex.Current(), props)
        volumes.append(props.Mass())
        ex.Next()
    t = load_spec(spec_path).plates.thickness
    plates = sorted(fp.outline.area * t for fp in _outlines(spec_path).values())
    assert len(plates) == 6 and len(set(np.round(plates, 6))) > 1  # six parts, not all alike
    for want in plates:  # each plate's solid: its exact outline's area × thickness
        assert min(abs(v - want) / want for v in volumes) <= 1e-6, want


def test_kit_bom_and_manifest_list_every_shaped_plate(kit: tuple[Path, Path]) -> None:
    import csv
    import json

    _, folder = kit
    rows = list(csv.DictReader((folder / "bom.csv").read_text(encoding="utf-8").splitlines()))
    plates = {r["part"]: r for r in rows if r["kind"] == "plate"}
    assert sorted(plates) == [f"Q{i} 0x0488" for i in range(1, 7)]
    assert all(r["count"] == "1" and r["file"] == f"parts/plate-{r['part'].replace(' ', '-')}.stl"
               for r in plates.values())
    assert all((folder / r["file"]).is_file() for r in plates.values())
    manifest = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    assert sum(v for k, v in manifest["counts"].items() if k.startswith("S-")) == 12
    assert any("sleeves on interface midpoints within" in line for line in manifest["checks"])


def test_kit_sheets_read_back_with_every_plate_and_label(kit: tuple[Path, Path]) -> None:
    from fabpat.assembly.kit.sheets import read_sheet
    from fabpat.geometry.polygons import signed_area

    spec_path, folder = kit
    loops, texts = [], []
    for sheet in sorted((folder / "sheets").glob("*.dxf")):
        got = read_sheet(sheet, tolerance=0.005)
        loops += got[0]
        texts += got[1]
    assert {f"Q{i}" for i in range(1, 7)} <= set(texts)
    assert {f"E{k:02d}" for k in range(1, 13)} <= set(texts)
    want = sum(abs(signed_area(P)) for fp in _outlines(spec_path).values()
               for P in fp.outline.flatten(0.005))
    got_area = sum(abs(signed_area(P)) for P in loops)
    assert got_area == pytest.approx(want, rel=1e-3)  # arcs within 0.01 mm of the exact outline


def test_kit_segment_sheet_extrudes_to_the_exact_volume_in_openscad(kit: tuple[Path, Path],
                                                                    tmp_path: Path) -> None:
    """OpenSCAD reads a shaped kit's LINE + ARC sheet as the plates' exact area (the makers'-programs test
    of tests/test_fabrication_readers.py on shaped outlines); LibreCAD prints it."""
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.kit.sheets import nest_plates, sheet_document
    from tests.test_fabrication_readers import needs, openscad_volume

    needs("openscad", "openscad")
    spec_path = write_spec(tmp_path, box(), sheet='border = false\ndxf_entities = "segments"')
    asm, filleted = plan(load_spec(spec_path, need_sheet=True), ids=["0x0488"] * 6)
    nesting = nest_plates(asm)
    path = tmp_path / "sheet.dxf"
    sheet_document(asm, nesting, 0, filleted).saveas(path)
    outlines = [filleted[asm.plates[i].type].outline for i in nesting.on_sheet(0)]
    exact = 2.0 * sum(o.area for o in outlines)
    slack = 2.0 * sum(o.perimeter for o in outlines) * asm.spec.curve_tolerance
    assert abs(openscad_volume(path, tmp_path) - exact) <= slack
    librecad = shutil.which("librecad")
    if librecad is not None:
        r = subprocess.run([librecad, "dxf2pdf", "-a", "-o", str(path.with_suffix(".pdf")), str(path)],
                           capture_output=True, text=True, timeout=60, cwd=tmp_path,
                           env={**os.environ, "QT_QPA_PLATFORM": "offscreen"})
        assert r.returncode == 0 and path.with_suffix(".pdf").read_bytes()[:5] == b"%PDF-"


def test_shaped_label_spots_of_a_regular_polygon_are_the_regular_ones() -> None:
    from fabpat.assembly.kit.sheets import edge_label_spots
    from fabpat.assembly.place.placement import PlateType
    from fabpat.patterns.lattice import polygon_vertices

    for n in (4, 6):
        P = polygon_vertices(n, 36.0)
        shaped = ShapedPlateType(n, "0x0488", face_label="X1", corners=tuple(map(tuple, P)))
        got, want = edge_label_spots(shaped, 36.0, 3), edge_label_spots(PlateType(n, "0x0488"), 36.0, 3)
        assert len(got) == len(want) == n
        for (a, b, ang, h), (a0, b0, ang0, h0) in zip(got, want, strict=True):
            assert np.abs(a - a0).max() < 1e-9 and np.abs(b - b0).max() < 1e-9
            assert math.remainder(ang - ang0, 2 * math.pi) == pytest.approx(0.0, abs=1e-12) and h == pytest.approx(h0)


# -- the closure ------------------------------------------------------------------------------------


def test_closure_with_dihedral_sleeves_keeps_the_mesh_shape(tmp_path: Path) -> None:
    """Shaped plates sit exactly on their faces: sleeves printed at the dihedral angles (rounded to 0.1°,
    the parts' step) close the box with (near) zero strain, each plate where the mesh put it."""
    from fabpat.assembly.solve.closure import closure_setup, run_closure

    spec = load_spec(write_spec(tmp_path, box()))
    setup = closure_setup(spec, ["0x0488"] * 6, h=7.0)
    run = run_closure(setup, steps=1)
    assert run.mesh_deviation_max < 0.01  # mm, against the placed plates on the mesh's faces
    assert run.peak_strain < 1e-3
