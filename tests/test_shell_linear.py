"""Linear shell element: patch tests, closed forms for edge moments, beam and plate references."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.shell import Material, ShellProblem, solve_linear
from fabpat.shell.element import local_stiffness
from fabpat.simulation.mesh import mesh_polygons
from tests.shell_fixtures import edge_weights, rect_mesh


def test_element_rigid_modes_and_symmetry() -> None:
    x, y = np.array([[0.0, 2.0, 0.3]]), np.array([[0.0, 0.2, 1.5]])
    ls = local_stiffness(x, y, Material(1000.0, 0.3, 0.2))
    assert np.allclose(ls.K, ls.K.transpose(0, 2, 1), atol=1e-12 * np.abs(ls.K).max())
    ev = np.linalg.eigvalsh(ls.K[0])
    assert np.sum(np.abs(ev) < 1e-9 * ev.max()) == 6  # exactly the 6 rigid motions


def _solve(V, F, mat, fixed, loads):
    return solve_linear(ShellProblem(V, F, mat, fixed, loads))


def _patch(u_exact: np.ndarray, keep: list[int]) -> tuple[np.ndarray, float]:
    """Displacement patch test on a distorted mesh: prescribe the exact field on the boundary (dofs
    ``keep``, others held at 0 everywhere), solve K_ii u_i = −K_ib u_b, return the interior error and
    the energy ½ uᵀKu."""
    import scipy.sparse.linalg as spla

    from fabpat.shell.assembly import Assembler
    from fabpat.shell.corotational import CorotationalTriangles

    V, F = rect_mesh(10.0, 6.0, 5, 4, skew=0.25)
    n = len(V)
    model = CorotationalTriangles(np.c_[V, np.zeros(n)], F, Material(1000.0, 0.3, 1.0))
    active = np.zeros((n, 6), bool)
    active[:, keep] = True
    asm = Assembler(model.edofs, active.ravel())
    K = asm.matrix(model.linear_element_matrices())
    bnd = (V[:, 0] < 1e-9) | (V[:, 0] > 10 - 1e-9) | (V[:, 1] < 1e-9) | (V[:, 1] > 6 - 1e-9)
    is_b = np.repeat(bnd, 6)[asm.free]
    ue = u_exact.ravel()[asm.free]
    i, b = np.flatnonzero(~is_b), np.flatnonzero(is_b)
    Kc = K.tocsr()
    ui = spla.spsolve(Kc[i][:, i].tocsc(), -Kc[i][:, b] @ ue[b])
    u = ue.copy()
    u[i] = ui
    return np.abs(ui - ue[i]).max(), 0.5 * u @ (K @ u)


def test_membrane_patch_constant_strain() -> None:
    """OPT membrane: a linear displacement field (uniform strain, no rotation) is reproduced exactly."""
    V, _ = rect_mesh(10.0, 6.0, 5, 4, skew=0.25)
    eps = np.array([1e-3, -4e-4, 6e-4])  # εxx, εyy, γxy
    u = np.zeros((len(V), 6))
    u[:, 0] = eps[0] * V[:, 0] + 0.5 * eps[2] * V[:, 1]
    u[:, 1] = eps[1] * V[:, 1] + 0.5 * eps[2] * V[:, 0]
    err, U = _patch(u, [0, 1, 5])
    assert err < 1e-14
    mat = Material(1000.0, 0.3, 1.0)
    assert U == pytest.approx(0.5 * 60.0 * eps @ mat.D_membrane @ eps, rel=1e-10)


def test_bending_patch_displacement_form() -> None:
    """DKMT: the quadratic w of a uniform curvature (and its rotations) is reproduced exactly."""
    V, _ = rect_mesh(10.0, 6.0, 5, 4, skew=0.25)
    kx, ky, kxy = 2e-3, -1e-3, 1.5e-3
    x, y = V[:, 0], V[:, 1]
    u = np.zeros((len(V), 6))
    u[:, 2] = -(kx * x**2 + ky * y**2 + kxy * x * y) / 2
    u[:, 4] = kx * x + 0.5 * kxy * y
    u[:, 3] = -(ky * y + 0.5 * kxy * x)
    err, U = _patch(u, [2, 3, 4])
    assert err < 1e-14
    k = np.array([kx, ky, kxy])
    assert U == pytest.approx(0.5 * 60.0 * k @ Material(1000.0, 0.3, 1.0).D_bending @ k, rel=1e-10)


def test_bending_patch_constant_curvature() -> None:
    """Prescribed-curvature patch: the quadratic w field's nodal values make every element carry
    exactly κ (energy ½ A κᵀDκ, zero transverse shear) on a distorted mesh."""
    from fabpat.shell.corotational import CorotationalTriangles

    V, F = rect_mesh(10.0, 6.0, 5, 4, skew=0.25)
    mat = Material(1000.0, 0.3, 1.0)
    kx, ky, kxy = 2e-3, -1e-3, 1.5e-3  # κxx, κyy, 2κxy
    x, y = V[:, 0], V[:, 1]
    u = np.zeros((len(V), 6))
    u[:, 2] = -(kx * x**2 + ky * y**2 + kxy * x * y) / 2
    u[:, 4] = kx * x + 0.5 * kxy * y  # θy = βx = −w,x
    u[:, 3] = -(ky * y + 0.5 * kxy * x)  # θx = −βy = w,y
    model = CorotationalTriangles(np.c_[V, np.zeros(len(V))], F, mat)
    ee = model.energy_split(model.linear_local_dofs(u))
    k = np.array([kx, ky, kxy])
    assert ee[:, 1].sum() == pytest.approx(0.5 * 60.0 * k @ mat.D_bending @ k, rel=1e-12)
    assert np.abs(ee[:, [0, 2]]).max() < 1e-12 * ee[:, 1].sum()


@pytest.mark.parametrize("nu", [0.0, 0.35])
def test_free_plate_uniform_edge_moment_is_a_sphere(nu: float) -> None:
    """Notes' closed form: moment m per length on every edge of a free plate → U = A m²/(D(1+ν))."""
    a = np.radians(np.arange(6) * 60.0)
    hexa = np.c_[20.0 * np.cos(a), 20.0 * np.sin(a)]
    m_mesh = mesh_polygons([hexa], 3.0)
    V, F = m_mesh.V, m_mesh.F
    mat = Material(1000.0, nu, 2.0)
    mper = 2.0
    n = len(V)
    loads = np.zeros((n, 6))
    for i in range(6):
        p0, p1 = hexa[i], hexa[(i + 1) % 6]
        t = (p1 - p0) / np.linalg.norm(p1 - p0)
        rel = V - p0
        on = np.flatnonzero(np.abs(rel[:, 0] * t[1] - rel[:, 1] * t[0]) < 1e-6)
        w = edge_weights(V, on) * 20.0
        loads[on, 3] += mper * w * t[0]
        loads[on, 4] += mper * w * t[1]
    fixed = np.zeros((n, 6), bool)
    c = int(np.argmin(np.linalg.norm(V, axis=1)))
    fixed[c, :3] = True  # three points against rigid motion: pin at the centre, two rollers
    k1 = int(np.argmax(V[:, 0]))
    fixed[k1, [1, 2]] = True
    k2 = int(np.argmax(V[:, 1]))
    fixed[k2, 2] = True
    r = _solve(V, F, mat, fixed, loads)
    A = m_mesh.areas.sum()
    D = 1000.0 * 8.0 / (12 * (1 - nu**2))
    assert r.energy == pytest.approx(A * mper**2 / (D * (1 + nu)), rel=1e-8)
    assert np.abs(r.reactions).max() < 1e-8  # supports carry nothing


