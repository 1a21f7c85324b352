"""Finite rotations, vectorised over leading axes: exp/log maps and the inverse tangent operator.

A rotation vector θ (…, 3) maps to R = exp([θ]×) (…, 3, 3) by Rodrigues' formula. Nodal rotations
are updated by a *spatial* spin ω: R ← exp([ω]×) R, so variations are δR Rᵀ = [δω]×.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Arr = NDArray[np.float64]


def skew(v: Arr) -> Arr:
    """[v]× (…, 3, 3) of vectors v (…, 3)."""
    S = np.zeros((*v.shape[:-1], 3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def expmap(theta: Arr) -> Arr:
    """Rotation matrices (…, 3, 3) of rotation vectors (…, 3) (Rodrigues; series below 1e-4 rad)."""
    t2 = np.einsum("...i,...i->...", theta, theta)
    t = np.sqrt(t2)
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    a = np.where(small, 1.0 - t2 / 6.0, np.sin(ts) / ts)
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(ts)) / (ts * ts))
    K = skew(theta)
    return np.eye(3) + a[..., None, None] * K + b[..., None, None] * (K @ K)


def logmap(R: Arr) -> Arr:
    """Rotation vectors (…, 3) of rotation matrices (…, 3, 3), angle in [0, π).

    Uses atan2(sin, cos) for accuracy at small angles; valid away from π, which the deformational
    rotations of the corotational element never approach.
    """
    w = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                        R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    return log_from_axial(w, 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0))


def log_from_axial(w: Arr, c: Arr) -> Arr:
    """Rotation vectors (…, 3) of rotations given by their axial vector w = sin(t) axis (…, 3), the
    axial vector of (R − Rᵀ)/2, and c = cos t = (tr R − 1)/2 (…): what :func:`logmap` needs of R, for
    callers that get these two without forming R."""
    s = np.sqrt(np.einsum("...i,...i->...", w, w))
    t = np.arctan2(s, c)
    small = s < 1e-7
    f = np.where(small, 1.0 + s * s / 6.0, t / np.where(small, 1.0, s))
    return f[..., None] * w


def _eta(t2: Arr) -> Arr:
    """η = (1 − (t/2) cot(t/2)) / t² of squared angles t2 = t² (…); series 1/12 + t²/720 below t = 10⁻³."""
    t = np.sqrt(t2)
    small = t < 1e-3
    ts = np.where(small, 1.0, t)
    return np.where(small, 1.0 / 12.0 + t2 / 720.0, (1.0 - 0.5 * ts / np.tan(0.5 * ts)) / (ts * ts))


def _add_diag_minus_skew(out: Arr, diag: Arr, v: Arr) -> None:
    """out += diag I − [v]× in place, out (…, 3, 3), diag (…), v (…, 3): entry by entry, because these
    run per element node and skew/eye temporaries would cost more than the arithmetic."""
    out[..., 0, 0] += diag
    out[..., 1, 1] += diag
    out[..., 2, 2] += diag
    out[..., 0, 1] += v[..., 2]
    out[..., 1, 0] -= v[..., 2]
    out[..., 0, 2] -= v[..., 1]
    out[..., 2, 0] += v[..., 1]
    out[..., 1, 2] += v[..., 0]
    out[..., 2, 1] -= v[..., 0]


def dexp_inv(theta: Arr) -> Arr:
    """H⁻¹(θ) (…, 3, 3) with δθ = H⁻¹(θ) δψ when δR Rᵀ = [δψ]×, R = exp([θ]×).

    H⁻¹ = I − ½Θ + η Θ², η = (1 − (t/2) cot(t/2)) / t² (series 1/12 + t²/720 for small t).
    """
    t2 = np.einsum("...i,...i->...", theta, theta)
    eta = _eta(t2)
    # Θ² = θθᵀ − |θ|² I
    et = eta[..., None] * theta
    H = et[..., :, None] * theta[..., None, :]
    diag = 1.0 - eta * t2
    half = 0.5 * theta
    _add_diag_minus_skew(H, diag, half)
    return H


def dexp_inv_t_apply(theta: Arr, m: Arr) -> Arr:
    """H⁻ᵀ(θ) m (…, 3) = m + ½ θ × m + η (θ(θ·m) − |θ|² m): a local moment sent through H⁻ᵀ without
    forming the matrix (same η as :func:`dexp_inv`)."""
    t2 = np.einsum("...i,...i->...", theta, theta)
    eta = _eta(t2)
    tm = np.einsum("...i,...i->...", theta, m)
    t0, t1, t2_ = theta[..., 0], theta[..., 1], theta[..., 2]
    m0, m1, m2 = m[..., 0], m[..., 1], m[..., 2]
    txm = np.stack([t1 * m2 - t2_ * m1, t2_ * m0 - t0 * m2, t0 * m1 - t1 * m0], axis=-1)
    return m + 0.5 * txm + eta[..., None] * (theta * tm[..., None] - t2[..., None] * m)


def dexp_inv_t_jacobian(theta: Arr, m: Arr) -> Arr:
    """∂(H⁻ᵀ(θ) m)/∂θ (…, 3, 3) at fixed m (…, 3): the variation of a local moment sent through H⁻ᵀ.

    H⁻ᵀ m = m + ½ θ×m + η (θ(θ·m) − |θ|² m), so the derivative is −½[m]× + η (θ mᵀ + (θ·m) I − 2 m θᵀ)
    + (θ(θ·m) − |θ|² m)(η'/t) θᵀ, with η'/t → 1/360 + t²/7560 below t = 10⁻² (where the closed form
    starts to cancel).
    """
    t2 = np.einsum("...i,...i->...", theta, theta)
    t = np.sqrt(t2)
    small = t < 1e-2
    ts = np.where(small, 1.0, t)
    half = 0.5 * ts
    c = half / np.tan(half)
    eta = np.where(small, 1.0 / 12.0 + t2 / 720.0, (1.0 - c) / (ts * ts))
    dc = 0.5 / np.tan(half) - 0.25 * ts / np.sin(half) ** 2
    deta_t = np.where(small, 1.0 / 360.0 + t2 / 7560.0, -dc / ts**3 - 2.0 * (1.0 - c) / ts**4)
    tm = np.einsum("...i,...i->...", theta, m)
    # θ (η m)ᵀ + (η'/t (θ(θ·m) − |θ|² m) − 2η m) θᵀ, then the diagonal and skew parts
    w = deta_t[..., None] * (theta * tm[..., None] - t2[..., None] * m) - 2.0 * eta[..., None] * m
    J = theta[..., :, None] * (eta[..., None] * m)[..., None, :] + w[..., :, None] * theta[..., None, :]
    diag = eta * tm
    _add_diag_minus_skew(J, diag, 0.5 * m)
    return J
