"""Surface strains of a deformed corotational triangle shell: membrane plus bending, per element.

For a state (x, R) of a :class:`~fabpat.shell.corotational.CorotationalTriangles` mesh the local
deformational dofs d (per node u, v, w, θx, θy, θz in the element frame, see
:meth:`~fabpat.shell.corotational.CorotationalTriangles.deformational`) are turned into the strains
the element's own stiffness is built from, averaged over the element:

* **membrane** ε_m = (εxx, εyy, γxy): the *basic* (constant) strain of Felippa's OPT triangle,
  B d_m with B of Felippa, CMAME 192 (2003) 2125, eq. 22 (α_b = 3/2; an Allman-type field, so the
  drilling rotations θz contribute). OPT's higher-order strains are deviatoric with zero element mean
  (the three β-matrices Q₁ + Q₂ + Q₃ = 0), so B d_m *is* the element mean of OPT's strain field.
  With θz = 0 it is the CST strain of the local in-plane displacements.
* **curvature** κ = (κxx, κyy, 2κxy) with β = (βx, βy) = (θy, −θx), κxx = ∂βx/∂x, κyy = ∂βy/∂y,
  2κxy = ∂βx/∂y + ∂βy/∂x: the element mean of the DKMT curvature field (Katili, IJNME 36 (1993)
  1859; the DKT of Batoz 1980 when thin), i.e. the Mindlin linear-interpolation curvature plus the
  mean of the quadratic side corrections Σ ∇P_k Δβ_k t_k (mean ∇P_k = 4/3 (∇Nᵢ + ∇Nⱼ)).
* **surfaces** z = ±t/2 (z along the current element normal, +z the side F's triangles turn
  counter-clockwise about): ε(z) = ε_m + z κ, whose principal values (tensor shear γxy/2) give
  :attr:`SurfaceStrain.principal`.

The strain measure is the one the solver's energy uses (small strain in the corotated frame, exact
for rigid motions of any size), so it is valid for moderate strains (PLA's 2 % limit) at any
rotation. It is an **element average**: the peak of a bar in in-plane bending, or of a curvature that
varies within an element, is resolved only as far as the mesh resolves it (refine h to converge it).
Shapes: n nodes, m elements; units mm, rad, strains dimensionless, curvature 1/mm.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import BENDING_DOFS, MEMBRANE_DOFS, Material, opt_basic_strain
from fabpat.shell.rotations import expmap

Arr = NDArray[np.float64]

_SIDES = ((0, 1), (1, 2), (2, 0))


@dataclass(frozen=True, eq=False)
class SurfaceStrain:
    """Per-element strains in each element's current frame (e1, e2 in-plane, e3 normal).

    membrane: (m, 3) (εxx, εyy, γxy), γ the engineering shear; curvature: (m, 3) (κxx, κyy, 2κxy)
    in 1/mm; principal: (m, 2, 2) principal strains [surface, (ε1 ≥ ε2)] on the bottom (z = −t/2,
    index 0) and top (z = +t/2, index 1) surfaces.
    """

    membrane: Arr
    curvature: Arr
    principal: Arr

    @property
    def peak(self) -> Arr:
        """(m,) largest principal strain magnitude on either surface (≥ 0)."""
        return np.abs(self.principal).max(axis=(1, 2))

    @property
    def peak_signed(self) -> Arr:
        """(m,) that principal strain with its sign (> 0 tension, < 0 compression)."""
        p = self.principal.reshape(len(self.principal), 4)
        return p[np.arange(len(p)), np.abs(p).argmax(axis=1)]


def dkmt_mean_curvature(x: Arr, y: Arr, mat: Material) -> Arr:
    """(m, 3, 9) element-mean DKMT curvature operator on dofs (w, θx, θy) per node, giving
    (κxx, κyy, 2κxy) in 1/mm; the fields of :func:`fabpat.shell.element.dkmt_bending` (Katili 1993),
    averaged over the triangle. x, y: (m, 3) local corner coordinates, counter-clockwise."""
    m = x.shape[0]
    P = np.stack([x, y], axis=-1)
    A2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    g = np.stack([
        np.stack([y[:, 1] - y[:, 2], x[:, 2] - x[:, 1]], -1),
        np.stack([y[:, 2] - y[:, 0], x[:, 0] - x[:, 2]], -1),
        np.stack([y[:, 0] - y[:, 1], x[:, 1] - x[:, 0]], -1),
    ], axis=1) / A2[:, None, None]
    Lk = np.stack([np.linalg.norm(P[:, j] - P[:, i], axis=-1) for i, j in _SIDES], axis=1)
    tk = np.stack([P[:, j] - P[:, i] for i, j in _SIDES], axis=1) / Lk[..., None]
    tx, ty = tk[..., 0], tk[..., 1]
    phi = 12.0 * mat.D_bending[0, 0] / (mat.D_shear * Lk * Lk)
    Aw = np.zeros((m, 3, 9))
    for k, (i, j) in enumerate(_SIDES):
        Aw[:, k, 3 * i] = 1.0
        Aw[:, k, 3 * j] = -1.0
        for a in (i, j):
            Aw[:, k, 3 * a + 2] -= 0.5 * Lk[:, k] * tx[:, k]
            Aw[:, k, 3 * a + 1] += 0.5 * Lk[:, k] * ty[:, k]
    G = Aw / ((2.0 / 3.0) * Lk * (1.0 + phi))[:, :, None]  # Δβ_k per dof (m, 3, 9)
    Bm = np.zeros((m, 3, 9))  # linear part: βx = θy (dof 3a + 2), βy = −θx (dof 3a + 1)
    for a in range(3):
        Bm[:, 0, 3 * a + 2] = g[:, a, 0]
        Bm[:, 1, 3 * a + 1] = -g[:, a, 1]
        Bm[:, 2, 3 * a + 2] = g[:, a, 1]
        Bm[:, 2, 3 * a + 1] = -g[:, a, 0]
    dP = np.stack([4.0 / 3.0 * (g[:, i] + g[:, j]) for i, j in _SIDES], axis=1)  # mean ∇P_k
    cP = np.stack([dP[..., 0] * tx, dP[..., 1] * ty, dP[..., 1] * tx + dP[..., 0] * ty], axis=1)
    return Bm + cP @ G


def principal_2d(e: Arr) -> Arr:
    """(…, 2) principal values (ε1 ≥ ε2) of Voigt strains e (…, 3) = (εxx, εyy, γxy)."""
    c = 0.5 * (e[..., 0] + e[..., 1])
    r = np.hypot(0.5 * (e[..., 0] - e[..., 1]), 0.5 * e[..., 2])
    return np.stack([c + r, c - r], axis=-1)


def thickness_groups(thickness: Arr, m: int) -> list[tuple[float, NDArray[np.int64]]]:
    """The elements of each distinct thickness: [(t mm, element indices), …] for a per-element ``thickness``
    (m,) in mm, thinnest first. A mesh whose plates differ in thickness computes each group's element
    matrices with ``Material(E, nu, t)`` as one batch (every element's matrices depend on its own
    corners and thickness only). Raises GeometryError unless ``thickness`` is m finite positive numbers."""
    t = np.asarray(thickness, dtype=np.float64)
    if t.shape != (m,) or not np.all(np.isfinite(t)) or not np.all(t > 0.0):
        raise GeometryError(f"thickness must be {m} finite positive numbers (mm), one per element, got shape "
                            f"{t.shape}")
    values, which = np.unique(t, return_inverse=True)
    return [(float(v), np.flatnonzero(which == i)) for i, v in enumerate(values)]


class LocalCorners(Protocol):
    """What :func:`strain_from_dofs` reads of a mesh: ``xl0`` (m, 3, 2) each element's corners in its initial
    frame (mm) and ``mat`` its material (a :class:`~fabpat.shell.corotational.CorotationalTriangles`, or
    the congruent triangles of :mod:`fabpat.shell.congruent`)."""

    xl0: Arr
    mat: Material


def strain_from_dofs(model: LocalCorners, d: Arr, thickness: Arr | None = None) -> SurfaceStrain:
    """Surface strains of local deformational dofs d (m, 18) of ``model`` (see module doc); ``thickness``
    (m,) mm per element, None: every element has ``model.mat.t`` (:func:`thickness_groups`)."""
    x, y = model.xl0[..., 0], model.xl0[..., 1]
    em = (opt_basic_strain(x, y) @ d[:, MEMBRANE_DOFS, None])[..., 0]
    if thickness is None:
        kap = (dkmt_mean_curvature(x, y, model.mat) @ d[:, BENDING_DOFS, None])[..., 0]
        h: float | Arr = 0.5 * model.mat.t
    else:
        kap = np.empty_like(em)
        for t, idx in thickness_groups(thickness, len(d)):
            C = dkmt_mean_curvature(x[idx], y[idx], replace(model.mat, t=t))  # the shear ratio depends on t
            kap[idx] = (C @ d[idx][:, BENDING_DOFS, None])[..., 0]
        h = 0.5 * np.asarray(thickness, dtype=np.float64)[:, None]
    principal = np.stack([principal_2d(em - h * kap), principal_2d(em + h * kap)], axis=1)
    return SurfaceStrain(em, kap, principal)


def _rotations(R: Arr, n: int) -> Arr:
    R = np.asarray(R, dtype=np.float64)
    if R.shape == (n, 3):
        return expmap(R)
    if R.shape != (n, 3, 3):
        raise GeometryError(f"rotations must be (n, 3, 3) matrices or (n, 3) rotation vectors with n = {n}, "
                            f"got shape {R.shape}")
    return R


def surface_strain_field(X: Arr, F: NDArray[np.int64], material: Material, x: Arr, R: Arr,
                         thickness: Arr | None = None) -> SurfaceStrain:
    """Per-element membrane strain, curvature and surface principal strains of a deformed shell.

    X: (n, 3) or (n, 2) initial node coordinates (mm, flat or not); F: (m, 3) triangles; x: (n, 3)
    deformed coordinates (mm); R: (n, 3, 3) nodal rotation matrices, or (n, 3) rotation vectors
    (rad, e.g. ``ShellResult.rotation``); ``thickness`` (m,) mm per element (None: ``material.t``
    everywhere; the surfaces are then at ±t/2 of each element's own t). Raises GeometryError on
    mismatched shapes or degenerate (zero-area) triangles. Formulas and sources: module doc.
    """
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 2 and X.shape[1] == 2:
        X = np.column_stack([X, np.zeros(len(X))])
    x = np.asarray(x, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if X.ndim != 2 or X.shape[1] != 3 or x.shape != X.shape:
        raise GeometryError(f"X and x must both be (n, 3) node coordinates, got {X.shape} and {x.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or (F.size and (F.min() < 0 or F.max() >= len(X))):
        raise GeometryError(f"F must be (m, 3) indices of the {len(X)} nodes")
    Rm = _rotations(R, len(X))
    with np.errstate(divide="ignore", invalid="ignore"):
        model = CorotationalTriangles(X, F, material)
        xe, Re = model.gather(x, Rm)
        d, _ = model.deformational(xe, Re)
        out = strain_from_dofs(model, d, thickness)
    if not np.all(np.isfinite(out.principal)):
        raise GeometryError("degenerate (zero-area) triangle in the reference or deformed mesh")
    return out


def surface_strains(X: Arr, F: NDArray[np.int64], material: Material, x: Arr, R: Arr,
                    thickness: Arr | None = None) -> Arr:
    """(m,) per element, the largest principal strain magnitude on either surface z = ±t/2
    (membrane plus bending, ≥ 0, dimensionless): :attr:`SurfaceStrain.peak` of
    :func:`surface_strain_field` (same arguments; its ``peak_signed`` keeps the sign)."""
    return surface_strain_field(X, F, material, x, R, thickness).peak
