"""Regressions from a new user's pass over the Python front door and the commands whose stdout is data:
exact notebook pictures, callable modules that describe their call, clear errors, suffix checks."""

from __future__ import annotations

import inspect
import json
import os
import pydoc
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import fabpat
from fabpat.errors import ExportError, FabpatError, GeometryError, PatternError
from fabpat.geometry.outline import Outline

ROOT = Path(__file__).resolve().parents[1]


def _commands(svg: str) -> set[str]:
    d = ET.fromstring(svg.split("\n", 1)[1]).find("{http://www.w3.org/2000/svg}path").get("d")
    return set(re.findall(r"[A-Za-z]", d))


def _viewbox(svg: str) -> list[float]:
    return [float(v) for v in ET.fromstring(svg.split("\n", 1)[1]).get("viewBox").split()]


@pytest.fixture(scope="module")
def fp():  # noqa: ANN201
    return fabpat.pattern("0x0488").fillet(weight=0.2)


def test_outline_picture_is_exact_and_framed_like_the_filleted_pattern(fp) -> None:  # noqa: ANN001
    o, f = fp.outline._repr_svg_(), fp._repr_svg_()
    assert _commands(o) == _commands(f) and "A" in _commands(o) and "C" not in _commands(o)
    # the same frame: the polygon's extent, centred, and the grey polygon drawn in both
    assert _viewbox(o) == _viewbox(f) and _viewbox(o)[0] == -_viewbox(o)[2] / 2
    assert o.count("<polygon") == f.count("<polygon") == 1
    # a free-standing outline (no polygon) is framed by its bounding box, still with exact arcs
    free = Outline(fp.outline.outer, fp.outline.holes)
    x0, y0, w, h = _viewbox(free._repr_svg_())
    lo, hi = free.bbox
    assert x0 < lo[0] and x0 + w > hi[0] and y0 < -hi[1] and y0 + h > -lo[1]
    assert "A" in _commands(free._repr_svg_()) and "C" not in _commands(free._repr_svg_())


def test_exact_svg_export_is_the_documented_option(fp, tmp_path: Path) -> None:  # noqa: ANN001
    doc = (ROOT / "docs" / "python-api.md").read_text()
    assert "exact arcs" not in re.findall(r'fp\.export\("plate\.svg"\).*', doc)[0]
    for field in ("dxf_entities", "svg_curves", "origin"):
        assert f"`{field}`" in doc
    fp.export(tmp_path / "c.svg")
    fp.export(tmp_path / "e.svg", svg_curves="exact")
    assert " C " in (tmp_path / "c.svg").read_text() and " A " not in (tmp_path / "c.svg").read_text()
    assert " A " in (tmp_path / "e.svg").read_text()


