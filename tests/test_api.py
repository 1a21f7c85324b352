"""The top-level Python API (``fabpat.patterns.library``, ``pattern``, ``simulate``, ``catalog``), the objects'
notebook display, and the errors bad arguments raise."""

from __future__ import annotations

import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import fabpat
from fabpat.errors import ExportError, FabpatError, GeometryError, PatternError, SolverError

DEPTH3_ID = "0xc311aba5e62c0080"  # sample_library(6, 3, 1, seed=0)
SUB_AREA = math.sqrt(3) / 4 * 36.0**2 / 16  # mm²: one depth-2 sub-triangle of the 36 mm hexagon's fan


def test_import_is_lazy_and_dir_lists_the_api() -> None:
    code = ("import sys, fabpat; heavy = [m for m in ('fabpat.patterns.library', 'fabpat.geometry.outline', 'numpy', "
            "'scipy') "
            "if m in sys.modules]; print(heavy, sorted(dir(fabpat)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.startswith("[] ")
    for name in ("library", "pattern", "simulate", "catalog", "Pattern", "FilletedPattern", "FabpatError"):
        assert f"'{name}'" in out


def test_library_is_iterable_indexable_and_sized() -> None:
    lib = fabpat.library(sides=6, depth=2, edge=36.0)
    assert len(lib) == 430 and lib.edge == 36.0  # the paper's count (notes: "The library count")
    first = next(iter(lib))
    assert first.id == lib.ids[0] and lib[0].id == first.id and lib[-1].id == lib.ids[-1]
    assert lib["0x0488"].id == "0x0488" and "0x0488" in lib
    assert sum(1 for _ in lib) == 430
    assert repr(lib) == "Library(sides=6, depth=2, edge=36 mm, 430 patterns)"
    assert fabpat.library(sides=5, depth=1, edge=20.0)[0].edge == 20.0


def test_pattern_infers_depth_and_knows_its_area() -> None:
    p = fabpat.pattern("0x0488")
    assert (p.depth, p.sides, p.edge) == (2, 6, 36.0)
    # 0x0488 = faces 5, 8 and 12 of the slice, six times: 18 sub-triangles
    assert p.metrics.area == pytest.approx(18 * SUB_AREA, rel=1e-12)
    assert repr(p) == f"Pattern('0x0488', sides=6, depth=2, edge=36 mm, area={18 * SUB_AREA:.1f} mm²)"
    deep = fabpat.pattern(DEPTH3_ID)
    assert deep.depth == 3 and deep.id == DEPTH3_ID
    assert fabpat.pattern("0x0488", sides=5, edge=20.0).sides == 5


@pytest.mark.parametrize(
    "call, error, words",
    [
        (lambda: fabpat.pattern("0xzz"), PatternError, "not hexadecimal"),
        (lambda: fabpat.pattern("0x12345"), PatternError, "hex digits"),
        (lambda: fabpat.pattern("0x0001"), PatternError, "not in the"),
        (lambda: fabpat.pattern("0x0488", depth=3), PatternError, "depth 3 needs 16"),
        (lambda: fabpat.pattern("0x0488", sides=2), PatternError, "sides"),
        (lambda: fabpat.pattern("0x0488", edge=-1), PatternError, "edge"),
        (lambda: fabpat.library(depth=3), PatternError, "sampl"),
        (lambda: fabpat.library(depth=3, sample=0), PatternError, "sample size"),
        (lambda: fabpat.library()["0x0001"], PatternError, "not in the"),
        (lambda: fabpat.library()[430], PatternError, "out of range"),
        (lambda: fabpat.library()[1.5], PatternError, "pattern ID"),
        (lambda: fabpat.pattern("0x0488").fillet(weight=0), GeometryError, "weight"),
        (lambda: fabpat.pattern("0x0488").fillet(weight="heavy"), GeometryError, "weight"),
        (lambda: fabpat.simulate(fabpat.pattern("0x0488"), "dome"), SolverError, "FilletedPattern"),
        (lambda: fabpat.simulate(fabpat.pattern("0x0488").fillet(), "twist"), SolverError, "cantilever"),
        (lambda: fabpat.simulate(fabpat.pattern("0x0488").fillet(), "dome", h=0), SolverError, "h = 0 is out of range"),
        (lambda: fabpat.simulate(fabpat.pattern("0x0488").fillet(), "dome", poisson=0.5), SolverError, "poisson"),
        (lambda: fabpat.pattern(0x0488), PatternError, "string"),
        (lambda: fabpat.library(depth=3, sample=2, seed="a"), PatternError, "seed"),
        (lambda: fabpat.pattern("0x0488").fillet().export(5), ExportError, "file name"),
        (lambda: fabpat.pattern("0x0488").fillet().export("p.dxf", kerf="a"), ExportError, "kerf"),
        (lambda: fabpat.pattern("0x0488").fillet().export("p.stl", thickness="a"), ExportError, "thickness"),
        (lambda: fabpat.pattern("0x0488").fillet().outline.plot(ax=5), GeometryError, "Axes"),
        (lambda: fabpat.catalog(5), fabpat.CatalogError, "file name"),
        (lambda: fabpat.catalog(sides="six"), fabpat.CatalogError, "sides"),
        (lambda: fabpat.catalog(colour="red"), fabpat.CatalogError, "colour"),
        (lambda: fabpat.catalog("/nonexistent/c.sqlite"), fabpat.CatalogError, "does not exist"),
    ],
)
def test_bad_arguments_raise_fabpat_errors(call, error: type[FabpatError], words: str) -> None:  # noqa: ANN001
    with pytest.raises(error, match=words) as info:
        call()
    assert isinstance(info.value, FabpatError)


def test_filleted_pattern_knows_its_polygon_and_one_metrics() -> None:
    p = fabpat.pattern("0x0488", sides=5, edge=30.0)
    fp = p.fillet(weight=0.3)
    assert (fp.id, fp.sides, fp.edge, fp.depth, fp.weight) == ("0x0488", 5, 30.0, 2, 0.3)
    frame = fp.outline.polygon
    assert frame.sides == 5 and frame.edge == 30.0 and np.array_equal(frame.interfaces, fp.interface_segments)
    # one name, one type: Pattern.metrics, FilletedPattern.metrics and Outline.metrics are RegionMetrics
    assert type(p.metrics) is type(fp.metrics) is type(fp.outline.metrics) is fabpat.RegionMetrics
    assert fp.metrics is fp.outline.metrics
    assert fp.metrics.ratio == pytest.approx(4 * math.pi * fp.metrics.area / fp.metrics.perimeter**2)
    cols = fp.catalog_columns()
    assert cols["filleted_area"] == fp.metrics.area and 0 < cols["min_width"] < 30
    assert len(fp.support_arcs) == 2 * 5 and all(a.w == pytest.approx(0.3) for a in fp.support_arcs)


def test_pentagon_outline_meshes_without_being_told_its_sides() -> None:
    """Friction: ``mesh_outline`` on a pentagon's outline used to assume a hexagon and fail about h."""
    from fabpat.simulation.mesh import mesh_outline

    fp = fabpat.pattern("0x0488", sides=5).fillet()
    mesh = mesh_outline(fp.outline, 2.0)
    assert len(mesh.interfaces) == 5 and all(len(i) >= 2 for i in mesh.interfaces)
    seg = fp.interface_segments
    for i, nodes in enumerate(mesh.interfaces):  # the tagged nodes lie on that interface segment
        a, b = seg[i]
        t = (mesh.V[nodes] - a) @ (b - a) / ((b - a) @ (b - a))
        assert t.min() == pytest.approx(0, abs=1e-9) and t.max() == pytest.approx(1, abs=1e-9)
    assert mesh_outline(fp, 2.0).n_nodes == mesh.n_nodes  # a FilletedPattern meshes as its outline
    with pytest.raises(GeometryError, match="5-gon"):
        mesh_outline(fp.outline, 2.0, sides=6, edge=36.0)
    bare = type(fp.outline)(fp.outline.outer, fp.outline.holes)  # no polygon frame: must be told
    with pytest.raises(GeometryError, match="pass sides and edge"):
        mesh_outline(bare, 2.0)
    with pytest.raises(GeometryError, match="does not reach interface"):
        mesh_outline(bare, 2.0, 6, 36.0)


def test_export_dispatches_on_the_suffix_like_the_cli(tmp_path: Path) -> None:
    from fabpat.exchange.registry import Part

    fp = fabpat.pattern("0x0488").fillet()
    svg = fp.export(tmp_path / "p.svg")
    assert svg == tmp_path / "p.svg" and ET.parse(svg).getroot().get("width").endswith("mm")
    dxf = fp.export(tmp_path / "p.dxf", kerf=0.15, curves="lines", curve_tolerance=0.05)
    import ezdxf

    assert {e.dxf.layer for e in ezdxf.readfile(dxf).modelspace()} >= {"CUT"}
    stl = fp.export(tmp_path / "p.stl", thickness=3.0, mesh_tolerance=0.01)
    import trimesh

    vol = trimesh.load(stl).volume
    assert vol == pytest.approx(3.0 * fp.metrics.area, rel=1e-3)  # exact area × thickness, chord 0.01 mm
    for bad, words in ((tmp_path / "p.obj", "suffix"), (tmp_path / "p", "suffix")):
        with pytest.raises(ExportError, match=words):
            fp.export(bad)
    with pytest.raises(ExportError, match="unknown export option 'colour'"):
        fp.export(tmp_path / "q.svg", colour="red")
    with pytest.raises(ExportError, match="thickness"):
        fp.export(tmp_path / "q.stl", thickness=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.dxf", "p.stl", "p.svg"]  # no partial file
    # the failing call: the interface arc pairs are flattened by Part itself
    part = Part(fp.outline, support=fp.interface_arcs)
    assert part.support == fp.support_arcs
    with pytest.raises(ExportError, match="support"):
        Part(fp.outline, support=[fp.outline])


def test_export_step_keeps_the_interface_weight(tmp_path: Path) -> None:
    fp = fabpat.pattern("0x0488").fillet(weight=0.2)
    text = fp.export(tmp_path / "p.step").read_text()
    assert "RATIONAL_B_SPLINE_CURVE" in text and "0x0488" in text


def test_a_registered_suffix_is_exported_without_other_changes(tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    """A new registry entry (e.g. ``.3dm`` later) is reachable from ``FilletedPattern.export``."""
    import types

    from fabpat.exchange import registry

    seen = []
    module = types.ModuleType("fabpat.exchange.fake")
    module.write = lambda part, path, settings: (seen.append(part.support), Path(path).write_text(part.name))
    monkeypatch.setitem(sys.modules, "fabpat.exchange.fake", module)
    monkeypatch.setitem(registry.FORMATS, "fake", registry.Format("fake", ".fake", "fake", "print", "test"))
    fp = fabpat.pattern("0x0488").fillet()
    out = fp.export(tmp_path / "p.fake", thickness=2.5)
    assert "0x0488" in out.read_text() and seen == [fp.support_arcs]


def test_notebook_display() -> None:
    p = fabpat.pattern("0x2d88")
    fp = p.fillet()
    for obj in (p, fp, fp.outline):
        root = ET.fromstring(obj._repr_svg_().split("\n", 1)[1])
        assert root.tag.endswith("svg") and root.get("width").endswith("mm")  # true size
        assert len(repr(obj)) < 120 and "array" not in repr(obj)
    # true curves: the elliptic interface arcs (w < 1) are SVG "A" commands, not polylines
    assert " A " in fp._repr_svg_() and " A " in fp.outline._repr_svg_()
    assert float(ET.fromstring(p._repr_svg_().split("\n", 1)[1]).get("width")[:-2]) > 2 * 36.0  # 72 mm across
    html = fabpat.library()._repr_html_()
    assert html.count("<tr>") == 1 + 10 + 1 and "… and 420 more" in html and "0x" in html
    assert repr(fp).startswith("FilletedPattern('0x2d88', sides=6, edge=36 mm, weight=0.2, area=")


def test_outline_plot_draws_the_area() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fp = fabpat.pattern("0x0488").fillet()
    ax = fp.outline.plot()
    patch = ax.patches[0]
    # the drawn path's area (shoelace per loop, holes reversed) is the exact area to the flattening
    area = 0.0
    for poly in patch.get_path().to_polygons(closed_only=True):
        x, y = poly[:, 0], poly[:, 1]
        area += 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    assert abs(area) == pytest.approx(fp.metrics.area, rel=1e-3)
    assert ax.get_aspect() == 1.0
    fig, ax2 = plt.subplots()
    assert fp.plot(ax2) is ax2
    plt.close("all")


def test_simulate_result_and_its_files(tmp_path: Path) -> None:
    from fabpat.simulation.mesh import mesh_outline
    from fabpat.simulation.scenarios import run_scenario

    fp = fabpat.pattern("0x0488").fillet()
    r = fabpat.simulate(fp, "cantilever", h=3.5, linear=True)
    # the same numbers as meshing and running by hand with the paper's set-up
    ref = run_scenario(mesh_outline(fp.outline, 3.5, 6, 36.0), "cantilever", sides=6, nonlinear=False)
    assert r.energy == pytest.approx(ref.energy, rel=1e-12) and r.max_displacement == ref.max_displacement
    # linear: U = F·w/2 at the loaded interface for a point-like line load (Clapeyron), here the
    # work of the tributary nodal forces
    f = r.problem.loads[:, 2]
    work = 0.5 * float(f @ r.result.displacement[:, 2])
    assert r.energy == pytest.approx(work, rel=1e-8)
    assert "energy=" in repr(r) and len(repr(r)) < 160
    vtu = r.to_vtu(tmp_path / "r.vtu")
    import meshio

    m = meshio.read(vtu)
    assert len(m.points) == r.nodes
    png = r.to_png(tmp_path / "r.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    stiff = fabpat.simulate(fp, "cantilever", h=3.5, linear=True, youngs_modulus=2000)
    assert stiff.energy == pytest.approx(r.energy / 2, rel=1e-9)  # linear: U ∝ 1/E under a fixed force


def test_catalog_rows_and_dataframe() -> None:
    rows = fabpat.catalog()
    assert len(rows) == 430 and {"id", "energy_dome", "min_width", "filleted_area"} <= set(rows[0])
    by_id = {r["id"]: r for r in rows}
    # the lattice area column is the closed form: 18 sub-triangles for 0x0488
    assert by_id["0x0488"]["area"] == pytest.approx(18 * SUB_AREA, rel=1e-9)
    with pytest.raises(fabpat.CatalogError, match=r"no catalog energies for squares \(sides = 4\).*fabpat sweep "
                       r"--sides 4 .* holds sides=5 depth=2 edge=36 .*430.*sides=6 depth=2 edge=36 .*430"):
        fabpat.catalog(sides=4)  # not a silent []: the catalog is not empty, it has no squares
    pd = pytest.importorskip("pandas", reason="pandas (optional extra fabpat[pandas]) is not installed")
    df = rows.to_dataframe()
    assert isinstance(df, pd.DataFrame) and df.shape[0] == 430
    assert df.loc["0x0488", "energy_dome"] == by_id["0x0488"]["energy_dome"]


def test_writers_reached_from_pipeline_objects_stay_out_of_the_solver_digest() -> None:
    """``Pattern._repr_svg_``, ``FilletedPattern.export`` and ``ScenarioResult.to_vtu`` import writers
    lazily; those never change a stored number, so editing them must not invalidate a catalog."""
    from fabpat.catalog import builtin_path, pipeline_modules

    names = {p.relative_to(builtin_path().parents[1]).as_posix() for p in pipeline_modules()}
    assert {"geometry/fillet.py", "patterns/pattern.py", "simulation/scenarios.py", "simulation/mesh.py",
            "_callable.py"} <= names
    writers = ("simulation/vtu.py", "simulation/png_result.py", "simulation/inp.py", "io.py", "_moved.py")
    assert not {n for n in names if n.startswith(("exchange/", "views/")) or n in writers}


def test_export_3dm_through_the_registry(tmp_path: Path) -> None:
    """The .3dm writer registered by the Rhino work is reached from ``FilletedPattern.export`` and writes
    what ``fabpat export --3dm`` writes: the CUT curves enclose the exact area (openNURBS sampling)."""
    r3 = pytest.importorskip("rhino3dm", reason="rhino3dm (PyPI) is needed to read .3dm files back")
    from tests.conftest import run_cli
    from tests.test_exchange_rhino import _layers, _on_layer, _sampled_area

    fp = fabpat.pattern("0x0688").fillet(weight=0.35)
    model = r3.File3dm.Read(str(fp.export(tmp_path / "api.3dm", thickness=3.0)))
    assert run_cli("export", "0x0688", "--weight", "0.35", "--thickness", "3", "--3dm",
                   str(tmp_path / "cli.3dm")).returncode == 0
    cli = r3.File3dm.Read(str(tmp_path / "cli.3dm"))
    cut = _on_layer(model, _layers(model)["CUT"])
    assert len(cut) == len(_on_layer(cli, _layers(cli)["CUT"])) == 1 + len(fp.outline.holes)
    assert all(c.Degree == 2 and c.IsRational for c in cut)
    areas = sorted((abs(_sampled_area([c], 64)) for c in cut), reverse=True)
    assert areas[0] - sum(areas[1:]) == pytest.approx(fp.metrics.area, rel=1e-4)


def test_the_flat_module_names_still_import_as_the_same_modules() -> None:
    """Code written before the stage packages keeps working: an old module path imports the module under
    its new one (one object, classes and all), and the new module keeps its own spec."""
    import importlib

    from fabpat._moved import MOVED

    for old, new in MOVED.items():
        assert importlib.import_module(old) is importlib.import_module(new), old
    from fabpat.fillet import FilletedPattern

    from fabpat.geometry import fillet

    assert FilletedPattern is fillet.FilletedPattern and fillet.__spec__.name == "fabpat.geometry.fillet"
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("fabpat.no_such_module")
