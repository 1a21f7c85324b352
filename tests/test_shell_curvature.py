"""Nodal principal curvatures with libigl (fabpat.shell.curvature) on sphere caps and cylinders."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.shell.curvature import curvature_fields, mesh_components, principal_curvatures
from fabpat.simulation.mesh import mesh_polygons, solid_polygon_mesh

RHO_SPHERE = 87.0  # about the truncated icosahedron's midradius for edge 36 (2.4271 a)
RHO_CYL = 20.0


def _cap(V2: np.ndarray, rho: float) -> np.ndarray:
    """Wrap a flat mesh around the sphere of radius rho centred at (0, 0, −rho), keeping distances
    from the origin as geodesic distances; normals of counter-clockwise F point outwards."""
    r = np.linalg.norm(V2, axis=1)
    d = V2 / np.maximum(r, 1e-300)[:, None]
    th = r / rho
    return np.c_[rho * np.sin(th)[:, None] * d, rho * np.cos(th) - rho]


def _cylinder(V2: np.ndarray, rho: float) -> np.ndarray:
    """Roll the plane onto a cylinder of radius rho about the line z = rho parallel to y (bends
    towards +z, i.e. towards the normal of counter-clockwise F)."""
    phi = V2[:, 0] / rho
    return np.c_[rho * np.sin(phi), V2[:, 1], rho * (1 - np.cos(phi))]


@pytest.fixture(scope="module")
def hexagon_cap() -> tuple[np.ndarray, np.ndarray]:
    m = solid_polygon_mesh(6, 36.0, 2.0)
    return _cap(m.V, RHO_SPHERE), m.F


@pytest.fixture(scope="module")
def rolled_rect() -> tuple[np.ndarray, np.ndarray]:
    m = mesh_polygons([np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 10.0], [0.0, 10.0]])], 1.0)
    return _cylinder(m.V, RHO_CYL), m.F


def test_sphere_cap_mean_and_gaussian(hexagon_cap) -> None:
    V, F = hexagon_cap
    k1, k2 = principal_curvatures(V, F)
    # a quadric fit is exact to second order on a sphere; what is left is the fit's third-order
    # residual over 2 rings of h = 2 elements, measured ≤ 0.07 % (mean) and 0.14 % (gaussian),
    # boundary nodes included
    assert np.all(k1 >= k2)
    assert np.allclose((k1 + k2) / 2, 1 / RHO_SPHERE, rtol=0.005)
    assert np.allclose(k1 * k2, 1 / RHO_SPHERE**2, rtol=0.01)
    f = curvature_fields(V, F)
    assert np.allclose(f["mean_curvature"], (k1 + k2) / 2) and np.allclose(f["gaussian_curvature"], k1 * k2)
    assert np.all(f["curvature_fitted"] == 1)
    # reversed triangles flip the sign; `center` restores "convex is positive"
    k1r, k2r = principal_curvatures(V, F[:, ::-1])
    assert np.allclose(k1r, -k2) and np.allclose(k2r, -k1)
    assert np.allclose(principal_curvatures(V, F[:, ::-1], center=[0, 0, -RHO_SPHERE])[0], k1)


def test_lacy_plate_on_a_sphere() -> None:
    """The sphere's plates are lacy: bars a few elements wide. Ring neighbourhoods stay on the bars."""
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import mesh_outline

    m = mesh_outline(fillet_pattern(get_pattern("0x0488")).outline, 1.5, 6, 36.0)
    k1, k2 = principal_curvatures(_cap(m.V, RHO_SPHERE), m.F)
    assert np.allclose((k1 + k2) / 2, 1 / RHO_SPHERE, rtol=0.005)  # measured ≤ 0.03 % (gaussian 0.06 %)
    assert np.allclose(k1 * k2, 1 / RHO_SPHERE**2, rtol=0.01)