def test_simulate_stdout_is_only_data_in_text_mode(tmp_path: Path) -> None:
    vtu, png = tmp_path / "x.vtu", tmp_path / "x.png"
    r = subprocess.run([sys.executable, "-m", "fabpat", "simulate", "0x0488", "--scenario", "Cantilever",
                        "--h", "3.5", "--linear", "--vtu", str(vtu), "--png", str(png)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 1 and all("=" in tok for tok in lines[0].split())
    assert dict(tok.split("=", 1) for tok in lines[0].split())["scenario"] == "cantilever"
    assert f"wrote {vtu}" in r.stderr and f"wrote {png}" in r.stderr and vtu.exists() and png.exists()


@pytest.mark.parametrize("tol", [-1, 0, "a", None])
def test_bad_tolerance_is_a_geometry_error(fp, tol) -> None:  # noqa: ANN001
    with pytest.raises(GeometryError, match=r"^tol .*\[1e-05, 1\] mm"):
        fp.min_width(tol)
    with pytest.raises(FabpatError):
        fp.outline.flatten(tol)


def test_callable_modules_describe_their_call() -> None:
    from fabpat.catalog import catalog
    from fabpat.patterns.library import library, pattern

    for module, func in ((fabpat.library, library), (fabpat.pattern, pattern), (fabpat.catalog, catalog)):
        sig = inspect.signature(module)
        assert sig == inspect.signature(func) and "args" not in str(sig)
        doc = module.__doc__
        assert doc.index(inspect.getdoc(func)[:40]) < doc.index("The module")
        text = pydoc.render_doc(module, renderer=pydoc.plaintext)
        assert str(sig).split(",")[0] in text and inspect.getdoc(func).split("\n")[0] in text
    assert "sample" in str(inspect.signature(fabpat.library)) and "depth" in str(inspect.signature(fabpat.pattern))


#: in a fresh interpreter: ``fabpat.design`` first, then (the submodules forgotten) the submodule import first
_FRONT_DOOR = """
import inspect, sys, fabpat
from fabpat.errors import FabpatError

def check(order):
    from fabpat.design.api import design
    same = inspect.signature(fabpat.design) == inspect.signature(design)
    try:
        fabpat.design(object(), "no.toml")
    except FabpatError as e:
        print(order, same, type(e).__name__)

fabpat.design
check("attribute-first")
for name in [m for m in sys.modules if m.startswith("fabpat.design")]:
    del sys.modules[name]
del fabpat.design
from fabpat.design import design  # the import system sets fabpat.design to the submodule here
check("submodule-first")
"""


def test_design_is_the_call_whichever_import_comes_first() -> None:
    """``from fabpat.design import design`` binds the submodule to ``fabpat.design`` (today's main: "'module'
    object is not callable"); the call must survive it, and ``fabpat.assemble`` is the kit's front door."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = subprocess.run([sys.executable, "-c", _FRONT_DOOR], capture_output=True, text=True, env=env, timeout=60)
    assert run.stdout.split() == ["attribute-first", "True", "TargetError", "submodule-first", "True", "TargetError"], \
        run.stderr.strip().splitlines()[-1:]
    from fabpat.assembly.kit.build import assemble

    assert fabpat.assemble is assemble and "assemble" in dir(fabpat)


def test_stp_suffix_is_step(fp, tmp_path: Path) -> None:  # noqa: ANN001
    from fabpat.exchange.registry import format_of

    assert format_of("a.stp") == format_of("a.STP") == format_of("a.Step") == "step"
    out = fp.export(tmp_path / "p.stp")
    assert out.read_text().startswith("ISO-10303-21;")
    with pytest.raises(ExportError, match=r"\.step \.stp \.stl"):
        fp.export(tmp_path / "p.foo")


def test_result_files_refuse_wrong_suffixes(fp, tmp_path: Path) -> None:  # noqa: ANN001
    r = fabpat.simulate(fp, "CANTILEVER", h=3.5, linear=True)
    assert r.scenario == "cantilever"
    with pytest.raises(ExportError, match=r"must end in \.vtu"):
        r.to_vtu(tmp_path / "x.txt")
    with pytest.raises(ExportError, match=r"must end in \.png"):
        r.to_png(tmp_path / "x.svg")
    assert list(tmp_path.iterdir()) == []
    res = subprocess.run([sys.executable, "-m", "fabpat", "simulate", "0x0488", "--scenario", "dome",
                          "--vtu", str(tmp_path / "bad.txt")], capture_output=True, text=True)
    assert res.returncode == 2 and "--vtu must end in .vtu" in res.stderr and res.stderr.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_empty_catalog_filter_says_what_the_catalog_holds() -> None:
    with pytest.raises(fabpat.CatalogError, match="holds sides=5 depth=2.*sides=6 depth=2"):
        fabpat.catalog(sides=4)
    res = subprocess.run([sys.executable, "-m", "fabpat", "catalog", "--sides", "4", "--format", "json"],
                         capture_output=True, text=True)
    assert res.returncode == 2 and res.stdout == ""
    assert "holds sides=5" in res.stderr and "; sides=6 depth=2" in res.stderr
    assert "empty catalog" not in res.stderr
    for sides in (5, 6):  # both shipped polygons: the library count (paper §3.2) each
        ok = subprocess.run([sys.executable, "-m", "fabpat", "catalog", "--sides", str(sides), "--format", "json"],
                            capture_output=True, text=True, check=True)
        assert len(json.loads(ok.stdout)) == 430


def test_binary_looking_id_is_named_so() -> None:
    with pytest.raises(PatternError, match="not a hex ID") as info:
        fabpat.pattern("0b1")
    assert "3 hex digits" not in str(info.value)


def test_sampled_library_header_counts_slices_not_draws() -> None:
    res = subprocess.run([sys.executable, "-m", "fabpat", "library", "--depth", "3", "--sample", "3", "--no-fillet"],
                         capture_output=True, text=True, check=True)
    header = res.stdout.splitlines()[0]
    assert "2^64 − 1 slices" in header and "4096" not in header


def test_part_is_exported_and_docs_do_not_mention_issues(fp) -> None:  # noqa: ANN001
    from fabpat.exchange.registry import Part

    assert fabpat.Part is Part and "Part" in dir(fabpat)
    assert fabpat.Part(fp.outline, support=fp.interface_arcs).support == fp.support_arcs
    hits = [f"{p.name}:{n}" for p in (ROOT / "docs").rglob("*.md")
            for n, line in enumerate(p.read_text().splitlines(), 1) if re.search(r"\bissues?\b", line, re.I)]
    assert hits == []
