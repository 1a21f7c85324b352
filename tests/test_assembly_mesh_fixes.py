"""The break test of the polygon-mesh tilings (issue 26): each problem a new user hit, as a test.

Meshes are typed in by hand (a square grid, a single square, an octahedron, a hexagonal prism, a sheared
cube); expected values come from their geometry, or from what the kit's own final check (the exact
part intersections) says of a kit built as the advice says.
"""

from __future__ import annotations

import json
import math
import re
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from fabpat.assembly.place.necks import neck_extent, neck_half_width
from fabpat.assembly.place.placement import place
from fabpat.assembly.solve.closure import SPHERE_RMS_LIMIT, shape_sphere
from fabpat.assembly.solve.simulation import simulate_assembly
from fabpat.assembly.spec.load import load_spec, parse_spec
from fabpat.assembly.surface.joints import required_setback
from fabpat.assembly.surface.mesh_tiling import read_polygon_mesh
from fabpat.errors import SpecError
from tests.helpers import invoke

SHEET = '[sheet]\nwidth = 600.0\nheight = 400.0\n[output]\nformats = ["bom"]\n'


def write_obj(path: Path, V: list, F: list) -> None:
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V)
                    + "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in F), encoding="utf-8")


def grid(n: int, m: int, e: float = 36.0) -> tuple[list, list]:
    V = [(i * e, j * e, 0.0) for j in range(m + 1) for i in range(n + 1)]
    F = [(j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i)
         for j in range(m) for i in range(n)]
    return V, F


def mesh_spec(tmp_path: Path, V: list, F: list, patterns: str, sleeve: str = "", tiling: str = "") -> Path:
    write_obj(tmp_path / "m.obj", V, F)
    spec = tmp_path / "spec.toml"
    spec.write_text(f'name = "t"\n[tiling]\nkind = "mesh"\nfile = "m.obj"\n{tiling}\n[patterns]\n{patterns}\n'
                    f"[sleeve]\n{sleeve}\n{SHEET}", encoding="utf-8")
    return spec


def assemble(spec: Path, out: Path) -> subprocess.CompletedProcess[str]:
    return invoke("assemble", str(spec), "--out", str(out), "--no-predict", "--no-progress")


# -- 1. no sphere for a shape that is not one -------------------------------------------------------


def test_shape_sphere_of_points_on_a_plane_a_sphere_and_a_cube() -> None:
    rng = np.random.default_rng(1)
    flat = np.column_stack([rng.uniform(0, 100, 200), rng.uniform(0, 100, 200), np.zeros(200)])
    assert shape_sphere(flat).radius is None and shape_sphere(flat).note.startswith("flat")
    u = rng.normal(size=(300, 3))
    ball = 50.0 * u / np.linalg.norm(u, axis=1, keepdims=True) + [1.0, 2.0, 3.0]
    s = shape_sphere(ball[ball[:, 2] > 20.0])  # a cap of a sphere of radius 50: reported
    assert s.radius == pytest.approx(50.0, rel=1e-9) and s.sphericity_rms < 1e-9 and s.note == ""
    g = np.linspace(-18.0, 18.0, 7)
    cube = np.array([p for a in g for b in g for p in ((a, b, 18.0), (a, b, -18.0), (a, 18.0, b), (a, -18.0, b),
                                                        (18.0, a, b), (-18.0, a, b))])
    c = shape_sphere(cube)  # closed, but its best sphere leaves ≈ 15 % RMS radial deviation
    assert c.radius is None and c.sphericity_rms is None and f"over {100 * SPHERE_RMS_LIMIT:g} %" in c.note


def test_flat_grid_reports_no_sphere(tmp_path: Path) -> None:
    spec = mesh_spec(tmp_path, *grid(2, 2), 'square = "0x0488"', "margin = 2.8")
    sim = simulate_assembly(spec, h=7.5)
    f = sim.fields()
    assert f["radius"] is None and f["sphericity_rms"] is None and f["sphericity_max"] is None
    assert "radius=None (flat: no sphere)" in repr(sim)


def test_flat_cap_reports_null_in_json_and_text(tmp_path: Path) -> None:
    spec = tmp_path / "cap.toml"
    spec.write_text('name = "cap"\n[tiling]\nkind = "hex-cap"\nrings = 1\ncentre = 6\nedge = 36.0\n'
                    '[patterns]\nhexagon = "0x0488"\n', encoding="utf-8")
    r = invoke("simulate-assembly", str(spec), "--h", "7.5", "--json", "--no-progress")
    assert r.returncode == 0, r.stderr
    f = json.loads(r.stdout)
    assert f["plates"] == 7 and f["radius"] is None and f["sphericity_rms"] is None
    r = invoke("simulate-assembly", str(spec), "--h", "7.5", "--no-progress")
    assert "radius=null\n" in r.stdout and "sphericity_rms=null\n" in r.stdout


