"""Linear stiffness of the flat 3-node shell triangle, vectorised over elements.

Local degrees of freedom per node, in the element frame (x, y in the mid-plane, z normal):
``(u, v, w, θx, θy, θz)`` — θ is the right-handed rotation vector, θz the drilling rotation. The
18 × 18 local matrix is the sum of two uncoupled parts (the element is flat):

* **membrane**: Felippa's optimal ANDES triangle "OPT" with drilling freedoms (CMAME 192 (2003)
  2125): basic stiffness with α_b = 3/2 plus a higher-order stiffness with β0 = max((1 − 4ν²)/2,
  0.01). It passes the patch test, has the drilling rotation built in (no artificial spring) and,
  unlike the CST, is accurate in in-plane bending, which the narrow bars of a pattern see in Dome.
* **bending + transverse shear**: the DKMT of Katili (IJNME 36 (1993) 1859): the rotations
  β = (βx, βy) = (θy, −θx) are quadratic, β = Σ Nᵢβᵢ + Σ P_k Δβ_k t_k (t_k the unit tangent of side k,
  P_k = 4 NᵢNⱼ), and the tangential shear strain is constant on each side, γ_sk = −(2/3) φ_k Δβ_k
  (side k as a Timoshenko beam, φ_k = 12 D/(D_s L_k²)). Imposing ∫_side (w,s + β_s − γ_s) ds = 0 on the
  three sides fixes the Δβ_k; bending energy ½∫κᵀD_bκ (3 mid-side points, exact) + shear energy
  ½∫γᵀD_sγ with γ the linear field having the side values γ_sk. When t → 0, φ_k → 0 and this is
  exactly the DKT (Batoz 1980).

Units: mm, N, N/mm². Shapes are written ``(m, …)`` for m elements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Arr = NDArray[np.float64]

#: shear correction factor of the Reissner–Mindlin plate
SHEAR_FACTOR = 5.0 / 6.0

MEMBRANE_DOFS = np.array([0, 1, 5, 6, 7, 11, 12, 13, 17])  # u, v, θz of nodes 0, 1, 2
BENDING_DOFS = np.array([2, 3, 4, 8, 9, 10, 14, 15, 16])  # w, θx, θy of nodes 0, 1, 2

_SIDES = ((0, 1), (1, 2), (2, 0))
_MID = np.array([[0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])  # area coords of mid-side points


@dataclass(frozen=True)
class Material:
    """Linear elastic isotropic shell: E (N/mm²), ν, thickness t (mm)."""

    E: float = 1000.0
    nu: float = 0.35
    t: float = 2.0

    @property
    def D_membrane(self) -> Arr:
        """(3, 3) membrane stiffness per unit length (N/mm), Voigt (xx, yy, 2xy)."""
        return self.E * self.t / (1 - self.nu**2) * _iso(self.nu)

    @property
    def D_bending(self) -> Arr:
        """(3, 3) bending stiffness D (N·mm)."""
        return self.E * self.t**3 / (12 * (1 - self.nu**2)) * _iso(self.nu)

    @property
    def D_shear(self) -> float:
        """Transverse shear stiffness κ G t (N/mm)."""
        return SHEAR_FACTOR * self.E / (2 * (1 + self.nu)) * self.t


def _iso(nu: float) -> Arr:
    return np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1 - nu)]])


@dataclass(frozen=True)
class LocalStiffness:
    """Per-element local matrices. Km (m, 9, 9) on MEMBRANE_DOFS; Kb, Ks (m, 9, 9) bending and shear on
    BENDING_DOFS; K (m, 18, 18) the full local matrix; area (m,)."""

    Km: Arr
    Kb: Arr
    Ks: Arr
    K: Arr
    area: Arr


def opt_basic_strain(x: Arr, y: Arr, alpha_b: float = 1.5) -> Arr:
    """(m, 3, 9) OPT basic (constant) strain–displacement matrix B = Lᵀ / A of the Allman-type boundary
    field on dofs (u, v, θz) per node (Felippa 2003 eq. 22; α_b = 3/2 for OPT). x, y: (m, 3) local
    corner coordinates. :func:`opt_membrane` integrates it; :mod:`fabpat.shell.strain` reads strains with it."""
    x12, x23, x31 = x[:, 0] - x[:, 1], x[:, 1] - x[:, 2], x[:, 2] - x[:, 0]
    y12, y23, y31 = y[:, 0] - y[:, 1], y[:, 1] - y[:, 2], y[:, 2] - y[:, 0]
    x21, x32, x13, y21, y32, y13 = -x12, -x23, -x31, -y12, -y23, -y31
    A2 = x21 * y31 - x31 * y21
    z = np.zeros_like(A2)
    ab6 = alpha_b / 6.0
    cols = [
        (y23, z, x32), (z, x32, y23),
        (ab6 * y23 * (y13 - y21), ab6 * x32 * (x31 - x12), ab6 * 2 * (x31 * y13 - x12 * y21)),
        (y31, z, x13), (z, x13, y31),
        (ab6 * y31 * (y21 - y32), ab6 * x13 * (x12 - x23), ab6 * 2 * (x12 * y21 - x23 * y32)),
        (y12, z, x21), (z, x21, y12),
        (ab6 * y12 * (y32 - y13), ab6 * x21 * (x23 - x31), ab6 * 2 * (x23 * y32 - x31 * y13)),
    ]
    return np.stack([np.stack(c, axis=-1) for c in cols], axis=-1) / A2[:, None, None]


def opt_membrane(x: Arr, y: Arr, mat: Material) -> Arr:
    """OPT membrane stiffness (m, 9, 9), dofs (u, v, θz) per node. x, y: (m, 3) local corner coords."""
    nu = mat.nu
    alpha_b = 1.5
    beta0 = max(0.5 * (1 - 4 * nu * nu), 0.01)
    x1, x2, x3 = x.T
    y1, y2, y3 = y.T
    x12, x23, x31 = x1 - x2, x2 - x3, x3 - x1
    y12, y23, y31 = y1 - y2, y2 - y3, y3 - y1
    x21, x32, x13, y21, y32, y13 = -x12, -x23, -x31, -y12, -y23, -y31
    A2 = x21 * y31 - x31 * y21
    A = 0.5 * A2
    m = x.shape[0]
    z = np.zeros(m)
    B = opt_basic_strain(x, y, alpha_b)  # (m, 3, 9)
    # hierarchical (deviatoric) corner rotations θ̃ᵢ = θᵢ − θ_CST (eq. 16)
    row = np.stack([x32, y32, z, x13, y13, z, x21, y21, z], axis=-1) / (2 * A2)[:, None]
    Tth = np.repeat(row[:, None, :], 3, axis=1)
    Tth[:, [0, 1, 2], [2, 5, 8]] += 1.0
    L21, L32, L13 = x21**2 + y21**2, x32**2 + y32**2, x13**2 + y13**2
    # straingage rosette: Cartesian strains from the natural (side) strains (eq. 12)
    Te = np.stack([
        np.stack([y23 * y13, x23 * x13, y23 * x31 + x32 * y13], -1) * L21[:, None],
        np.stack([y31 * y21, x31 * x21, y31 * x12 + x13 * y21], -1) * L32[:, None],
        np.stack([y12 * y32, x12 * x32, y12 * x23 + x21 * y32], -1) * L13[:, None],
    ], axis=-1) / (A2 * A2)[:, None, None]
    b = np.array([1, 2, 1, 0, 1, -1, -1, -1, -2], dtype=float)  # optimal β1..β9 (eq. 42)
    Qbase = [b.reshape(3, 3), b[[8, 6, 7, 2, 0, 1, 5, 3, 4]].reshape(3, 3),
             b[[4, 5, 3, 7, 8, 6, 1, 2, 0]].reshape(3, 3)]
    scale = (A2 / 3.0)[:, None] / np.stack([L21, L32, L13], axis=-1)  # (m, 3) row scaling
    # linear strain field ε(L) = Σᵢ Lᵢ (B + β̃0 Te Qᵢ Tθ) d with β̃0 = 3/2 √β0 integrates to
    # Kb + Kh of eq. (32); three mid-side points integrate it exactly
    bt0 = 1.5 * np.sqrt(beta0)
    Bi = [B + bt0 * Te @ (scale[:, :, None] * Q) @ Tth for Q in Qbase]
    Dm = mat.D_membrane
    K = np.zeros((m, 9, 9))
    for lam in _MID:
        Bq = lam[0] * Bi[0] + lam[1] * Bi[1] + lam[2] * Bi[2]
        K += Bq.transpose(0, 2, 1) @ (Dm @ Bq) * (A / 3.0)[:, None, None]  # matmul: 10× an einsum
    return K


def dkmt_bending(x: Arr, y: Arr, mat: Material) -> tuple[Arr, Arr]:
    """DKMT bending and shear stiffness (m, 9, 9) each, dofs (w, θx, θy) per node.

    x, y: (m, 3) local corner coordinates (counter-clockwise). With ``mat.t → 0`` this is the DKT.
    """
    m = x.shape[0]
    P = np.stack([x, y], axis=-1)  # (m, 3, 2)
    A2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    A = 0.5 * A2
    # gradients of the linear shape functions (m, 3, 2)
    g = np.stack([
        np.stack([y[:, 1] - y[:, 2], x[:, 2] - x[:, 1]], -1),
        np.stack([y[:, 2] - y[:, 0], x[:, 0] - x[:, 2]], -1),
        np.stack([y[:, 0] - y[:, 1], x[:, 1] - x[:, 0]], -1),
    ], axis=1) / A2[:, None, None]
    Lk = np.stack([np.linalg.norm(P[:, j] - P[:, i], axis=-1) for i, j in _SIDES], axis=1)  # (m, 3)
    tk = np.stack([(P[:, j] - P[:, i]) for i, j in _SIDES], axis=1) / Lk[..., None]  # (m, 3, 2)
    D = mat.D_bending
    Ds = mat.D_shear

    def grad_P(lam: Arr) -> Arr:
        """∇P_k (m, 3, 2) at area coordinates lam (3,), P_k = 4 N_i N_j."""
        return np.stack([4 * (lam[j] * g[:, i] + lam[i] * g[:, j]) for i, j in _SIDES], axis=1)

    tx, ty = tk[..., 0], tk[..., 1]

    def curv_P(dP: Arr) -> Arr:
        """(m, 3, 3) curvature (κxx, κyy, 2κxy) per unit Δβ_k given ∂P_k/∂(x, y) as dP (m, 3, 2)."""
        return np.stack([dP[..., 0] * tx, dP[..., 1] * ty, dP[..., 1] * tx + dP[..., 0] * ty], axis=1)

    # Side k as a Timoshenko beam (Katili 1993): β_s = P_k Δβ_k gives T_s = D d²β_s/ds² = −8 D Δβ_k/L²,
    # so γ_sk = −(2/3) φ_k Δβ_k with φ_k = 12 D / (D_s L_k²) = 2 (t/L_k)² / (κ (1 − ν)). The relation is
    # local to the side, so neighbours agree on Δβ_k and the patch test is passed.
    phi = 12.0 * D[0, 0] / (Ds * Lk * Lk)
    ADelta = (2.0 / 3.0) * Lk * (1.0 + phi)  # (m, 3) diagonal
    Aw = np.zeros((m, 3, 9))
    for k, (i, j) in enumerate(_SIDES):
        Aw[:, k, 3 * i] = 1.0
        Aw[:, k, 3 * j] = -1.0
        for n_ in (i, j):
            Aw[:, k, 3 * n_ + 2] -= 0.5 * Lk[:, k] * tx[:, k]  # βx = θy
            Aw[:, k, 3 * n_ + 1] += 0.5 * Lk[:, k] * ty[:, k]  # βy = −θx
    G = Aw / ADelta[:, :, None]  # Δβ = G u (m, 3, 9)
    # linear part: (βx, βy) of the nodes from u
    S = np.zeros((6, 9))
    for n_ in range(3):
        S[2 * n_, 3 * n_ + 2] = 1.0
        S[2 * n_ + 1, 3 * n_ + 1] = -1.0
    Blin = np.zeros((m, 3, 6))
    Blin[:, 0, 0::2] = g[..., 0]
    Blin[:, 1, 1::2] = g[..., 1]
    Blin[:, 2, 0::2] = g[..., 1]
    Blin[:, 2, 1::2] = g[..., 0]
    Blin = Blin @ S
    Kb = np.zeros((m, 9, 9))
    for lam in _MID:
        Bq = Blin + curv_P(grad_P(lam)) @ G
        Kb += Bq.transpose(0, 2, 1) @ (D @ Bq) * (A / 3.0)[:, None, None]
    # assumed shear strain: the linear field γ = c + b·(−y, x) whose tangential component on side k is
    # the constant γ_sk (rotated lowest-order Raviart–Thomas, as in MITC3); 3 mid-side points
    Gs = -(2.0 / 3.0) * phi[:, :, None] * G  # γ_s = Gs u (m, 3, 9)
    mids = 0.5 * (P[:, [0, 1, 2]] + P[:, [1, 2, 0]])  # (m, 3, 2) side midpoints
    C = np.stack([tx, ty, tx * -mids[..., 1] + ty * mids[..., 0]], axis=-1)  # (m, 3, 3)
    coef = np.linalg.solve(C, Gs)  # (c_x, c_y, b) per u (m, 3, 9)
    Ks = np.zeros((m, 9, 9))
    for k in range(3):
        px, py = mids[:, k, 0], mids[:, k, 1]
        gx = coef[:, 0] - coef[:, 2] * py[:, None]
        gy = coef[:, 1] + coef[:, 2] * px[:, None]
        Bs = np.stack([gx, gy], axis=1)  # (m, 2, 9)
        Ks += Bs.transpose(0, 2, 1) @ Bs * (Ds * A / 3.0)[:, None, None]
    return Kb, Ks


def local_stiffness(x: Arr, y: Arr, mat: Material) -> LocalStiffness:
    """Full local stiffness (m, 18, 18) of flat triangles with local corner coordinates x, y (m, 3)."""
    Km = opt_membrane(x, y, mat)
    Kb, Ks = dkmt_bending(x, y, mat)
    m = x.shape[0]
    K = np.zeros((m, 18, 18))
    K[:, MEMBRANE_DOFS[:, None], MEMBRANE_DOFS[None, :]] = Km
    K[:, BENDING_DOFS[:, None], BENDING_DOFS[None, :]] = Kb + Ks
    area = 0.5 * ((x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0]))
    return LocalStiffness(Km, Kb, Ks, K, area)


def element_frames(X: Arr, F: NDArray[np.int64]) -> tuple[Arr, Arr, Arr]:
    """Initial element frames and local coordinates.

    X: (n, 3) node coordinates; F: (m, 3) triangles. Returns E0 (m, 3, 3) with columns e1 (along side
    0→1), e2, e3 (normal), and local corner coordinates x, y (m, 3) relative to the centroid.
    """
    P = X[F]  # (m, 3, 3)
    e1 = P[:, 1] - P[:, 0]
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e3 = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    e3 /= np.linalg.norm(e3, axis=1)[:, None]
    e2 = np.cross(e3, e1)
    E0 = np.stack([e1, e2, e3], axis=-1)
    r = P - P.mean(axis=1, keepdims=True)
    loc = np.einsum("mai,mij->maj", r, E0)
    return E0, loc[..., 0], loc[..., 1]
