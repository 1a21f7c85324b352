"""Sparse assembly over free degrees of freedom with a precomputed pattern.

The element → global scatter is computed once per mesh and support set (from the node adjacency,
≈ 10 ms for 2 k triangles): the sum of duplicate entries is then one ``np.bincount`` per assembly
(≈ 3 ms), and the matrix comes out directly in CSC order for SuperLU.
"""

from __future__ import annotations

from dataclasses import dataclass

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


@dataclass(frozen=True, eq=False)
class NodePattern:
    """The free dofs' numbering and the CSC pattern of a mesh, built on *node* pairs (:func:`node_pattern`).

    ``order`` (n,) each node's rank in the fill-reducing order, ``by_rank`` its inverse; ``nf`` (n,) free dofs
    per node; ``start`` (n,) the matrix row of each node's first free dof; ``pf`` (n, 6) a dof's index among
    its node's free dofs (−1 if fixed); ``glob`` the free global dofs ascending and ``fidx`` their matrix rows;
    ``free`` the free global dofs in matrix order; ``RJ`` (m, 3) each element node's rank; ``uniq`` the
    distinct node pairs (column rank · n + row rank), ``inv`` (m·9,) each element corner pair's index in them,
    ``uJ``/``uI`` their column and row ranks, ``nf_r`` free dofs per rank, ``w`` each pair's rows; ``rowoff``,
    ``colnnz``, ``base``: entry (I p, J q) sits at base_J + q'·colnnz_J + rowoff_IJ + p'; ``nnz`` and the CSC
    ``indptr`` (n_free + 1,) int32.
    """

    order: NDArray[np.int64]
    by_rank: NDArray[np.int64]
    nf: NDArray[np.int64]
    start: NDArray[np.int64]
    pf: NDArray[np.int64]
    glob: NDArray[np.int64]
    fidx: NDArray[np.int64]
    free: NDArray[np.int64]
    RJ: NDArray[np.int64]
    uniq: NDArray[np.int64]
    inv: NDArray[np.int64]
    uJ: NDArray[np.int64]
    uI: NDArray[np.int64]
    nf_r: NDArray[np.int64]
    w: NDArray[np.int64]
    rowoff: NDArray[np.int64]
    colnnz: NDArray[np.int64]
    base: NDArray[np.int64]
    nnz: int
    indptr: NDArray[np.int32]


def node_pattern(Fn: NDArray[np.int64], free: NDArray[np.bool_], n: int) -> NodePattern:
    """The numbering and pattern of the free dofs ``free`` (6 n,) of a mesh of triangles ``Fn`` (m, 3) on n nodes,
    shared by :class:`Assembler` and :class:`fabpat.shell.compiled.CompiledAssembler` (one fact in one place).

    The free dofs are numbered node by node in a fill-reducing (MMD) order of the *node* graph: SuperLU then
    factors without its own ordering (symmetric mode), ~1.3× faster, and the order is computed once on a 6×
    smaller graph. The pattern is built on node pairs (9 per element instead of 324 dof pairs: a 36× smaller
    sort) and expanded to blocks: CSC column (J, q) lists the free dofs of J's neighbour nodes I in rank order,
    so entry (I p, J q) sits at base_J + q'·colnnz_J + rowoff_IJ + p', with p', q' the indices among the nodes'
    free dofs. Raises nothing."""
    order = _node_order(Fn, n)  # rank of each node
    by_rank = np.argsort(order)
    freeN = free.reshape(n, 6)
    nf = freeN.sum(axis=1)  # free dofs per node
    start = np.zeros(n, dtype=np.int64)  # first free index of each node (its free dofs are contiguous)
    start[by_rank] = np.concatenate([[0], np.cumsum(nf[by_rank])[:-1]])
    pf = np.where(freeN, np.cumsum(freeN, axis=1) - 1, -1)  # (n, 6) index among the node's free dofs
    glob = np.flatnonzero(free)
    fidx = start[glob // 6] + pf.ravel()[glob]
    in_order = np.empty_like(glob)
    in_order[fidx] = glob
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
    nnz = int(np.sum(nf_r * colnnz))
    indptr = np.empty(glob.size + 1, dtype=np.int32)
    indptr[fidx] = base[order[glob // 6]] + pf.ravel()[glob] * colnnz[order[glob // 6]]
    indptr[glob.size] = nnz
    return NodePattern(order, by_rank, nf, start, pf, glob, fidx, in_order, RJ, uniq, inv, uJ, uI, nf_r, w, rowoff,
                       colnnz, base, nnz, indptr)


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
        pat = node_pattern(Fn, free, n)  # the numbering (a fill-reducing order of the node graph) and pattern
        start, pf, RJ, inv, colnnz, base, rowoff = pat.start, pat.pf, pat.RJ, pat.inv, pat.colnnz, pat.base, pat.rowoff
        self.free = pat.free
        self._nnz = pat.nnz
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
        self._indptr = pat.indptr
        self.n_free = int(pat.glob.size)

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
