"""The sparse pattern of :class:`fabpat.shell.assembly.Assembler` against the expansion it replaced: the
same free-dof order, scatter positions, CSC indices and pointers, bit for bit, on a small and a medium mesh,
with and without fixed dofs."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from fabpat.shell.assembly import Assembler, _node_order


def _reference(edofs: NDArray[np.int64], free: NDArray[np.bool_]) -> dict[str, object]:
    """The pattern as the assembler built it before (every term expanded to all m·324 entries)."""
    n = free.size // 6
    Fn = edofs[:, ::6] // 6
    m = Fn.shape[0]
    order = _node_order(Fn, n)
    by_rank = np.argsort(order)
    freeN = free.reshape(n, 6)
    nf = freeN.sum(axis=1)
    start = np.zeros(n, dtype=np.int64)
    start[by_rank] = np.concatenate([[0], np.cumsum(nf[by_rank])[:-1]])
    pf = np.where(freeN, np.cumsum(freeN, axis=1) - 1, -1)
    glob = np.flatnonzero(free)
    fidx = start[glob // 6] + pf.ravel()[glob]
    order_free = np.empty_like(glob)
    order_free[fidx] = glob
    RI = np.broadcast_to(order[Fn][:, :, None], (m, 3, 3))
    RJ3 = np.broadcast_to(order[Fn][:, None, :], (m, 3, 3))
    uniq, inv = np.unique((RJ3 * n + RI).ravel(), return_inverse=True)
    uJ, uI = uniq // n, uniq % n
    nf_r = nf[by_rank]
    w = nf_r[uI]
    cs = np.cumsum(w)
    first = np.searchsorted(uJ, uJ)
    rowoff = cs - w - np.where(first > 0, cs[first - 1], 0)
    colnnz = np.bincount(uJ, weights=w, minlength=n).astype(np.int64)
    base = np.concatenate([[0], np.cumsum(nf_r * colnnz)[:-1]])
    nnz = int(np.sum(nf_r * colnnz))
    RJ = order[Fn]
    pI = pf[Fn]
    pos = (base[RJ][:, None, None, :, None] + (pf[Fn] * colnnz[RJ][..., None])[:, None, None, :, :]
           + rowoff[inv.reshape(m, 3, 3)][:, :, None, :, None] + pI[:, :, :, None, None])
    valid = (pI >= 0)[:, :, :, None, None] & (pf[Fn] >= 0)[:, None, None, :, :]
    rows = np.broadcast_to((start[Fn][..., None] + pI)[:, :, :, None, None], pos.shape)
    vidx = None if valid.all() else np.flatnonzero(valid)
    inv_e = pos.reshape(-1) if vidx is None else pos.ravel()[vidx]
    rows = rows.reshape(-1) if vidx is None else rows.ravel()[vidx]
    indices = np.zeros(nnz, dtype=np.int32)
    indices[inv_e] = rows
    indptr = np.empty(glob.size + 1, dtype=np.int32)
    indptr[fidx] = base[order[glob // 6]] + pf.ravel()[glob] * colnnz[order[glob // 6]]
    indptr[glob.size] = nnz
    return {"free": order_free, "_inv": inv_e, "_indices": indices, "_indptr": indptr, "_valid": vidx, "_nnz": nnz}


def _grid(k: int, fixed_share: float) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """A k × k node grid of 2 (k − 1)² triangles with shuffled node numbers, and a random free mask."""
    i, j = np.meshgrid(np.arange(k - 1), np.arange(k - 1), indexing="ij")
    a = (i * k + j).ravel()
    F = np.vstack([np.stack([a, a + 1, a + k + 1], 1), np.stack([a, a + k + 1, a + k], 1)])
    rng = np.random.default_rng(k)
    F = rng.permutation(k * k)[F]
    edofs = (6 * F[:, :, None] + np.arange(6)).reshape(-1, 18).astype(np.int64)
    return edofs, rng.random(6 * k * k) >= fixed_share


@pytest.mark.parametrize("k", [5, 30])
@pytest.mark.parametrize("fixed_share", [0.0, 0.05])
def test_pattern_is_the_expanded_one_bit_for_bit(k: int, fixed_share: float) -> None:
    edofs, free = _grid(k, fixed_share)
    asm, ref = Assembler(edofs, free), _reference(edofs, free)
    assert asm._nnz == ref["_nnz"]
    for name in ("free", "_inv", "_indices", "_indptr"):
        got, want = getattr(asm, name), ref[name]
        assert isinstance(want, np.ndarray)
        assert got.dtype == want.dtype and np.array_equal(got, want), name
    want_valid = ref["_valid"]
    if want_valid is None:
        assert asm._valid is None
    else:
        assert isinstance(want_valid, np.ndarray) and asm._valid is not None
        assert np.array_equal(asm._valid, want_valid)