def test_cylinder_mean_half_and_gaussian_zero(rolled_rect) -> None:
    V, F = rolled_rect
    k1, k2 = principal_curvatures(V, F)
    # bends towards the normal: negative. Measured with h = 1, ρ = 20 and 2 rings: k2·ρ in
    # −1.0030 … −1.0002, |k1·ρ| ≤ 0.0019 (igl's default 5 rings: −1.021 … −1.008 and 0.006); the
    # error is the quadric fit's third-order residual, growing with the neighbourhood
    assert np.allclose(k2, -1 / RHO_CYL, rtol=0.01)
    assert np.abs(k1).max() < 0.005 / RHO_CYL
    assert np.allclose((k1 + k2) / 2, -1 / (2 * RHO_CYL), rtol=0.01)
    assert np.abs(k1 * k2).max() < 0.005 / RHO_CYL**2
    k5 = principal_curvatures(V, F, radius=5)[1]
    assert np.abs(k5 * RHO_CYL + 1).max() > np.abs(k2 * RHO_CYL + 1).max()  # why 2 rings is the default


def test_components_are_fitted_separately(hexagon_cap, rolled_rect) -> None:
    """Two plates in one mesh (an assembly): each keeps its own curvature, found by scipy or labelled."""
    (Vs, Fs), (Vc, Fc) = hexagon_cap, rolled_rect
    V = np.r_[Vs, Vc + [200.0, 0.0, 0.0]]
    F = np.r_[Fs, Fc + len(Vs)]
    lab = mesh_components(F, len(V))
    assert np.array_equal(lab, np.r_[np.zeros(len(Vs)), np.ones(len(Vc))])
    k1, k2 = principal_curvatures(V, F)
    a1, a2 = principal_curvatures(Vs, Fs)
    b1, b2 = principal_curvatures(Vc, Fc)
    assert np.allclose(k1, np.r_[a1, b1]) and np.allclose(k2, np.r_[a2, b2])
    assert np.allclose(principal_curvatures(V, F, lab + 7)[0], k1)


def test_failed_fits_are_filled_and_flagged(hexagon_cap) -> None:
    """A lone triangle (igl cannot fit 3 points) is a component with no fitted node: 0 and flagged;
    an isolated node too. Nothing non-finite comes out."""
    Vs, Fs = hexagon_cap
    V = np.r_[Vs, [[300.0, 0, 0], [301, 0, 0], [300, 1, 0], [400, 0, 0]]]
    F = np.r_[Fs, [[len(Vs), len(Vs) + 1, len(Vs) + 2]]]
    f = curvature_fields(V, F)
    assert all(np.all(np.isfinite(v)) for v in f.values())
    assert np.array_equal(f["curvature_fitted"], np.r_[np.ones(len(Vs)), np.zeros(4)].astype(np.uint8))
    assert np.all(f["mean_curvature"][len(Vs):] == 0)


def test_bad_input_raises(hexagon_cap) -> None:
    V, F = hexagon_cap
    with pytest.raises(GeometryError, match="components"):
        principal_curvatures(V, F, np.zeros(len(V) - 1, dtype=int))
    lab = np.zeros(len(V), dtype=int)
    lab[F[0, 0]] = 1
    with pytest.raises(GeometryError, match="different components"):
        principal_curvatures(V, F, lab)
    with pytest.raises(GeometryError, match="radius"):
        principal_curvatures(V, F, radius=1)
    fan = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    with pytest.raises(GeometryError, match="edge-manifold"):
        principal_curvatures(np.random.default_rng(0).random((5, 3)), fan)


def test_same_sign_as_the_element_curvature() -> None:
    """igl's nodal curvature and fabpat.shell.strain's element curvature agree in sign and size on
    the rolled plate (both: bending towards the normal is negative)."""
    from fabpat.shell import Material
    from fabpat.shell.rotations import expmap
    from fabpat.shell.strain import principal_2d, surface_strain_field

    m = mesh_polygons([np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 10.0], [0.0, 10.0]])], 1.0)
    X = np.c_[m.V, np.zeros(len(m.V))]
    V, F = _cylinder(m.V, RHO_CYL), m.F
    R = expmap(np.c_[np.zeros(len(V)), -X[:, 0] / RHO_CYL, np.zeros(len(V))])
    kel = principal_2d(surface_strain_field(X, F, Material(), V, R).curvature)
    k1, k2 = principal_curvatures(V, F)
    assert np.allclose(kel.sum(axis=1) / 2, -1 / (2 * RHO_CYL), rtol=0.01)
    assert np.allclose((k1 + k2) / 2, -1 / (2 * RHO_CYL), rtol=0.01)
