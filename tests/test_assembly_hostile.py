"""What a hostile tester broke in assemblies: every spec problem at once, spec files that are not files,
names that break pictures and XML, absurd results, unbounded work, raw exceptions and long reprs."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

from fabpat.errors import ExportError, GeometryError, SolverError, SpecError
from tests.conftest import run_cli
from tests.helpers import invoke

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "assemblies" / "test-small.toml"
STRIP = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
         "patterns": {"groups": ["0x0488", "0x0508", "0x0588"], "group_columns": 1}, "plates": {"thickness": 0.8}}
SHEET = {"width": 170.0, "height": 90.0}


def parse(data: dict, **kw: object):  # type: ignore[no-untyped-def, type-arg]
    from fabpat.assembly.spec.load import parse_spec

    return parse_spec(data, "s.toml", **kw)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def strip_run():  # type: ignore[no-untyped-def]
    """STRIP (no [sheet]) simulated at h = 6 mm, once for the tests that read a finished simulation."""
    from fabpat.assembly.solve.simulation import simulate_assembly

    return simulate_assembly(parse(STRIP), h=6.0)


# -- every problem of a spec at once ---------------------------------------------------------------------

BAD = """name = "x"
bogus = 1
[tiling]
kind = "honeycomb-strip"
edge = -3
rows = 1
columns = 2
foo = 2
[patterns]
pattern = "0x0488"
[plates]
thickness = "thick"
[sheet]
width = 100
"""


def test_every_problem_of_a_spec_is_one_line_in_one_run(tmp_path: Path) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_text(BAD)
    r = run_cli("assemble", str(spec), "--out", str(tmp_path / "kit"))
    assert r.returncode == 2, r.stderr
    lines = r.stderr.splitlines()
    assert all(ln.startswith("fabpat: error: ") for ln in lines), lines
    assert lines[0] == f"fabpat: error: {spec}: 5 problems in the spec:"
    for words in ("unknown key bogus", "unknown key tiling.foo", "tiling.edge = -3", "plates.thickness",
                  "missing key sheet.height"):
        assert sum(words in ln for ln in lines[1:]) == 1, (words, lines)
    assert len(lines) == 6 and sorted(os.listdir(tmp_path)) == ["bad.toml"]


def test_the_library_lists_the_problems() -> None:
    from fabpat.assembly.spec.load import SpecProblems

    with pytest.raises(SpecProblems) as e:
        parse({**STRIP, "tiling": {"kind": "honeycomb-strip", "edge": 0, "rows": 0, "columns": 2},
               "plates": {"process": "weld"}, "sheet": {"width": 100, "height": 100, "kerf": 0.1}})
    assert len(e.value.problems) == 3, e.value.problems  # edge, rows, process (kerf is not blamed on a bad process)
    assert str(e.value).splitlines()[1:] == list(e.value.problems)


def test_one_problem_stays_one_line() -> None:
    with pytest.raises(SpecError) as e:
        parse({**STRIP, "sheet": {**SHEET, "colour": "red"}})
    assert str(e.value) == ("s.toml: unknown key sheet.colour (allowed: width, height, margin, spacing, kerf, border, "
                            "dxf_entities)")


# -- [sheet] is the kit's --------------------------------------------------------------------------------


def test_a_simulation_needs_no_sheet(strip_run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    assert parse(STRIP).sheet is None  # strip_run's spec: simulated without a sheet
    assert strip_run.fields()["plates"] == 3
    with pytest.raises(SpecError, match=r"missing table \[sheet\]"):
        parse(STRIP, need_sheet=True)
    path = tmp_path / "nosheet.toml"
    path.write_text(SMALL.read_text().split("[sheet]")[0])
    r = invoke("assemble", str(path), "--out", str(tmp_path / "kit"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "missing table [sheet]" in r.stderr, r.stderr
    # a short, one-step push: the point is that the command reads a spec without [sheet], not the arch
    r = invoke("simulate-assembly", str(path), "--h", "6", "--end-shortening", "0.005", "--steps", "1",
                "--no-progress")
    assert r.returncode == 0 and "plates=3" in r.stdout, r.stderr


# -- spec files that are not specs -----------------------------------------------------------------------


@pytest.mark.parametrize("case", ["dev-zero", "fifo", "folder", "large", "deep"])
def test_spec_files_that_are_not_specs_are_one_line(tmp_path: Path, case: str) -> None:
    if case == "dev-zero":
        path = Path("/dev/zero")
    elif case == "fifo":
        path = tmp_path / "f.toml"
        os.mkfifo(path)
    elif case == "folder":
        path = tmp_path / "d.toml"
        path.mkdir()
    elif case == "large":
        path = tmp_path / "big.toml"
        path.write_text("# padding\n" * 120_000 + SMALL.read_text())
    else:
        path = tmp_path / "deep.toml"
        path.write_text("a = " + "[" * 3000 + "]" * 3000 + "\n")
    r = run_cli("simulate-assembly", str(path))  # run_cli's timeout guards against a hang
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith("fabpat: error: "), r.stderr
    assert "Traceback" not in r.stderr
    words = {"dev-zero": "not a regular file", "fifo": "not a regular file", "folder": "is a directory",
             "large": "larger than a spec can be", "deep": "nested too deep"}[case]
    assert words in r.stderr, r.stderr


def test_deep_values_in_a_decoded_spec_are_a_spec_error() -> None:
    deep: list = []  # type: ignore[type-arg]
    for _ in range(5000):
        deep = [deep]
    with pytest.raises(SpecError):
        parse({**STRIP, "patterns": {"groups": deep, "group_columns": 1}})


# -- names ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "words"), [("a\x00b", "control character"), ("tab\there", "control character"),
                                              ("x" * 81, "at most 80"), ("   ", "non-empty")])
def test_names_must_be_printable_and_short(name: str, words: str) -> None:
    with pytest.raises(SpecError, match=words) as e:
        parse({**STRIP, "name": name})
    assert "\n" not in str(e.value) and "\x00" not in str(e.value)


@pytest.mark.slow
def test_a_mathtext_name_draws_and_a_unicode_name_is_valid_xml(tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import assemble
    from fabpat.assembly.show.render import picture_size

    for k, name in enumerate(["$\\frac{ $", "Kuppel – Ø 90 mm <&> ✓"]):
        spec = parse({**STRIP, "name": name, "sheet": SHEET, "output": {"formats": ["png", "svg"]}})
        res = assemble(spec, tmp_path / f"kit{k}", predict_h=6.0)  # a coarse prediction: the names are the point
        assert {"assembly.png", "predicted.png", "net.svg"} <= set(res.files)
        for png in ("assembly.png", "predicted.png"):
            assert min(picture_size(tmp_path / f"kit{k}" / png)) > 200
        title = ElementTree.parse(tmp_path / f"kit{k}" / "net.svg").getroot().find("{http://www.w3.org/2000/svg}title")
        assert title is not None and title.text is not None and title.text.startswith(name)


# -- absurd results and unbounded work ---------------------------------------------------------------------


def test_an_absurd_strain_is_not_converged() -> None:
    from fabpat.assembly.solve.simulation import simulate_assembly

    with pytest.raises(SolverError, match="small-strain shell model") as e:
        # h = 7.5 mm: the strain is about 100 % at any mesh (104 % at h = 3, 98 % at 7.5, measured)
        simulate_assembly(parse({**STRIP, "plates": {"thickness": 2.0}}), h=7.5, youngs_modulus=0.001)
    assert "at most 20 %" in str(e.value)


def test_candidates_are_bounded() -> None:
    from fabpat.assembly.spec.load import MAX_CANDIDATES

    sphere = {"tiling": {"kind": "truncated-icosahedron", "edge": 36.0}, "sleeve": {"angle": "flat"}}
    assert parse({**sphere, "patterns": {"rule": "roundest", "candidates": MAX_CANDIDATES}}).patterns.candidates == 20
    with pytest.raises(SpecError, match=r"patterns.candidates = 1000 must be an integer in \[1, 20\]"):
        parse({**sphere, "patterns": {"rule": "roundest", "candidates": 1000}})


def test_memory_is_estimated_before_meshing(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 1 × 1000 strip at h = 6 is inside the 200 000-element limit but needs about 7 GB: on a machine
    with 4 GB free it is refused with one line naming both, before anything is meshed."""
    from fabpat.assembly.solve import simulation, sizing

    spec = parse({**STRIP, "tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 1000},
                  "patterns": {"pattern": "0x0488"}})
    monkeypatch.setattr(sizing, "available_memory", lambda: 4_000_000_000)
    monkeypatch.setattr("fabpat.assembly.solve.strip.strip_setup", lambda *a, **k: pytest.fail("meshed"))
    with pytest.raises(GeometryError) as e:
        simulation.simulate_assembly(spec, h=6.0)
    line = str(e.value)
    assert "\n" not in line and "more than the 4.0 GB" in line, line
    need = float(line.split("about ")[1].split(" GB")[0])
    assert 6.5 < need < 8.5  # ≈ 116 000 elements × 62 kB


