"""One-piece panels from a flat mesh file (``tiling.kind = "panel"`` with ``tiling.file``).

The meshes are built here from integer lattice coordinates (a few lines of numpy each) and written as
OBJ, OFF or PLY; every expected number comes from something the fusion did not produce: each plate's
own filleted outline and solid (built apart) times its count, the panel of rows × columns hexagons,
OCCT's BRepCheck, and the files as trimesh and ezdxf read them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.helpers import solid_count
from tests.test_assembly_panel import dxf_loops, outer_loops, toml_text

E = 36.0  # mm
A, B = "0x0488", "0x0588"



def chosen_panel(spec):  # noqa: ANN001, ANN201 - a test's shorthand
    """The panel of ``spec`` with the patterns its ``[patterns]`` choose."""
    from fabpat.assembly.choose.choice import face_patterns
    from fabpat.assembly.place.panel import build_panel

    return build_panel(spec, face_patterns(spec))

def write_obj(path: Path, V: np.ndarray, faces: list[tuple[int, ...]]) -> Path:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(V).tolist()]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_off(path: Path, V: np.ndarray, faces: list[tuple[int, ...]]) -> Path:
    lines = ["OFF", f"{len(V)} {len(faces)} 0", *(f"{x!r} {y!r} {z!r}" for x, y, z in np.asarray(V).tolist()),
             *(f"{len(f)} " + " ".join(map(str, f)) for f in faces)]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_ply(path: Path, V: np.ndarray, faces: list[tuple[int, ...]]) -> Path:
    head = ["ply", "format ascii 1.0", f"element vertex {len(V)}", "property double x", "property double y",
            "property double z", f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    lines = head + [f"{x!r} {y!r} {z!r}" for x, y, z in np.asarray(V).tolist()]
    lines += [f"{len(f)} " + " ".join(map(str, f)) for f in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def mesh_of(polygons: list[np.ndarray]) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """Polygons ((n, 2) corners, counter-clockwise) → shared vertices (m, 3) at z = 0 and index loops."""
    index: dict[tuple[int, int], int] = {}
    points: list[np.ndarray] = []
    faces = []
    for P in polygons:
        loop = []
        for p in P:
            key = tuple(np.round(p / 1e-6).astype(int))  # corners of neighbours agree to ~1e-13 mm
            if key not in index:
                index[key] = len(points)
                points.append(p)
            loop.append(index[key])
        faces.append(tuple(loop))
    return np.column_stack([np.array(points), np.zeros(len(points))]), faces


def regular(n: int, centre: tuple[float, float], phase: float) -> np.ndarray:
    """(n, 2) corners of the regular n-gon of edge E about ``centre``, the first at angle ``phase`` (rad)."""
    R = E / (2.0 * math.sin(math.pi / n))
    a = phase + 2.0 * math.pi * np.arange(n) / n
    return np.asarray(centre) + R * np.column_stack([np.cos(a), np.sin(a)])


def squares(rows: int, cols: int) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """rows × cols squares of edge E, row by row from the bottom left, each from its lower left corner."""
    return mesh_of([regular(4, (E * (i + 0.5), E * (j + 0.5)), -0.75 * math.pi)
                    for j in range(rows) for i in range(cols)])


def triangles(rows: int, cols: int) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """A triangle grid: ``rows`` strips of ``cols`` pairs of up and down triangles."""
    h = E * math.sqrt(3.0) / 2.0
    polys = []
    for j in range(rows):
        for i in range(cols):
            x = E * (i + 0.5 * j)
            polys += [regular(3, (x + E / 2, j * h + h / 3), -5 * math.pi / 6),  # apex up
                      regular(3, (x + E, j * h + 2 * h / 3), -math.pi / 2)]  # apex down
    return mesh_of(polys)


def hexagons(rows: int, cols: int) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """rows × cols flat-topped hexagons as the honeycomb strip lays them (column by column, odd columns half
    a hexagon up)."""
    return mesh_of([regular(6, (1.5 * E * c, math.sqrt(3.0) * E * (r + 0.5 * (c % 2))), 0.0)
                    for c in range(cols) for r in range(rows)])


def octagons_and_square() -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """A piece of the 4.8.8 tiling: 2 × 2 octagons of edge E (centres E (1 + √2) apart) round one square."""
    a = E * (1.0 + math.sqrt(2.0))
    octs = [regular(8, (a * i, a * j), math.pi / 8) for j in range(2) for i in range(2)]
    return mesh_of([*octs, regular(4, (a / 2, a / 2), 0.0)])


def squares_under_triangles(cols: int) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """A piece of the elongated triangular tiling 3³.4²: a row of ``cols`` squares under a row of triangles."""
    h = E * math.sqrt(3.0) / 2.0
    polys = [regular(4, (E * (i + 0.5), E / 2), -0.75 * math.pi) for i in range(cols)]
    polys += [regular(3, (E * (i + 0.5), E + h / 3), -5 * math.pi / 6) for i in range(cols)]  # apex up
    polys += [regular(3, (E * (i + 1), E + 2 * h / 3), -math.pi / 2) for i in range(cols - 1)]  # apex down
    return mesh_of(polys)


def spec_of(tmp: Path, mesh: str, patterns: dict, **tiling: object):  # noqa: ANN201 - AssemblySpec
    from fabpat.assembly.spec.load import parse_spec

    data = {"name": "mesh panel", "tiling": {"kind": "panel", "file": mesh, **tiling}, "patterns": patterns,
            "plates": {"thickness": 2.0}, "sheet": {"width": 300.0, "height": 260.0, "border": False},
            "output": {"mesh_tolerance": 0.05, "formats": ["stl", "dxf", "bom"]}}
    return parse_spec(data, str(tmp / "spec.toml"), need_sheet=True)


def plate(pid: str, n: int):  # noqa: ANN201 - FilletedPattern
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    return fillet_pattern(get_pattern(pid, n, 2, E), 0.2)


def plate_volume(pid: str, n: int) -> float:
    """One plate's exact solid (2 mm), built apart from any panel."""
    from fabpat.exchange.cad import make_solid, volume

    fp = plate(pid, n)
    return volume(make_solid(fp.outline, 2.0, fp.support_arcs))


