"""Mapped tilings (fabpat.design.remesh): a base tiling carried onto a target and relaxed into flat, nearly
regular faces on it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fabpat.assembly.surface.mesh_tiling import read_polygon_mesh
from fabpat.assembly.surface.tiling import truncated_icosahedron
from fabpat.design import remesh
from fabpat.design.remesh import (
    RelaxError,
    RemeshError,
    Weights,
    approximation_error,
    face_points,
    map_tiling,
    measure,
    relax,
    write_obj,
)
from fabpat.design.remesh_target import TargetSurface, face_area, place_target
from fabpat.design.target import TargetError
from fabpat.errors import FabpatError

TI = truncated_icosahedron(36.0)


def _egg(path: Path, rings: int = 16, segments: int = 32) -> Path:
    """A small egg (a surface of revolution about z, 1.25 : 1, blunt end up) as OBJ."""
    th = np.linspace(0.0, math.pi, rings + 1)[1:-1]
    ph = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    ring = [(r * math.cos(p), r * math.sin(p), -1.25 * math.cos(t))
            for t, r in zip(th, np.sin(th) * (1.0 - 0.12 * np.cos(th)), strict=True) for p in ph]
    V = [(0.0, 0.0, -1.25), *((float(x), float(y), float(z)) for x, y, z in ring), (0.0, 0.0, 1.25)]
    n, top = segments, len(V) - 1
    F = [(0, 1 + (j + 1) % n, 1 + j) for j in range(n)]
    for i in range(rings - 2):
        a, b = 1 + i * n, 1 + (i + 1) * n
        for j in range(n):
            F += [(a + j, a + (j + 1) % n, b + (j + 1) % n), (a + j, b + (j + 1) % n, b + j)]
    a = 1 + (rings - 2) * n
    F += [(a + j, a + (j + 1) % n, top) for j in range(n)]
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V)
                    + "".join(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in F), encoding="utf-8")
    return path


def test_a_point_off_the_ellipsoid_along_its_normal_is_that_far_from_it() -> None:
    # points built from the ellipsoid's parametrisation, its normal from the gradient of Σ (x_i / a_i)²
    semi = np.array([50.0, 40.0, 70.0])
    surface = TargetSurface("test", "ellipsoid", np.array([1.0, 2.0, 3.0]), 1.0, semi=semi)
    rng = np.random.default_rng(3)
    u, v = rng.uniform(0.2, math.pi - 0.2, 40), rng.uniform(0, 2 * math.pi, 40)
    on = semi * np.column_stack([np.sin(u) * np.cos(v), np.sin(u) * np.sin(v), np.cos(u)])
    normal = on / semi ** 2
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    off = rng.uniform(-3.0, 3.0, 40)  # within the reach (the smallest radius of curvature is 40² / 70 mm)
    P, N, d = surface.closest(on + off[:, None] * normal + surface.centre)
    assert np.allclose(P, on + surface.centre, atol=1e-9)
    assert np.allclose(N, normal, atol=1e-9)
    assert np.allclose(d, off, atol=1e-9)


def test_mapping_puts_the_vertices_on_the_ellipsoid_at_the_base_area_and_the_design_axis_on_its_own() -> None:
    Vm = map_tiling(TI.V, TI.faces, "ellipsoid:1,1,1.15")
    surface, _ = place_target(TI.V, TI.faces, "ellipsoid:1,1,1.15")
    assert surface.semi is not None
    assert np.allclose(surface.semi / surface.semi[0], [1.0, 1.0, 1.15])
    assert np.allclose(((Vm / surface.semi) ** 2).sum(axis=1), 1.0, atol=1e-12)
    assert face_area(Vm, TI.faces) == pytest.approx(face_area(TI.V, TI.faces), rel=1e-12)
    first_pentagon = next(loop for loop in TI.faces if len(loop) == 5)
    axis = Vm[list(first_pentagon)].mean(axis=0)
    assert abs(axis[2]) / np.linalg.norm(axis) == pytest.approx(1.0, abs=1e-12)  # the distinct axis is z


def test_a_sphere_leaves_the_regular_truncated_icosahedron_as_it_is() -> None:
    base = measure(TI.V, TI.faces)
    Vm = map_tiling(TI.V, TI.faces, "sphere")
    r = relax(Vm, TI.faces, "sphere")
    m = r.measures
    assert m.edge_deviation.max() <= base.edge_deviation.max() + 1e-12
    assert m.angle_deviation.max() <= base.angle_deviation.max() + 1e-12
    assert m.planarity.max() <= 1e-9 * m.size
    assert np.abs(r.V - Vm).max() <= 1e-9 * m.size
    # the mapped sphere is the base's own circumsphere: same area, so the vertices did not move either
    assert np.abs(Vm - (TI.V - TI.V.mean(axis=0)) @ place_target(TI.V, TI.faces, "sphere")[1].T).max() < 1e-9


def test_an_ellipsoid_relaxes_to_flat_faces_near_the_surface() -> None:
    surface, _ = place_target(TI.V, TI.faces, "ellipsoid:1,1,1.15")
    Vm = map_tiling(TI.V, TI.faces, "ellipsoid:1,1,1.15")
    before = measure(Vm, TI.faces, surface)
    r = relax(Vm, TI.faces, surface)
    m = r.measures
    assert before.planarity.max() > 0.5  # mm: the mapped faces are far from flat
    assert m.planarity.max() <= 1e-6 * m.size
    # the stated trade-off (target weight 10): every corner within 0.2 % of the size of the ellipsoid
    assert m.distance_max <= 0.002
    # and the faces more regular than where the mapping left them
    assert m.edge_deviation.max() < before.edge_deviation.max()
    P = np.asarray(r.V)
    for loop in TI.faces:  # an independent check of flatness: the corners' covariance has a null direction
        Q = P[list(loop)] - P[list(loop)].mean(axis=0)
        assert np.linalg.svd(Q, compute_uv=False)[-1] <= 1e-6 * m.size


def test_the_jacobian_is_the_central_difference_of_the_residuals() -> None:
    surface, _ = place_target(TI.V, TI.faces, "ellipsoid:1.04,1,0.97")
    Vm = map_tiling(TI.V, TI.faces, "ellipsoid:1.04,1,0.97")
    lay = remesh._layout(len(Vm), TI.faces)
    rng = np.random.default_rng(0)
    x = np.concatenate([(Vm + rng.normal(scale=0.5, size=Vm.shape)).ravel(), rng.normal(size=3 * len(TI.faces)),
                        30.0 + rng.random(len(TI.faces)), [33.0]])
    w = Weights(planar=3.0, edge=1.5, angle=0.7, across=2.0, target=5.0, spin=4.0)

    def r(x: np.ndarray) -> np.ndarray:
        return remesh.residuals(x, lay, surface, w, 36.0, Vm)[0]

    J = remesh.residuals(x, lay, surface, w, 36.0, Vm)[1].toarray()
    nv, nf = len(Vm), len(TI.faces)
    # a seeded sample of every block of unknowns: vertices, normals, face edges, the tiling's edge
    cols = np.concatenate([rng.choice(3 * nv, 30, replace=False), 3 * nv + rng.choice(3 * nf, 15, replace=False),
                           3 * nv + 3 * nf + rng.choice(nf, 5, replace=False), [len(x) - 1]])
    h = 1e-6
    numeric = np.column_stack([(r(x + h * e) - r(x - h * e)) / (2 * h) for e in np.eye(len(x))[cols]])
    assert np.abs(J[:, cols] - numeric).max() <= 1e-6 * max(1.0, float(np.abs(J).max()))
    assert np.abs(J[:, cols]).max(axis=0).min() > 0  # every sampled unknown enters some residual


def test_an_egg_mesh_relaxes_onto_its_surface(tmp_path: Path) -> None:
    path = str(_egg(tmp_path / "egg.obj"))
    surface, _ = place_target(TI.V, TI.faces, path)
    Vm = map_tiling(TI.V, TI.faces, path)
    assert measure(Vm, TI.faces, surface).distance_max <= 1e-9  # the rays end on the mesh
    r = relax(Vm, TI.faces, surface)
    assert r.measures.planarity.max() <= 1e-6 * r.measures.size
    assert r.measures.distance_max <= 0.01
    # the egg's 1.25 : 1 shows in the vertices (its axis is z; pentagons, not corners, sit at its poles)
    extent = r.V.max(axis=0) - r.V.min(axis=0)
    assert 1.1 < extent[2] / extent[:2].mean() < 1.3


def test_corners_on_a_sphere_fit_it_and_flat_faces_sag_inside() -> None:
    assert approximation_error(TI.V, TI.faces, "sphere", corners=True) < 1e-9
    # a flat hexagon's centre is 7.6 mm inside the 89 mm sphere through its corners: a few per cent rms
    assert 0.01 < approximation_error(TI.V, TI.faces, "sphere") < 0.085


def test_face_points_cover_a_square_and_nothing_outside() -> None:
    V = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]])
    P = face_points(V, ((0, 1, 2, 3),), k=4)
    assert P[:, :2].min() >= 0.0 and P[:, :2].max() <= 2.0 and np.all(P[:, 2] == 0.0)
    assert {(0.0, 0.0), (2.0, 2.0), (1.0, 1.0), (1.0, 0.0)} <= {tuple(p) for p in P[:, :2].tolist()}


def test_the_obj_keeps_the_polygons(tmp_path: Path) -> None:
    Vm = map_tiling(TI.V, TI.faces, "ellipsoid:1,1,1.15")
    path = tmp_path / "mapped.obj"
    path.write_bytes(write_obj(Vm, TI.faces))
    V, F = read_polygon_mesh(path)
    assert sorted(len(f) for f in F) == [5] * 12 + [6] * 20
    assert np.allclose(V[[i for f in F for i in f]], Vm[[i for f in TI.faces for i in f]])


@pytest.mark.parametrize("target, words", [
    ("ellipsoid:1,2", "ellipsoid:A,B,C"),
    ("ellipsoid:1,1,100", "axis ratio C"),
    ("no-such-surface.obj", "no such file"),
    ("cube", "cube"),
])
def test_bad_targets_are_refused(target: str, words: str) -> None:
    with pytest.raises(TargetError, match=words):
        map_tiling(TI.V, TI.faces, target)
    with pytest.raises(TargetError):
        relax(TI.V, TI.faces, target)


def test_a_strip_target_is_refused(tmp_path: Path) -> None:
    csv = tmp_path / "arch.csv"
    csv.write_text("x,z\n0,0\n50,10\n100,0\n", encoding="utf-8")
    with pytest.raises(TargetError, match="strip mid-line"):
        map_tiling(TI.V, TI.faces, str(csv))


def test_bad_faces_are_refused() -> None:
    with pytest.raises(RemeshError, match="face 2"):
        map_tiling(TI.V, (TI.faces[0], (0, 1, 1)), "sphere")
    with pytest.raises(RemeshError, match="finite"):
        relax(np.full((4, 3), np.nan), ((0, 1, 2), (0, 2, 3)), "sphere")
    assert issubclass(RemeshError, FabpatError)


def test_a_relaxation_cut_short_says_what_it_reached() -> None:
    Vm = map_tiling(TI.V, TI.faces, "ellipsoid:1,1,1.15")
    with pytest.raises(RelaxError, match=r"did not converge in 1 steps: planarity reached .* mm") as e:
        relax(Vm, TI.faces, "ellipsoid:1,1,1.15", max_iterations=1)
    assert isinstance(e.value, FabpatError)
