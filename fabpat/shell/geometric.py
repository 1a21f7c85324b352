"""The geometric part L_gᵀ R_g of the corotational tangent (``CorotationalTriangles.element_tangents``).

The derivation is in :func:`geometric_rows`; the factors are formed in the element frame, with the
element index last while computing, and handed to the tangent as (m, 10, 18) rows.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Arr = NDArray[np.float64]

#: inner dimension of the geometric factors of the tangent (see geometric_rows)
NG = 10
#: δ(b − a, −b, a) = Σ_b s_cb δx_b for the sides a = x1 − x0, b = x2 − x0 of the normal-tilt vectors v_c
SNUM = np.array([[0.0, -1.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 1.0, 0.0]])


def geometric_constants(gN: Arr) -> tuple[Arr, Arr]:
    """LgS, RgS (10, 3, 2, 3, m) for :func:`geometric_rows` of m triangles with ∂N_a/∂(X, Y) gN (m, 3, 2):
    zero except their constant entries, n δ_ac (L_g rows 6–8) and p_b (R_g row 9). :func:`geometric_rows`
    writes the same entries every call, so the zeros stay."""
    m = gN.shape[0]
    LgS, RgS = np.zeros((NG, 3, 2, 3, m)), np.zeros((NG, 3, 2, 3, m))
    for c in range(3):
        LgS[6 + c, c, 0, 2] = 1.0
    RgS[9, :, 0, :2] = gN.transpose(1, 2, 0)
    return LgS, RgS


def geometric_rows(Lg: Arr, Rg: Arr, fr: dict[str, Arr], lp: dict[str, Arr], MS: Arr, gN: Arr, LgS: Arr,
                   RgS: Arr) -> None:
    """Fill L_g, R_g (m, 10, 3, 2, 3) (element-frame columns) with L_gᵀ R_g = ∂(Bᵀ f_l)/∂q at fixed
    f_l, less the diagonal blocks M_a of ``CorotationalTriangles.element_tangents``.

    fr, lp: the frame and local parts of the element forces (``CorotationalTriangles.deformational``,
    ``_local_parts``); MS (3, 3, 3, m): M_a[i, j] as MS[i, j, a]; gN (m, 3, 2): ∂N_a/∂(X, Y); LgS,
    RgS: the arrays of :func:`geometric_constants`, kept between calls (overwritten here).
    Computed with the element index last (numpy's loops over the many length-3 axes here cost
    several times more per entry than over elements; ~5 ms instead of ~11 ms at 3 k elements),
    then copied into L_g and R_g.

    With the frame spin ω = Ω δx = Σ_b W_b δx_b (W_b = v_b nᵀ + n q_bᵀ) and δθ_a = H_a⁻¹(δω_a − ω):
    δf_t → δg_a = ω × g_a; δmg_a = ω × mg_a + M_a (δω_a − ω); δh = Σ_b [G_b]× δx_b + S ω − Σ_b M_b δω_b
    with G_b = f_t,b − mean f_t and S = Σ_a (f_t,a r_aᵀ − (r_a·f_t,a) I + [mg_a]× + M_a). Then
    f_x,a = f_t,a − mean f_t + n (v_a·h) + q_a (n·h) varies by
      −[f_x,a]× ω                 (f_t, n and the e1, e2 in q_a turn with the frame)
      + W_aᵀ δh                   (δh sent to the nodes)
      + n (δv_a·h)                (v_a = num_a/|a × b|: the triangle's sides)
      + q_a (ω·(n × h) − (n·h)/trF δtrF)   (δn·h and the tr F in q_a),
    δtrF = Σ_a p_a·(δr_a + r_a × ω), p_a = (∂N_a/∂X, ∂N_a/∂Y, 0); and f_m,a = mg_a by
    −([mg_a]× + M_a) ω + M_a δω_a. Inner index: 0–2 ω-coefficients ⟷ Ω; 3–5 W_aᵀ ⟷ ([G_b]×, −M_b);
    6–8 n δ_ac ⟷ δv_c·h; 9 −(n·h)/trF q_a ⟷ p_b.

    One function: the rows are one closed-form derivation (the reference above), term by term over the
    vectorised elements; splitting it would split the formula.
    """
    # LgS, RgS: (row, node, [x | m or ω], axis, element)
    lx, ly, trF, cn = fr["lx"].T, fr["ly"].T, fr["trF"], fr["cn"]  # (a, m) and (m,)
    gx, gy = gN[:, :, 0].T, gN[:, :, 1].T
    ft, mg, fx = (np.moveaxis(lp[k], (-1, -2), (0, 1)) for k in ("ft", "mg", "fx"))  # (i, a, m)
    h = lp["h"].T
    vx, vy, qx, qy, vh = (lp[k].T for k in ("vx", "vy", "qx", "qy", "vh"))
    nh = h[2]

    def dot3(u: Arr, w: Arr) -> Arr:
        return u[0] * w[0] + u[1] * w[1] + u[2] * w[2]

    # S = Σ_a f_a r_aᵀ − Σ_a (r_a·f_a) I + [Σ mg_a]× + Σ M_a, r_a = (x_a, y_a, 0)
    S = MS.sum(axis=2)  # (i, j, m)
    rf = dot3(lx, ft[0]) + dot3(ly, ft[1])
    for i in range(3):
        S[i, 0] += dot3(ft[i], lx)
        S[i, 1] += dot3(ft[i], ly)
        S[i, i] -= rf
    g = mg.sum(axis=1)
    # −[v]×_ij = ε_ijk v_k: over the cyclic (i, j, k), +v_k at (i, j) and −v_k at (j, i)
    cyclic = ((0, 1, 2), (1, 2, 0), (2, 0, 1))
    for i, j, k in cyclic:
        S[i, j] -= g[k]
        S[j, i] += g[k]
    # κ = n × h − (n·h)/trF Σ_a p_a × r_a; z-row of S plus κ multiplies q_a
    sk = S[2].copy()
    sk[0] -= h[1]
    sk[1] += h[0]
    sk[2] -= nh / trF * (dot3(gx, ly) - dot3(gy, lx))
    # ω-coefficients (transposed: L_g[j, a, ·, i] = Λ_a[i, j]): x rows −[f_x,a]× + W_aᵀ S + q_a κᵀ
    # with W_aᵀ S = n (Sᵀv_a)ᵀ + q_a (Sᵀn)ᵀ; m rows −[mg_a]× − M_a
    np.multiply(sk[:, None], qx, out=LgS[0:3, :, 0, 0])
    np.multiply(sk[:, None], qy, out=LgS[0:3, :, 0, 1])
    np.multiply(S[0][:, None], vx, out=LgS[0:3, :, 0, 2])
    LgS[0:3, :, 0, 2] += S[1][:, None] * vy
    np.negative(MS.transpose(1, 2, 0, 3), out=LgS[0:3, :, 1])
    for i, j, k in cyclic:
        LgS[j, :, 0, i] += fx[k]
        LgS[i, :, 0, j] -= fx[k]
        LgS[j, :, 1, i] += mg[k]
        LgS[i, :, 1, j] -= mg[k]
    # R_g: Ω (rows i, columns (b, k)) = W_b = [[0, 0, vx], [0, 0, vy], [qx, qy, 0]]; [G_b]× and −M_b;
    # δv_c·h; p_b (constant)
    RgS[0, :, 0, 2], RgS[1, :, 0, 2] = vx, vy
    RgS[2, :, 0, 0], RgS[2, :, 0, 1] = qx, qy
    # L_g: W_aᵀ (rows 3–5, the same entries as rows 0–2 of R_g); n δ_ac (constant); −(n·h)/trF q_a
    LgS[3:6] = RgS[0:3]
    s9 = -(nh / trF)
    np.multiply(s9, qx, out=LgS[9, :, 0, 0])
    np.multiply(s9, qy, out=LgS[9, :, 0, 1])
    G = ft - ft.mean(axis=1, keepdims=True)
    for i, j, k in cyclic:  # [G_b]×_ij = −ε_ijk G_k
        np.negative(G[k], out=RgS[3 + i, :, 0, j])
        RgS[3 + j, :, 0, i] = G[k]
    np.negative(MS.transpose(0, 2, 1, 3), out=RgS[3:6, :, 1])
    # δ|a × b| = δa·(b × n) + δb·(n × a), δa = δx1 − δx0, δb = δx2 − δx0: in-plane (b × n, n × a)
    ax_, ay_ = lx[1] - lx[0], ly[1] - ly[0]
    bx_, by_ = lx[2] - lx[0], ly[2] - ly[0]
    dcn_x = np.stack([ay_ - by_, by_, -ay_])  # (b, m)
    dcn_y = np.stack([bx_ - ax_, -bx_, ax_])
    inv_cn = 1.0 / cn
    snum = SNUM[:, :, None]
    RgS[6:9, :, 0, 0] = (snum * h[0] - vh[:, None] * dcn_x) * inv_cn
    RgS[6:9, :, 0, 1] = (snum * h[1] - vh[:, None] * dcn_y) * inv_cn
    RgS[6:9, :, 0, 2] = snum * (h[2] / cn)
    Lg[...] = LgS.transpose(4, 0, 1, 2, 3)
    Rg[...] = RgS.transpose(4, 0, 1, 2, 3)
