"""Sparse assembly over free degrees of freedom with a precomputed pattern.

The element → global scatter is computed once per mesh and support set: the sum of duplicate entries
is then one ``np.bincount`` per assembly (≈ 10 ms for 2.5 k triangles), and the matrix comes out
directly in CSC order for SuperLU.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray


def _node_order(F: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """(n,) rank of each node in SuperLU's MMD(AᵀA + A) ordering of the node adjacency graph."""
    import scipy.sparse.linalg as spla

    rows = np.repeat(F, 3, axis=1).ravel()
    cols = np.tile(F, (1, 3)).ravel()
    A = sp.csc_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n)) + 100.0 * sp.identity(n, format="csc")
    lu = spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    return np.asarray(lu.perm_c, dtype=np.int64)


class Assembler:
    """Scatter of (m, 18, 18) element matrices and (m, 18) element vectors.

    edofs: (m, 18) global dof numbers of each element; free: (N,) bool mask of the free global dofs.
    The attribute ``free`` lists the global free dofs in matrix order.
    """

    def __init__(self, edofs: NDArray[np.int64], free: NDArray[np.bool_]) -> None:
        self.edofs = edofs
        self.n_dofs = int(free.size)
        self.free = np.flatnonzero(free)
        # number the free dofs node by node in a fill-reducing (MMD) order of the *node* graph: SuperLU
        # then factors without its own ordering (symmetric mode), ~1.3× faster, and
        # the order is computed once on a 6× smaller graph
        order = _node_order(edofs[:, ::6] // 6, self.n_dofs // 6)  # new position of each node
        key_free = (6 * order[self.free // 6] + self.free % 6)
        self.free = self.free[np.argsort(key_free, kind="stable")]
        gmap = np.full(self.n_dofs, -1, dtype=np.int64)
        gmap[self.free] = np.arange(self.free.size)
        le = gmap[edofs]  # (m, 18), -1 on fixed dofs
        rows = np.broadcast_to(le[:, :, None], (le.shape[0], 18, 18)).ravel()
        cols = np.broadcast_to(le[:, None, :], (le.shape[0], 18, 18)).ravel()
        self._valid = np.flatnonzero((rows >= 0) & (cols >= 0))
        nf = self.free.size
        key = cols[self._valid] * nf + rows[self._valid]  # column-major key → CSC order
        uniq, self._inv = np.unique(key, return_inverse=True)
        self._indices = (uniq % nf).astype(np.int32)
        self._indptr = np.searchsorted(uniq // nf, np.arange(nf + 1)).astype(np.int32)
        self._nnz = uniq.size
        self.n_free = nf

    def matrix(self, Ke: NDArray[np.float64]) -> sp.csc_matrix:
        """(n_free, n_free) CSC matrix of element matrices Ke (m, 18, 18) (free rows/columns only)."""
        data = np.bincount(self._inv, weights=Ke.reshape(-1)[self._valid], minlength=self._nnz)
        return sp.csc_matrix((data, self._indices, self._indptr), shape=(self.n_free, self.n_free))

    def vector(self, fe: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N,) global vector of element vectors fe (m, 18) (all dofs)."""
        return np.bincount(self.edofs.ravel(), weights=fe.ravel(), minlength=self.n_dofs)
