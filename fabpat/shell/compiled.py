"""The assembly solver's element kernels compiled and on every core (:mod:`fabpat.shell.kernels`).

An assembly's mesh has 10–50 k triangles, and its Newton iterations spend most of their time in the
element forces and tangents and in summing the element matrices into the sparse tangent. Here those
run as compiled loops over the elements, shared among the cores, and the PARDISO factorisations of
the one large matrix use the same cores (:func:`pardiso_threads`). The catalog's per-plate scenarios
keep the numpy kernels of :class:`fabpat.shell.corotational.CorotationalTriangles`: their numbers are
the catalog's, pinned by its solver version, and their worker processes already fill the cores.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace

import numba
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

import fabpat.shell.kernel_cache  # noqa: F401 - numba's cache folder, chosen before the kernels are defined
from fabpat.shell.assembly import Assembler
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import LocalStiffness, Material, local_stiffness
from fabpat.shell.kernels import block_sum, element_kernels, link_transform
from fabpat.shell.linalg import mkl
from fabpat.shell.news import tell
from fabpat.shell.strain import thickness_groups

Arr = NDArray[np.float64]
Ints = NDArray[np.int64]

# numba's own work queue, not OpenMP: after a kernel has run on GNU OpenMP threads, a fork()ed child
# (the design loop's and the sweep's worker processes) terminates at once ("fork() called from a process
# already using GNU OpenMP"); the work queue is as fast here (shipped strip: 15.6 s against 16.1 s) and
# survives a fork, but must not be entered from two threads at once, hence the lock
if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"
_KERNEL_LOCK = threading.Lock()
# MKL's OpenMP threads spin for 200 ms after each PARDISO call by default, on the cores the element
# kernels run on next: without the spin the shipped strip's tangents take 5.5 s rather than 6.0 s.
# Read when MKL starts its threads (the first factorisation), so it is set here, before any solve.
os.environ.setdefault("KMP_BLOCKTIME", "0")


def cores() -> int:
    """Threads a solve in this process uses by default: the cores it may run on (its CPU affinity; the
    machine's count where that is unknown), or 1 in a child process (a worker of the design loop's
    pool, which shares the cores with its siblings)."""
    if multiprocessing.parent_process() is not None:
        return 1
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


#: the kernels of this process are compiled or loaded (:func:`ensure_kernels`)
_READY: list[bool] = []
#: the kernels numba compiles and caches (their cache index files tell whether a run compiles them)
_CACHED = (element_kernels, block_sum, link_transform)


def kernels_cached() -> bool:
    """Whether numba's cache holds every kernel (an index file each), so this process loads them in a
    fraction of a second rather than compiling them (about 40 s). An unreadable cache counts as absent."""
    try:
        return all(os.path.exists(vars(f)["_cache"]._cache_file._index_path) for f in _CACHED)  # numba's cache layout
    except (AttributeError, KeyError):  # another numba's layout: say nothing rather than guess
        return True


def ensure_kernels() -> None:
    """Compile or load the kernels once per process (:func:`load_kernels`), first telling the solver's
    listeners (:mod:`fabpat.shell.news`) when they are being compiled, which takes about 40 s once after
    an install (or a numba upgrade) and is otherwise silent."""
    if _READY:
        return
    if not kernels_cached():
        where = fabpat.shell.kernel_cache.CACHE_DIR
        tell("compiling the solver's kernels (once after an install: about 40 s"
             + (f"; kept in {where})" if where else ")"))
    load_kernels()


def load_kernels() -> float:
    """Compile the kernels (or load them from numba's cache, :mod:`fabpat.shell.kernel_cache`) by
    calling them once on one triangle; returns the seconds it took (about 40 s the first time on the
    2-core machine, 0.2 s from the cache). A solve does this on its first call anyway
    (:func:`ensure_kernels`); benchmarks call it first so that their timings are of the solver alone."""
    import time

    t = time.perf_counter()
    try:
        X = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        tri = CompiledTriangles(X, np.array([[0, 1, 2]]), Material(), threads=1)
        xe, Re = tri.gather(X, np.broadcast_to(np.eye(3), (3, 3, 3)).copy())
        tri.element_tangents(xe, Re, tri.element_forces(xe, Re)[2])
        asm = Assembler(tri.edofs, np.ones(18, dtype=bool))
        CompiledAssembler(asm, threads=1).matrix(np.zeros((1, 18, 18)))
        transform_elements(np.zeros((1, 18, 18)), np.zeros(1, dtype=np.int64), np.zeros((1, 3, 3)), threads=1)
    except OSError as e:  # numba saving the compiled kernels: a full disk, a quota, a folder made read-only
        from fabpat.errors import SolverError
        from fabpat.shell.kernel_cache import remove_empty_folders

        folder = fabpat.shell.kernel_cache.CACHE_DIR or "numba's cache folder"
        remove_empty_folders()
        raise SolverError(f"cannot keep the solver's compiled kernels in {folder}: {e.strerror or e}; free space "
                          "there, or set FABPAT_CACHE=off (they are then compiled again by every process)") from e
    _READY.append(True)
    return time.perf_counter() - t


def graded_local_stiffness(x: Arr, y: Arr, mat: Material, thickness: Arr) -> LocalStiffness:
    """:func:`fabpat.shell.element.local_stiffness` of triangles of per-element ``thickness`` (m,) mm: each
    group of one thickness (:func:`fabpat.shell.strain.thickness_groups`) is one batch with ``mat``'s E and
    ν at that t, so an element's matrices are those of a mesh of its thickness alone. x, y: (m, 3) local
    corner coordinates (mm). Raises GeometryError on a ``thickness`` of the wrong shape or not positive."""
    m = x.shape[0]
    Km, Kb, Ks = np.empty((m, 9, 9)), np.empty((m, 9, 9)), np.empty((m, 9, 9))
    K, area = np.empty((m, 18, 18)), np.empty(m)
    for t, idx in thickness_groups(thickness, m):
        part = local_stiffness(x[idx], y[idx], replace(mat, t=t))
        for whole, piece in ((Km, part.Km), (Kb, part.Kb), (Ks, part.Ks), (K, part.K), (area, part.area)):
            whole[idx] = piece
    return LocalStiffness(Km, Kb, Ks, K, area)


class CompiledTriangles(CorotationalTriangles):
    """:class:`CorotationalTriangles` whose unbatched force and tangent evaluations run compiled on
    ``threads`` threads (default :func:`cores`). Same shapes and units; the numbers agree with the numpy
    kernels to round-off (~1e-13 relative), not bitwise.

    X: (n, 3) node coordinates (mm); F: (m, 3) triangles; mat: material and thickness; ``thickness``
    (m,) mm per element overrides ``mat.t`` (None: ``mat.t`` everywhere, the numbers unchanged;
    :func:`graded_local_stiffness`). Raises GeometryError on a ``thickness`` of the wrong shape or not positive.
    """

    def __init__(self, X: Arr, F: NDArray[np.int64], mat: Material, *, threads: int | None = None,
                 thickness: Arr | None = None) -> None:
        super().__init__(X, F, mat)
        if thickness is not None:  # computed twice for such a mesh: the base class's numbers stay untouched
            self.local = graded_local_stiffness(self.xl0[..., 0], self.xl0[..., 1], mat, thickness)
        self.threads = max(1, min(threads or cores(), numba.config.NUMBA_NUM_THREADS))
        self._consts = tuple(np.ascontiguousarray(a) for a in
                             (self.gN, self.xl0, self.E0, self.local.K, self._stiffness_root()))
        m = len(self.F)
        self._fe, self._U, self._d = np.empty((m, 18)), np.empty(m), np.empty((m, 18))
        self._Kt: Arr | None = None

    def _run(self, x: Arr, R: Arr, F: NDArray[np.int64], Kt: Arr | None) -> None:
        x = np.ascontiguousarray(x, dtype=np.float64)
        R = np.ascontiguousarray(R, dtype=np.float64)
        out = Kt if Kt is not None else np.empty((0, 18, 18))
        with _KERNEL_LOCK:
            numba.set_num_threads(self.threads)
            element_kernels(x, R, F, *self._consts, self._fe, self._U, self._d, out, Kt is not None)

    def _own(self, xe: Arr) -> NDArray[np.int64]:
        """Triangles numbering the corners of element arrays (m, 3, …) as nodes 3e, 3e + 1, 3e + 2."""
        return np.arange(3 * xe.shape[0], dtype=np.int64).reshape(-1, 3)

    def forces_at(self, x: Arr, R: Arr) -> tuple[Arr, Arr, Arr]:
        """:meth:`element_forces` of node positions x (n, 3) mm and rotations R (n, 3, 3), read by the
        kernels through ``F`` (no gathered copies)."""
        self._run(x, R, self.F, None)
        return self._fe.copy(), self._U.copy(), self._d.copy()

    def tangents_at(self, x: Arr, R: Arr) -> Arr:
        """:meth:`element_tangents` of node positions x (n, 3) mm and rotations R (n, 3, 3); the array is
        overwritten by the next call."""
        if self._Kt is None:
            self._Kt = np.empty((len(self.F), 18, 18))
        self._run(x, R, self.F, self._Kt)
        return self._Kt

    def linear_diagonal(self) -> Arr:
        """(m, 18) diagonals of the global-frame element stiffness at the initial geometry: those of
        :meth:`CorotationalTriangles.linear_element_matrices` without forming the matrices."""
        m = len(self.F)
        K = self.local.K.reshape(m, 6, 3, 6, 3)
        blocks = K[:, np.arange(6), :, np.arange(6), :]  # (6, m, 3, 3): the node-dof diagonal blocks
        return np.einsum("mij,bmjk,mik->mbi", self.E0, blocks, self.E0).reshape(m, 18)

    def element_forces(self, xe: Arr, Re: Arr) -> tuple[Arr, Arr, Arr]:
        """Element internal forces (m, 18), strain energies (m,) N·mm and local dofs (m, 18) of element
        states xe (m, 3, 3) mm, Re (m, 3, 3, 3) (batched states: the numpy kernels)."""
        if xe.ndim != 3:
            return super().element_forces(xe, Re)
        self._run(xe.reshape(-1, 3), Re.reshape(-1, 3, 3), self._own(xe), None)
        return self._fe.copy(), self._U.copy(), self._d.copy()

    def element_tangents(self, xe: Arr, Re: Arr, d: Arr) -> Arr:
        """(m, 18, 18) consistent tangents at element states xe, Re (their local dofs d are recomputed:
        compiled, the frame costs less than checking that d belongs to them). The array is overwritten
        by the next call."""
        if self._Kt is None:
            self._Kt = np.empty((len(self.F), 18, 18))
        self._run(xe.reshape(-1, 3), Re.reshape(-1, 3, 3), self._own(xe), self._Kt)
        return self._Kt


def _blocks(asm: Assembler) -> tuple[Ints, Ints, Ints, Ints, Ints, Ints, Ints, Ints]:
    """The node blocks of an assembler's matrix for :func:`fabpat.shell.kernels.block_sum`: (bases, bstart,
    rows, cols, first, stride, dofs, nfree) (that kernel's doc), each an int64 array; rows and cols are
    node numbers, the blocks in the matrix's column order (by column node, then row node)."""
    Fn = asm.edofs[:, ::6] // 6  # (m, 3) element nodes (the assembler numbers dofs node by node)
    m, n = Fn.shape[0], asm.n_dofs // 6
    is_free = np.zeros(asm.n_dofs, dtype=bool)
    is_free[asm.free] = True
    freeN = is_free.reshape(n, 6)
    nfree = freeN.sum(axis=1).astype(np.int64)
    dofs = np.argsort(~freeN, axis=1, kind="stable").astype(np.int64)  # each node's free local dofs first, ascending
    # every (element, a, b) corner pair: its 6 × 6 block starts at e·324 + 6a·18 + 6b of the element matrices
    ri = np.repeat(Fn, 3, axis=1).ravel()  # row node of (e, a, b), in that (increasing position) order
    cj = np.tile(Fn, (1, 3)).ravel()  # its column node
    corner = (108 * np.arange(3)[:, None] + 6 * np.arange(3)).ravel()  # 6a·18 + 6b
    base = (324 * np.arange(m, dtype=np.int64)[:, None] + corner).ravel()
    keep = np.flatnonzero((nfree[ri] > 0) & (nfree[cj] > 0))
    key = cj[keep] * n + ri[keep]  # column-node major, as the CSC matrix
    order = keep[np.argsort(key, kind="stable")]  # within a block, increasing position
    key = cj[order] * n + ri[order]
    cut = np.flatnonzero(np.diff(key)) + 1
    bstart = np.concatenate([[0], cut, [order.size]]).astype(np.int64)
    head = order[bstart[:-1]]
    rows, cols = ri[head], cj[head]
    # the nonzero of the block's first free (row, column) dofs: where the assembler sends that entry
    flat = base[head] + 18 * dofs[rows, 0] + dofs[cols, 0]
    first = asm._inv[flat] if asm._valid is None else asm._inv[np.searchsorted(asm._valid, flat)]
    col = np.searchsorted(asm._indptr, first, side="right") - 1
    stride = (asm._indptr[col + 1] - asm._indptr[col]).astype(np.int64)
    return base[order], bstart, rows, cols, np.asarray(first, dtype=np.int64), stride, dofs, nfree


class CompiledAssembler:
    """An :class:`Assembler`'s matrix sum as a compiled gather over the matrix entries, on every core.

    Each nonzero sums its element entries in the order ``np.bincount`` does, so the matrix is bitwise
    :meth:`Assembler.matrix`'s. ``free``, ``n_free`` and ``vector`` are the assembler's. The sum goes node
    block by node block (:func:`fabpat.shell.kernels.block_sum`): on GP(3, 0)'s tangent at h = 3 (14.5 M
    element entries into 6.9 M nonzeros, one thread) 0.052 s a matrix rather than 0.078 s for a gather
    entry by entry in a stable sort of the entries by nonzero, and the blocks are found in 0.09 s rather
    than that sort's 0.7 s (a sort of the 0.4 M corner pairs rather than of the entries).
    """

    def __init__(self, asm: Assembler, threads: int | None = None) -> None:
        self.asm, self.free, self.n_free = asm, asm.free, asm.n_free
        self.threads = max(1, min(threads or cores(), numba.config.NUMBA_NUM_THREADS))
        self._blocks = _blocks(asm)

    def matrix(self, Ke: Arr, tail: Arr | None = None) -> sp.csc_matrix:
        """(n_free, n_free) CSC matrix of element matrices Ke (m, 18, 18) followed by ``tail`` (k, 18, 18)
        (the assembler's elements m … m + k − 1; none by default): the sum of the two without
        concatenating them."""
        data = np.empty(self.asm._nnz)
        rest = np.zeros(0) if tail is None else np.ascontiguousarray(tail).reshape(-1)
        with _KERNEL_LOCK:
            numba.set_num_threads(self.threads)
            bases, bstart, rows, cols, first, stride, dofs, nfree = self._blocks
            block_sum(np.ascontiguousarray(Ke).reshape(-1), rest, bases, bstart, rows, cols, first, stride, dofs,
                      nfree, data)
        return sp.csc_matrix((data, self.asm._indices, self.asm._indptr), shape=(self.n_free, self.n_free))

    def vector(self, fe: Arr) -> Arr:
        """(N,) global vector of element vectors fe (m, 18)."""
        return self.asm.vector(fe)


def transform_elements(Kt: Arr, elements: NDArray[np.int64], c: Arr, threads: int | None = None) -> None:
    """Kt[e] ← Tᵀ Kt[e] T in place for the ``elements`` whose corners have lever arms c (k, 3, 3) mm to a
    master (0 at corners that are not slaves): the rigid-link transformation of
    :mod:`fabpat.shell.rigid_links`, compiled (:func:`fabpat.shell.kernels.link_transform`)."""
    with _KERNEL_LOCK:
        numba.set_num_threads(max(1, min(threads or cores(), numba.config.NUMBA_NUM_THREADS)))
        link_transform(Kt, np.ascontiguousarray(elements, dtype=np.int64), np.ascontiguousarray(c, dtype=np.float64))


@contextmanager
def pardiso_threads(n: int) -> Iterator[None]:
    """Let PARDISO use ``n`` threads inside the block (one outside it, :mod:`fabpat.shell.linalg`);
    no effect without MKL."""
    lib = mkl()
    if lib is None or n <= 1:
        yield
        return
    lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(n), ctypes.c_int(4))  # 4: MKL_DOMAIN_PARDISO
    try:
        yield
    finally:
        lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(1), ctypes.c_int(4))
