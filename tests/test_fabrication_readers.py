"""fabpat's DXF and SVG files opened by the Debian programs makers use, headless.

* OpenSCAD (package ``openscad``) imports the DXF, extrudes it 2 mm and exports an STL whose volume
  (computed here from the triangles) must be 2 × the exact area within 2 × perimeter × tolerance:
  LINE + ARC files (R12 and R2010 with ``entities="segments"``); the arc tessellation is made fine
  with ``$fa`` = 0.5° (chords within 1e-5 × radius). A kit sheet without its border imports as its
  CUT layer alone; with ``[sheet] dxf_entities = "segments"`` its volume is the plates' exact one.
* LibreCAD (package ``librecad``): ``librecad dxf2pdf`` must finish (it hung on the old one-SPLINE-
  per-loop files) and write a PDF, for every curve mode.
* Inkscape's DXF importer (``dxf_input.py`` from package ``inkscape``, run with the system Python as
  Inkscape runs it) must turn the LINE + ARC outline into paths enclosing the exact area.
* Inkscape (``inkscape --query-all``) must place the default SVG's cut path on its page.

Each test is skipped, naming the package, when the program is missing.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from fabpat.exchange.dxf import write_dxf
from fabpat.exchange.svg import write_svg

INKSCAPE_EXTENSIONS = Path("/usr/share/inkscape/extensions")
TOL = 0.01


def needs(program: str, package: str) -> str:
    path = shutil.which(program)
    if path is None:
        pytest.skip(f"{program} not installed (Debian package {package})")
    return path


@functools.cache
def library_outline(pattern_id: str, sides: int = 6):  # noqa: ANN201
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import enumerate_library

    return fillet_pattern(enumerate_library(sides, 2).pattern(pattern_id, 36.0), 0.2).outline


def stl_volume(path: Path) -> float:
    """Signed volume of a (binary or ASCII) STL: Σ v0 · (v1 × v2) / 6."""
    data = path.read_bytes()
    if data[:5] == b"solid" and b"facet" in data[:300]:
        V = [[float(x) for x in line.split()[1:4]] for line in data.decode().splitlines()
             if line.strip().startswith("vertex")]
        T = np.array(V).reshape(-1, 3, 3)
    else:
        n = int.from_bytes(data[80:84], "little")
        rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
        T = np.frombuffer(data[84:84 + 50 * n], dtype=rec)["v"].astype(np.float64)
    return float(np.einsum("ij,ij->i", T[:, 0], np.cross(T[:, 1], T[:, 2])).sum() / 6.0)


def openscad_volume(dxf: Path, tmp_path: Path, layer: str | None = None) -> float:
    exe = needs("openscad", "openscad")
    which = f', layer="{layer}"' if layer else ""
    scad = tmp_path / "import.scad"
    scad.write_text(f'linear_extrude(height=2) import(file="{dxf}"{which}, $fn=0, $fa=0.5, $fs=0.01);\n')
    stl = tmp_path / "import.stl"
    r = subprocess.run([exe, "-o", str(stl), str(scad)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-500:]
    return stl_volume(stl)


@pytest.mark.parametrize(("pattern_id", "options"), [
    ("0x2d88", {"dxf_version": "R12"}),
    ("0x2d88", {"entities": "segments"}),
    ("0x2508", {"entities": "segments", "kerf": 0.15}),
])
def test_openscad_extrudes_line_and_arc_dxf_to_the_exact_volume(tmp_path: Path, pattern_id: str,
                                                                 options: dict) -> None:
    import math

    outline = library_outline(pattern_id)
    dxf = write_dxf(outline, tmp_path / "p.dxf", pattern_id, tolerance=TOL, **options)
    volume = openscad_volume(dxf, tmp_path)
    d = 0.5 * options.get("kerf", 0.0)
    # With a kerf the area grows by perimeter × d, give or take the O(d²) corner terms.
    exact = 2.0 * (outline.area + outline.perimeter * d)
    slack = 2.0 * (outline.perimeter * TOL + (40 * math.pi * d * d if d else 0.0))
    assert abs(volume - exact) <= slack, (volume, exact)


def test_openscad_imports_a_borderless_kit_sheet_as_its_plates(tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.kit.sheets import nest_plates, sheet_document
    from fabpat.assembly.place.parts import PartLibrary
    from fabpat.assembly.spec.load import parse_spec

    needs("openscad", "openscad")
    spec = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 2},
            "patterns": {"pattern": "0x2508"}, "sheet": {"width": 170.0, "height": 90.0}}
    lib = PartLibrary(*plan(parse_spec(spec)))
    nesting = nest_plates(lib.assembly)
    volumes = {}
    for border in (True, False):
        sp = lib.assembly.spec
        asm = dataclasses.replace(lib.assembly, spec=dataclasses.replace(
            sp, sheet=dataclasses.replace(sp.sheet, border=border)))
        path = tmp_path / f"sheet-{border}.dxf"
        sheet_document(asm, nesting, 0, lib.filleted).saveas(path)
        volumes[border] = openscad_volume(path, tmp_path)
    plates = openscad_volume(tmp_path / "sheet-True.dxf", tmp_path, layer="CUT")
    assert plates > 2.0 * library_outline("0x2508").area * 0.9  # at least one plate
    assert volumes[False] == pytest.approx(plates, rel=1e-9)
    assert volumes[True] > 2.0 * 170 * 90 - plates - 1.0  # with the border: a slab with holes


def test_openscad_extrudes_a_segment_kit_sheet_to_the_exact_volume(tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.kit.sheets import nest_plates, sheet_document
    from fabpat.assembly.place.parts import PartLibrary
    from fabpat.assembly.spec.load import parse_spec

    needs("openscad", "openscad")
    spec = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 2},
            "patterns": {"groups": ["0x2508", "0x0488"], "group_columns": 1},
            "sheet": {"width": 170.0, "height": 90.0, "border": False, "dxf_entities": "segments"}}
    lib = PartLibrary(*plan(parse_spec(spec)))
    asm = lib.assembly
    nesting = nest_plates(asm)
    path = tmp_path / "sheet.dxf"
    sheet_document(asm, nesting, 0, lib.filleted).saveas(path)
    outlines = [lib.filleted[asm.plates[i].type].outline for i in nesting.on_sheet(0)]
    assert len(outlines) == 2
    exact = 2.0 * sum(o.area for o in outlines)
    slack = 2.0 * sum(o.perimeter for o in outlines) * asm.spec.curve_tolerance
    volume = openscad_volume(path, tmp_path)
    assert abs(volume - exact) <= slack, (volume, exact)


@pytest.mark.parametrize("options", [{}, {"curves": "spline"}, {"curves": "spline", "kerf": 0.15},
                                     {"dxf_version": "R12"}])
def test_librecad_prints_every_dxf_mode(tmp_path: Path, options: dict) -> None:
    exe = needs("librecad", "librecad")
    dxf = write_dxf(library_outline("0x0488"), tmp_path / "p.dxf", "0x0488", **options)
    pdf = tmp_path / "p.pdf"
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen"}
    r = subprocess.run([exe, "dxf2pdf", "-a", "-o", str(pdf), str(dxf)], capture_output=True, text=True,
                       timeout=60, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-500:]
    assert pdf.read_bytes()[:5] == b"%PDF-"


def _inkscape_dxf_paths(dxf: Path) -> list:  # noqa: ANN001
    """Paths of Inkscape's DXF import, in mm (its output is px at 96/in, y down)."""
    import svgpathtools

    script = INKSCAPE_EXTENSIONS / "dxf_input.py"
    python = shutil.which("python3", path="/usr/bin")
    if not script.exists() or python is None:
        pytest.skip("Inkscape's DXF importer not installed (Debian package inkscape)")
    r = subprocess.run([python, str(script), str(dxf)], capture_output=True, text=True, timeout=120,
                       cwd=INKSCAPE_EXTENSIONS)
    assert r.returncode == 0, r.stderr[-500:]
    from xml.etree import ElementTree

    root = ElementTree.fromstring(r.stdout.encode())
    layers = [g for g in root.iter("{http://www.w3.org/2000/svg}g") if g.get(
        "{http://www.inkscape.org/namespaces/inkscape}label") == "CUT"]
    px = 25.4 / 96.0
    return [svgpathtools.parse_path(p.get("d")).scaled(px) for g in layers
            for p in g.iter("{http://www.w3.org/2000/svg}path")]


