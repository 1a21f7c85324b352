"""Library calls with bad arguments raise one FabpatError subclass with a clear line, never a raw
TypeError/ValueError/AttributeError (the hostile-tester cases, then a fuzz of None, text, NaN, inf,
negative numbers and lists through the public entry points, and the bad numbers and ``max_elements`` of the
meshing, solving and export calls)."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

import fabpat
from fabpat.errors import ExportError, FabpatError, GeometryError, PatternError, SolverError
from fabpat.geometry.fillet import fillet_pattern
from fabpat.geometry.outline import Line, Loop, Outline
from fabpat.simulation.scenarios import run_scenario


@pytest.fixture(scope="module")
def fp():
    return fabpat.pattern("0x0488").fillet()


@pytest.fixture(scope="module")
def result(fp):
    return fabpat.simulate(fp, "cantilever", h=3.5, linear=True)


def test_named_cases(fp, result, tmp_path) -> None:
    with pytest.raises(GeometryError, match="fillet_pattern needs a Pattern"):
        fillet_pattern(None)  # type: ignore[arg-type]
    with pytest.raises(SolverError, match="run_scenario needs a ShellMesh"):
        run_scenario(None, "dome")  # type: ignore[arg-type]
    with pytest.raises(ExportError, match="must be a file name"):
        result.to_png(None)
    with pytest.raises(ExportError, match="must be a file name"):
        result.to_vtu(None)
    with pytest.raises(ExportError, match="NUL"):
        fp.export(str(tmp_path / "x.stl\x00.svg"))
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(PatternError, match=r"edge must be a finite number in \[1, 1000\] mm"):
        fabpat.library().pattern("0x0488", edge=math.nan)


def test_min_width_tolerance_is_bounded(fp) -> None:
    # 1e-300 made the ray cast grow to 24 GB; inf flattened every arc to its chord (3.80 mm, not 1.95)
    for tol in (1e-300, 1e-6, math.inf, math.nan, 3.0):
        with pytest.raises(GeometryError, match=r"tol .*\[1e-05, 1\] mm"):
            fp.min_width(tol=tol)
    assert fp.min_width(tol=1e-5) == pytest.approx(1.95, abs=0.01)  # reference: 0x0488's neck, 1.95 mm
    assert fp.min_width(tol=1.0) == pytest.approx(1.95, abs=0.02)
    with pytest.raises(GeometryError, match="finite"):
        fp.outline.flatten(math.inf)


def test_outline_repr_counts_holes() -> None:
    square = Loop(tuple(Line((x0, y0), (x1, y1)) for (x0, y0), (x1, y1) in
                        [((0, 0), (4, 0)), ((4, 0), (4, 4)), ((4, 4), (0, 4)), ((0, 4), (0, 0))]))
    hole = Loop(tuple(Line((x0, y0), (x1, y1)) for (x0, y0), (x1, y1) in
                      [((1, 1), (1, 2)), ((1, 2), (2, 2)), ((2, 2), (2, 1)), ((2, 1), (1, 1))]))
    hole2 = Loop(tuple(Line((x0 + 1.5, y0), (x1 + 1.5, y1)) for s in hole.segments
                       for (x0, y0), (x1, y1) in [(tuple(s.p0), tuple(s.p1))]))
    assert repr(Outline(square)).startswith("Outline(0 holes, 4 segments")
    assert repr(Outline(square, (hole,))).startswith("Outline(1 hole, 8 segments")
    assert repr(Outline(square, (hole, hole2))).startswith("Outline(2 holes, 12 segments")


BAD = [None, "abc", math.nan, math.inf, -math.inf, -1, [1, 2]]


def _entry_points(fp) -> dict[str, Callable[[object], object]]:  # noqa: ANN001
    p = fp.pattern
    lib = fabpat.library()
    return {
        "pattern(id)": lambda x: fabpat.pattern(x),
        "pattern(sides)": lambda x: fabpat.pattern("0x0488", sides=x),
        "pattern(edge)": lambda x: fabpat.pattern("0x0488", edge=x),
        "pattern(depth)": lambda x: fabpat.pattern("0x0488", depth=x),
        "library(sides)": lambda x: fabpat.library(sides=x),
        "library(depth)": lambda x: fabpat.library(depth=x),
        "library(edge)": lambda x: fabpat.library(edge=x),
        "Library.pattern(id)": lambda x: lib.pattern(x),
        "Library.pattern(edge)": lambda x: lib.pattern("0x0488", edge=x),
        "Library.patterns(edge)": lambda x: lib.patterns(edge=x),
        "Library[key]": lambda x: lib[x],
        "Pattern.fillet(weight)": lambda x: p.fillet(x),
        "fillet_pattern(pattern)": lambda x: fillet_pattern(x),
        "simulate(filleted)": lambda x: fabpat.simulate(x, "dome"),
        "simulate(scenario)": lambda x: fabpat.simulate(fp, x, h=3.5),
        "simulate(h)": lambda x: fabpat.simulate(fp, "dome", h=x),
        "simulate(thickness)": lambda x: fabpat.simulate(fp, "dome", h=3.5, thickness=x),
        "simulate(youngs_modulus)": lambda x: fabpat.simulate(fp, "dome", h=3.5, youngs_modulus=x),
        "simulate(poisson)": lambda x: fabpat.simulate(fp, "dome", h=3.5, poisson=x),
        "simulate(max_elements)": lambda x: fabpat.simulate(fp, "dome", h=3.5, max_elements=x),
        "simulate(linear)": lambda x: fabpat.simulate(fp, "dome", h=3.5, linear=x),
        "simulate(extrapolate)": lambda x: fabpat.simulate(fp, "dome", h=3.5, extrapolate=x),
        "run_scenario(mesh)": lambda x: run_scenario(x, "dome"),
        "export(path)": lambda x: fp.export(x),
        "export(thickness)": lambda x: fp.export("unused.stl", thickness=x),
        "min_width(tol)": lambda x: fp.min_width(tol=x),
        "validate(tol)": lambda x: fp.validate(tol=x),
        "catalog_columns(tol)": lambda x: fp.catalog_columns(tol=x),
        "Outline.flatten(tol)": lambda x: fp.outline.flatten(x),
        "Outline.estimate_segments(tol)": lambda x: fp.outline.estimate_segments(x),
        "Outline(outer)": lambda x: Outline(x),
        "Outline(holes)": lambda x: Outline(fp.outline.outer, x),
        "Loop(segments)": lambda x: Loop(x),
    }


#: where None is a documented choice (the default)
NONE_IS_VALID = {"simulate(extrapolate)", "simulate(h)", "pattern(depth)", "Library.pattern(edge)",
                 "Library.patterns(edge)"}


@pytest.mark.parametrize("bad", BAD, ids=repr)
def test_fuzz_raises_fabpat_errors(fp, bad, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)  # an export that wrongly succeeded would land here, not in the repo
    raw = {}
    for name, call in _entry_points(fp).items():
        if bad is None and name in NONE_IS_VALID:
            continue
        try:
            call(bad)
        except FabpatError as e:
            assert "\n" not in str(e) and str(e), (name, str(e))
        except Exception as e:  # noqa: BLE001 — the point: nothing else may escape
            raw[name] = f"{type(e).__name__}: {e}"
        else:
            if not (name == "Library[key]" and bad == -1):  # lib[-1] is the last pattern, as a list's
                raw[name] = "accepted"
    assert raw == {}


def test_api_refuses_bad_numbers() -> None:
    from fabpat.exchange.registry import ExportSettings
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern, sample_library
    from fabpat.simulation.mesh import mesh_outline, solid_polygon_mesh
    from fabpat.simulation.scenarios import run_scenario

    with pytest.raises(PatternError, match=r"edge = -1 is out of range"):
        get_pattern("0x0488", edge=-1)
    with pytest.raises(PatternError, match="edge"):
        get_pattern("0x0488", edge=math.nan)
    with pytest.raises(PatternError, match="seed"):
        sample_library(6, 3, 2, seed=-1)
    mesh = solid_polygon_mesh(6, 36.0, h=9.0)
    with pytest.raises(FabpatError, match=r"thickness = -2 is out of range"):
        run_scenario(mesh, "cantilever", sides=6, thickness=-2.0)
    for kw in ({"E": math.inf}, {"nu": 0.5}, {"edge": math.nan}):
        with pytest.raises(FabpatError):
            run_scenario(mesh, "cantilever", sides=6, **kw)
    fp = fillet_pattern(get_pattern("0x0488"))
    with pytest.raises(GeometryError, match="weight"):
        fillet_pattern(get_pattern("0x0488"), 1e9)
    with pytest.raises(FabpatError, match="h must be a finite"):
        mesh_outline(fp.outline, math.nan)
    with pytest.raises(ExportError, match="mesh tolerance"):
        ExportSettings(mesh_tolerance=math.inf).check()


@pytest.mark.parametrize("value", [0, -1, 10**19, "36", None, float("inf")])
def test_api_max_elements_is_checked(value: object) -> None:
    import fabpat as api

    fp = api.pattern("0x0488").fillet()
    with pytest.raises(FabpatError, match="max_elements"):
        api.simulate(fp, "dome", h=3, max_elements=value)  # type: ignore[arg-type]