def test_memory_is_estimated_against_the_process_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    """Under `ulimit -v 6000000` (RLIMIT_AS, 6 GB) the same strip died of a MemoryError traceback: free memory
    was all the estimate knew."""
    import resource

    from fabpat.assembly.solve import simulation, sizing

    real = resource.getrlimit
    monkeypatch.setattr(resource, "getrlimit", lambda which: (6_000_000_000, resource.RLIM_INFINITY)
                        if which == resource.RLIMIT_AS else real(which))
    room = sizing.available_memory()
    assert room is not None and room < 6_000_000_000  # less what the process has mapped already
    spec = parse({**STRIP, "tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 1000},
                  "patterns": {"pattern": "0x0488"}})
    monkeypatch.setattr("fabpat.assembly.solve.strip.strip_setup", lambda *a, **k: pytest.fail("meshed"))
    with pytest.raises(GeometryError, match=r"more than the [0-5]\.\d GB available to this process .*ulimit -v"):
        simulation.simulate_assembly(spec, h=6.0)


# -- library calls with the wrong types -----------------------------------------------------------------------


def test_library_calls_raise_one_line_errors(strip_run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from fabpat.assembly.kit.build import assemble
    from fabpat.assembly.spec.load import load_spec, parse_spec

    with pytest.raises(SpecError, match="must be a table"):
        parse_spec(None)  # type: ignore[arg-type]
    with pytest.raises(SpecError, match="must be a table"):
        parse_spec("tiling = 1")  # type: ignore[arg-type]
    with pytest.raises(SpecError, match="path of a TOML file"):
        load_spec(None)  # type: ignore[arg-type]
    with pytest.raises(SpecError, match="progress must be a callable"):
        assemble(SMALL, tmp_path / "kit", progress=5)  # type: ignore[arg-type]
    assert not (tmp_path / "kit").exists()
    sim = strip_run
    folder = tmp_path / "a_folder"
    folder.mkdir()
    for write in (sim.to_png, sim.to_vtu):
        with pytest.raises(ExportError, match="it is a folder"):
            write(folder)
    if sys.platform.startswith("linux"):
        with pytest.raises(ExportError, match="not a regular file"):
            sim.to_png("/dev/null")


def test_a_strip_png_takes_no_field(strip_run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(SpecError, match=r"png field must be one of energy, .*, got 'bogus'"):
        strip_run.to_png(tmp_path / "s.png", "bogus")  # was drawn as the profile, the field ignored
    with pytest.raises(SpecError, match=r"png field 'strain' colours a closed assembly's bent shape; a strip's PNG"):
        strip_run.to_png(tmp_path / "s.png", "strain")
    with pytest.raises(SpecError, match="got 5"):
        strip_run.to_png(tmp_path / "s.png", 5)
    with pytest.raises(ExportError, match=r"must end in \.png"):
        strip_run.to_png(tmp_path / "s.jpg")  # PNG bytes under a .jpg name opened as a broken image
    assert list(tmp_path.iterdir()) == []


# -- reprs ----------------------------------------------------------------------------------------------------


def test_a_simulation_reprs_in_one_short_line(strip_run) -> None:  # type: ignore[no-untyped-def]
    sim = strip_run
    text = repr(sim)
    assert "\n" not in text and len(text) < 300, text  # was 104 KB
    f = sim.fields()
    assert text.startswith("AssemblySimulation(kind='honeycomb-strip', name='s', plates=3, sleeves=2, ")
    assert f"nodes={f['nodes']}" in text and f"peak={f['peak']:.3f}" in text
    html = sim._repr_html_()
    assert "<table>" in html and "peak_strain" in html and "plate_energies" not in html and len(html) < 5000
    png = sim._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


# -- hostile tiling meshes: every one refused by name, without a warning or a traceback -------------------

HEX_MESH = {"patterns": {"pattern": "0x0488"}, "plates": {"thickness": 1.0}}


def _mesh_spec(tmp_path: Path, kind: str, file: object) -> SpecError:
    from fabpat.assembly.spec.load import parse_spec

    with pytest.raises(SpecError) as e:
        parse_spec({**HEX_MESH, "tiling": {"kind": kind, "file": file, "edge": 36.0}}, str(tmp_path / "s.toml"))
    assert "\n" not in str(e.value)
    return e.value


@pytest.mark.parametrize("kind", ["mesh", "panel"])
def test_an_off_file_of_only_its_keyword_is_broken_not_an_index_error(tmp_path: Path, kind: str) -> None:
    (tmp_path / "only.off").write_text("OFF\n")
    assert "only.off: broken OFF file" in str(_mesh_spec(tmp_path, kind, "only.off"))


@pytest.mark.parametrize("kind", ["mesh", "panel"])
def test_a_file_that_is_not_a_string_is_one_problem(tmp_path: Path, kind: str) -> None:
    err = _mesh_spec(tmp_path, kind, 5)
    assert str(err).endswith("tiling.file = 5 must be a string"), err  # not also "tiling.file is missing"


@pytest.mark.parametrize("scale, words", [
    (1e300, "has a coordinate of 1.5e+300: beyond 1e+100"),
    (1e-300, "mean edge is 1e-300: below 1e-100"),
])
def test_non_representable_mesh_scales_are_refused_by_name_without_warnings(tmp_path: Path, scale: float,
                                                                           words: str) -> None:
    import warnings

    tri = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.5, 0.8660254037844386, 0.0), (1.5, 0.8660254037844386, 0.0)]
    lines = [f"v {x * scale!r} {y * scale!r} {z!r}" for x, y, z in tri] + ["f 1 2 3", "f 2 4 3"]
    (tmp_path / "m.obj").write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow warnings came before the line
        err = _mesh_spec(tmp_path, "mesh", "m.obj")
    assert words in str(err) and "rescale the mesh" in str(err), err  # not "visits a vertex twice"


