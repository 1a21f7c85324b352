"""Congruent triangles sharing their reference data (fabpat.shell.congruent) against each its own."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.shell.compiled import CompiledTriangles
from fabpat.shell.congruent import CongruentTriangles, representatives
from fabpat.shell.element import Material
from fabpat.shell.rotations import expmap

MAT = Material(E=1800.0, nu=0.33, t=1.2)


def _plate() -> tuple[np.ndarray, np.ndarray]:
    """A small irregular flat mesh in z = 0 (no two triangles alike)."""
    xs, ys = np.meshgrid(np.linspace(0.0, 12.0, 4), np.linspace(0.0, 9.0, 3))
    rng = np.random.default_rng(7)
    V = np.column_stack([xs.ravel(), ys.ravel()]) + rng.uniform(-0.7, 0.7, size=(xs.size, 2))
    idx = np.arange(xs.size).reshape(3, 4)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return V, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def _copies(turns: list[np.ndarray], shifts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three plates: copies of one mesh placed by rotations and shifts; returns X, F and the hint."""
    V, F = _plate()
    P = np.column_stack([V, np.zeros(len(V))])
    X = np.vstack([P @ A.T + s for A, s in zip(turns, shifts, strict=True)])
    Fs = np.vstack([F + k * len(V) for k in range(len(turns))])
    hint = np.tile(np.arange(len(F)), len(turns))
    return X, Fs, hint


def _state(X: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = X + rng.normal(scale=0.3, size=X.shape)
    return x, expmap(rng.normal(scale=0.4, size=X.shape))


#: quarter turns about z and about x: exact in floating point, so the copies' own data are bitwise the first's
QUARTER = [np.eye(3), np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
           np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])]


def test_shared_data_gives_bitwise_the_forces_and_tangents_of_each_its_own() -> None:
    X, F, hint = _copies(QUARTER, [np.zeros(3)] * 3)
    own, shared = CompiledTriangles(X, F, MAT, threads=1), CongruentTriangles(X, F, MAT, hint, threads=1)
    assert len(shared.reference.F) == len(F) // 3  # one plate's data for three
    x, R = _state(X, 11)
    for a, b in zip(own.forces_at(x, R), shared.forces_at(x, R), strict=True):
        assert np.array_equal(a, b)
    Kt = own.tangents_at(x, R).copy()
    assert np.array_equal(Kt, shared.tangents_at(x, R)) and np.abs(Kt).max() > 0.0
    d = own.forces_at(x, R)[2]
    assert np.array_equal(own.energy_split(d), shared.energy_split(d))
    assert np.array_equal(own.linear_diagonal(), shared.linear_diagonal())


def test_copies_placed_anywhere_agree_to_round_off() -> None:
    turns = [expmap(np.array(w)) for w in ([0.0, 0.0, 0.0], [0.3, -1.1, 0.7], [2.0, 0.4, -0.9])]
    X, F, hint = _copies(turns, [np.zeros(3), np.array([40.0, -3.0, 7.5]), np.array([-12.0, 55.0, 1.25])])
    own, shared = CompiledTriangles(X, F, MAT, threads=1), CongruentTriangles(X, F, MAT, hint, threads=1)
    x, R = _state(X, 5)
    fe, fs = own.forces_at(x, R)[0], shared.forces_at(x, R)[0]
    assert np.abs(fe - fs).max() <= 1e-11 * np.abs(fe).max()
    Ke = own.tangents_at(x, R).copy()
    assert np.abs(Ke - shared.tangents_at(x, R)).max() <= 1e-11 * np.abs(Ke).max()


def test_a_hint_naming_another_shape_or_another_thickness_is_refused() -> None:
    # a mirror image of a flat triangle is a half turn of it: congruent, its corner order kept
    X, F, hint = _copies([np.eye(3), np.diag([-1.0, 1.0, 1.0]), QUARTER[1]], [np.zeros(3)] * 3)
    CongruentTriangles(X, F, MAT, hint, threads=1)
    X, F, hint = _copies([np.eye(3), QUARTER[1], 1.001 * np.eye(3)], [np.zeros(3)] * 3)
    with pytest.raises(GeometryError, match="are not"):
        CongruentTriangles(X, F, MAT, hint, threads=1)  # the third copy is 0.1 % larger
    X, F, hint = _copies(QUARTER, [np.zeros(3)] * 3)
    t = np.full(len(F), MAT.t)
    t[-1] = 2.0
    with pytest.raises(GeometryError, match="thickness"):
        CongruentTriangles(X, F, MAT, hint, threads=1, thickness=t)
    with pytest.raises(GeometryError, match="one triangle number"):
        representatives(np.full(len(F), len(F)), len(F))


def test_the_assembly_model_names_the_plates_of_one_mesh_and_thickness_congruent() -> None:
    from fabpat.assembly.solve.model import ModelPlate, assembly_model
    from fabpat.simulation.mesh import ShellMesh

    V, F = _plate()
    mesh, other = ShellMesh(V, F), ShellMesh(V.copy(), F.copy())
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = expmap(np.array([0.2, -0.5, 1.1])), [30.0, 4.0, -2.0]
    S = np.eye(4)
    S[:3, :3] *= 1.5  # a scale: not a placement of the mesh
    plates = [ModelPlate("a", mesh, np.eye(4)), ModelPlate("b", mesh, T), ModelPlate("c", other, T),
              ModelPlate("d", mesh, T, thickness=2.0), ModelPlate("e", mesh, S), ModelPlate("f", mesh, T, 2.0)]
    model = assembly_model(plates, [], MAT)
    m = len(F)
    own = np.arange(m)
    want = np.concatenate([own, own, own + 2 * m, own + 3 * m, own + 4 * m, own + 3 * m])
    assert np.array_equal(model.congruent, want)
    x, R = _state(model.X, 3)
    t = model.element_thickness
    shared = CongruentTriangles(model.X, model.F, MAT, model.congruent, threads=1, thickness=t)
    assert len(shared.reference.F) == 4 * m
    fe = CompiledTriangles(model.X, model.F, MAT, threads=1, thickness=t).forces_at(x, R)[0]
    assert np.abs(shared.forces_at(x, R)[0] - fe).max() <= 1e-11 * np.abs(fe).max()


def test_surface_strains_of_shared_data_are_those_of_the_numpy_read_out() -> None:
    from fabpat.shell.strain import surface_strains

    turns = [expmap(np.array(w)) for w in ([0.0, 0.0, 0.0], [0.3, -1.1, 0.7], [2.0, 0.4, -0.9])]
    X, F, hint = _copies(turns, [np.zeros(3), np.array([40.0, -3.0, 7.5]), np.array([-12.0, 55.0, 1.25])])
    rng = np.random.default_rng(2)
    x, R = X + rng.normal(scale=0.05, size=X.shape), expmap(rng.normal(scale=0.05, size=X.shape))
    t = np.repeat([1.2, 1.2, 2.0], len(F) // 3)  # the third copy thicker: its own rows
    hint[-(len(F) // 3):] += 2 * (len(F) // 3)
    want = surface_strains(X, F, MAT, x, R, t)
    got = CongruentTriangles(X, F, MAT, hint, threads=1, thickness=t).surface_strains(x, R)
    assert np.abs(got - want).max() <= 1e-10 * want.max() and want.min() > 0.0
