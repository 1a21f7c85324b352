"""The assembly solver's element kernels compiled and on every core (:mod:`fabpat.shell.kernels`).

An assembly's mesh has 10–50 k triangles, and its Newton iterations spend most of their time in the
element forces and tangents and in summing the element matrices into the sparse tangent. Here those
run as compiled loops over the elements, shared among the cores, and the PARDISO factorisations of
the one large matrix use the same cores (:func:`solver_threads`). The catalog's per-plate scenarios
keep the numpy kernels of :class:`fabpat.shell.corotational.CorotationalTriangles`: their numbers are
the catalog's, pinned by its solver version, and their worker processes already fill the cores.
"""

from __future__ import annotations

import ctypes
import itertools
import multiprocessing
import operator
import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace

import numba
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from threadpoolctl import ThreadpoolController

import fabpat.shell.kernel_cache  # noqa: F401 - numba's cache folder, chosen before the kernels are defined
from fabpat.shell.assembly import node_pattern
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import LocalStiffness, Material, local_stiffness
from fabpat.shell.kernels import block_rows, block_sum, element_kernels, link_transform, shared_element_kernels
from fabpat.shell.linalg import mkl
from fabpat.shell.news import tell
from fabpat.shell.strain import thickness_groups

Arr = NDArray[np.float64]

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


def kernel_lock() -> threading.Lock:
    """The lock every compiled kernel call holds (numba's work queue must not be entered from two threads at
    once); a forked child gets a fresh one (:func:`_fresh_in_child`)."""
    return _KERNEL_LOCK


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
_CACHED = (element_kernels, shared_element_kernels, block_sum, block_rows, link_transform)


def kernels_cached() -> bool:
    """Whether numba's cache holds every kernel (an index file each), so this process loads them in a
    fraction of a second rather than compiling them (about 10 s on two cores). An unreadable cache counts as
    absent."""
    try:
        return all(os.path.exists(vars(f)["_cache"]._cache_file._index_path) for f in _CACHED)  # numba's cache layout
    except (AttributeError, KeyError):  # another numba's layout: say nothing rather than guess
        return True


def ensure_kernels() -> None:
    """Compile or load the kernels once per process (:func:`load_kernels`), first telling the solver's
    listeners (:mod:`fabpat.shell.news`) when they are being compiled, which takes about 10 s on two cores
    once after an install (or a numba upgrade) and is otherwise silent."""
    if _READY:
        return
    if not kernels_cached():
        where, refused = fabpat.shell.kernel_cache.CACHE_DIR, fabpat.shell.kernel_cache.REFUSED
        tell("compiling the solver's kernels (once after an install: about 10 s"
             + (f"; kept in {where})" if where else f"; {refused})" if refused else ")"))
    load_kernels()


def load_kernels() -> float:
    """Compile the kernels (or load them from numba's cache, :mod:`fabpat.shell.kernel_cache`) by
    calling them once on one triangle, in every signature a solve uses; returns the seconds it took (about
    10 s the first time on the 2-core machine, 0.2 s from the cache). A solve does this on its first call anyway
    (:func:`ensure_kernels`); benchmarks call it first so that their timings are of the solver alone."""
    import time

    t = time.perf_counter()
    try:
        X = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        tri = CompiledTriangles(X, np.array([[0, 1, 2]]), Material(), threads=1)
        xe, Re = tri.gather(X, np.broadcast_to(np.eye(3), (3, 3, 3)).copy())
        tri.element_tangents(xe, Re, tri.element_forces(xe, Re)[2])
        R = np.broadcast_to(np.eye(3), (3, 3, 3)).copy()
        tri.tangents_at(X, R)  # the solves' signatures: a mesh's own triangles, and shared element data
        # (fabpat.shell.congruent.CongruentTriangles calls the shared kernel with these types)
        gN, xl0, E0, K, Q = tri._consts
        shared_element_kernels(X, R, tri._F, gN, xl0, E0, K, Q, np.zeros(1, dtype=np.int64), np.empty((1, 18)),
                               np.empty(1), np.empty((1, 18)), np.empty((1, 18, 18)), True)
        CompiledAssembler(tri.edofs, np.ones(18, dtype=bool), threads=1).matrix(np.zeros((1, 18, 18)))
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
        # the kernels' own copy of the triangles, writable: a read-only array (a frozen mesh's) is another
        # type to numba, compiled again (seconds, once per install) on the first solve
        self._F = np.array(self.F, dtype=np.int64, order="C")
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
        self._run(x, R, self._F, None)
        return self._fe.copy(), self._U.copy(), self._d.copy()

    def tangents_at(self, x: Arr, R: Arr) -> Arr:
        """:meth:`element_tangents` of node positions x (n, 3) mm and rotations R (n, 3, 3); the array is
        overwritten by the next call."""
        if self._Kt is None:
            self._Kt = np.empty((len(self.F), 18, 18))
        self._run(x, R, self._F, self._Kt)
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