SCAN = 160_000  # faces of a scan: a mesh of this many was still in its checks after 300 s
SCANS = {
    "off": f"OFF\n3 {SCAN} 0\n0 0 0\n1 0 0\n0 1 0\n" + "3 0 1 2\n" * SCAN,
    "obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * SCAN,
    "ply": ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {SCAN}\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
            + "3 0 1 2\n" * SCAN),
}


@pytest.mark.parametrize("suffix", sorted(SCANS))
def test_a_mesh_of_too_many_faces_is_refused_before_its_checks(tmp_path: Path, suffix: str) -> None:
    import time

    from fabpat.assembly.surface.mesh_tiling import MAX_MESH_FACES, mesh_tiling, read_polygon_mesh

    path = tmp_path / f"scan.{suffix}"
    path.write_text(SCANS[suffix])
    start = time.perf_counter()
    with pytest.raises(SpecError, match=f"has {SCAN} faces, more than the {MAX_MESH_FACES} plates"):
        read_polygon_mesh(path)  # counted from the header or the face lines, before they are read
    with pytest.raises(SpecError, match=f"has {MAX_MESH_FACES + 1} faces"):
        mesh_tiling(np.zeros((3, 3)), ((0, 1, 2),) * (MAX_MESH_FACES + 1))
    assert time.perf_counter() - start < 2.0  # 0.001–0.2 s idle; the checks of 160 000 faces took minutes


