"""Compiled loops of :mod:`fabpat.catalog.response` (numba): walking boosted trees and checking that a pattern
is one piece, per pattern, so that ranking ten thousand IDs takes well under a second.

Why compiled: the numpy versions (every tree walked at once by fancy indexing; one block-diagonal sparse graph
for :func:`fabpat.patterns.library.is_connected`) measured 1 600 patterns per second, their temporaries being
(patterns × trees) arrays; these loops keep one node index in a register. Imported only when a prediction is
made, so the sweep and the catalog readers never load numba.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True)
def walk_trees(X: NDArray[np.float64], feature: NDArray[np.int64], threshold: NDArray[np.float64],
               left: NDArray[np.int64], right: NDArray[np.int64], value: NDArray[np.float64]) -> NDArray[np.float64]:
    """(k,) sum over the trees of the leaf each row of ``X`` (k, f) reaches; trees as (T, n) arrays
    (``left`` −1 at a leaf; a row goes left where its feature ≤ the node's threshold)."""
    k, T = X.shape[0], feature.shape[0]
    out = np.zeros(k)
    for i in range(k):
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


@njit(cache=True)
def one_piece(solid: NDArray[np.bool_], F: NDArray[np.int64], nv: int) -> NDArray[np.bool_]:
    """(k,) bool: are the solid faces of each row of ``solid`` (k, nf) one piece, faces joined through shared
    vertices (the face–vertex incidence graph of paper §3.2), ``F`` (nf, 3) the faces' vertices (< ``nv``)?
    A row with no solid face is not."""
    k, nf = solid.shape
    out = np.zeros(k, dtype=np.bool_)
    parent = np.empty(nv, dtype=np.int64)
    for i in range(k):
        for v in range(nv):
            parent[v] = v
        first = -1
        for f in range(nf):
            if solid[i, f]:
                a = _root(parent, F[f, 0])
                for c in range(1, 3):
                    b = _root(parent, F[f, c])
                    if a != b:
                        parent[b] = a
                if first < 0:
                    first = F[f, 0]
        if first < 0:
            continue
        r = _root(parent, first)
        ok = True
        for f in range(nf):
            if solid[i, f] and _root(parent, F[f, 0]) != r:
                ok = False
                break
        out[i] = ok
    return out