def test_rectangle_moments_on_opposite_edges() -> None:
    """Notes' closed form: U = A m² / (2 D (1 − ν²)) (other edges free, anticlastic)."""
    V, F = rect_mesh(30.0, 12.0, 10, 4, skew=0.2)
    nu = 0.35
    mat = Material(1000.0, nu, 2.0)
    mper = 1.5
    n = len(V)
    loads = np.zeros((n, 6))
    for xe, sgn in ((0.0, -1.0), (30.0, 1.0)):
        on = np.flatnonzero(np.abs(V[:, 0] - xe) < 1e-9)
        loads[on, 4] += sgn * mper * edge_weights(V, on) * 12.0
    fixed = np.zeros((n, 6), bool)
    c = 0
    fixed[c, :3] = True
    k = int(np.flatnonzero((np.abs(V[:, 1]) < 1e-9) & (np.abs(V[:, 0] - 30) < 1e-9))[0])
    fixed[k, 1:3] = True
    k2 = int(np.flatnonzero((np.abs(V[:, 1] - 12) < 1e-9) & (V[:, 0] < 1e-9))[0])
    fixed[k2, 2] = True
    r = _solve(V, F, mat, fixed, loads)
    D = 1000.0 * 8.0 / (12 * (1 - nu**2))
    assert r.energy == pytest.approx(360.0 * mper**2 / (2 * D * (1 - nu**2)), rel=1e-8)


@pytest.mark.parametrize("load", ["shear", "moment", "inplane"])
def test_cantilever_strip_vs_beam_theory(load: str) -> None:
    L, b, t, E = 100.0, 10.0, 1.0, 1e4
    V, F = rect_mesh(L, b, 40, 4)
    n = len(V)
    fixed = np.zeros((n, 6), bool)
    fixed[V[:, 0] < 1e-9] = True
    tip = np.flatnonzero(V[:, 0] > L - 1e-9)
    w = edge_weights(V, tip)
    loads = np.zeros((n, 6))
    Iy, Iz, GA = b * t**3 / 12, t * b**3 / 12, 5 / 6 * E / 2 * b * t
    if load == "shear":
        loads[tip, 2] = w
        ref, comp = L**3 / (3 * E * Iy), 2
    elif load == "moment":
        loads[tip, 4] = -w
        ref, comp = L**2 / (2 * E * Iy), 2
    else:  # in-plane bending (Timoshenko beam): tests the OPT membrane + drilling freedom
        loads[tip, 1] = w
        ref, comp = L**3 / (3 * E * Iz) + L / GA, 1
    r = solve_linear(ShellProblem(V, F, Material(E, 0.0, t), fixed, loads))
    assert r.displacement[tip, comp].mean() == pytest.approx(ref, rel=0.02)
    assert r.energy == pytest.approx(r.external_work, rel=1e-9)


def test_clamped_square_plate_central_load() -> None:
    """Timoshenko & Woinowsky-Krieger Table 55: w_c = 0.00560 P a² / D (clamped, ν = 0.3)."""
    a, t = 100.0, 1.0
    V, F = rect_mesh(a, a, 16, 16)
    n = len(V)
    edge = (V[:, 0] < 1e-9) | (V[:, 0] > a - 1e-9) | (V[:, 1] < 1e-9) | (V[:, 1] > a - 1e-9)
    fixed = np.zeros((n, 6), bool)
    fixed[edge] = True
    c = int(np.argmin(np.linalg.norm(V - [a / 2, a / 2], axis=1)))
    loads = np.zeros((n, 6))
    loads[c, 2] = 1.0
    mat = Material(1000.0, 0.3, t)
    r = solve_linear(ShellProblem(V, F, mat, fixed, loads))
    D = 1000.0 * t**3 / (12 * (1 - 0.09))
    assert r.displacement[c, 2] == pytest.approx(0.00560 * a**2 / D, rel=0.03)
