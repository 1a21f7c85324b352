"""Compiled loops of :mod:`fabpat.catalog.response` (numba): walking boosted trees and checking that a pattern
is one piece, per pattern, so that ranking ten thousand IDs takes well under a second; and the small SPD
solves of its plate model (:mod:`fabpat.catalog.response_plate`).

Why compiled: the numpy versions (every tree walked at once by fancy indexing; one block-diagonal sparse graph
for :func:`fabpat.patterns.library.is_connected`) measured 1 600 patterns per second, their temporaries being
(patterns × trees) arrays; these loops keep one node index in a register. Imported only when a prediction is
made, so the sweep and the catalog readers never load numba.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

import fabpat.shell.kernel_cache  # noqa: F401 - sets numba.config.CACHE_DIR (the user's cache), read by the decorators below


@njit(cache=True, parallel=True)
def walk_trees(X: NDArray[np.float64], feature: NDArray[np.int64], threshold: NDArray[np.float64],
               left: NDArray[np.int64], right: NDArray[np.int64], value: NDArray[np.float64]) -> NDArray[np.float64]:
    """(k,) sum over the trees of the leaf each row of ``X`` (k, f) reaches; trees as (T, n) arrays
    (``left`` −1 at a leaf; a row goes left where its feature ≤ the node's threshold)."""
    k, T = X.shape[0], feature.shape[0]
    out = np.zeros(k)
    for i in prange(k):  # rows are independent: spread over the cores
        s = 0.0
        for t in range(T):
            node = 0
            while left[t, node] >= 0:
                if X[i, feature[t, node]] <= threshold[t, node]:
                    node = left[t, node]
                else:
                    node = right[t, node]
            s += value[t, node]
        out[i] = s
    return out


@njit(cache=True)
def _root(parent: NDArray[np.int64], a: int) -> int:
    while parent[a] != a:
        parent[a] = parent[parent[a]]  # path halving
        a = parent[a]
    return a


@njit(cache=True, parallel=True)
def one_piece(solid: NDArray[np.bool_], F: NDArray[np.int64], nv: int) -> NDArray[np.bool_]:
    """(k,) bool: are the solid faces of each row of ``solid`` (k, nf) one piece, faces joined through shared
    vertices (the face–vertex incidence graph of paper §3.2), ``F`` (nf, 3) the faces' vertices (< ``nv``)?
    A row with no solid face is not."""
    k = solid.shape[0]
    out = np.zeros(k, dtype=np.bool_)
    chunks = min(k, 8)
    # one union-find array per chunk, allocated here: numba would hoist one allocated in the prange body
    parents = np.empty((chunks, nv), dtype=np.int64)
    for c in prange(chunks):
        for i in range(c * k // chunks, (c + 1) * k // chunks):
            out[i] = _one_piece(solid[i], F, parents[c])
    return out


@njit(cache=True)
def _one_piece(solid: NDArray[np.bool_], F: NDArray[np.int64], parent: NDArray[np.int64]) -> bool:
    """:func:`one_piece` of one row, ``parent`` a work array of one entry per vertex."""
    for v in range(parent.size):
        parent[v] = v
    first = -1
    for f in range(solid.size):
        if solid[f]:
            a = _root(parent, F[f, 0])
            for c in range(1, 3):
                b = _root(parent, F[f, c])
                if a != b:
                    parent[b] = a
            if first < 0:
                first = F[f, 0]
    if first < 0:
        return False
    r = _root(parent, first)
    for f in range(solid.size):
        if solid[f] and _root(parent, F[f, 0]) != r:
            return False
    return True


# --- the plate model's solves (fabpat.catalog.response_plate) ---------------------------------------------

@njit(cache=True, fastmath=True)  # fastmath: the inner products vectorise (4× on the factorisation)
def skyline_solve(A: NDArray[np.float64], first: NDArray[np.int64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Solve A x = b for SPD A (its lower triangle within the skyline ``first``), factorising A in place."""
    n = A.shape[0]
    for i in range(n):
        for j in range(first[i], i + 1):
            s = A[i, j]
            for k in range(max(first[i], first[j]), j):
                s -= A[i, k] * A[j, k]
            if j < i:
                A[i, j] = s / A[j, j]
            else:
                A[i, i] = math.sqrt(max(s, 1e-300))
    x = b.copy()
    for i in range(n):
        s = x[i]
        for k in range(first[i], i):
            s -= A[i, k] * x[k]
        x[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):
        x[i] /= A[i, i]
        for k in range(first[i], i):
            x[k] -= A[i, k] * x[i]
    return x


@njit(cache=True)
def dense_solve(A: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Solve A x = b for SPD A (n, n) (its lower triangle), factorising A in place (:func:`skyline_solve`)."""
    first = np.zeros(A.shape[0], dtype=np.int64)
    return skyline_solve(A, first, b)


@njit(cache=True)
def add_pair(K: NDArray[np.float64], idx: NDArray[np.int64], row: NDArray[np.float64], k: float) -> None:
    """K[idx, idx] += k · row rowᵀ, lower triangle (idx may repeat)."""
    for a in range(idx.size):
        for b in range(idx.size):
            if idx[b] <= idx[a]:
                K[idx[a], idx[b]] += k * row[a] * row[b]


@njit(cache=True)
def unit_unused(solid: NDArray[np.bool_], face: NDArray[np.int64], rep: NDArray[np.int64], K: NDArray[np.float64],
                dofs: int) -> None:
    """A unit diagonal for each unknown (``dofs`` per vertex) that no solid face moves."""
    used = np.zeros(K.shape[0], dtype=np.bool_)
    for f in range(face.shape[0]):
        if solid[f]:
            for c in range(3):
                for d in range(dofs):
                    used[dofs * rep[face[f, c]] + d] = True
    for v in range(K.shape[0]):
        if not used[v]:
            K[v, v] += 1.0


@njit(cache=True, fastmath=True)  # fastmath: the inner products vectorise
def condense(K: NDArray, first: NDArray[np.int64], m: int) -> None:
    """In place on the lower triangle of Hermitian K (n, n) (within the skyline ``first``): the leading m
    unknowns factorised (K = L Lᴴ there), the rows below get L's coupling in columns < m and the Schur complement
    K_bb − K_ba K_aa⁻¹ K_ab (the rest condensed onto them) in columns ≥ m."""
    n = K.shape[0]
    for i in range(n):
        for j in range(first[i], min(i + 1, m)):
            s = K[i, j]
            for k in range(max(first[i], first[j]), j):
                s -= K[i, k] * np.conj(K[j, k])
            if j < i:
                K[i, j] = s / K[j, j].real
            else:
                K[i, i] = math.sqrt(max(s.real, 1e-300))
        for j in range(m, i + 1):
            s = K[i, j]
            for k in range(max(first[i], first[j]), m):
                s -= K[i, k] * np.conj(K[j, k])
            K[i, j] = s
