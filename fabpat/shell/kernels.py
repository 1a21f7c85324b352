"""The corotational triangle's force and consistent tangent, compiled: one element at a time (numba).

The same formulas as :mod:`fabpat.shell.corotational` (frame, deformational dofs, force), its
tangent (``CorotationalTriangles.element_tangents``), :mod:`fabpat.shell.geometric` (the geometric
rows) and :mod:`fabpat.shell.rotations` (H⁻¹, H⁻ᵀm and its Jacobian), written out per element:
numpy evaluates them as long vectors over the elements, so every intermediate is an array of tens of
MB that goes through memory; here an element's intermediates stay in registers and the elements are
shared among the cores (``prange``). The two agree to round-off (tested to 1e-11 relative on
random states); the numpy kernels stay the reference, and the catalog's numbers come from them.
Indices: node a, b ∈ 0…2; element-frame components i, j, k; a row of an element matrix or vector is
6a + 3t + i with t = 0 for translations (x) and 1 for rotations (m or ω).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

import fabpat.shell.kernel_cache  # noqa: F401 - sets numba.config.CACHE_DIR, read by the decorators below

# numba compiles these on first use (9.6 s on the idle 2-core machine, benchmarks/bench_first_run.py; a
# first `fabpat assemble` takes 17 s rather than 7) and keeps the machine code in the user's cache
# (cache=True, fabpat.shell.kernel_cache)

Arr = NDArray[np.float64]
Ints = NDArray[np.int64]

_CYCLIC = ((0, 1, 2), (1, 2, 0), (2, 0, 1))
#: elements per block of the parallel loop (one set of scratch arrays each)
_BLOCK = 256


@njit(cache=True, inline="always")
def _eta(t2: float) -> float:
    """η = (1 − (t/2) cot(t/2)) / t² (series below t = 10⁻³), as rotations._eta."""
    t = math.sqrt(t2)
    if t < 1e-3:
        return 1.0 / 12.0 + t2 / 720.0
    return (1.0 - 0.5 * t / math.tan(0.5 * t)) / (t * t)


@njit(cache=True)
def _state(
    e: int, ref: int, x: Arr, R: Arr, F: Arr | NDArray[np.int64], gN: Arr, xl0: Arr, E0: Arr, K: Arr, cols: Arr,
    lx: Arr, ly: Arr, th: Arr, d: Arr, ft: Arr, ml: Arr, mg: Arr, fx: Arr, v: Arr, q: Arr, h: Arr, r: Arr, Q0: Arr,
    RQ: Arr,
) -> tuple[float, float, float]:
    """Frame of element e (corners F[e] of node positions x (n, 3) mm, rotations R (n, 3, 3); initial
    frame E0[e]; its reference data gN, xl0, K in row ref, :func:`element_kernels`), local dofs
    d (18), local force K d split per node and the force's local parts; returns (energy, |a × b|, tr F).
    cols[k] = e1, e2, n; v, q (2, 3): (vx, vy), (qx, qy) per node."""
    # frame (CorotationalTriangles.deformational); r, Q0, RQ (3, 3) scratch
    for i in range(3):
        xc = (x[F[e, 0], i] + x[F[e, 1], i] + x[F[e, 2], i]) / 3.0
        for a in range(3):
            r[a, i] = x[F[e, a], i] - xc
    A0, A1, A2 = x[F[e, 1], 0] - x[F[e, 0], 0], x[F[e, 1], 1] - x[F[e, 0], 1], x[F[e, 1], 2] - x[F[e, 0], 2]
    B0, B1, B2 = x[F[e, 2], 0] - x[F[e, 0], 0], x[F[e, 2], 1] - x[F[e, 0], 1], x[F[e, 2], 2] - x[F[e, 0], 2]
    c0, c1, c2 = A1 * B2 - A2 * B1, A2 * B0 - A0 * B2, A0 * B1 - A1 * B0
    cn = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    n0, n1, n2 = c0 / cn, c1 / cn, c2 / cn
    la = math.sqrt(A0 * A0 + A1 * A1 + A2 * A2)
    u0, u1, u2 = A0 / la, A1 / la, A2 / la
    w0, w1, w2 = n1 * u2 - n2 * u1, n2 * u0 - n0 * u2, n0 * u1 - n1 * u0
    F00 = F01 = F10 = F11 = 0.0
    for a in range(3):
        p1 = r[a, 0] * u0 + r[a, 1] * u1 + r[a, 2] * u2
        p2 = r[a, 0] * w0 + r[a, 1] * w1 + r[a, 2] * w2
        F00 += p1 * gN[ref, a, 0]
        F01 += p1 * gN[ref, a, 1]
        F10 += p2 * gN[ref, a, 0]
        F11 += p2 * gN[ref, a, 1]
    phi = math.atan2(F10 - F01, F00 + F11)
    cp, sp = math.cos(phi), math.sin(phi)
    cols[0, 0], cols[0, 1], cols[0, 2] = cp * u0 + sp * w0, cp * u1 + sp * w1, cp * u2 + sp * w2
    cols[1, 0], cols[1, 1], cols[1, 2] = -sp * u0 + cp * w0, -sp * u1 + cp * w1, -sp * u2 + cp * w2
    cols[2, 0], cols[2, 1], cols[2, 2] = n0, n1, n2
    trF = 0.0
    for a in range(3):
        lx[a] = r[a, 0] * cols[0, 0] + r[a, 1] * cols[0, 1] + r[a, 2] * cols[0, 2]
        ly[a] = r[a, 0] * cols[1, 0] + r[a, 1] * cols[1, 1] + r[a, 2] * cols[1, 2]
        trF += lx[a] * gN[ref, a, 0] + ly[a] * gN[ref, a, 1]
    # θ_a = log(Eᵀ R_a E₀) through the axial vector of R_a (E₀ Eᵀ)
    for i in range(3):
        for k in range(3):
            Q0[i, k] = E0[e, i, 0] * cols[0, k] + E0[e, i, 1] * cols[1, k] + E0[e, i, 2] * cols[2, k]
    for a in range(3):
        for i in range(3):
            for k in range(3):
                RQ[i, k] = R[F[e, a], i, 0] * Q0[0, k] + R[F[e, a], i, 1] * Q0[1, k] + R[F[e, a], i, 2] * Q0[2, k]
        x0, x1, x2 = 0.5 * (RQ[2, 1] - RQ[1, 2]), 0.5 * (RQ[0, 2] - RQ[2, 0]), 0.5 * (RQ[1, 0] - RQ[0, 1])
        cos_t = 0.5 * (RQ[0, 0] + RQ[1, 1] + RQ[2, 2] - 1.0)
        s2 = 0.0
        for k in range(3):
            th[a, k] = x0 * cols[k, 0] + x1 * cols[k, 1] + x2 * cols[k, 2]
            s2 += th[a, k] * th[a, k]
        s = math.sqrt(s2)
        f = 1.0 + s * s / 6.0 if s < 1e-7 else math.atan2(s, cos_t) / s
        for k in range(3):
            th[a, k] *= f
        d[6 * a] = lx[a] - xl0[ref, a, 0]
        d[6 * a + 1] = ly[a] - xl0[ref, a, 1]
        d[6 * a + 2] = 0.0
        for k in range(3):
            d[6 * a + 3 + k] = th[a, k]
    # local force f_l = K d and its parts (CorotationalTriangles._local_parts)
    U = 0.0
    for a in range(3):
        for t in range(2):
            for i in range(3):
                row = 6 * a + 3 * t + i
                s = 0.0
                for j in range(18):
                    s += K[ref, row, j] * d[j]
                U += 0.5 * d[row] * s
                if t == 0:
                    ft[a, i] = s
                else:
                    ml[a, i] = s
    h[0] = h[1] = h[2] = 0.0
    for a in range(3):
        t0, t1, t2 = th[a, 0], th[a, 1], th[a, 2]
        m0, m1, m2 = ml[a, 0], ml[a, 1], ml[a, 2]
        tt = t0 * t0 + t1 * t1 + t2 * t2
        tm = t0 * m0 + t1 * m1 + t2 * m2
        eta = _eta(tt)
        mg[a, 0] = m0 + 0.5 * (t1 * m2 - t2 * m1) + eta * (t0 * tm - tt * m0)
        mg[a, 1] = m1 + 0.5 * (t2 * m0 - t0 * m2) + eta * (t1 * tm - tt * m1)
        mg[a, 2] = m2 + 0.5 * (t0 * m1 - t1 * m0) + eta * (t2 * tm - tt * m2)
        for i in range(3):
            h[i] -= mg[a, i]
        h[0] -= ly[a] * ft[a, 2]
        h[1] += lx[a] * ft[a, 2]
        h[2] -= lx[a] * ft[a, 1] - ly[a] * ft[a, 0]
    for b in range(3):
        b1, b2 = (b + 2) % 3, (b + 1) % 3  # v_b = (x_{b+2} − x_{b+1}) / |a × b| (sides, cyclic)
        v[0, b] = (lx[b1] - lx[b2]) / cn
        v[1, b] = (ly[b1] - ly[b2]) / cn
        q[0, b] = -gN[ref, b, 1] / trF
        q[1, b] = gN[ref, b, 0] / trF
    for i in range(3):
        mean = (ft[0, i] + ft[1, i] + ft[2, i]) / 3.0
        for a in range(3):
            fx[a, i] = ft[a, i] - mean
    for a in range(3):
        fx[a, 0] += q[0, a] * h[2]
        fx[a, 1] += q[1, a] * h[2]
        fx[a, 2] += v[0, a] * h[0] + v[1, a] * h[1]
    return U, cn, trF


@njit(cache=True, inline="always")
def _to_global(vec: Arr, cols: Arr, out: Arr, row: int) -> None:
    """out[row, 6a + 3t + k] = Σ_i vec[6a + 3t + i] cols[i, k]: element-frame components to global."""
    for blk in range(6):
        for k in range(3):
            out[row, 3 * blk + k] = (vec[3 * blk] * cols[0, k] + vec[3 * blk + 1] * cols[1, k]
                                     + vec[3 * blk + 2] * cols[2, k])


@njit(cache=True)
def _moment_jacobians(th: Arr, ml: Arr, H: Arr, M: Arr, J: Arr) -> None:
    """H_a⁻¹ and M_a = ∂(H⁻ᵀ m_a)/∂θ H_a⁻¹ of the three nodes (rotations.dexp_inv_and_moment_jacobian);
    J (3, 3) scratch."""
    for a in range(3):
        t2 = th[a, 0] * th[a, 0] + th[a, 1] * th[a, 1] + th[a, 2] * th[a, 2]
        t = math.sqrt(t2)
        ts = 1.0 if t < 1e-3 else t
        half = 0.5 * ts
        tan_h = math.tan(half)
        c = half / tan_h
        eta_closed = (1.0 - c) / (ts * ts)
        eta_h = 1.0 / 12.0 + t2 / 720.0 if t < 1e-3 else eta_closed
        small = t < 1e-2
        eta = 1.0 / 12.0 + t2 / 720.0 if small else eta_closed
        sh = math.sin(half)
        dc = 0.5 / tan_h - 0.25 * ts / (sh * sh)
        deta_t = 1.0 / 360.0 + t2 / 7560.0 if small else -dc / ts**3 - 2.0 * (1.0 - c) / ts**4
        tm = th[a, 0] * ml[a, 0] + th[a, 1] * ml[a, 1] + th[a, 2] * ml[a, 2]
        dh, dj = 1.0 - eta_h * t2, eta * tm
        for i in range(3):
            wi = deta_t * (th[a, i] * tm - t2 * ml[a, i]) - 2.0 * eta * ml[a, i]
            for j in range(3):
                H[a, i, j] = eta_h * th[a, i] * th[a, j]
                J[i, j] = th[a, i] * (eta * ml[a, j]) + wi * th[a, j]
            H[a, i, i] += dh
            J[i, i] += dj
        for i, j, k in _CYCLIC:
            H[a, i, j] += 0.5 * th[a, k]
            H[a, j, i] -= 0.5 * th[a, k]
            J[i, j] += 0.5 * ml[a, k]
            J[j, i] -= 0.5 * ml[a, k]
        for i in range(3):
            for j in range(3):
                M[a, i, j] = J[i, 0] * H[a, 0, j] + J[i, 1] * H[a, 1, j] + J[i, 2] * H[a, 2, j]


@njit(cache=True)
def _geometric(
    e: int, gN: Arr, lx: Arr, ly: Arr, ft: Arr, mg: Arr, fx: Arr, v: Arr, q: Arr, h: Arr, M: Arr, cn: float,
    trF: float, Lg: Arr, Rg: Arr, S: Arr, G: Arr,
) -> None:
    """Rows L_g, R_g (10, 18) of the geometric tangent L_gᵀ R_g in element-frame columns
    (fabpat.shell.geometric.geometric_rows, which has the derivation), e the element's row of gN;
    S (3, 3), G (3) scratch."""
    Lg[:] = 0.0
    Rg[:] = 0.0
    nh = h[2]
    S[:] = 0.0
    for a in range(3):
        for i in range(3):
            for j in range(3):
                S[i, j] += M[a, i, j]
    rf = 0.0
    for a in range(3):
        rf += lx[a] * ft[a, 0] + ly[a] * ft[a, 1]
    for i in range(3):
        for a in range(3):
            S[i, 0] += ft[a, i] * lx[a]
            S[i, 1] += ft[a, i] * ly[a]
        S[i, i] -= rf
    for i, j, k in _CYCLIC:
        g = mg[0, k] + mg[1, k] + mg[2, k]
        S[i, j] -= g
        S[j, i] += g
    pxr = 0.0
    for a in range(3):
        pxr += gN[e, a, 0] * ly[a] - gN[e, a, 1] * lx[a]
    sk0, sk1, sk2 = S[2, 0] - h[1], S[2, 1] + h[0], S[2, 2] - nh / trF * pxr
    for a in range(3):
        c = 6 * a
        for rr, skr in ((0, sk0), (1, sk1), (2, sk2)):
            Lg[rr, c] = skr * q[0, a]
            Lg[rr, c + 1] = skr * q[1, a]
            Lg[rr, c + 2] = S[0, rr] * v[0, a] + S[1, rr] * v[1, a]
            for x in range(3):
                Lg[rr, c + 3 + x] = -M[a, x, rr]
        for i, j, k in _CYCLIC:
            Lg[j, c + i] += fx[a, k]
            Lg[i, c + j] -= fx[a, k]
            Lg[j, c + 3 + i] += mg[a, k]
            Lg[i, c + 3 + j] -= mg[a, k]
        Rg[0, c + 2], Rg[1, c + 2] = v[0, a], v[1, a]
        Rg[2, c], Rg[2, c + 1] = q[0, a], q[1, a]
        Lg[3, c + 2], Lg[4, c + 2] = v[0, a], v[1, a]
        Lg[5, c], Lg[5, c + 1] = q[0, a], q[1, a]
        Lg[6 + a, c + 2] = 1.0
        s9 = -(nh / trF)
        Lg[9, c] = s9 * q[0, a]
        Lg[9, c + 1] = s9 * q[1, a]
        Rg[9, c], Rg[9, c + 1] = gN[e, a, 0], gN[e, a, 1]
        for k in range(3):
            G[k] = ft[a, k] - (ft[0, k] + ft[1, k] + ft[2, k]) / 3.0
        for i, j, k in _CYCLIC:
            Rg[3 + i, c + j] = -G[k]
            Rg[3 + j, c + i] = G[k]
        for rr in range(3):
            for x in range(3):
                Rg[3 + rr, c + 3 + x] = -M[a, rr, x]
    ax, ay = lx[1] - lx[0], ly[1] - ly[0]
    bx, by = lx[2] - lx[0], ly[2] - ly[0]
    dcx = (ay - by, by, -ay)
    dcy = (bx - ax, -bx, ax)
    for cc in range(3):
        vh = v[0, cc] * h[0] + v[1, cc] * h[1]
        for b in range(3):
            snum = 1.0 if b == (cc + 2) % 3 else (-1.0 if b == (cc + 1) % 3 else 0.0)  # geometric.SNUM
            Rg[6 + cc, 6 * b] = (snum * h[0] - vh * dcx[b]) / cn
            Rg[6 + cc, 6 * b + 1] = (snum * h[1] - vh * dcy[b]) / cn
            Rg[6 + cc, 6 * b + 2] = snum * (h[2] / cn)


@njit(cache=True)
def _tangent(
    e: int, ref: int, Q: Arr, lx: Arr, ly: Arr, cols: Arr, H: Arr, M: Arr, Lg: Arr, Rg: Arr, Kt: Arr, QY: Arr,
    C: Arr, CE: Arr, LE: Arr, RE: Arr,
) -> None:
    """Kt[e] (18, 18) = [L_g ; C]ᵀ [R_g ; C] in global columns + the M_a blocks, C = Q[ref] B̃ (the material
    part; ``CorotationalTriangles.element_tangents``), from the geometric rows and H_a⁻¹, M_a; QY (r, 3),
    C (18), CE (r, 18), LE, RE (10, 18) scratch (r the rows of Q)."""
    r = Q.shape[1]
    QY[:] = 0.0
    for rr in range(r):
        for a in range(3):
            c = 6 * a
            # Y_a = [[r_a]× ; −H_a⁻¹]: translations (0, 0, ly), (0, 0, −lx), (−ly, lx, 0)
            QY[rr, 0] -= Q[ref, rr, c + 2] * ly[a]
            QY[rr, 1] += Q[ref, rr, c + 2] * lx[a]
            QY[rr, 2] += Q[ref, rr, c] * ly[a] - Q[ref, rr, c + 1] * lx[a]
            for i in range(3):
                for j in range(3):
                    QY[rr, j] -= Q[ref, rr, c + 3 + i] * H[a, i, j]
    for rr in range(r):
        for k in range(3):
            mean = (Q[ref, rr, k] + Q[ref, rr, 6 + k] + Q[ref, rr, 12 + k]) / 3.0
            for b in range(3):
                C[6 * b + k] = (QY[rr, 0] * Rg[0, 6 * b + k] + QY[rr, 1] * Rg[1, 6 * b + k]
                                + QY[rr, 2] * Rg[2, 6 * b + k] + Q[ref, rr, 6 * b + k] - mean)
                C[6 * b + 3 + k] = (Q[ref, rr, 6 * b + 3] * H[b, 0, k] + Q[ref, rr, 6 * b + 4] * H[b, 1, k]
                                    + Q[ref, rr, 6 * b + 5] * H[b, 2, k])
        _to_global(C, cols, CE, rr)
    for rr in range(10):
        _to_global(Lg[rr], cols, LE, rr)
        _to_global(Rg[rr], cols, RE, rr)
    # two rows × six columns at a time, their twelve sums in registers (20 % less time for the tangent
    # than a row at a time summed in Kt, whose stores the compiler could not keep out of the loop); each
    # entry still adds its terms from 0.0 in the same order (L_gᵀ R_g's, then Cᵀ C's), so bitwise the same
    for al in range(0, 18, 2):
        for be in range(0, 18, 6):
            s0 = s1 = s2 = s3 = s4 = s5 = t0 = t1 = t2 = t3 = t4 = t5 = 0.0
            for part in range(2):
                X, Y, rows = (LE, RE, 10) if part == 0 else (CE, CE, r)
                for rr in range(rows):
                    c, d = X[rr, al], X[rr, al + 1]
                    y0, y1, y2 = Y[rr, be], Y[rr, be + 1], Y[rr, be + 2]
                    y3, y4, y5 = Y[rr, be + 3], Y[rr, be + 4], Y[rr, be + 5]
                    s0 += c * y0
                    s1 += c * y1
                    s2 += c * y2
                    s3 += c * y3
                    s4 += c * y4
                    s5 += c * y5
                    t0 += d * y0
                    t1 += d * y1
                    t2 += d * y2
                    t3 += d * y3
                    t4 += d * y4
                    t5 += d * y5
            Kt[e, al, be], Kt[e, al, be + 1], Kt[e, al, be + 2] = s0, s1, s2
            Kt[e, al, be + 3], Kt[e, al, be + 4], Kt[e, al, be + 5] = s3, s4, s5
            Kt[e, al + 1, be], Kt[e, al + 1, be + 1], Kt[e, al + 1, be + 2] = t0, t1, t2
            Kt[e, al + 1, be + 3], Kt[e, al + 1, be + 4], Kt[e, al + 1, be + 5] = t3, t4, t5
    # δmg_a = M_a δω_a: E M_a Eᵀ on the (m, ω) diagonal blocks
    for a in range(3):
        for i in range(3):
            for k in range(3):
                s = 0.0
                for j in range(3):
                    for jj in range(3):
                        s += cols[j, i] * M[a, j, jj] * cols[jj, k]
                Kt[e, 6 * a + 3 + i, 6 * a + 3 + k] += s


@njit(cache=True)
def element_kernels(
    x: Arr, R: Arr, F: Arr, gN: Arr, xl0: Arr, E0: Arr, K: Arr, Q: Arr, fe: Arr, U: Arr, d: Arr, Kt: Arr,
    tangent: bool,
) -> None:
    """Element forces fe (m, 18), energies U (m,), local dofs d (m, 18) and, if ``tangent``, tangents
    Kt (m, 18, 18) of the triangles F (m, 3) at node positions x (n, 3) mm and rotations R (n, 3, 3), with
    the element constants of a
    ``CorotationalTriangles`` (gN, xl0, E0, local K, its root Q); outputs are filled in place: each
    element its own constants (:func:`shared_element_kernels` with rows 0 … m − 1)."""
    shared_element_kernels(x, R, F, gN, xl0, E0, K, Q, np.arange(F.shape[0]), fe, U, d, Kt, tangent)


@njit(cache=True, parallel=True)
def shared_element_kernels(
    x: Arr, R: Arr, F: Arr | NDArray[np.int64], gN: Arr, xl0: Arr, E0: Arr, K: Arr, Q: Arr, rows: NDArray[np.int64],
    fe: Arr, U: Arr, d: Arr, Kt: Arr, tangent: bool,
) -> None:
    """:func:`element_kernels` of elements that share their reference data: element e reads its gN, xl0,
    K and Q in row rows[e] (m,) and only its initial frame E0[e] (m, 3, 3) is its own, so congruent
    elements need one row (:mod:`fabpat.shell.congruent`).

    The elements go in blocks, each with its scratch arrays (allocating them per element cost more
    than the arithmetic)."""
    m, r = F.shape[0], Q.shape[1]
    blocks = (m + _BLOCK - 1) // _BLOCK
    for blk in prange(blocks):
        cols, th, r3, Q0, RQ = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
        lx, ly, h, G = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
        ft, ml, mg, fx = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
        J, S = np.empty((3, 3)), np.empty((3, 3))
        v, q = np.empty((2, 3)), np.empty((2, 3))
        de, C = np.empty(18), np.empty(18)
        H, M = np.empty((3, 3, 3)), np.empty((3, 3, 3))
        Lg, Rg = np.empty((10, 18)), np.empty((10, 18))
        QY, CE, LE, RE = np.empty((r, 3)), np.empty((r, 18)), np.empty((10, 18)), np.empty((10, 18))
        for e in range(blk * _BLOCK, min(m, (blk + 1) * _BLOCK)):
            ref = rows[e]
            Ue, cn, trF = _state(e, ref, x, R, F, gN, xl0, E0, K, cols, lx, ly, th, de, ft, ml, mg, fx, v, q, h, r3,
                                 Q0, RQ)
            U[e] = Ue
            for j in range(18):
                d[e, j] = de[j]
            for a in range(3):
                for k in range(3):
                    fe[e, 6 * a + k] = fx[a, 0] * cols[0, k] + fx[a, 1] * cols[1, k] + fx[a, 2] * cols[2, k]
                    fe[e, 6 * a + 3 + k] = mg[a, 0] * cols[0, k] + mg[a, 1] * cols[1, k] + mg[a, 2] * cols[2, k]
            if tangent:
                _moment_jacobians(th, ml, H, M, J)
                _geometric(ref, gN, lx, ly, ft, mg, fx, v, q, h, M, cn, trF, Lg, Rg, S, G)
                _tangent(e, ref, Q, lx, ly, cols, H, M, Lg, Rg, Kt, QY, C, CE, LE, RE)


@njit(cache=True, parallel=True)
def block_sum(values: Arr, tail: Arr, bases: Ints, bstart: Ints, rows: Ints, cols: Ints, first: Ints, stride: Ints,
              dofs: Ints, nfree: Ints, out: Arr) -> None:
    """out (nnz,): the sparse sum of element matrices, v = values followed by tail (both flat, each
    matrix 18 × 18 row-major), node block by node block, the cores sharing the blocks (so no two write
    one entry). Block b holds the entries of the node pair (rows[b], cols[b]) (node numbers); its
    elements' 6 × 6 blocks start at positions bases[k] of v, k ∈ [bstart[b], bstart[b + 1]),
    increasing; its nonzero (p', q') (indices among the nodes' free dofs, whose local dof numbers are
    dofs[node, :nfree[node]], ascending) is out[first[b] + q'·stride[b] + p'].

    Each nonzero adds its entries from 0.0 in increasing position, the order of ``np.bincount``, so the
    sums are bitwise :meth:`fabpat.shell.assembly.Assembler.matrix`'s. A block lists its elements once
    (not once per entry: 36× fewer indices to read than a gather by entry) and reads each element's
    6 × 6 block while it is in cache."""
    nv = values.size
    for b in prange(bstart.size - 1):
        i, j, k0, k1 = rows[b], cols[b], bstart[b], bstart[b + 1]
        if nfree[i] == 6 and nfree[j] == 6 and bases[k1 - 1] < nv:  # all free, no tail: loops of fixed length
            for q in range(6):
                at = first[b] + q * stride[b]
                for p in range(6):
                    s = 0.0
                    for k in range(k0, k1):
                        s += values[bases[k] + 18 * p + q]
                    out[at + p] = s
            continue
        for qq in range(nfree[j]):
            q = dofs[j, qq]
            at = first[b] + qq * stride[b]
            for pp in range(nfree[i]):
                off = 18 * dofs[i, pp] + q
                s = 0.0
                for k in range(k0, k1):
                    o = bases[k] + off
                    s += values[o] if o < nv else tail[o - nv]
                out[at + pp] = s


@njit(cache=True)
def block_rows(first: Ints, stride: Ints, row0: Ints, nrow: Ints, ncol: Ints, out: NDArray[np.int32]) -> None:
    """The row indices (out, the CSC matrix's ``indices``) of node blocks laid out as :func:`block_sum`'s:
    block b's nonzero (p', q') at first[b] + q'·stride[b] + p' is in row row0[b] + p', for p' < nrow[b]
    and q' < ncol[b] (its nodes' free dofs)."""
    for b in range(first.size):
        for qq in range(ncol[b]):
            at = first[b] + qq * stride[b]
            for pp in range(nrow[b]):
                out[at + pp] = row0[b] + pp


@njit(cache=True, parallel=True)
def link_transform(Kt: Arr, elements: Arr, c: Arr) -> None:
    """Kt[e] ← Tᵀ Kt[e] T in place for the elements listed, T = I except the blocks −[c_a]× that tie the
    rotation columns of corner a to its translations (a slave's variation δx = δx_s + δω_s × c_a,
    :mod:`fabpat.shell.rigid_links`); c (len(elements), 3, 3) is 0 at corners that are not slaves."""
    for q in prange(elements.size):
        e = elements[q]
        for a in range(3):
            c0, c1, c2 = c[q, a, 0], c[q, a, 1], c[q, a, 2]
            if c0 == 0.0 and c1 == 0.0 and c2 == 0.0:
                continue
            # S = −[c]× = [[0, c2, −c1], [−c2, 0, c0], [c1, −c0, 0]]
            t, w = 6 * a, 6 * a + 3
            for row in range(18):  # K T: rotation columns += translation columns · S
                k0, k1, k2 = Kt[e, row, t], Kt[e, row, t + 1], Kt[e, row, t + 2]
                Kt[e, row, w] += -c2 * k1 + c1 * k2
                Kt[e, row, w + 1] += c2 * k0 - c0 * k2
                Kt[e, row, w + 2] += -c1 * k0 + c0 * k1
            for col in range(18):  # Tᵀ (K T): rotation rows += Sᵀ · translation rows
                k0, k1, k2 = Kt[e, t, col], Kt[e, t + 1, col], Kt[e, t + 2, col]
                Kt[e, w, col] += -c2 * k1 + c1 * k2
                Kt[e, w + 1, col] += c2 * k0 - c0 * k2
                Kt[e, w + 2, col] += -c1 * k0 + c0 * k1