# -- 2. neck advice that leads to a kit -------------------------------------------------------------


class _Outline:
    def __init__(self, P: list) -> None:
        self.P = np.array(P, dtype=np.float64)

    def flatten(self, _tol: float) -> list:
        return [self.P]


def test_neck_extent_counts_where_a_chord_crosses_the_depth_line() -> None:
    # a trapezoid widening from ±1 at the edge (y = −10) to ±7 six mm in: 3 mm in it is ±4 wide
    o = _Outline([(-1.0, -10.0), (1.0, -10.0), (7.0, -4.0), (-7.0, -4.0)])
    assert neck_half_width(o, -10.0, 3.0, 20.0) == pytest.approx(1.0)  # its corners only
    assert neck_extent(o, -10.0, 3.0, 20.0) == pytest.approx(4.0)
    assert neck_extent(o, -10.0, 3.0, 2.5) == pytest.approx(2.5)  # the reach bounds it
    assert neck_extent(o, -10.0, 8.0, 20.0) == pytest.approx(7.0)


OCTA_V = [(x * 36.0 / math.sqrt(2.0), y * 36.0 / math.sqrt(2.0), z * 36.0 / math.sqrt(2.0))
          for x, y, z in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))]
OCTA_F = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]


def _advice(stderr: str) -> dict[str, float]:
    return {k: float(v) for k, v in re.findall(r"(margin|depth) to [≥≤] ([0-9.]+)", stderr)}


@pytest.mark.parametrize("depth, follow", [(3.0, "depth"), (2.0, "margin")])
def test_triangle_neck_advice_builds(tmp_path: Path, depth: float, follow: str) -> None:
    """The old advice on this octahedron, "raise sleeve.margin to ≥ 4.83", asked for 8.40 once followed,
    then 12.75, … Now the value given, followed, gives a kit the part-intersection check passes; at depth 3
    no margin settles without the sleeves meeting at the triangles' corners, so only depth is advised."""
    spec = mesh_spec(tmp_path, OCTA_V, OCTA_F, 'triangle = "0x0488"', f'angle = "dihedral"\ndepth = {depth}')
    r = assemble(spec, tmp_path / "kit")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "neck" in r.stderr, r.stderr
    advice = _advice(r.stderr)
    assert follow in advice and (follow == "margin") == ("margin" in advice), r.stderr
    keys = {"depth": depth, follow: advice[follow]}
    spec = mesh_spec(tmp_path, OCTA_V, OCTA_F, 'triangle = "0x0488"',
                     'angle = "dihedral"\n' + "".join(f"{k} = {v}\n" for k, v in keys.items()))
    r = assemble(spec, tmp_path / "kit")
    assert r.returncode == 0, r.stderr
    assert "largest overlap 0.00e+00 mm³" in r.stderr


# -- 3. a plate that enters its slot less than sleeve.depth -----------------------------------------


def test_hexagonal_prism_warns_of_the_shallow_hexagons(tmp_path: Path) -> None:
    V = [(36.0 * math.cos(k * math.pi / 3), 36.0 * math.sin(k * math.pi / 3), z) for z in (0.0, 36.0)
         for k in range(6)]
    F = [tuple(range(5, -1, -1)), tuple(range(6, 12))] + [(k, (k + 1) % 6, (k + 1) % 6 + 6, k + 6) for k in range(6)]
    spec = mesh_spec(tmp_path, V, F, 'hexagon = "0x0488"\nsquare = "0x0488"', 'angle = "dihedral"\nmargin = 2.8')
    r = assemble(spec, tmp_path / "kit")
    assert r.returncode == 0, r.stderr
    E = json.loads((tmp_path / "kit" / "manifest.json").read_text(encoding="utf-8"))["skeleton_edge_mm"]
    # the part's slots are set back by a square's apothem difference, a hexagon's is √3 / 1 of it
    shallow = 3.0 - 0.5 * (E - 36.0) * (math.sqrt(3.0) - 1.0)
    warnings = [line for line in r.stderr.splitlines() if line.startswith("fabpat: warning: plate H")]
    assert len(warnings) == 1, r.stderr  # one line for the S-HQ part (S-QQ holds squares only)
    assert f"only {shallow:.2f} mm of sleeve.depth = 3 mm" in warnings[0] and "(S-HQ)" in warnings[0]
    manifest = json.loads((tmp_path / "kit" / "manifest.json").read_text(encoding="utf-8"))
    assert any("only" in w and "S-HQ" in w for w in manifest["warnings"])