class CompiledAssembler:
    """The sparse tangent of element matrices as a compiled sum, node block by node block, on every core:
    :class:`fabpat.shell.assembly.Assembler`'s matrix (the same dof numbering, CSC pattern and sums, bitwise)
    with its pattern built from the 9 node pairs of each element rather than from its 324 entries.

    edofs: (m, 18) global dof numbers of each element (6 per node, node by node); free: (N,) bool mask of the
    free global dofs. ``free`` lists the global free dofs in matrix order; ``n_free`` counts them.
    The sum (:func:`fabpat.shell.kernels.block_sum`) reads each node pair's element list once, not one index
    per element entry: on GP(3, 0)'s tangent at h = 3 (14.5 M element entries into 6.9 M nonzeros) 0.028 s
    a matrix on two threads (0.054 s on one) rather than 0.049 s (0.075 s) for a gather entry by entry; and
    the pattern's set-up sorts the 0.4 M corner pairs, not the entries (0.13 CPU s rather than 0.3 s for
    the Assembler and 0.3 s for the gather's order).
    """

    def __init__(self, edofs: NDArray[np.int64], free: NDArray[np.bool_], threads: int | None = None) -> None:
        self.threads = max(1, min(threads or cores(), numba.config.NUMBA_NUM_THREADS))
        free = np.asarray(free, dtype=bool).ravel()
        self.n_dofs = int(free.size)
        Fn = edofs[:, ::6] // 6  # (m, 3) element nodes
        n = self.n_dofs // 6
        # the Assembler's numbering and pattern (node pairs (column rank, row rank); pair u's nonzero (p', q')
        # at base[column] + q'·colnnz[column] + rowoff[u] + p')
        pat = node_pattern(Fn, free, n)
        by_rank, nf, start, uniq, inv = pat.by_rank, pat.nf, pat.start, pat.uniq, pat.inv
        uJ, uI, nf_r, w, rowoff, colnnz, base = pat.uJ, pat.uI, pat.nf_r, pat.w, pat.rowoff, pat.colnnz, pat.base
        freeN = free.reshape(n, 6)
        self.free, self.n_free, self._nnz, self._indptr = pat.free, int(pat.glob.size), pat.nnz, pat.indptr
        # the blocks: pairs with free dofs on both nodes, in the order of their node numbers (column, then
        # row), which is close to the elements' order: the sum then reads the element matrices nearly in
        # turn (in the matrix's column order it was no faster than the gather entry by entry, 0.078 s
        # against 0.075 s on GP(3, 0), one thread); each lists its (element, a, b) in increasing position
        # e·324 + 6a·18 + 6b (inv runs over (e, a, b))
        live = np.flatnonzero((w > 0) & (nf_r[uJ] > 0))
        live = live[np.argsort(by_rank[uJ[live]] * n + by_rank[uI[live]])]
        block = np.full(uniq.size, -1)
        block[live] = np.arange(live.size)
        g = block[inv]
        k = np.flatnonzero(g >= 0)
        k = k[np.argsort(g[k], kind="stable")]
        corner = (108 * np.arange(3)[:, None] + 6 * np.arange(3)).ravel()
        pos = 324 * (k // 9) + corner[k % 9]
        count = np.bincount(g[g >= 0], minlength=live.size)
        rows, cols = by_rank[uI[live]], by_rank[uJ[live]]
        first = (base[uJ] + rowoff)[live].astype(np.int64)
        stride = colnnz[uJ[live]]
        self._indices = np.empty(self._nnz, dtype=np.int32)
        block_rows(first, stride, start[rows], nf[rows].astype(np.int64), nf[cols].astype(np.int64), self._indices)
        dofs = np.argsort(~freeN, axis=1, kind="stable").astype(np.int64)  # free local dofs first, ascending
        self._blocks = (pos.astype(np.int64), np.concatenate([[0], np.cumsum(count)]).astype(np.int64),
                        rows.astype(np.int64), cols.astype(np.int64), first, stride, dofs, nf.astype(np.int64))

    def matrix(self, Ke: Arr, tail: Arr | None = None) -> sp.csc_matrix:
        """(n_free, n_free) CSC matrix of element matrices Ke (m, 18, 18) followed by ``tail`` (k, 18, 18)
        (the assembler's elements m … m + k − 1; none by default): the sum of the two without
        concatenating them."""
        data = np.empty(self._nnz)
        rest = np.zeros(0) if tail is None else np.ascontiguousarray(tail).reshape(-1)
        with _KERNEL_LOCK:
            numba.set_num_threads(self.threads)
            bases, bstart, rows, cols, first, stride, dofs, nfree = self._blocks
            block_sum(np.ascontiguousarray(Ke).reshape(-1), rest, bases, bstart, rows, cols, first, stride, dofs,
                      nfree, data)
        return sp.csc_matrix((data, self._indices, self._indptr), shape=(self.n_free, self.n_free))


def transform_elements(Kt: Arr, elements: NDArray[np.int64], c: Arr, threads: int | None = None) -> None:
    """Kt[e] ← Tᵀ Kt[e] T in place for the ``elements`` whose corners have lever arms c (k, 3, 3) mm to a
    master (0 at corners that are not slaves): the rigid-link transformation of
    :mod:`fabpat.shell.rigid_links`, compiled (:func:`fabpat.shell.kernels.link_transform`)."""
    with _KERNEL_LOCK:
        numba.set_num_threads(max(1, min(threads or cores(), numba.config.NUMBA_NUM_THREADS)))
        link_transform(Kt, np.ascontiguousarray(elements, dtype=np.int64), np.ascontiguousarray(c, dtype=np.float64))


def _openblas_counts() -> list[tuple[Callable[[], int], Callable[[int], object]]]:
    """(get, set) of the thread count of every OpenBLAS loaded (numpy's and scipy's, found by threadpoolctl),
    called directly: threadpoolctl's own setter lets only the first Python thread that used it change the count
    and silently ignores the others, so a limit set in one thread and given back in another would stay."""
    out: list[tuple[Callable[[], int], Callable[[int], object]]] = []
    for lib in ThreadpoolController().select(internal_api="openblas").lib_controllers:
        for prefix, suffix in itertools.product(("", "scipy_"), ("", "64_", "_64")):
            get = getattr(lib.dynlib, f"{prefix}openblas_get_num_threads{suffix}", None)
            put = getattr(lib.dynlib, f"{prefix}openblas_set_num_threads{suffix}", None)
            if get is not None and put is not None:
                out.append((get, put))
                break
    return out


class _OneBlasThread:
    """The one OpenBLAS limit shared by every block that asks for it (:func:`one_blas_thread`): the first to
    enter sets it, the last to leave gives back the counts the first found, so blocks of several Python threads
    that overlap leave the caller's setting as it was."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.users = 0
        self.libs: list[tuple[Callable[[], int], Callable[[int], object]]] | None = None
        self.saved: list[int] = []

    def enter(self) -> None:
        with self.lock:
            if self.users == 0:
                if self.libs is None:  # the libraries loaded by now: numpy's and scipy's
                    self.libs = _openblas_counts()
                self.saved = [int(get()) for get, _ in self.libs]
                # the C functions called from one C loop (map, operator.call): no Python code runs between them,
                # so no KeyboardInterrupt can land with some counts set and others not
                list(map(operator.call, [put for _, put in self.libs], itertools.repeat(1)))
            self.users += 1

    def leave(self) -> None:
        with self.lock:
            if self.users == 0:  # a block entered before a fork, left in the child (fresh state, nothing to give)
                return
            self.users -= 1
            if self.users == 0 and self.libs is not None:
                list(map(operator.call, [put for _, put in self.libs], self.saved))  # as in enter


_BLAS = _OneBlasThread()
#: whether a path has set PARDISO's threads in this process (then MKL is loaded; a forked child resets them)
_PARDISO_SET = False


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """One OpenBLAS thread inside the block (numpy's and scipy's; MKL's BLAS is left alone).

    After a BLAS call on several threads OpenBLAS keeps its workers spinning for about 0.1 s, on the very
    cores the element kernels and PARDISO then run on, and this code's BLAS calls (norms and small products)
    gain nothing from threads. Measured on the idle 2-core machine with ``python benchmarks/bench_assembly.py
    --solve --h 3``: the shipped sphere 1.7 → 1.3 s (its factorisations 0.047 → 0.028–0.034 s each, its tangents
    0.06 → 0.03–0.04 s), the shipped strip 5.4 → 4.4 s. The libraries are those loaded at the first call
    (threadpoolctl), which is after numpy and scipy. The limit is the process's while a block runs: another
    Python thread's BLAS calls meanwhile run on one thread too. Blocks may overlap from several threads; the
    last to end gives back the setting the first found."""
    _BLAS.enter()
    try:
        yield
    finally:
        _BLAS.leave()


@contextmanager
def solver_threads(n: int) -> Iterator[None]:
    """The threads of one large matrix's path inside the block: PARDISO may use ``n`` (one outside it,
    :mod:`fabpat.shell.linalg`; no effect without MKL), OpenBLAS one (:func:`one_blas_thread`).

    A thread-local MKL thread count (what ``threadpoolctl.threadpool_limits`` sets) would override PARDISO's
    count: a caller's limit of 3 made a small strip's path take 3.3 s rather than 0.4 s on two cores. It is
    cleared inside the block and given back afterwards."""
    global _PARDISO_SET
    lib = mkl()
    with one_blas_thread():
        if lib is None:
            yield
            return
        _PARDISO_SET = True
        local = lib.MKL_Set_Num_Threads_Local(ctypes.c_int(0))  # 0: the global and domain counts apply
        try:
            # set even for one thread: a child forked during a parent's path inherits the parent's count
            lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(max(1, n)), ctypes.c_int(4))  # 4: MKL_DOMAIN_PARDISO
            yield
        finally:
            lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(1), ctypes.c_int(4))
            lib.MKL_Set_Num_Threads_Local(ctypes.c_int(local))


def _fresh_in_child() -> None:
    """A forked child gets its own kernel lock and BLAS limit: the parent's may have been held by another
    thread at the fork (a solve under way), and nothing in the child would release them. PARDISO is set back to
    one thread (the parent's path may have had two); the child's OpenBLAS keeps the parent's count of the moment
    (one, if a path was running)."""
    global _KERNEL_LOCK, _BLAS
    _KERNEL_LOCK = threading.Lock()
    _BLAS = _OneBlasThread()
    if _PARDISO_SET:  # MKL loaded and a path ran: PARDISO on one thread outside a path, as in the parent
        lib = mkl()
        if lib is not None:
            lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(1), ctypes.c_int(4))


os.register_at_fork(after_in_child=_fresh_in_child)
