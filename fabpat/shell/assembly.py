"""Sparse assembly over free degrees of freedom with a precomputed pattern.

The element → global scatter is computed once per mesh and support set (from the node adjacency,
≈ 10 ms for 2 k triangles): the sum of duplicate entries is then one ``np.bincount`` per assembly
(≈ 3 ms), and the matrix comes out directly in CSC order for SuperLU.
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
        n = self.n_dofs // 6
        Fn = edofs[:, ::6] // 6  # (m, 3) element nodes
        m = Fn.shape[0]
        # number the free dofs node by node in a fill-reducing (MMD) order of the *node* graph: SuperLU
        # then factors without its own ordering (symmetric mode), ~1.3× faster, and
        # the order is computed once on a 6× smaller graph
        order = _node_order(Fn, n)  # rank of each node
        by_rank = np.argsort(order)
        freeN = free.reshape(n, 6)
        nf = freeN.sum(axis=1)  # free dofs per node
        start = np.zeros(n, dtype=np.int64)  # first free index of each node (its free dofs are contiguous)
        start[by_rank] = np.concatenate([[0], np.cumsum(nf[by_rank])[:-1]])
        pf = np.where(freeN, np.cumsum(freeN, axis=1) - 1, -1)  # (n, 6) index among the node's free dofs
        glob = np.flatnonzero(free)
        fidx = start[glob // 6] + pf.ravel()[glob]
        self.free = np.empty_like(glob)
        self.free[fidx] = glob
        # The pattern is built on *node* pairs (9 per element instead of 324 dof pairs: a 36× smaller
        # sort) and expanded to blocks: CSC column (J, q) lists the free dofs of J's neighbour nodes I
        # in rank order, so entry (I p, J q) sits at base_J + q'·colnnz_J + rowoff_IJ + p', with p', q'
        # the indices among the nodes' free dofs.
        RJ = order[Fn]  # (m, 3) rank of each element node
        uniq, inv = np.unique((RJ[:, None, :] * n + RJ[:, :, None]).ravel(), return_inverse=True)
        uJ, uI = uniq // n, uniq % n
        nf_r = nf[by_rank]
        w = nf_r[uI]
        cs = np.cumsum(w)
        first = np.searchsorted(uJ, uJ)  # first pair of each node column
        rowoff = cs - w - np.where(first > 0, cs[first - 1], 0)
        colnnz = np.bincount(uJ, weights=w, minlength=n).astype(np.int64)  # per rank
        base = np.concatenate([[0], np.cumsum(nf_r * colnnz)[:-1]])  # per rank
        self._nnz = int(np.sum(nf_r * colnnz))
        # the (m, 3, 6, 3, 6) positions are summed from small per-element parts, only the last sum full
        # size; the rows of an entry depend on its (element, a, p) only, so they are repeated from an
        # (m, 18) table in int32 (the indices' type), not expanded to every entry in int64 and gathered:
        # a third less peak memory on 71 k triangles with fixed dofs (tracemalloc, 983 → 630 MB; 0.72 → 0.57 CPU s)
        pI = pf[Fn]  # (m, 3, 6) index among the node's free dofs, −1 if fixed
        col = base[RJ][..., None] + pI * colnnz[RJ][..., None]  # (m, b, q)
        blk = col[:, None, :, :] + rowoff[inv.reshape(m, 3, 3)][..., None]  # (m, a, b, q)
        pos = (blk[:, :, None, :, :] + pI[:, :, :, None, None]).reshape(-1)
        rows18 = (start[Fn][..., None] + pI).reshape(-1).astype(np.int32)  # matrix row of each element row
        ok = (pI >= 0).reshape(m, 18)
        # _valid: the element-matrix entries on free rows and columns; None when all are (the shared
        # all-dofs assembler of solve.py), which skips three gathers of m·324 entries here and one per matrix
        self._valid: NDArray[np.int64] | None = None
        if ok.all():
            self._inv = pos
            rows = np.repeat(rows18, 18)
        else:
            self._valid = np.flatnonzero(ok[:, :, None] & ok[:, None, :])
            self._inv = pos[self._valid]
            del pos
            k = np.repeat(ok.sum(axis=1), 18).reshape(m, 18)  # free columns of each element
            rows = np.repeat(rows18[ok.ravel()], k[ok])
        self._indices = np.zeros(self._nnz, dtype=np.int32)
        self._indices[self._inv] = rows
        nfree = glob.size
        self._indptr = np.empty(nfree + 1, dtype=np.int32)
        self._indptr[fidx] = base[order[glob // 6]] + pf.ravel()[glob] * colnnz[order[glob // 6]]
        self._indptr[nfree] = self._nnz
        self.n_free = nfree

    def matrix(self, Ke: NDArray[np.float64]) -> sp.csc_matrix:
        """(n_free, n_free) CSC matrix of element matrices Ke (m, 18, 18) (free rows/columns only)."""
        # all-free: no gather of Ke; a precomputed sparse gather matrix (S @ Ke.ravel()) is only ~15 %
        # faster than this bincount and costs ~8 bincounts to build, so it does not pay off
        w = Ke.reshape(-1) if self._valid is None else Ke.reshape(-1)[self._valid]
        data = np.bincount(self._inv, weights=w, minlength=self._nnz)
        return sp.csc_matrix((data, self._indices, self._indptr), shape=(self.n_free, self.n_free))

    def vector(self, fe: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N,) global vector of element vectors fe (m, 18) (all dofs)."""
        return np.bincount(self.edofs.ravel(), weights=fe.ravel(), minlength=self.n_dofs)