# -- 4. a single face -------------------------------------------------------------------------------


def test_single_face_kit_reports_no_sleeve_checks_not_inf(tmp_path: Path) -> None:
    spec = mesh_spec(tmp_path, *grid(1, 1), 'square = "0x0488"', "margin = 2.8")
    r = assemble(spec, tmp_path / "kit")
    assert r.returncode == 0, r.stderr
    assert not re.search(r"\binf\b", r.stderr) and "check: no sleeves (one plate, no shared edge)" in r.stderr
    assert not re.search(r"\binf\b", (tmp_path / "kit" / "bom.md").read_text(encoding="utf-8"))


# -- 5. PLY dialects --------------------------------------------------------------------------------

SQUARE = [(0.0, 0.0, 0.0), (36.0, 0.0, 0.0), (36.0, 36.0, 0.0), (0.0, 36.0, 0.0)]


def _ply_ascii(vprops: list[str], rows: list[str], fprops: list[str], face: str) -> str:
    return "\n".join(["ply", "format ascii 1.0", "comment made by hand", f"element vertex {len(rows)}",
                      *(f"property float {p}" for p in vprops), "element face 1", *fprops, "end_header",
                      *rows, face]) + "\n"


@pytest.mark.parametrize("vprops, fprops, face", [
    (["x", "y", "z"], ["property list uchar int vertex_index"], "4 0 1 2 3"),  # singular
    (["nx", "ny", "nz", "x", "y", "z"], ["property list uchar int vertex_indices"], "4 0 1 2 3"),  # normals first
    (["x", "y", "z"], ["property list uchar int vertex_indices", "property list uchar float texcoord"],
     "4 0 1 2 3 8 0 0 1 0 1 1 0 1"),  # texture coordinates per face corner
])
def test_ply_dialects_are_read(tmp_path: Path, vprops: list[str], fprops: list[str], face: str) -> None:
    rows = [" ".join(["0 0 1"] * (len(vprops) == 6) + [f"{x:g} {y:g} {z:g}"]) for x, y, z in SQUARE]
    (tmp_path / "m.ply").write_text(_ply_ascii(vprops, rows, fprops, face), encoding="utf-8")
    V, F = read_polygon_mesh(tmp_path / "m.ply")
    assert V.tolist() == [list(v) for v in SQUARE] and F == ((0, 1, 2, 3),)


def test_binary_big_endian_ply_with_colours_and_an_edge_element(tmp_path: Path) -> None:
    head = (b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty uchar red\nproperty double z\n"
            b"property double y\nproperty double x\nelement face 1\nproperty uchar flags\n"
            b"property list uchar uint vertex_index\nelement edge 1\nproperty int vertex1\nproperty int vertex2\n"
            b"end_header\n")
    body = b"".join(struct.pack(">Bddd", 7, z, y, x) for x, y, z in SQUARE)
    body += struct.pack(">BB4I", 1, 4, 3, 2, 1, 0) + struct.pack(">ii", 0, 1)
    (tmp_path / "m.ply").write_bytes(head + body)
    V, F = read_polygon_mesh(tmp_path / "m.ply")
    assert V.tolist() == [list(v) for v in SQUARE] and F == ((3, 2, 1, 0),)
    (tmp_path / "m.ply").write_bytes(head + body[:-12])  # cut inside the face
    with pytest.raises(SpecError, match=r"m.ply: cannot read the tiling mesh as PLY: element face row 1 of 1, "
                                        r"property vertex_index: the data ends early"):
        read_polygon_mesh(tmp_path / "m.ply")


@pytest.mark.parametrize("text, message", [
    (_ply_ascii(["nx", "ny", "nz"], ["0 0 1"] * 4, ["property list uchar int vertex_indices"], "4 0 1 2 3"),
     r"the vertex element has no scalar x, y and z \(it has nx, ny, nz\); accepted: x, y, z in any order"),
    (_ply_ascii(["x", "y", "z"], ["0 0 0"] * 4, ["property list uchar int vertex_indexes"], "4 0 1 2 3"),
     r"the face element has no list vertex_indices or vertex_index \(it has vertex_indexes\)"),
    ("ply\nformat binary_middle_endian 1.0\nend_header\n", r"format binary_middle_endian: accepted ascii, "),
    ("solid cube\n", r"not a PLY file"),
    ("", r"not a PLY file"),
])
def test_bad_ply_is_one_line_naming_what_is_accepted(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "m.ply").write_text(text, encoding="utf-8")
    with pytest.raises(SpecError, match=r"m.ply: cannot read the tiling mesh as PLY: " + message) as e:
        read_polygon_mesh(tmp_path / "m.ply")
    assert "\n" not in str(e.value)


