"""Sparse LU factorisations of the tangent for the Newton iterations.

Newton factors many matrices with *one* sparsity pattern (the Assembler's). Intel MKL's PARDISO can
split a factorisation into a symbolic analysis (fill-reducing ordering, elimination tree), done
once per pattern, and a numerical factorisation, done per matrix: on the scenarios' tangents
(4–23 k dofs, one thread) the numerical step takes 2.4–7× less time than a complete SuperLU
factorisation (``benchmarks/bench_linalg.py``; docs/benchmarks.md). MKL ships as the ``mkl`` wheel
on Linux x86-64, where fabpat installs it; elsewhere, or if ``libmkl_rt`` cannot be loaded, SuperLU
(SciPy) is used with the same results to the Newton tolerance.

PARDISO runs on one thread here: the sweep already keeps every core busy with worker processes,
and one thread makes results bitwise reproducible from run to run.
PARDISO is called through ``ctypes`` as documented in the oneMKL reference ("pardiso", "pardiso iparm
parameter"); the thin binding is ours because the Python wrappers re-run the analysis on every call.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import os
import site
import sys
import weakref
from typing import Protocol

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from fabpat.errors import SolverError

Arr = NDArray[np.float64]

#: Linear-solver back-ends accepted by :func:`factorizer` ("auto": PARDISO when MKL loads, else SuperLU).
BACKENDS = ("auto", "pardiso", "superlu")

#: SuperLU threshold pivoting: a row swap only where the diagonal is below 0.1 × the column's largest
#: entry. The tangent is nearly symmetric with a dominant diagonal, so this keeps the fill of the
#: Assembler's symmetric ordering (−25 % nonzeros in L + U and ~30 % less factor time than full
#: partial pivoting at 7 k dofs) with the same residuals (~1e-9 relative).
PIVOT_THRESHOLD = 0.1

#: Rows from which PARDISO factors with its two-level parallel algorithm (``iparm(24) = 1``), which orders
#: the matrix by nested dissection. On the assembly closures' tangents at h = 3, two threads (least of 3):
#: GP(3, 0) (209 838 rows) analysis 1.23 → 0.38 s, factorisation 0.083 → 0.093 s, solve 0.026 → 0.016 s;
#: GP(4, 0) (372 378 rows) 4.15 → 0.83 s, 0.298 → 0.193 s, 0.048 → 0.030 s; but the graded strip
#: (93 270 rows) factors in 0.100 s rather than 0.055 s. No catalog scenario comes near (4–23 k dofs), so
#: their numbers do not change; above the bound the solutions differ from the classic ones by ~1e-11.
TWO_LEVEL_ROWS = 150_000


class Factor(Protocol):
    """A factorised matrix K: ``solve(b)`` returns x (n,) with K x = b for b (n,)."""

    def solve(self, b: Arr) -> Arr:
        """x (n,) with K x = b."""
        ...


def superlu(K: sp.csc_matrix) -> Factor:
    """SuperLU factor of K (CSC) whose columns are already in a fill-reducing order (the Assembler's).

    Raises SolverError if K is exactly singular."""
    try:
        # no reordering here (the Assembler numbers the dofs in MMD order; symmetric mode keeps it)
        return spla.splu(K, permc_spec="NATURAL", diag_pivot_thresh=PIVOT_THRESHOLD,
                         options={"SymmetricMode": True})
    except RuntimeError as exc:  # "Factor is exactly singular"
        raise SolverError(f"singular stiffness matrix ({exc}): supports leave a rigid-body motion free?") from exc


def _find_mkl() -> ctypes.CDLL | None:
    """libmkl_rt from $FABPAT_MKL_RT, the ``mkl`` wheel (``<prefix>/lib``) or the system; None if absent."""
    names = [os.environ.get("FABPAT_MKL_RT", "")]
    for base in (sys.prefix, site.getuserbase()):
        names += sorted(glob.glob(os.path.join(base, "lib", "libmkl_rt.so*")), key=len)
    names.append(ctypes.util.find_library("mkl_rt") or "")
    for name in names:
        if not name:
            continue
        try:
            lib = ctypes.CDLL(name)
            lib.pardiso  # noqa: B018 (raises AttributeError if this is not MKL)
        except (OSError, AttributeError):
            continue
        # one thread for PARDISO (domain 4 = MKL_DOMAIN_PARDISO): see the module docstring
        lib.MKL_Domain_Set_Num_Threads(ctypes.c_int(1), ctypes.c_int(4))
        return lib
    return None


_MKL: ctypes.CDLL | None | bool = False  # False: not looked for yet


def mkl() -> ctypes.CDLL | None:
    """The loaded MKL runtime, or None when it is not installed (looked for once per process)."""
    global _MKL
    if _MKL is False:
        _MKL = _find_mkl()
    return _MKL  # type: ignore[return-value]


_P = ctypes.POINTER
_I32 = ctypes.c_int32


class Pardiso:
    """PARDISO factorisations of real nonsymmetric matrices, for a sequence sharing one CSC pattern.

    ``factor(K)`` analyses the pattern on the first call (and whenever it changes) and otherwise only
    refactors numerically;
    the returned object's ``solve`` uses the *latest* factorisation. Matrices whose factorisation needs
    perturbed pivots (singular or nearly so) are handed to SuperLU instead, which either factors them
    or raises SolverError naming the singularity.
    """

    _MTYPE = 11  # real nonsymmetric

    def __init__(self, lib: ctypes.CDLL) -> None:
        self._lib = lib
        self._fn = lib.pardiso
        self._fn.restype = None
        self._pt = np.zeros(64, dtype=np.int64)
        self._iparm = np.zeros(64, dtype=np.int32)
        ip = self._iparm  # 0-based positions of the reference's iparm(1…64)
        ip[0] = 1  # use the values below, not the defaults
        # minimum-degree ordering; no scaling or weighted matching: the shell tangent is nearly symmetric
        # with a dominant diagonal, and these choices cut the analysis from 87 to 20 ms (12 k dofs) with
        # the same residuals (~1e-10); a matrix that needs perturbed pivots goes to SuperLU (below)
        ip[1] = 0
        ip[9] = 13  # pivot perturbation 1e-13 (the default for nonsymmetric matrices)
        ip[11] = 2  # the arrays given are CSC, i.e. CSR of Kᵀ: solve the transposed system
        ip[34] = 1  # zero-based indices
        self._pattern: bool | None = None
        self._indptr = self._indices = np.zeros(0, dtype=np.int32)
        self._n = 0
        self._data = np.zeros(0)
        self._fallback: Factor | None = None
        self.analyses = 0  # symbolic analyses so far (phase 11): one per pattern it has seen in turn
        self._finalizer = weakref.finalize(self, Pardiso._release, lib, self._pt, self._iparm)

    def _call(self, phase: int, data: Arr, b: Arr | None = None) -> Arr:
        x = np.zeros(self._n) if b is not None else np.zeros(1)
        bb = np.ascontiguousarray(b, dtype=np.float64) if b is not None else np.zeros(1)
        err = _I32(0)
        self._fn(self._pt.ctypes.data_as(_P(ctypes.c_int64)), ctypes.byref(_I32(1)), ctypes.byref(_I32(1)),
                 ctypes.byref(_I32(self._MTYPE)), ctypes.byref(_I32(phase)), ctypes.byref(_I32(self._n)),
                 data.ctypes.data_as(_P(ctypes.c_double)), self._indptr.ctypes.data_as(_P(_I32)),
                 self._indices.ctypes.data_as(_P(_I32)), None, ctypes.byref(_I32(1)),
                 self._iparm.ctypes.data_as(_P(_I32)), ctypes.byref(_I32(0)),
                 bb.ctypes.data_as(_P(ctypes.c_double)), x.ctypes.data_as(_P(ctypes.c_double)), ctypes.byref(err))
        if err.value != 0:
            raise SolverError(f"PARDISO failed in phase {phase} with error {err.value} (oneMKL reference, "
                              "'pardiso': −2 out of memory, −4 zero pivot)")
        return x

    @staticmethod
    def _release(lib: ctypes.CDLL, pt: NDArray[np.int64], iparm: NDArray[np.int32]) -> None:
        if not pt.any():
            return
        err, dummy = _I32(0), np.zeros(1)
        idx = np.zeros(1, dtype=np.int32)
        lib.pardiso(pt.ctypes.data_as(_P(ctypes.c_int64)), ctypes.byref(_I32(1)), ctypes.byref(_I32(1)),
                    ctypes.byref(_I32(Pardiso._MTYPE)), ctypes.byref(_I32(-1)), ctypes.byref(_I32(1)),
                    dummy.ctypes.data_as(_P(ctypes.c_double)), idx.ctypes.data_as(_P(_I32)),
                    idx.ctypes.data_as(_P(_I32)), None, ctypes.byref(_I32(1)), iparm.ctypes.data_as(_P(_I32)),
                    ctypes.byref(_I32(0)), dummy.ctypes.data_as(_P(ctypes.c_double)),
                    dummy.ctypes.data_as(_P(ctypes.c_double)), ctypes.byref(err))
        pt[:] = 0

    def factor(self, K: sp.csc_matrix) -> Factor:
        """Factor K (CSC, float64). Raises SolverError if K is singular."""
        K = K.tocsc()
        data = np.ascontiguousarray(K.data, dtype=np.float64)
        indices = np.ascontiguousarray(K.indices, dtype=np.int32)
        if self._pattern is None or self._n != K.shape[0] or not np.array_equal(self._indices, indices) \
                or not np.array_equal(self._indptr, K.indptr):
            # first matrix, or another pattern: (re-)analyse
            Pardiso._release(self._lib, self._pt, self._iparm)
            self._n = K.shape[0]
            self._indptr = np.ascontiguousarray(K.indptr, dtype=np.int32)
            self._indices = indices
            self._pattern = True
            self._iparm[23] = 1 if self._n >= TWO_LEVEL_ROWS else 0  # iparm(24): TWO_LEVEL_ROWS
            self._call(11, data)
            self.analyses += 1
        self._call(22, data)
        self._data = data  # phase 33 refines iteratively against K when pivots were perturbed
        self._fallback = superlu(K) if self._iparm[13] > 0 else None  # iparm(14): perturbed pivots
        return self

    def solve(self, b: Arr) -> Arr:
        """x with K x = b for the latest factored K."""
        if self._fallback is not None:
            return self._fallback.solve(b)
        return self._call(33, self._data, b)


class SuperLUFactorizer:
    """A complete SuperLU factorisation per matrix (the fallback; same interface as :class:`Pardiso`).
    ``analyses`` counts them: SuperLU orders every matrix again."""

    def __init__(self) -> None:
        self.analyses = 0

    def factor(self, K: sp.csc_matrix) -> Factor:
        """SuperLU factor of K (CSC). Raises SolverError if K is exactly singular."""
        self.analyses += 1
        return superlu(K)


def factorizer(backend: str = "auto") -> Pardiso | SuperLUFactorizer:
    """A factoriser for a sequence of matrices with one pattern.

    backend: "auto" (PARDISO if MKL loads, else SuperLU), "pardiso" (SolverError if MKL is missing) or
    "superlu". The environment variable ``FABPAT_LINEAR_SOLVER`` (one of these, any case) says what "auto"
    means; another value raises SolverError.
    """
    if backend not in BACKENDS:
        raise SolverError(f"unknown linear solver {backend!r}; expected one of {', '.join(BACKENDS)}")
    if backend == "auto":
        env = os.environ.get("FABPAT_LINEAR_SOLVER", "auto").strip().lower() or "auto"
        if env not in BACKENDS:
            raise SolverError(f"FABPAT_LINEAR_SOLVER={os.environ['FABPAT_LINEAR_SOLVER']!r} is not a linear solver; "
                              f"expected one of {', '.join(BACKENDS)} (any case)")
        backend = env
    if backend == "superlu":
        return SuperLUFactorizer()
    lib = mkl()
    if lib is None:
        if backend == "pardiso":
            raise SolverError("linear solver 'pardiso' needs Intel MKL (pip install mkl, Linux x86-64); "
                              "use 'superlu' or 'auto'")
        return SuperLUFactorizer()
    return Pardiso(lib)