def test_inkscape_imports_line_and_arc_dxf_with_the_exact_area(tmp_path: Path) -> None:
    from tests.test_exchange_dxf import chain, solid_area

    pytest.importorskip("svgpathtools")
    outline = library_outline("0x2508")
    paths = _inkscape_dxf_paths(write_dxf(outline, tmp_path / "p.dxf", entities="segments", tolerance=TOL))
    assert paths, "Inkscape dropped the outline"
    import svgpathtools

    def cross(a: complex, b: complex) -> float:
        return (a.conjugate() * b).imag

    pieces = []
    for p in paths:
        for seg in p:
            # ∫ (x dy − y dx)/2 along the piece: chord term for a line; for an elliptical arc
            # c + (rx cos φ, ry sin φ) it is ½ [c × (end − start) + rx ry Δφ].
            if isinstance(seg, svgpathtools.Arc):
                area = 0.5 * (cross(seg.center, seg.end - seg.start)
                              + seg.radius.real * seg.radius.imag * np.radians(seg.delta))
            else:
                assert isinstance(seg, svgpathtools.Line)
                area = 0.5 * cross(seg.start, seg.end)
            pieces.append((np.array([seg.start.real, seg.start.imag]), np.array([seg.end.real, seg.end.imag]), area))
    areas = chain(pieces, directed=False, atol=5e-3)  # Inkscape rounds its arc ends (≈ 1 µm seen)
    assert len(areas) == len(outline.loops)
    assert solid_area(areas) == pytest.approx(outline.area, abs=outline.perimeter * TOL)


def test_inkscape_puts_the_default_svg_on_its_page(tmp_path: Path) -> None:
    exe = needs("inkscape", "inkscape")
    outline = library_outline("0x0488")
    svg = write_svg(outline, tmp_path / "p.svg", "0x0488")
    r = subprocess.run([exe, "--query-all", str(svg)], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "HOME": str(tmp_path)})
    assert r.returncode == 0, r.stderr[-500:]
    rows = {line.split(",")[0]: [float(v) for v in line.split(",")[1:]] for line in r.stdout.splitlines()
            if line.count(",") == 4}
    px = 25.4 / 96.0  # Inkscape reports user units of 1/96 in
    x, y, w, h = (v * px for v in rows["cut"])
    (lo, hi) = outline.bbox
    # The visual box includes the 0.1 mm stroke and its miters at sharp corners (≈ 0.07 mm here).
    assert (x, y) == pytest.approx((1.0, 1.0), abs=0.15)
    assert (w, h) == pytest.approx((hi[0] - lo[0], hi[1] - lo[1]), abs=0.25)
    page_w, page_h = hi[0] - lo[0] + 2.0, hi[1] - lo[1] + 2.0
    assert 0 < x and 0 < y and x + w < page_w and y + h < page_h  # wholly on the page