# -- 6. a sheared mesh with a loose tolerance -------------------------------------------------------

CUBE_V = [(0, 0, 0), (36, 0, 0), (36, 36, 0), (0, 36, 0), (0, 0, 36), (36, 0, 36), (36, 36, 36), (0, 36, 36)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]


def sheared_cube(shear: float) -> list:
    return [(float(x + shear * z), float(y), float(z)) for x, y, z in CUBE_V]


def test_sheared_cube_sleeves_leave_the_web_at_their_printed_angle(tmp_path: Path) -> None:
    """Its joints of 87.14° are printed at 87.1° (one part per 0.1°): the skeleton must leave the web at
    87.1°, not only at 87.14° (which failed, unattributed: "sleeve setback 2.127 mm leaves a web thinner
    than the wall")."""
    spec = load_spec(mesh_spec(tmp_path, sheared_cube(0.05), CUBE_F, 'square = "0x0488"',
                               'angle = "dihedral"\nmargin = 2.8', 'tolerance = 10.0\nfit = "best"'))
    asm = place(spec, ["0x0488"] * 6)
    assert {round(math.degrees(s.angle), 6) for s in asm.sleeves} == {87.1, 90.0, 92.9}
    for sleeve in asm.sleeve_types.values():  # the web formula of the sleeve's docstring, at the printed angle
        assert sleeve.setback >= required_setback(sleeve.dihedral, 2.0, 0.2, 1.2) - 1e-12


def test_sheared_cube_off_its_slots_names_the_face_and_the_tolerance(tmp_path: Path) -> None:
    spec = mesh_spec(tmp_path, sheared_cube(0.05), CUBE_F, 'square = "0x0488"', 'angle = "dihedral"\nmargin = 2.8',
                     "tolerance = 10.0")
    r = assemble(spec, tmp_path / "kit")
    assert r.returncode == 2 and not (tmp_path / "kit").exists()
    line = r.stderr.strip()
    assert "\n" not in line and re.search(r"m.obj: face \d \(plate Q\d\) sits [0-9.]+ mm off the slot of sleeve "
                                          r"E\d+ at the edge between vertices \d and \d", line), line
    tol = float(re.search(r"refuses the face at tiling.tolerance < ([0-9.]+) mm", line)[1])
    # the sheared faces' far corners move 1.8 mm (5 % of 36 mm); the best-superposed square takes up part of
    # that; the slot takes 0.1 mm (sleeve.clearance / 2)
    assert 0.1 < tol < 1.8
    spec.write_text(spec.read_text(encoding="utf-8").replace("tolerance = 10.0", f"tolerance = {0.99 * tol:.4f}"),
                    encoding="utf-8")
    with pytest.raises(SpecError, match=r"m.obj: (face \d is not a regular 4-gon|the edge between)"):
        load_spec(spec)


# -- 7. the best fit's default tolerance within the range -------------------------------------------


def test_best_fit_tolerance_range_holds_its_default_at_any_edge(tmp_path: Path) -> None:
    V = [(0.0, 0.0, 0.0), (60.0, 0.0, 0.0), (60.0, 60.0, 0.0), (0.0, 60.0, 0.0)]

    def parse(tiling: str):  # noqa: ANN202 - an AssemblySpec
        write_obj(tmp_path / "m.obj", V, [(0, 1, 2, 3)])
        return parse_spec({"tiling": {"kind": "mesh", "file": "m.obj", "fit": "best", **tiling},
                           "patterns": {"square": "0x0488"}}, str(tmp_path / "spec.toml"))

    assert parse({}).tiling.tolerance == pytest.approx(12.0)  # 0.2 × 60 mm: over the old 10 mm bound
    assert parse({"tolerance": 12.0}).tiling.tolerance == 12.0  # refused before: "must be in [1e-06, 10] mm"
    assert parse({"tolerance": 30.0}).tiling.tolerance == 30.0
    with pytest.raises(SpecError, match=r"tiling.tolerance = 30.5 mm must be in \[1e-06, 0.5 × the edge = 30\] mm"):
        parse({"tolerance": 30.5})
    with pytest.raises(SpecError, match=r"tiling.tolerance = 1e-07 mm must be in \[1e-06, "):
        parse({"tolerance": 1e-7})
