"""The fast corotational kernels: stiffness root, batched forces and the tangent at large rotations."""

from __future__ import annotations

import numpy as np

from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import Material
from fabpat.shell.rotations import (
    dexp_inv,
    dexp_inv_and_moment_jacobian,
    dexp_inv_t_apply,
    expmap,
    log_from_axial,
    logmap,
)
from tests.shell_fixtures import rect_mesh
from tests.test_shell_nonlinear import _perturbed


def _model_and_state(seed: int = 0) -> tuple[CorotationalTriangles, np.ndarray, np.ndarray]:
    V, F = rect_mesh(4.0, 3.0, 4, 3, skew=0.2)
    X = np.c_[V, np.zeros(len(V))]
    model = CorotationalTriangles(X, F, Material(1000.0, 0.35, 0.8))
    rng = np.random.default_rng(seed)
    Q = expmap(np.array([0.4, -0.9, 0.3]))
    x = X @ Q.T + rng.normal(size=X.shape) * 0.05
    R = expmap(rng.normal(size=(len(X), 3)) * 0.4) @ Q
    return model, x, R


def test_stiffness_root_reproduces_local_stiffness() -> None:
    model, _, _ = _model_and_state()
    Q = model._stiffness_root()
    K = model.local.K
    assert np.abs(Q.transpose(0, 2, 1) @ Q - K).max() <= 1e-12 * np.abs(K).max()
    assert Q.shape[1] == 12  # the rigid-body modes are dropped
    # the eigen-decomposition fallback spans the same 12-dimensional root
    Qe = model._stiffness_root_eigh()
    assert Qe.shape[1] == 12
    assert np.abs(Qe.transpose(0, 2, 1) @ Qe - K).max() <= 1e-12 * np.abs(K).max()


def test_dexp_inv_t_apply_matches_matrix() -> None:
    rng = np.random.default_rng(3)
    th = rng.normal(size=(50, 3)) * rng.random((50, 1)) * 2.0
    m = rng.normal(size=(50, 3))
    ref = np.einsum("nji,nj->ni", dexp_inv(th), m)
    assert np.allclose(dexp_inv_t_apply(th, m), ref, atol=1e-13)
    # components first (the layout of the force kernels)
    assert np.allclose(dexp_inv_t_apply(th.T, m.T, axis=0).T, ref, atol=1e-13)
    R = expmap(th)
    w = 0.5 * np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]])
    c = 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0)
    assert np.allclose(log_from_axial(w, c, axis=0).T, logmap(R), rtol=0, atol=1e-13)


def test_moment_jacobian_matches_finite_differences() -> None:
    rng = np.random.default_rng(5)
    # angles on both sides of the series switches (10⁻³ for H⁻¹, 10⁻² for the jacobian) and large ones
    scale = np.repeat([1e-4, 3e-3, 3e-2, 0.8], 10)[:, None, None]
    th = (rng.normal(size=(40, 3, 3)) * scale)
    m = rng.normal(size=(40, 3, 3))
    H, M = dexp_inv_and_moment_jacobian(th, m)
    assert np.allclose(H, dexp_inv(th), rtol=0, atol=1e-15)
    e = 1e-6
    J = np.stack([(dexp_inv_t_apply(th + e * np.eye(3)[k], m) - dexp_inv_t_apply(th - e * np.eye(3)[k], m)) / (2 * e)
                  for k in range(3)], axis=-1)
    assert np.allclose(M, J @ dexp_inv(th), rtol=0, atol=1e-8)
    # components first: (3, …) in, (3, 3, …) out
    H0, M0 = dexp_inv_and_moment_jacobian(np.moveaxis(th, -1, 0), np.moveaxis(m, -1, 0), axis=0)
    assert np.array_equal(np.moveaxis(H0, (0, 1), (-2, -1)), H) and np.array_equal(np.moveaxis(M0, (0, 1), (-2, -1)), M)


def test_batched_forces_match_and_tangent_matches_finite_differences() -> None:
    model, x, R = _model_and_state()
    xe, Re = model.gather(x, R)
    fe, U, d = model.element_forces(xe, Re)
    fb, Ub, _ = model.element_forces(np.stack([xe, xe]), np.stack([Re, Re]))
    assert np.allclose(fb[1], fe, rtol=0, atol=1e-12 * np.abs(fe).max())
    assert np.allclose(Ub[0], U)
    Kt = model.element_tangents(xe, Re, d)
    e = 1e-6
    for j in (0, 4, 8, 9, 13, 17):  # translations and spins of the three nodes
        fd = (_perturbed(model, xe, Re, j, e)[0] - _perturbed(model, xe, Re, j, -e)[0]) / (2 * e)
        assert np.allclose(Kt[:, :, j], fd, atol=1e-5 * np.abs(Kt).max())


def test_tangent_reuses_the_force_evaluation_only_at_the_same_state() -> None:
    model, x, R = _model_and_state()
    xe, Re = model.gather(x, R)
    _, _, d = model.element_forces(xe, Re)
    fresh, _, _ = _model_and_state()  # no force evaluation: frame and local parts computed afresh
    ref = fresh.element_tangents(xe, Re, d)
    assert np.array_equal(model.element_tangents(*model.gather(x, R), d), ref)
    # changing the evaluated arrays in place, or a force evaluation elsewhere, must not leave a stale frame
    moved = xe + np.random.default_rng(1).normal(size=xe.shape) * 0.02
    _, _, d2 = model.element_forces(moved, Re)
    stale = fresh.element_tangents(moved, Re, d2)
    moved[:, 0] += 0.05
    now = model.element_tangents(moved, Re, d2)
    assert np.array_equal(now, fresh.element_tangents(moved, Re, d2))
    assert not np.allclose(now, stale)  # the two states differ enough to tell
    assert np.array_equal(model.element_tangents(xe, Re, d), ref)