V3 = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.8660254037844386, 0.0]])


@pytest.mark.parametrize("call, words", [
    (lambda: read_polygon_mesh_(None),
     "the tiling mesh must be a file name"),
    (lambda: mesh_tiling_(None, ((0, 1, 2),)), "the vertices must be an (n, 3) array of finite numbers"),
    (lambda: mesh_tiling_("abc", ((0, 1, 2),)), "the vertices must be an (n, 3) array"),
    (lambda: mesh_tiling_(1.5, ((0, 1, 2),)), "the vertices must be an (n, 3) array"),
    (lambda: mesh_tiling_(V3, None), "the faces must be a sequence of vertex loops, got NoneType"),
    (lambda: mesh_tiling_(V3, "abc"), "the faces must be a sequence of vertex loops, got str"),
    (lambda: mesh_tiling_(V3, (1.5,)), "face 1 must be a loop of vertex indices, got float"),
    (lambda: mesh_tiling_(V3, ((0, 1.5, 2),)), "face 1 names vertex 1.5: a vertex index is an integer"),
    (lambda: mesh_tiling_(V3, ((0, 1, 2.0),)), "face 1 names vertex 2.0: a vertex index is an integer"),
    (lambda: mesh_tiling_(V3, ((0, 1, 2),), edge="abc"), "edge must be a finite number of mm (or None), got 'abc'"),
    (lambda: mesh_tiling_(V3, ((0, 1, 2),), tolerance=float("nan")), "tolerance must be a finite number"),
    (lambda: mesh_tiling_(V3, ((0, 1, 2),), fit=None), "fit = None: choose one of exact, best"),
    (lambda: polyhedra_().goldberg(None, 0), "m must be an integer, got None"),
    (lambda: polyhedra_().goldberg(2, "1"), "n must be an integer, got '1'"),
    (lambda: polyhedra_().goldberg(1.5, 0), "m must be an integer, got 1.5"),
    (lambda: polyhedra_().hex_tube(None, 2), "rows must be an integer, got None"),
    (lambda: polyhedra_().hex_tube(3, 2.5), "columns must be an integer, got 2.5"),
    (lambda: polyhedra_().hex_cap("2"), "rings must be an integer, got '2'"),
    (lambda: polyhedra_().hex_cap(1.5), "rings must be an integer, got 1.5"),
    (lambda: polyhedra_().hex_cap(1, None), "centre must be an integer, got None"),
])
def test_the_mesh_helpers_refuse_none_strings_and_floats_by_name(call, words: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(SpecError) as e:
        call()
    assert words in str(e.value), e.value


def mesh_tiling_(*args: object, **kw: object):  # type: ignore[no-untyped-def]
    from fabpat.assembly.surface.mesh_tiling import mesh_tiling

    return mesh_tiling(*args, **kw)  # type: ignore[arg-type]


def polyhedra_():  # type: ignore[no-untyped-def]
    from fabpat.assembly.surface import polyhedra

    return polyhedra


def read_polygon_mesh_(path: object):  # type: ignore[no-untyped-def]
    from fabpat.assembly.surface.mesh_tiling import read_polygon_mesh

    return read_polygon_mesh(path)  # type: ignore[arg-type]
