"""Per-element thickness in the shell engine: plates of different thickness in one mesh.

A mesh whose elements all have the material's thickness gives the same numbers whether the thickness is
passed per element or not; an element's matrices are those of its own thickness (the membrane part grows
as t, the closed form of the OPT triangle's D_membrane = E t / (1 − ν²) …), and its surface strain in pure
bending is t/(2ρ) of its own t.
"""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.shell.compiled import CompiledTriangles, graded_local_stiffness
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import Material, local_stiffness
from fabpat.shell.rigid_links import LinkedProblem
from fabpat.shell.strain import surface_strain_field, thickness_groups
from fabpat.simulation.mesh import mesh_polygons
from tests.test_shell_strain import _rolled

MAT = Material(E=1000.0, nu=0.35, t=2.0)
RECT = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 10.0], [0.0, 10.0]])


def _flat(h: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    m = mesh_polygons([RECT], h)
    return np.c_[m.V, np.zeros(len(m.V))], m.F


def _halves(X: np.ndarray, F: np.ndarray, left: float, right: float) -> np.ndarray:
    """Thickness ``left`` on the elements whose centroid has x < 20 mm, ``right`` elsewhere."""
    return np.where(X[F].mean(axis=1)[:, 0] < 20.0, left, right)


def test_one_thickness_per_element_is_the_material_bitwise() -> None:
    X, F = _flat()
    plain = CompiledTriangles(X, F, MAT, threads=1)
    graded = CompiledTriangles(X, F, MAT, threads=1, thickness=np.full(len(F), MAT.t))
    assert np.array_equal(plain.local.K, graded.local.K)
    assert np.array_equal(plain.local.area, graded.local.area)


def test_each_element_has_the_matrices_of_its_own_thickness() -> None:
    X, F = _flat()
    t = _halves(X, F, 1.0, 3.0)
    tri = CompiledTriangles(X, F, MAT, threads=1, thickness=t)
    ref = CorotationalTriangles(X, F, MAT)
    x, y = ref.xl0[..., 0], ref.xl0[..., 1]
    thin, thick = t == 1.0, t == 3.0
    assert thin.any() and thick.any()
    for mask, value in ((thin, 1.0), (thick, 3.0)):
        alone = local_stiffness(x[mask], y[mask], Material(MAT.E, MAT.nu, value))
        assert np.allclose(tri.local.K[mask], alone.K, rtol=1e-13, atol=1e-12)
    # the membrane stiffness is E t / (1 − ν²) × geometry: linear in t, so 3 mm is 3 × 1 mm of the same triangle
    one = graded_local_stiffness(x, y, MAT, np.full(len(F), 1.0))
    assert np.allclose(tri.local.Km[thick], 3.0 * one.Km[thick], rtol=1e-12, atol=1e-12)
    assert np.allclose(tri.local.Km[thin], one.Km[thin], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("rho", [20.0, 50.0])
def test_surface_strain_of_a_rolled_plate_is_its_own_half_thickness_over_rho(rho: float) -> None:
    X, F = _flat(1.0)
    x, R = _rolled(X, rho)
    t = _halves(X, F, 1.0, 3.0)
    s = surface_strain_field(X, F, MAT, x, R, thickness=t)
    # peak = t/(2ρ) plus the chord-vs-arc membrane term, ≤ 1 % (tests/test_shell_strain.py)
    assert np.allclose(s.peak, t / (2.0 * rho), rtol=0.01)


def test_a_wrong_thickness_is_refused() -> None:
    X, F = _flat()
    with pytest.raises(GeometryError, match=rf"thickness must be {len(F)} finite positive numbers"):
        thickness_groups(np.ones(len(F) - 1), len(F))
    with pytest.raises(GeometryError, match="finite positive"):
        thickness_groups(np.r_[np.ones(len(F) - 1), 0.0], len(F))
    N = len(X)
    with pytest.raises(ValueError, match="one per triangle"):
        LinkedProblem(X, F, MAT, np.zeros((0, 3)), [], [], np.zeros((0, 3)), np.zeros((N, 6), bool),
                      np.zeros((N, 6)), np.zeros((N, 6)), thickness=np.full(len(F), -1.0))
