"""Binary STL (OCCT mesher and writer) read back by trimesh; 3MF (our writer) read back by trimesh,
by the standard library's XML parser and by lib3mf (the 3MF consortium's reference library); the triangle
estimate checked before meshing bounds the STL's count."""

from __future__ import annotations

import math
import struct
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

from fabpat.exchange import cad
from fabpat.exchange.stl import write_stl
from fabpat.exchange.threemf import write_3mf
from tests.test_cad import SHAPES, rounded_square, rounded_square_area

trimesh = pytest.importorskip("trimesh")


@pytest.mark.parametrize("name", list(SHAPES))
def test_stl_is_watertight_with_volume_within_0_1_percent(tmp_path: Path, name: str) -> None:
    make, area = SHAPES[name]
    path = write_stl(cad.make_solid(make(), 2.0), tmp_path / "p.stl")
    data = path.read_bytes()
    (n,) = struct.unpack("<I", data[80:84])
    assert len(data) == 84 + 50 * n  # binary STL
    m = trimesh.load(path, file_type="stl")
    assert m.is_watertight and m.is_winding_consistent and m.is_volume
    assert m.volume == pytest.approx(2.0 * area(), rel=1e-3)


def test_stl_tolerance_is_in_millimetres(tmp_path: Path) -> None:
    """A 2 m plate with 300 mm corner radii still meets 0.01 mm: a size-relative tolerance would not."""
    big = rounded_square(1000.0, 300.0)
    path = write_stl(cad.make_solid(big, 2.0), tmp_path / "big.stl", tolerance=0.01)
    m = trimesh.load(path, file_type="stl")
    deficit = 2.0 * rounded_square_area(1000.0, 300.0) - m.volume
    arc_length = 2 * math.pi * 300.0
    # Chords of convex arcs lie inside: 0 < deficit ≤ (2/3 · sagitta) × arc length × thickness.
    assert 0 < deficit <= 0.01 * arc_length * 2.0
    # Facet count is set by the chord height: each quarter arc needs ≥ (π/2) / (2 acos(1 − tol/R)).
    assert len(m.faces) > 4 * (math.pi / 2) / (2 * math.acos(1 - 0.01 / 300.0))
    coarse = trimesh.load(write_stl(cad.make_solid(big, 2.0), tmp_path / "c.stl", tolerance=1.0), file_type="stl")
    assert len(coarse.faces) < len(m.faces)


def _read_3mf_stdlib(path: Path) -> tuple[np.ndarray, np.ndarray, ElementTree.Element]:
    with zipfile.ZipFile(path) as z:
        assert {"[Content_Types].xml", "_rels/.rels", "3D/3dmodel.model"} <= set(z.namelist())
        root = ElementTree.fromstring(z.read("3D/3dmodel.model"))
    ns = {"m": "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"}
    V = np.array([[float(v.get(k)) for k in "xyz"] for v in root.iterfind(".//m:vertex", ns)])  # type: ignore[arg-type]
    F = np.array([[int(t.get(k)) for k in ("v1", "v2", "v3")] for t in root.iterfind(".//m:triangle", ns)])  # type: ignore[arg-type]
    return V, F, root


@pytest.mark.parametrize("name", list(SHAPES))
def test_3mf_reads_back_watertight_in_millimetres(tmp_path: Path, name: str) -> None:
    make, area = SHAPES[name]
    path = write_3mf(cad.make_solid(make(), 2.0), tmp_path / "p.3mf", "fabpat <test> & co")
    V, F, root = _read_3mf_stdlib(path)
    assert root.get("unit") == "millimeter"
    obj = root.find(".//{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}object")
    assert obj is not None and obj.get("name") == "fabpat <test> & co"
    m = trimesh.Trimesh(V, F, process=False)
    assert m.is_watertight and m.is_winding_consistent and m.volume == pytest.approx(2.0 * area(), rel=1e-3)


def test_3mf_loads_in_trimesh(tmp_path: Path) -> None:
    pytest.importorskip("lxml")  # trimesh's 3MF loader needs lxml and networkx
    pytest.importorskip("networkx")
    path = write_3mf(cad.make_solid(rounded_square(), 2.0), tmp_path / "p.3mf", "fabpat square")
    scene = trimesh.load(path, file_type="3mf")
    meshes = list(scene.geometry.values()) if hasattr(scene, "geometry") else [scene]
    assert len(meshes) == 1
    m = meshes[0]
    assert m.is_watertight and m.volume == pytest.approx(2.0 * rounded_square_area(), rel=1e-3)


def test_3mf_loads_in_lib3mf(tmp_path: Path) -> None:
    lib3mf = pytest.importorskip("lib3mf")
    path = write_3mf(cad.make_solid(rounded_square(), 2.0), tmp_path / "p.3mf", "fabpat square")
    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(path))
    meshes = model.GetMeshObjects()
    assert meshes.MoveNext()
    mesh = meshes.GetCurrentMeshObject()
    assert mesh.GetName() == "fabpat square" and mesh.IsManifoldAndOriented()
    assert model.GetUnit() == lib3mf.ModelUnit.MilliMeter


def test_every_facet_lies_within_the_tolerance_of_the_exact_surface(tmp_path: Path) -> None:
    """Exact signed distance of the rounded-square plate, evaluated on facet centroids and edge midpoints."""
    half, r, t, tol = 10.0, 3.0, 2.0, 0.01
    m = trimesh.load(write_stl(cad.make_solid(rounded_square(half, r), t), tmp_path / "r.stl", tol), file_type="stl")
    T = m.triangles  # (k, 3, 3)
    X = np.vstack([T.mean(axis=1), (T[:, 0] + T[:, 1]) / 2, (T[:, 1] + T[:, 2]) / 2, (T[:, 2] + T[:, 0]) / 2])
    q = np.abs(X[:, :2]) - (half - r)
    d2 = np.hypot(*np.maximum(q, 0).T) + np.minimum(q.max(axis=1), 0) - r  # rounded rectangle
    w = np.stack([d2, np.abs(X[:, 2] - t / 2) - t / 2], axis=1)  # extruded along z
    sdf = np.minimum(w.max(axis=1), 0) + np.hypot(*np.maximum(w, 0).T)
    assert np.abs(sdf).max() <= tol + 1e-9


def test_triangle_estimate_bounds_the_stl(tmp_path: Path) -> None:
    import struct

    from fabpat.exchange.cad import make_solid
    from fabpat.exchange.registry import estimate_triangles
    from fabpat.exchange.stl import write_stl
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    outline = fillet_pattern(get_pattern("0x7f88")).outline
    write_stl(make_solid(outline, 2.0), tmp_path / "p.stl", 0.005)
    n = struct.unpack("<I", (tmp_path / "p.stl").read_bytes()[80:84])[0]  # binary STL: count after the header
    est = estimate_triangles(outline, 2.0, 0.005)
    assert n <= est < 3 * n, (n, est)