CHECKER = [A, B, A, B, B, A, B, A, A, B, A, B]  # the 3 × 4 squares row by row


@pytest.fixture(scope="module")
def square_spec(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201 - AssemblySpec
    tmp = tmp_path_factory.mktemp("squares")
    write_obj(tmp / "flat.obj", *squares(3, 4))
    return spec_of(tmp, "flat.obj", {"tiles": {f"Q{f + 1:02d}": pid for f, pid in enumerate(CHECKER)}})


@pytest.fixture(scope="module")
def square_panel(square_spec):  # noqa: ANN001, ANN201 - Panel

    return chosen_panel(square_spec)


@pytest.fixture(scope="module")
def square_kit(square_spec, tmp_path_factory: pytest.TempPathFactory) -> Path:  # noqa: ANN001
    from fabpat.assembly.kit.build import assemble

    out = tmp_path_factory.mktemp("square-kit") / "kit"
    assemble(square_spec, out, timestamp="2025-01-01T00:00:00Z")
    return out


def test_a_square_panel_is_its_plates_fused(square_panel) -> None:  # noqa: ANN001
    p = square_panel
    assert p.labels == tuple(f"Q{f:02d}" for f in range(1, 13))
    assert [pt.pattern_id for pt in p.types] == CHECKER and {pt.sides for pt in p.types} == {4}
    area = {pid: plate(pid, 4).outline.area for pid in (A, B)}
    holes = {pid: len(plate(pid, 4).outline.holes) for pid in (A, B)}
    assert p.outline.area == pytest.approx(sum(area[pid] for pid in CHECKER), rel=1e-12)
    # a gap is closed round every inner vertex of the grid: (3 - 1) × (4 - 1) of them
    assert len(p.outline.holes) == sum(holes[pid] for pid in CHECKER) + 6
    assert p.fused.fused == 3 * 3 + 2 * 4 and p.fused.mixed == 0  # 17 shared edges, one polygon


def test_a_square_panel_is_one_valid_solid_of_its_plates_volume(square_panel) -> None:  # noqa: ANN001
    from fabpat.exchange.cad import check_valid, volume

    check_valid(square_panel.solid, "square panel")  # BRepCheck_Analyzer
    assert solid_count(square_panel.solid) == 1
    one = {pid: plate_volume(pid, 4) for pid in (A, B)}
    assert volume(square_panel.solid) == pytest.approx(sum(one[pid] for pid in CHECKER), rel=1e-6)


def test_the_square_kit_is_one_watertight_part_with_one_outer_loop(square_kit: Path, square_panel) -> None:  # noqa: ANN001
    import json

    import trimesh

    manifest = json.loads((square_kit / "manifest.json").read_text())
    assert {"panel.stl", "panel.dxf", "sheets/sheet-01.dxf", "bom.csv", "bom.md"} <= set(manifest["files"])
    assert manifest["tiles"]["Q01"] == f"quad {A}" and manifest["tiles"]["Q02"] == f"quad {B}"
    # the provenance of a kit's manifest: each distinct tile's pattern, how it was chosen, why no energies
    assert [(r["part"], r["sides"], r["chosen_by"]) for r in manifest["patterns"]] == [
        (f"quad {A}", 4, "explicit (patterns.tiles)"), (f"quad {B}", 4, "explicit (patterns.tiles)")]
    assert all(set(r["energies_Nmm"].values()) == {None} and "no energies for 4-gons" in r["note"]
               for r in manifest["patterns"])
    m = trimesh.load(square_kit / "panel.stl", force="mesh")
    assert m.is_watertight and m.is_winding_consistent and len(m.split(only_watertight=False)) == 1
    exact = 2.0 * square_panel.outline.area
    assert abs(m.volume - exact) <= square_panel.outline.perimeter * 0.05 * 2.0  # chords within 0.05 mm
    for name in ("panel.dxf", "sheets/sheet-01.dxf"):
        loops = dxf_loops(square_kit / name)
        assert len(loops) == 1 + len(square_panel.outline.holes) and outer_loops(loops) == 1, name
    bom = (square_kit / "bom.md").read_text()
    assert "12 squares of flat.obj" in bom
    # no catalog holds squares: the energies are blank, and the BOM says why above them
    assert "| – | – | – |" in bom and "the catalog has no energies for 4-gons at depth 2" in bom


def test_a_panel_bom_names_the_sheet_file_only_when_the_kit_writes_it(square_panel) -> None:  # noqa: ANN001
    from fabpat.assembly.kit.panel import nest_panel
    from fabpat.assembly.kit.panel_bom import bom_rows

    nesting, _ = nest_panel(square_panel.spec)
    with_dxf = bom_rows(square_panel, nesting, ["panel.stl", "panel.dxf", "sheets/sheet-01.dxf"])
    without = bom_rows(square_panel, nesting, ["panel.stl"])
    assert square_panel.spec.plates.process == "print"  # the part's file is its STL, the sheet is a print bed
    assert [r.file for r in with_dxf] == ["panel.stl", "sheets/"]
    assert [r.file for r in without] == ["panel.stl", ""]  # formats without dxf: no sheet file is claimed
    assert without[1].count == with_dxf[1].count == 1  # the plan of the sheet is the same


def test_a_hexagon_patch_from_a_file_is_the_rows_by_columns_panel(tmp_path: Path) -> None:
    from fabpat.assembly.spec.load import parse_spec
    from fabpat.exchange.cad import volume

    write_obj(tmp_path / "hex.obj", *hexagons(2, 3))
    mesh = chosen_panel(spec_of(tmp_path, "hex.obj", {"hexagon": A}))
    grid = chosen_panel(parse_spec({"tiling": {"kind": "panel", "edge": E, "rows": 2, "columns": 3},
                                   "patterns": {"pattern": A}}, "grid.toml"))
    assert mesh.labels == tuple(f"H{f}" for f in range(1, 7))
    assert mesh.outline.area == pytest.approx(grid.outline.area, rel=1e-9)
    assert mesh.outline.perimeter == pytest.approx(grid.outline.perimeter, rel=1e-9)
    assert len(mesh.outline.holes) == len(grid.outline.holes) and mesh.fused.fused == grid.fused.fused
    assert volume(mesh.solid) == pytest.approx(volume(grid.solid), rel=1e-9)
    assert volume(mesh.solid) == pytest.approx(6 * plate_volume(A, 6), rel=1e-6)


def test_a_triangle_grid_from_an_off_file(tmp_path: Path) -> None:
    from fabpat.assembly.place.panel import joints, relink_angles

    V, faces = triangles(2, 3)
    write_off(tmp_path / "tri.off", V, faces)
    p = chosen_panel(spec_of(tmp_path, "tri.off", {"triangle": B}))
    assert len(p.types) == 12 and p.labels[0] == "T01" and p.fused.fused == 13
    assert p.outline.area == pytest.approx(12 * plate(B, 3).outline.area, rel=1e-12)
    degree = np.bincount(np.concatenate(faces))
    inner = int((degree == 6).sum())  # a vertex of six triangles inside the grid
    assert len(p.outline.holes) == 12 * len(plate(B, 3).outline.holes) + inner
    assert relink_angles(p.plates, joints(p.tiling)).max() < 1e-9


@pytest.mark.parametrize(("build", "pats", "sides", "mixed"), [
    (lambda: squares_under_triangles(3), {"square": A, "triangle": B}, {4: 3, 3: 5}, 3),
    (octagons_and_square, {"octagon": A, "square": B}, {8: 4, 4: 1}, 4),
])
def test_different_polygons_meet_g1_and_fuse(tmp_path: Path, build, pats: dict, sides: dict,  # noqa: ANN001
                                             mixed: int) -> None:
    from fabpat.assembly.place.panel import joints, relink_angles
    from fabpat.assembly.spec.types import POLYGON_KEYS
    from fabpat.exchange.cad import check_valid, volume

    write_ply(tmp_path / "mixed.ply", *build())
    p = chosen_panel(spec_of(tmp_path, "mixed.ply", pats))
    assert {n: sum(pt.sides == n for pt in p.types) for n in sides} == sides
    # the two bow-tie halves of different polygons meet at one point with one tangent: kept as two arcs
    assert p.fused.mixed == mixed and p.fused.mixed_gap[0] < 1e-12 and p.fused.mixed_gap[1] < 1e-12
    assert relink_angles(p.plates, joints(p.tiling)).max() < 1e-9
    check_valid(p.solid, "mixed panel")
    one = {n: plate_volume(pats[POLYGON_KEYS[n]], n) for n in sides}
    assert volume(p.solid) == pytest.approx(sum(k * one[n] for n, k in sides.items()), rel=1e-6)


def test_the_ends_of_a_mesh_panel_along_its_longer_side(square_panel, tmp_path: Path) -> None:  # noqa: ANN001
    from fabpat.assembly.solve.simulation import simulate_assembly

    x = [float(a[0]) for _, _, a, b in square_panel.pins()]
    fixed = len(square_panel.ends()[0])
    # the grid's left and right edges (the plates laid on the exact tiling: within round-off of the file's)
    assert x[:fixed] == pytest.approx([0.0] * 3, abs=1e-9) and x[fixed:] == pytest.approx([4 * E] * 3)
    write_obj(tmp_path / "column.obj", *squares(3, 1))  # longer along y: pushed along y
    spec = spec_of(tmp_path, "column.obj", {"square": A}, edge=E)
    sim = simulate_assembly(spec, h=6.0, steps=2, end_shortening=0.05)
    f = sim.fields()
    assert f["plates"] == 1 and f["sleeves"] == 0 and f["converged"] and f["reaction"] > 0
    assert sim.run.setup.length == pytest.approx(3 * E, rel=1e-9)
    rise = 2.0 / math.pi * math.sqrt(0.05) * 3 * E  # an inextensible half-sine arch shortened by 5 %
    assert f["max_deflection"] == pytest.approx(rise, rel=0.3)


def test_a_mesh_panel_without_two_ends_is_not_pushed(tmp_path: Path) -> None:
    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.errors import SpecError

    write_obj(tmp_path / "one.obj", *squares(1, 1))  # one square is at both ends: nothing to push
    with pytest.raises(SpecError, match="spec.toml: simulate-assembly pushes a panel.s two ends.*share face 1"):
        simulate_assembly(spec_of(tmp_path, "one.obj", {"square": A}), h=6.0, steps=1)


def curved(tmp: Path) -> None:
    V, faces = squares(2, 3)
    R = 100.0  # mm: the grid wrapped round a cylinder along y, every square kept planar and of edge E
    step = 2.0 * math.asin(E / (2.0 * R))
    theta = V[:, 0] / E * step
    write_obj(tmp / "flat.obj", np.column_stack([R * np.sin(theta), V[:, 1], R * (1 - np.cos(theta))]), faces)


@pytest.mark.parametrize(("setup", "tiling", "words"), [
    (curved, {}, "a panel must be flat"),
    (lambda tmp: write_obj(tmp / "flat.obj", *squares(1, 2)), {"rows": 2}, "tiling.file and tiling.rows both"),
    (lambda tmp: None, {}, "cannot read the tiling mesh"),
])
def test_bad_mesh_panels_are_one_line_and_write_nothing(tmp_path: Path, setup, tiling: dict,  # noqa: ANN001
                                                        words: str) -> None:
    setup(tmp_path)
    data = {"tiling": {"kind": "panel", "file": "flat.obj", **tiling}, "patterns": {"pattern": A},
            "sheet": {"width": 300.0, "height": 300.0}}
    spec = tmp_path / "bad.toml"
    spec.write_text(toml_text(data))
    out = tmp_path / "kit"
    r = run_cli("assemble", str(spec), "--out", str(out), "--no-progress")
    assert r.returncode == 2 and words in r.stderr and not out.exists(), r.stderr
    assert len([line for line in r.stderr.splitlines() if line.startswith("fabpat: error")]) == 1
    if words == "a panel must be flat":
        assert 'tiling.kind = "mesh"' in r.stderr


def _moved(V: np.ndarray, k: int, d: np.ndarray) -> np.ndarray:
    V = V.copy()
    V[k] += d
    return V


@pytest.mark.parametrize(("mesh", "words"), [
    (lambda: (_moved(*squares(2, 2)[:1], 4, np.array([0.0, 0.0, 0.5])), squares(2, 2)[1]), "is not planar"),
    (lambda: (_moved(*squares(1, 2)[:1], 5, np.array([3.0, 0.0, 0.0])), squares(1, 2)[1]), "mm long"),
    (lambda: (squares(1, 2)[0], [squares(1, 2)[1][0], squares(1, 2)[1][1][::-1]]), "inconsistent orientation"),
    (lambda: (np.vstack([squares(1, 2)[0], [[E, E / 2, E]]]),
              [*squares(1, 2)[1], (1, 2, 6)]), "non-manifold"),
])
def test_the_mesh_checks_name_the_face_or_edge(tmp_path: Path, mesh, words: str) -> None:  # noqa: ANN001
    from fabpat.errors import SpecError

    write_obj(tmp_path / "m.obj", *mesh())
    with pytest.raises(SpecError, match=words) as err:
        spec_of(tmp_path, "m.obj", {"pattern": A})
    assert "\n" not in str(err.value) and "tiling.file" in str(err.value)


def test_the_patterns_of_a_mesh_panel_are_chosen_by_polygon(tmp_path: Path) -> None:
    from fabpat.assembly.spec.load import parse_spec
    from fabpat.errors import SpecError

    write_obj(tmp_path / "sq.obj", *squares(1, 2))
    with pytest.raises(SpecError, match="names no face of this panel: its faces are square"):
        spec_of(tmp_path, "sq.obj", {"hexagon": A})
    with pytest.raises(SpecError, match="neither tiling.file nor tiling.rows"):
        parse_spec({"tiling": {"kind": "panel", "edge": E}, "patterns": {"pattern": A}}, "none.toml")
    with pytest.raises(SpecError, match="tiling.tolerance applies to a panel from tiling.file"):
        parse_spec({"tiling": {"kind": "panel", "edge": E, "rows": 1, "columns": 2, "tolerance": 0.1},
                    "patterns": {"pattern": A}}, "grid.toml")
    spec = spec_of(tmp_path, "sq.obj", {"square": A})
    assert not spec.tiling.strip and spec.tiling.panel and spec.tiling.pushed and spec.polygon_sides == (4,)


def test_the_shipped_square_panel_spec_parses() -> None:
    from fabpat.assembly.spec.load import load_spec

    root = Path(__file__).resolve().parents[1]
    spec = load_spec(root / "assemblies" / "panel-squares.toml", need_sheet=True)
    assert spec.tiling.panel and spec.tiling.file and len(spec.tiling.faces) == 12 and spec.polygon_sides == (4,)
    assert set(spec.patterns.tiles[0]) == {A, B}
