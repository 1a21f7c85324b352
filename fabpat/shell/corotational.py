"""Element-independent corotational (EICR) kinematics of the flat triangle, vectorised.

The patterns start flat, so the local linear stiffness (``element.local_stiffness``) is computed
once; large rotations are handled by moving a frame with each element (Felippa & Haugen, CMAME 194
(2005) 2285). Choices made here:

* **Element frame**: normal e3 of the current triangle; in-plane axes rotated so that the in-plane
  deformation gradient from the initial local coordinates is *symmetric* (polar decomposition,
  as in Caselli & Bisegna 2013). The frame does not depend on node numbering and the deformational
  in-plane displacements carry no rigid rotation.
* **Deformational dofs** of node a: dₐ = Eᵀ(xₐ − x_c) − Xₐ⁰ (local z is 0 by construction) and
  θₐ = log(Eᵀ Rₐ E₀), with Rₐ the node's total rotation and E₀ the initial frame.
* **Internal force** = exact gradient of U = ½ dᵀ K d with respect to node positions and *spatial*
  spins δω (δR Rᵀ = [δω]×), including the spin of the frame: the formulation is energy-consistent
  and f is exact. Tangent: material part Bᵀ K B analytic, geometric part (derivative of Bᵀ at
  fixed local force) by forward differences in one vectorised batch of 18 perturbed states.

Shapes: m elements, leading batch axes ``…`` allowed everywhere.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fabpat.shell.element import BENDING_DOFS, MEMBRANE_DOFS, LocalStiffness, Material, element_frames
from fabpat.shell.element import local_stiffness as _local_stiffness
from fabpat.shell.rotations import dexp_inv, expmap, logmap

Arr = NDArray[np.float64]

_FD_ROT = 1e-7  # rad, rotation perturbation of the finite-difference tangent
_FD_LEN = 1e-7  # × characteristic element length, translation perturbation


class CorotationalTriangles:
    """Precomputed data of a flat triangle mesh for linear and corotational analysis.

    X: (n, 3) initial node coordinates (mm); F: (m, 3) int64 triangles (counter-clockwise seen from
    +e3); mat: material and thickness.
    """

    def __init__(self, X: Arr, F: NDArray[np.int64], mat: Material) -> None:
        self.X = np.asarray(X, dtype=np.float64)
        self.F = np.asarray(F, dtype=np.int64)
        self.mat = mat
        self.E0, x, y = element_frames(self.X, self.F)
        self.xl0 = np.stack([x, y], axis=-1)  # (m, 3, 2)
        self.local: LocalStiffness = _local_stiffness(x, y, mat)
        A2 = 2 * self.local.area
        self.gN = np.stack([  # ∂Nₐ/∂(X, Y) in initial local coordinates (m, 3, 2)
            np.stack([y[:, 1] - y[:, 2], x[:, 2] - x[:, 1]], -1),
            np.stack([y[:, 2] - y[:, 0], x[:, 0] - x[:, 2]], -1),
            np.stack([y[:, 0] - y[:, 1], x[:, 1] - x[:, 0]], -1),
        ], axis=1) / A2[:, None, None]
        self.h_char = float(np.sqrt(np.mean(A2)))
        self.edofs = (6 * self.F[:, :, None] + np.arange(6)).reshape(-1, 18)  # (m, 18) global dofs

    # ------------------------------------------------------------------ linear
    def linear_element_matrices(self) -> Arr:
        """(m, 18, 18) global-frame stiffness Tᵀ K T at the initial geometry."""
        T = np.zeros((self.F.shape[0], 18, 18))
        Et = self.E0.transpose(0, 2, 1)
        for b in range(6):
            T[:, 3 * b:3 * b + 3, 3 * b:3 * b + 3] = Et
        return np.einsum("mai,mab,mbj->mij", T, self.local.K, T)

    def linear_local_dofs(self, u: Arr) -> Arr:
        """(m, 18) local dofs of a small global displacement field u (n, 6)."""
        ue = u[self.F]  # (m, 3, 6)
        Et = self.E0.transpose(0, 2, 1)
        d = np.concatenate([np.einsum("mij,maj->mai", Et, ue[..., :3]),
                            np.einsum("mij,maj->mai", Et, ue[..., 3:])], axis=-1)
        return d.reshape(-1, 18)

    # ------------------------------------------------------------- nonlinear
    def deformational(self, xe: Arr, Re: Arr) -> tuple[Arr, dict[str, Arr]]:
        """Local deformational dofs d (…, m, 18) of element node positions xe (…, m, 3, 3) and node
        rotations Re (…, m, 3, 3, 3); plus the frame quantities the force needs."""
        xc = xe.mean(axis=-2)
        r = xe - xc[..., None, :]
        a = xe[..., 1, :] - xe[..., 0, :]
        b = xe[..., 2, :] - xe[..., 0, :]
        c = np.cross(a, b)
        cn = np.linalg.norm(c, axis=-1)
        n = c / cn[..., None]
        a1 = a / np.linalg.norm(a, axis=-1)[..., None]
        a2 = np.cross(n, a1)
        p = r @ np.stack([a1, a2], axis=-1)  # (…, m, 3, 2) in-plane coords in a provisional frame
        Fp = np.swapaxes(p, -1, -2) @ self.gN
        phi = np.arctan2(Fp[..., 1, 0] - Fp[..., 0, 1], Fp[..., 0, 0] + Fp[..., 1, 1])
        cp, sp = np.cos(phi)[..., None], np.sin(phi)[..., None]
        e1 = cp * a1 + sp * a2
        e2 = -sp * a1 + cp * a2
        E = np.stack([e1, e2, n], axis=-1)  # (…, m, 3, 3) columns e1 e2 e3
        loc = r @ E
        Rloc = (np.swapaxes(E, -1, -2)[..., None, :, :] @ Re) @ self.E0[:, None]
        th = logmap(Rloc)  # (…, m, 3, 3)
        d = np.concatenate([loc[..., :2] - self.xl0, np.zeros(loc.shape[:-1] + (1,)), th], axis=-1)
        trF = np.einsum("...ai,...ai->...", loc[..., :2], self.gN)  # tr of the (symmetric) in-plane F
        frame = {"r": r, "a": a, "b": b, "cn": cn, "n": n, "e1": e1, "e2": e2, "E": E, "th": th, "trF": trF}
        return d.reshape(*d.shape[:-2], 18), frame

    def _to_global(self, fl: Arr, fr: dict[str, Arr]) -> Arr:
        """Global element force Bᵀ f_l (…, m, 18) of local element forces fl (…, m, 18) = δU/δd."""
        f = fl.reshape(*fl.shape[:-1], 3, 6)
        E = fr["E"]
        Et = np.swapaxes(E, -1, -2)
        g = f[..., :3] @ Et
        mloc = (f[..., 3:, None].swapaxes(-1, -2) @ dexp_inv(fr["th"]))[..., 0, :]
        mg = mloc @ Et
        # generalised force conjugate to the frame spin ω_e, sent to the nodes through ∂ω_e/∂x
        h = -np.cross(fr["r"], g).sum(axis=-2) - mg.sum(axis=-2)
        v, q, n = self._spin_parts(fr)
        vh = (v @ h[..., None])[..., 0]
        nh = (n * h).sum(axis=-1)
        qh = nh[..., None, None] * q
        fx = g - g.sum(axis=-2, keepdims=True) / 3.0 + n[..., None, :] * vh[..., None] + qh
        fe = np.concatenate([fx, mg], axis=-1)
        return fe.reshape(*fe.shape[:-2], 18)

    @staticmethod
    def _spin_parts_static(fr: dict[str, Arr], gN: Arr) -> tuple[Arr, Arr, Arr]:
        n = fr["n"]
        # ω_e = Σ_b W_b δx_b with W_b = v_b nᵀ (tilt of the normal) + n q_bᵀ (in-plane polar spin)
        v = np.stack([fr["b"] - fr["a"], -fr["b"], fr["a"]], axis=-2) / fr["cn"][..., None, None]
        q = (gN[..., 0:1] * fr["e2"][..., None, :] - gN[..., 1:2] * fr["e1"][..., None, :]) / fr["trF"][..., None, None]
        return v, q, n

    def _spin_parts(self, fr: dict[str, Arr]) -> tuple[Arr, Arr, Arr]:
        return self._spin_parts_static(fr, self.gN)

    def _B(self, fr: dict[str, Arr]) -> Arr:
        """(m, 18, 18) derivative of the local dofs d with respect to (δx, δω) of the element nodes."""
        v, q, n = self._spin_parts(fr)
        W = np.einsum("mbi,mj->mbij", v, n) + np.einsum("mi,mbj->mbij", n, q)  # (m, 3, 3, 3) ∂ω_e/∂x_b
        Et = fr["E"].transpose(0, 2, 1)
        Hi = dexp_inv(fr["th"])  # (m, 3, 3, 3)
        from fabpat.shell.rotations import skew

        Sr = skew(fr["r"])  # (m, 3, 3, 3)
        m = W.shape[0]
        B = np.zeros((m, 3, 6, 3, 6))
        EtSrW = (Et[:, None, None] @ Sr[:, :, None]) @ W[:, None]  # (m, a, b, 3, 3)
        HiEt = Hi @ Et[:, None]
        HiEtW = HiEt[:, :, None] @ W[:, None]
        for a in range(3):
            for b in range(3):
                B[:, a, :3, b, :3] = ((1.0 if a == b else 0.0) - 1.0 / 3.0) * Et + EtSrW[:, a, b]
                B[:, a, 3:, b, :3] = -HiEtW[:, a, b]
            B[:, a, 3:, a, 3:] = HiEt[:, a]
        return B.reshape(m, 18, 18)

    def element_forces(self, xe: Arr, Re: Arr) -> tuple[Arr, Arr, Arr]:
        """Element internal forces (…, m, 18) in global components [f_x, m_ω] per node, element
        strain energies (…, m) and local dofs d (…, m, 18)."""
        d, fr = self.deformational(xe, Re)
        fl = np.einsum("mij,...mj->...mi", self.local.K, d)
        U = 0.5 * np.einsum("...i,...i->...", d, fl)
        return self._to_global(fl, fr), U, d

    def gather(self, x: Arr, R: Arr) -> tuple[Arr, Arr]:
        """Element views (m, 3, 3) and (m, 3, 3, 3) of node positions x (n, 3) and rotations R (n, 3, 3)."""
        return x[self.F], R[self.F]

    def element_tangents(self, xe: Arr, Re: Arr, d: Arr) -> Arr:
        """(m, 18, 18) tangent stiffness at element state (xe, Re) with local dofs d (m, 18).

        Material part Bᵀ K B analytic; geometric part (∂Bᵀ/∂q at fixed local force) by forward
        differences over the 18 element dofs in one batch: its error scales with the stress, not with
        the (much larger) membrane stiffness, so Newton stays quadratic on thin shells.
        """
        m = xe.shape[0]
        _, fr = self.deformational(xe, Re)
        B = self._B(fr)
        fl = np.einsum("mij,mj->mi", self.local.K, d)
        f0 = self._to_global(fl, fr)
        xb = np.broadcast_to(xe, (18, *xe.shape)).copy()
        Rb = np.broadcast_to(Re, (18, *Re.shape)).copy()
        eps = np.empty(18)
        for a in range(3):
            for k in range(3):
                j = 6 * a + k
                eps[j] = _FD_LEN * self.h_char
                xb[j, :, a, k] += eps[j]
                w = np.zeros(3)
                w[k] = _FD_ROT
                eps[j + 3] = _FD_ROT
                Rb[j + 3, :, a] = expmap(w) @ Re[:, a]
        _, frb = self.deformational(xb, Rb)
        fb = self._to_global(np.broadcast_to(fl, (18, m, 18)), frb)  # (18, m, 18)
        Kg = ((fb - f0[None]) / eps[:, None, None]).transpose(1, 2, 0)
        return B.transpose(0, 2, 1) @ self.local.K @ B + Kg

    def energy_split(self, d: Arr) -> Arr:
        """(m, 3) element energies (membrane, bending, transverse shear) of local dofs d (m, 18), N·mm."""
        dm = d[:, MEMBRANE_DOFS]
        db = d[:, BENDING_DOFS]
        L = self.local
        return 0.5 * np.stack([np.einsum("mi,mij,mj->m", dm, L.Km, dm), np.einsum("mi,mij,mj->m", db, L.Kb, db),
                               np.einsum("mi,mij,mj->m", db, L.Ks, db)], axis=1)