class SupportedAssembler:
    """Assembly over *every* dof of a mesh, with the fixed dofs imposed as unit rows and columns.

    full: an :class:`Assembler` of the mesh with all dofs free; fixed: (N,) bool, the supported dofs;
    scale: the diagonal entry of a fixed dof's row (a typical stiffness keeps the matrix well scaled).
    The matrix pattern, and with it a factoriser's symbolic analysis, then depends on the mesh only and
    is shared by problems that differ only in supports (a pattern's three scenarios): at 2 k nodes this
    saves the ≈ 30 ms pattern set-up and ≈ 20 ms PARDISO analysis per problem. The free block is the
    same matrix as :class:`Assembler`'s over the free dofs, so the solutions are the same to round-off.
    ``free`` lists the free global dofs (ascending).
    """

    def __init__(self, full: Assembler, fixed: NDArray[np.bool_], scale: float) -> None:
        self.full = full
        self.n_dofs = full.n_dofs
        fixed = np.asarray(fixed, dtype=bool).ravel()
        self.order = full.free  # every dof, in matrix order
        self.free = np.flatnonzero(~fixed)
        self._fixed_rows = fixed[self.order]
        rows = full._indices
        cols = np.repeat(np.arange(full.n_free, dtype=np.int32), np.diff(full._indptr))
        hit = self._fixed_rows[rows] | self._fixed_rows[cols]
        self._zero = np.flatnonzero(hit)
        self._diag = np.flatnonzero(hit & (rows == cols))
        self._scale = float(scale)

    def matrix(self, Ke: NDArray[np.float64]) -> sp.csc_matrix:
        """(N, N) CSC matrix of element matrices Ke (m, 18, 18), fixed rows and columns replaced by unit ones."""
        K = self.full.matrix(Ke)
        K.data[self._zero] = 0.0
        K.data[self._diag] = self._scale
        return K

    def vector(self, fe: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N,) global vector of element vectors fe (m, 18)."""
        return self.full.vector(fe)

    def rhs(self, r: NDArray[np.float64]) -> NDArray[np.float64]:
        """Right-hand side in matrix order of a global (N,) vector, 0 at the fixed dofs."""
        b = r[self.order]
        b[self._fixed_rows] = 0.0
        return b

    def scatter(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Global (N,) vector of a solution y in matrix order (0 at the fixed dofs)."""
        u = np.empty(self.n_dofs)
        u[self.order] = y
        return u
