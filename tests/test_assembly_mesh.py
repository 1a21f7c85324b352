"""Mesh tilings (``[tiling] kind = "mesh"``): a polygon-mesh file whose faces carry the plates.

The references are outside the code under test: the truncated icosahedron built in
:mod:`fabpat.assembly.surface.tiling` (written as OBJ, PLY and OFF, it must come back as the same tiling and the
same kit), a cube of edge 36 mm typed in by hand (12 joints at 90°), and hand-made broken meshes, each
refused with one line that names the face or edge.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import meshio
import numpy as np
import pytest

from fabpat.assembly.place.placement import place
from fabpat.assembly.spec.load import load_spec, parse_spec
from fabpat.assembly.surface.mesh_tiling import mesh_tiling, read_polygon_mesh, write_obj
from fabpat.assembly.surface.tiling import truncated_icosahedron
from fabpat.errors import SpecError
from tests.helpers import invoke

ROOT = Path(__file__).resolve().parents[1]
SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
CUBE_V = [(0, 0, 0), (36, 0, 0), (36, 36, 0), (0, 36, 0), (0, 0, 36), (36, 0, 36), (36, 36, 36), (0, 36, 36)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]  # outward


def obj_text(V: list, F: list) -> str:
    return "".join(f"v {x} {y} {z}\n" for x, y, z in V) + "".join(
        "f " + " ".join(str(i + 1) for i in f) + "\n" for f in F)


def mesh_spec(tmp_path: Path, V: list, F: list, **patterns: str) -> dict:
    (tmp_path / "m.obj").write_text(obj_text(V, F), encoding="utf-8")
    return {"tiling": {"kind": "mesh", "file": "m.obj"}, "patterns": patterns or {"square": "0x0488"},
            "sleeve": {"margin": 2.8}}


def parse(tmp_path: Path, data: dict):  # noqa: ANN201 - an AssemblySpec
    return parse_spec(data, str(tmp_path / "spec.toml"))


@pytest.fixture(scope="module")
def ti_files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("ti")
    t = truncated_icosahedron(36.0)
    (d / "ti.obj").write_bytes(write_obj(t))
    meshio.write(d / "ti.ply", meshio.Mesh(t.V, [("polygon", np.array(t.faces[:20])),
                                                 ("polygon", np.array(t.faces[20:]))]), binary=True)
    off = [f"OFF\n{len(t.V)} {len(t.faces)} 0"] + [f"{x:.17g} {y:.17g} {z:.17g}" for x, y, z in t.V]
    off += [f"{len(f)} " + " ".join(map(str, f)) for f in t.faces]
    (d / "ti.off").write_text("\n".join(off) + "\n", encoding="utf-8")
    spec = SPHERE.read_text(encoding="utf-8")
    spec = spec.replace('kind = "truncated-icosahedron"', 'kind = "mesh"\nfile = "ti.obj"')
    (d / "ti-mesh.toml").write_text(spec.replace("edge = 36.0", ""), encoding="utf-8")
    return d


@pytest.mark.parametrize("suffix", ["obj", "ply", "off"])
def test_truncated_icosahedron_read_back_is_the_built_in_tiling(ti_files: Path, suffix: str) -> None:
    t = truncated_icosahedron(36.0)
    V, F = read_polygon_mesh(ti_files / f"ti.{suffix}")
    m = mesh_tiling(V, F)
    assert m.faces == t.faces and m.labels == t.labels
    tol = 1e-5 if suffix == "ply" else 1e-12  # binary PLY holds float32 vertices
    assert np.abs(m.V - t.V).max() < tol * 36.0
    assert np.abs(m.dihedral - t.dihedral).max() < 1e-5
    assert math.isclose(m.dihedral[m.interior_edges].min(), math.acos(-math.sqrt(5.0) / 3.0), abs_tol=1e-5)


def test_inside_out_mesh_is_turned_outward(tmp_path: Path) -> None:
    t = truncated_icosahedron(36.0)
    flipped = tuple(tuple(reversed(f)) for f in t.faces)
    m = mesh_tiling(t.V, flipped)
    assert np.allclose(m.normals, t.normals)  # every face's normal points outwards again
    open_cap = mesh_tiling(t.V, flipped[:6])  # an open piece of it: turned so that its folds are convex
    assert np.allclose(open_cap.normals, t.normals[:6])


def test_mesh_spec_places_the_plates_as_the_built_in_sphere(ti_files: Path) -> None:
    built, read = load_spec(SPHERE), load_spec(ti_files / "ti-mesh.toml")
    assert read.tiling.kind == "mesh" and read.tiling.edge == pytest.approx(36.0, abs=1e-12)
    assert read.polygon_sides == built.polygon_sides == (6, 5)
    a, b = place(built, ["0x0488"] * 20 + ["0x0508"] * 12), place(read, ["0x0488"] * 20 + ["0x0508"] * 12)
    assert a.skeleton.edge_length() == pytest.approx(b.skeleton.edge_length(), abs=1e-12)
    assert [p.label for p in a.plates] == [p.label for p in b.plates]
    assert [s.kind for s in a.sleeves] == [s.kind for s in b.sleeves] == ["S-flat"] * 90
    assert max(np.abs(p.transform - q.transform).max() for p, q in zip(a.plates, b.plates, strict=True)) < 1e-9
    assert max(np.abs(p.transform - q.transform).max() for p, q in zip(a.sleeves, b.sleeves, strict=True)) < 1e-9


@pytest.mark.slow
def test_mesh_kit_is_the_built_in_sphere_kit(ti_files: Path, tmp_path: Path) -> None:
    """The same kit file for file (no prediction: the closure is compared in test_sphere_closure)."""
    from fabpat.assembly.kit.build import assemble

    outs = []
    for name, spec in (("built", SPHERE), ("mesh", ti_files / "ti-mesh.toml")):
        text = spec.read_text(encoding="utf-8").replace('"step", "stl", "glb", "3dm", "dxf", "svg", "bom", "png"',
                                                         '"dxf", "svg", "bom"')
        text = text.replace('file = "ti.obj"', f'file = "{ti_files / "ti.obj"}"')
        (tmp_path / f"{name}.toml").write_text(text, encoding="utf-8")
        assemble(tmp_path / f"{name}.toml", tmp_path / name, predict=False)  # in-process: the kit's logic
        outs.append(tmp_path / name)
    files = sorted(p.relative_to(outs[0]) for p in outs[0].rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(outs[1]) for p in outs[1].rglob("*") if p.is_file())
    assert Path("net.svg") in files and any(f.suffix == ".dxf" for f in files)
    for f in files:
        a, b = ((o / f).read_text(encoding="utf-8") for o in outs)
        if f.suffix == ".dxf":  # the header and the objects hold the creation time
            a, b = (t.split("ENTITIES", 1)[1].split("ENDSEC", 1)[0] for t in (a, b))  # the drawing itself
        elif f.name in ("bom.md", "manifest.json"):  # they name the tiling kind and the spec file
            a, b = (t.replace("truncated-icosahedron", "mesh").split("\n") for t in (a, b))
            a, b = ([line for line in t if not re.search(r"source|within|[0-9a-f]{64}", line)] for t in (a, b))
        assert a == b, f


def test_cube_mesh_joints_at_90_degrees(tmp_path: Path) -> None:
    spec = parse(tmp_path, mesh_spec(tmp_path, CUBE_V, CUBE_F))
    asm = place(spec, ["0x0488"] * 6)
    assert [p.label for p in asm.plates] == ["Q1", "Q2", "Q3", "Q4", "Q5", "Q6"]
    assert len(asm.sleeves) == 12 and {s.kind for s in asm.sleeves} == {"S-QQ"}
    assert all(math.isclose(s.dihedral, math.pi / 2, abs_tol=1e-12) for s in asm.sleeves)


def test_patterns_by_polygon_name(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"patterns.hexagon names no face of this mesh: its faces are square"):
        parse(tmp_path, mesh_spec(tmp_path, CUBE_V, CUBE_F, square="0x0488", hexagon="0x0488"))
    data = mesh_spec(tmp_path, CUBE_V, CUBE_F)
    data["patterns"] = {"tiles": {f"Q{i}": "0x0508" if i == 3 else "0x0488" for i in range(1, 7)}}
    assert parse(tmp_path, data).patterns.tiles == (("0x0488", "0x0488", "0x0508", "0x0488", "0x0488", "0x0488"),)
    data["patterns"] = {"tiles": {"H01": "0x0488"}}
    with pytest.raises(SpecError, match=r"patterns.tiles.H01 is not a face of the mesh \(labels Q1 … Q6 by polygon: "
                                        r"Q squares\)"):
        parse(tmp_path, data)


def _skew_quad() -> tuple[list, list]:
    a, h = 25.0, 1.0  # four equal edges, corners alternately 1 mm above and below the mean plane
    return [(a, 0, h), (0, a, -h), (-a, 0, h), (0, -a, -h)], [(0, 1, 2, 3)]


def _zigzag() -> tuple[list, list]:
    """Three squares in a row, folded 30° up at the first joint and 30° down at the second."""
    c, s = 36 * math.cos(math.radians(30)), 36 * math.sin(math.radians(30))
    V = [(0, 0, 0), (36, 0, 0), (36, 36, 0), (0, 36, 0), (36 + c, 0, s), (36 + c, 36, s),
         (36 + 2 * c, 0, 0), (36 + 2 * c, 36, 0)]
    return V, [(0, 1, 2, 3), (1, 4, 5, 2), (4, 6, 7, 5)]


BAD = {
    "non-manifold": (CUBE_V + [(18, 18, -30)], CUBE_F + [(0, 1, 8)],
                     r"the edge between vertices 1 and 2 is shared by 3 faces \(1, 3, 7\).*non-manifold"),
    "orientation": (CUBE_V, CUBE_F[:1] + [tuple(reversed(CUBE_F[1]))] + CUBE_F[2:],
                    r"faces \d and \d run the same way along the edge between vertices \d and \d.*inconsistent"),
    "pieces": (CUBE_V, [CUBE_F[0], CUBE_F[1]], r"face 2 shares no chain of edges with face 1"),
    "lengths": ([(0, 0, 0), (36, 0, 0), (36, 40, 0), (0, 40, 0)], [(0, 1, 2, 3)],
                r"the edge between vertices 1 and 2 is 36.0000 mm long, 2 mm from the mean edge 38.0000 mm "
                r"\(tiling.tolerance = 0.01 mm\)"),
    "planar": (*_skew_quad(), r"face 1 is not planar: its corner 1 is 1 mm off the face's plane"),
    "regular": ([(0, 0, 0), (36, 0, 0), (54, 18 * math.sqrt(3), 0), (18, 18 * math.sqrt(3), 0)], [(0, 1, 2, 3)],
                r"face 1 is not a regular 4-gon of edge 36.0000 mm: its corner \d is [\d.]+ mm from"),
    "sides": ([(0, 0, 0), (36, 0, 0)], [(0, 1)], r"face 1 has 2 vertices: a plate is a polygon of 3 to 12 sides"),
    "index": (CUBE_V[:4], [(0, 1, 2, 3), (0, 1, 9)], r"face 2 names vertex 10, but the mesh has 4"),
    "concave": (*_zigzag(), r"the fold at the edge between vertices 2 and 3 is concave \(interior angle 210.00°\)"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_mesh_is_one_line_naming_the_face_or_edge(tmp_path: Path, case: str) -> None:
    V, F, message = BAD[case]
    with pytest.raises(SpecError, match=r"spec.toml: tiling.file: .*m.obj: " + message) as e:
        parse(tmp_path, mesh_spec(tmp_path, V, F))
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("name, content, message", [
    ("m.stl", "solid x\nendsolid x\n", r"must be an OBJ, PLY or OFF file \(.obj, .ply, .off\), not .stl"),
    ("m.obj", "v 0 0 0\nf 1 2 3 4 5 6\n", r"face 1 names vertex 2, but the mesh has 1"),
    ("m.off", "OFF\n4 1 0\n0 0 0\n", r"broken OFF file"),
    ("missing.obj", None, r"cannot read the tiling mesh"),
    ("folder.obj", "/dir", r"the tiling mesh is not a regular file"),
])
def test_bad_mesh_file_is_one_line(tmp_path: Path, name: str, content: str | None, message: str) -> None:
    if content == "/dir":
        (tmp_path / name).mkdir()
    elif content is not None:
        (tmp_path / name).write_text(content, encoding="utf-8")
    with pytest.raises(SpecError, match=r"tiling.file: .*" + message) as e:
        parse(tmp_path, {"tiling": {"kind": "mesh", "file": name}, "patterns": {"pattern": "0x0488"}})
    assert "\n" not in str(e.value)


def test_mesh_keys_belong_to_the_mesh_kind(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"tiling.file is only for kind = \"mesh\""):
        parse(tmp_path, {"tiling": {"kind": "truncated-icosahedron", "edge": 36.0, "file": "m.obj"},
                         "patterns": {"pattern": "0x0488"}})
    with pytest.raises(SpecError, match=r"tiling.file is missing: the polygon mesh"):
        parse(tmp_path, {"tiling": {"kind": "mesh"}, "patterns": {"pattern": "0x0488"}})


def test_edge_scales_the_mesh(tmp_path: Path) -> None:
    data = mesh_spec(tmp_path, CUBE_V, CUBE_F)
    data["tiling"]["edge"] = 45.0
    spec = parse(tmp_path, data)
    assert spec.tiling.edge == 45.0
    assert np.ptp(np.array(spec.tiling.vertices), axis=0) == pytest.approx([45.0, 45.0, 45.0])


def test_cli_bad_mesh_and_missing_catalog_exit_2_writing_nothing(tmp_path: Path) -> None:
    data = mesh_spec(tmp_path, CUBE_V, CUBE_F)
    spec = tmp_path / "cube.toml"
    sheet = '[sheet]\nwidth = 300.0\nheight = 200.0\n[sleeve]\nmargin = 2.8\n'
    spec.write_text(f'[tiling]\nkind = "mesh"\nfile = "m.obj"\n[patterns]\nrule = "similar-energy"\n{sheet}',
                    encoding="utf-8")
    r = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress")
    assert r.returncode == 2 and not (tmp_path / "kit").exists()
    line = r.stderr.strip()
    assert "\n" not in line and "no catalog energies for squares (sides = 4)" in line, line
    assert "run `fabpat sweep --sides 4 --db catalog.sqlite`" in line, line
    (tmp_path / "m.obj").write_text(obj_text(CUBE_V, [CUBE_F[0], tuple(reversed(CUBE_F[1])), *CUBE_F[2:]]),
                                    encoding="utf-8")
    r = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress")
    assert r.returncode == 2 and not (tmp_path / "kit").exists()
    assert r.stderr.count("\n") == 1 and "inconsistent orientation" in r.stderr, r.stderr
    assert data  # the spec above is the helper's mesh with a rule instead of named patterns


BLENDER_CUBE = """\ufeff# Blender 4.2
o Cube
v 0 0 0
v 0 0 36
v 0 36 0
v 0 36 36
v 36 0 0
v 36 0 36
v 36 36 0
v 36.004 36 36
vt 0 0
vt 1 0
vt 1 1
vn -1 0 0
usemtl plastic
s 0
f 1/1/1 2/2/1 4/3/1 3/1/1
f -4/1/1 -2/2/1 -1/3/1 -3/1/1
f 1//1 5//1 6//1 2//1
f 3 4 8 7
f 1 3 7 5
f 2 6 8 4
"""


def test_a_modelling_programs_obj_builds_within_the_tolerance(tmp_path: Path) -> None:
    """Texture and normal indices in other numbers than the vertices, negative (relative) indices, a
    byte-order mark, and one corner 0.004 mm off (within the 0.01 mm tolerance): placed and checked."""
    (tmp_path / "m.obj").write_text(BLENDER_CUBE, encoding="utf-8")
    spec = parse(tmp_path, {"tiling": {"kind": "mesh", "file": "m.obj"}, "patterns": {"square": "0x0488"},
                            "sleeve": {"margin": 2.8}})
    assert len(spec.tiling.faces) == 6 and spec.tiling.faces[1] == (4, 6, 7, 5)
    asm = place(spec, ["0x0488"] * 6)
    assert len(asm.sleeves) == 12 and {s.kind for s in asm.sleeves} == {"S-QQ"}


def test_split_vertices_are_welded(tmp_path: Path) -> None:
    """Every face with its own four coincident vertices (as exporters write normals or UV seams)."""
    V = [CUBE_V[i] for f in CUBE_F for i in f]
    F = [tuple(range(4 * k, 4 * k + 4)) for k in range(6)]
    spec = parse(tmp_path, mesh_spec(tmp_path, V, F))
    assert len(spec.tiling.vertices) == 8 and len(place(spec, ["0x0488"] * 6).sleeves) == 12


def test_an_empty_ply_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "m.ply").write_bytes(b"")  # meshio exited (sys.exit) on it
    with pytest.raises(SpecError, match=r"m.ply: cannot read the tiling mesh as PLY: not a PLY file"):
        parse(tmp_path, {"tiling": {"kind": "mesh", "file": "m.ply"}, "patterns": {"pattern": "0x0488"}})
