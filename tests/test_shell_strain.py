"""Surface strains of a deformed shell (fabpat.shell.strain) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.shell import Material, ShellProblem, solve_nonlinear
from fabpat.shell.rotations import expmap
from fabpat.shell.strain import principal_2d, surface_strain_field, surface_strains
from fabpat.simulation.mesh import mesh_polygons
from tests.shell_fixtures import edge_weights, rect_mesh

MAT = Material(E=1000.0, nu=0.35, t=2.0)
RECT = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 10.0], [0.0, 10.0]])


def _flat(h: float) -> tuple[np.ndarray, np.ndarray]:
    m = mesh_polygons([RECT], h)
    return np.c_[m.V, np.zeros(len(m.V))], m.F


def _rolled(X: np.ndarray, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """Wrap the plane z = 0 onto a cylinder of radius rho about an axis parallel to y (an isometry:
    arc length s = X keeps its length), rotating each node's frame by the arc angle s/rho."""
    phi = X[:, 0] / rho
    x = np.c_[rho * np.sin(phi), X[:, 1], rho * (1 - np.cos(phi))]
    return x, expmap(np.c_[np.zeros_like(phi), -phi, np.zeros_like(phi)])


@pytest.mark.parametrize(("h", "rho"), [(1.0, 20.0), (2.0, 50.0)])
def test_cylinder_bending_gives_t_over_2rho(h: float, rho: float) -> None:
    X, F = _flat(h)
    x, R = _rolled(X, rho)
    s = surface_strain_field(X, F, MAT, x, R)
    # curvature: one principal value −1/ρ (the surface bends towards +z), the other 0; the nodal
    # rotations are exact, so only the chord-vs-arc tilt of an element is left (measured ≤ 3e-4 relative)
    k = principal_2d(s.curvature)
    assert np.allclose(k[:, 1], -1.0 / rho, rtol=1e-3)
    assert np.allclose(k[:, 0], 0.0, atol=1e-3 / rho)
    # membrane: nodes sit on the arc, so an element's chords are shorter than their arcs by
    # L²/(24ρ²) for a side of length L along the arc; Triangle's sides reach ~1.7 h
    assert np.abs(s.membrane).max() <= (1.7 * h) ** 2 / (24 * rho**2)
    # hence peak = t/(2ρ) + that membrane term: ≤ 1 % here (h²/(4ρt)·1.7² ≤ 0.4 %)
    exact = MAT.t / (2 * rho)
    assert np.allclose(s.peak, exact, rtol=0.01)
    # concave side (+z, top) in compression, bottom in tension
    assert np.all(s.principal[:, 1, 1] < 0) and np.all(s.principal[:, 0, 0] > 0)
    assert np.array_equal(surface_strains(X, F, MAT, x, R), s.peak)


def test_uniform_stretch_gives_eps0_on_both_surfaces() -> None:
    X, F = _flat(2.0)
    eps0 = 0.015
    x = X * [1 + eps0, 1.0, 1.0]
    s = surface_strain_field(X, F, MAT, x, np.broadcast_to(np.eye(3), (len(X), 3, 3)))
    # tensors are in each element's frame (e1 along its first side): compare invariants
    assert np.allclose(principal_2d(s.membrane), [eps0, 0.0], atol=1e-12)
    assert np.allclose(s.curvature, 0.0, atol=1e-12)
    assert np.allclose(s.principal[:, :, 0], eps0, rtol=1e-12)
    assert np.allclose(s.peak, eps0, rtol=1e-12)
    # equibiaxial: both principal values ε0, any frame
    s2 = surface_strain_field(X, F, MAT, X * [1 + eps0, 1 + eps0, 1.0], np.zeros((len(X), 3)))
    assert np.allclose(s2.principal, eps0, rtol=1e-12)


def test_rigid_motion_gives_zero() -> None:
    X, F = _flat(2.0)
    for theta in ([0.3, -1.1, 0.7], [0.0, 0.0, 2.5], [2.0, 1.0, -0.5]):
        Q = expmap(np.array(theta))
        x = X @ Q.T + [5.0, -3.0, 12.0]
        s = surface_strain_field(X, F, MAT, x, np.broadcast_to(Q, (len(X), 3, 3)))
        assert s.peak.max() < 1e-12
    # and a rolled-up plate moved rigidly keeps its strains
    xr, Rr = _rolled(X, 30.0)
    Q = expmap(np.array([0.4, 1.2, -0.3]))
    a = surface_strains(X, F, MAT, xr, Rr)
    b = surface_strains(X, F, MAT, xr @ Q.T, Q @ Rr)
    assert np.allclose(a, b, rtol=1e-9, atol=1e-14)


def test_strip_under_end_moments_solver() -> None:
    """A free rectangle with equal and opposite edge moments m (N·mm/mm) on two opposite edges:
    Kirchhoff gives Mxx = m, Myy = 0 everywhere, κxx = m/(D(1 − ν²)) = 12 m/(E t³), κyy = −ν κxx
    (notes.md, "A closed form for moment loading"), so the surface strain is ±6 m/(E t²). The solver
    is the nonlinear one; the load is kept where that linear closed form holds (at m = 5 the
    anticlastic sag adds a mid-surface strain, Ashwell's effect, measured +0.6 % median, +1.9 % at
    the free edges, on every mesh)."""
    L, b, m_line = 40.0, 10.0, 1.0
    V, F = rect_mesh(L, b, 20, 5, skew=0.2)
    n = len(V)
    left = np.flatnonzero(np.isclose(V[:, 0], 0.0))
    right = np.flatnonzero(np.isclose(V[:, 0], L))
    loads = np.zeros((n, 6))
    loads[right, 4] = m_line * b * edge_weights(V, right)
    loads[left, 4] = -m_line * b * edge_weights(V, left)
    fixed = np.zeros((n, 6), dtype=bool)
    fixed[left[np.argmin(V[left, 1])]] = True  # one node holds the rigid motion; reactions are 0
    r = solve_nonlinear(ShellProblem(V, F, MAT, fixed, loads))
    X = np.c_[V, np.zeros(n)]
    s = surface_strain_field(X, F, MAT, X + r.displacement, r.rotation)
    exact = 6 * m_line / (MAT.E * MAT.t**2)
    assert abs(np.median(s.peak) / exact - 1) < 0.003  # measured 1.0013
    assert np.allclose(s.peak, exact, rtol=0.01)  # skewed h = 2 mesh: measured 1.0000 … 1.0039
    kxx = 12 * m_line / (MAT.E * MAT.t**3)
    kap = principal_2d(s.curvature)
    assert np.allclose(kap, [kxx, -MAT.nu * kxx], rtol=1e-3)  # measured within 3e-5


def test_bad_shapes_raise() -> None:
    X, F = _flat(4.0)
    with pytest.raises(GeometryError, match="rotations"):
        surface_strains(X, F, MAT, X, np.zeros((len(X), 4)))
    with pytest.raises(GeometryError, match="node coordinates"):
        surface_strains(X, F, MAT, X[:-1], np.zeros((len(X), 3)))
    with pytest.raises(GeometryError, match="indices"):
        surface_strains(X, F + len(X), MAT, X, np.zeros((len(X), 3)))
