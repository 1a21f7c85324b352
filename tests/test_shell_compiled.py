"""The compiled element kernels (fabpat.shell.kernels) against the numpy reference kernels."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from fabpat.shell.assembly import Assembler
from fabpat.shell.compiled import CompiledAssembler, CompiledTriangles, transform_elements
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.element import Material
from fabpat.shell.rotations import expmap, skew
from tests.helpers import SMALL_SPEC, in_small_tmpfs, needs_unshare, one_line_error, tmpfs_error


def _mesh(nx: int = 9, ny: int = 7) -> tuple[np.ndarray, np.ndarray]:
    xs, ys = np.meshgrid(np.linspace(0.0, 30.0, nx + 1), np.linspace(0.0, 20.0, ny + 1))
    rng = np.random.default_rng(3)
    X = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    X[:, :2] += rng.uniform(-0.4, 0.4, size=(len(X), 2))  # no two triangles alike
    idx = np.arange(len(X)).reshape(ny + 1, nx + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return X, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


@pytest.mark.parametrize("spin", [1e-9, 1e-3, 0.05, 0.8])
def test_compiled_force_and_tangent_match_the_numpy_kernels(spin: float) -> None:
    # rotation sizes on both sides of the kernels' series switches (1e-7, 1e-3, 1e-2 rad) and large ones
    X, F = _mesh()
    mat = Material(E=1800.0, nu=0.33, t=1.2)
    rng = np.random.default_rng(int(spin * 1e9) % 1000)
    x = X + rng.normal(scale=0.2, size=X.shape)
    x[:, 2] += 0.02 * np.abs(X[:, 0]) ** 1.5  # bent out of plane
    R = expmap(rng.normal(scale=spin, size=X.shape))
    ref, comp = CorotationalTriangles(X, F, mat), CompiledTriangles(X, F, mat, threads=2)
    xe, Re = ref.gather(x, R)
    fe0, U0, d0 = ref.element_forces(xe, Re)
    K0 = ref.element_tangents(xe, Re, d0)
    fe, U, d = comp.element_forces(xe, Re)
    K = comp.element_tangents(xe, Re, d)
    for got, want in ((fe, fe0), (U, U0), (d, d0), (K, K0)):
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    assert not np.array_equal(K0, np.zeros_like(K0))


def test_compiled_tangent_is_the_derivative_of_the_compiled_force() -> None:
    # independent of the numpy kernels: central differences of the force in one translation and one spin
    X, F = _mesh(3, 2)
    comp = CompiledTriangles(X, F, Material(E=1000.0, nu=0.3, t=1.0), threads=1)
    rng = np.random.default_rng(5)
    x = X + rng.normal(scale=0.3, size=X.shape)
    R = expmap(rng.normal(scale=0.2, size=X.shape))
    xe, Re = comp.gather(x, R)
    K = comp.element_tangents(xe, Re, comp.element_forces(xe, Re)[2]).copy()
    h = 1e-6
    for col in (2, 6 * 1 + 3 + 2):  # (node 0, z) and (node 1, ω_z)
        node, dof = divmod(col, 6)
        xp, xm, Rp, Rm = xe.copy(), xe.copy(), Re.copy(), Re.copy()
        if dof < 3:
            xp[:, node, dof] += h
            xm[:, node, dof] -= h
        else:
            w = np.zeros(3)
            w[dof - 3] = h
            Rp[:, node] = expmap(w) @ Re[:, node]
            Rm[:, node] = expmap(-w) @ Re[:, node]
        fd = (comp.element_forces(xp, Rp)[0] - comp.element_forces(xm, Rm)[0]) / (2 * h)
        assert np.abs(fd - K[:, :, col]).max() <= 1e-5 * np.abs(K).max()


def test_compiled_matrix_sum_is_bitwise_the_assemblers() -> None:
    X, F = _mesh()
    edofs = (6 * F[:, :, None] + np.arange(6)).reshape(-1, 18)
    free = np.ones(6 * len(X), dtype=bool)
    free[:6] = False  # one node's dofs left out: the assembler's gather of free entries
    asm = Assembler(edofs, free)
    Ke = np.random.default_rng(1).normal(size=(len(F), 18, 18))
    A = asm.matrix(Ke)
    B = CompiledAssembler(edofs, free, threads=2).matrix(Ke[:-4], Ke[-4:])  # the last 4 as the tail
    assert np.array_equal(A.indptr, B.indptr) and np.array_equal(A.indices, B.indices)
    assert np.array_equal(A.data, B.data)


def test_compiled_pattern_and_sum_are_bitwise_the_assemblers_with_linked_corners_and_held_dofs() -> None:
    # as the linked solver's reduced system: slaves renumbered to their master (triangles with two or three
    # corners on one node), one pseudo-element per master in the tail, a partly held master and a node
    # with one dof held (nodes whose free dofs are not all six take the kernel's general loop)
    X, F = _mesh()
    n = len(X)
    rep = np.arange(n + 2)
    rep[[0, 1, 2, 3]], rep[[10, 11]] = n, n + 1
    Fr = np.vstack([rep[F], [[n, n, n], [n + 1, n + 1, n + 1]]])
    assert (Fr[:, 0] == Fr[:, 1]).sum() >= 2  # corners that meet on one node
    edofs = (6 * Fr[:, :, None] + np.arange(6)).reshape(-1, 18)
    free = np.ones((n + 2, 6), dtype=bool)
    free[[0, 1, 2, 3, 10, 11]] = False
    free[n + 1, [0, 2]] = False
    free[20, 4] = False
    asm = Assembler(edofs, free.ravel())
    Ke = np.random.default_rng(4).normal(size=(len(Fr), 18, 18))
    A = asm.matrix(Ke)
    comp = CompiledAssembler(edofs, free.ravel(), threads=2)
    B = comp.matrix(Ke[:-2], Ke[-2:])
    assert np.array_equal(comp.free, asm.free) and comp.n_free == asm.n_free  # the same dof numbering
    assert np.array_equal(A.indptr, B.indptr) and np.array_equal(A.indices, B.indices)
    assert np.array_equal(A.data, B.data)


def test_link_transformation_is_t_transpose_k_t() -> None:
    rng = np.random.default_rng(2)
    Kt = rng.normal(size=(6, 18, 18))
    elements = np.array([1, 4])
    c = rng.normal(size=(2, 3, 3))
    c[0, 1] = 0.0  # a corner that is not a slave
    want = Kt.copy()
    for q, e in enumerate(elements):
        T = np.eye(18)
        for a in range(3):
            T[6 * a:6 * a + 3, 6 * a + 3:6 * a + 6] = -skew(c[q, a])
        want[e] = T.T @ Kt[e] @ T
    transform_elements(Kt, elements, c, threads=2)
    assert np.allclose(Kt, want, rtol=0.0, atol=1e-12)


def _child_run(_: int) -> tuple[int, float]:
    from fabpat.shell.compiled import cores, load_kernels

    return cores(), load_kernels()


def test_kernels_survive_a_fork_after_running_and_children_use_one_thread() -> None:
    # the design loop forks its worker processes after the parent has solved: on GNU OpenMP's threads
    # the children terminated at once and the pool waited forever
    import multiprocessing as mp

    from fabpat.shell.compiled import load_kernels

    load_kernels()
    with mp.get_context("fork").Pool(2) as pool:
        got = pool.map_async(_child_run, range(2)).get(timeout=120)
    assert [c for c, _ in got] == [1, 1]


def test_linear_diagonal_is_the_element_matrices_diagonal() -> None:
    X, F = _mesh(4, 3)
    X = X @ np.linalg.qr(np.random.default_rng(4).normal(size=(3, 3)))[0]  # a plate tilted in space
    comp = CompiledTriangles(X, F, Material(E=1000.0, nu=0.3, t=1.5), threads=1)
    want = np.einsum("mii->mi", comp.linear_element_matrices())
    assert np.allclose(comp.linear_diagonal(), want, rtol=1e-13, atol=1e-12 * np.abs(want).max())


def test_the_kernels_are_cached_in_the_users_cache_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """numba's cache goes to $XDG_CACHE_HOME/fabpat/numba (created), a user's NUMBA_CACHE_DIR is kept, and a
    folder that cannot be made leaves numba its own choice (no variable set)."""
    import numba

    from fabpat.shell import kernel_cache

    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)  # restored after the test
    monkeypatch.setattr(kernel_cache, "REFUSED", None)
    monkeypatch.delenv("FABPAT_CACHE", raising=False)
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    assert kernel_cache.choose_cache_dir() == str(tmp_path / "cache" / "fabpat" / "numba")
    assert (tmp_path / "cache" / "fabpat" / "numba").is_dir() and numba.config.CACHE_DIR == str(
        tmp_path / "cache" / "fabpat" / "numba")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert kernel_cache.choose_cache_dir() == str(tmp_path / "mine")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    (tmp_path / "file").write_text("")  # a file where the folder should be: cannot be created (even as root)
    monkeypatch.setenv("FABPAT_CACHE", str(tmp_path / "file"))
    assert kernel_cache.choose_cache_dir() is None and "NUMBA_CACHE_DIR" not in os.environ
    assert kernel_cache.REFUSED == f"FABPAT_CACHE={tmp_path / 'file'} cannot be written, so numba keeps its own cache"
    monkeypatch.setenv("FABPAT_CACHE", "off")
    assert kernel_cache.choose_cache_dir() is None


def test_the_catalogs_compiled_kernels_are_kept_in_the_users_cache_folder_too(tmp_path: Path) -> None:
    """The prediction kernels (fabpat.catalog.response_kernels, response_plate) go where the shell's do,
    $XDG_CACHE_HOME/fabpat/numba, never beside the source, which an install may not let anyone write (they
    were kept in fabpat/catalog/__pycache__). Only imported: the folder is chosen when they are defined."""
    import subprocess
    import sys

    import fabpat

    code = ("import fabpat.catalog.response_kernels as k, fabpat.catalog.response_plate as p\n"
            "print(k.skyline_solve._cache._cache_path)\nprint(p._membrane_energy._cache._cache_path)")
    env = {k: v for k, v in os.environ.items() if k not in ("FABPAT_CACHE", "NUMBA_CACHE_DIR")}
    env.update(XDG_CACHE_HOME=str(tmp_path / "cache"), PYTHONPATH=str(Path(fabpat.__file__).parents[1]))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    folders = out.split()
    assert len(folders) == 2
    for folder in folders:
        assert Path(folder).is_relative_to(tmp_path / "cache" / "fabpat" / "numba"), folder


def test_a_first_compilation_is_announced_and_a_cached_load_is_not(monkeypatch: pytest.MonkeyPatch) -> None:
    from fabpat.shell import compiled, news

    loads: list[int] = []
    monkeypatch.setattr(compiled, "_READY", [])
    monkeypatch.setattr(compiled, "load_kernels", lambda: loads.append(1) or compiled._READY.append(True) or 0.0)
    heard: list[str] = []
    for cached in (False, True):
        monkeypatch.setattr(compiled, "_READY", [])
        monkeypatch.setattr(compiled, "kernels_cached", lambda c=cached: c)
        with news.listening(heard.append):
            compiled.ensure_kernels()
            compiled.ensure_kernels()  # once per process
    assert len(loads) == 2 and len(heard) == 1 and heard[0].startswith("compiling the solver's kernels")
    # a FABPAT_CACHE that could not be used is said with the compilation, not dropped silently
    from fabpat.shell import kernel_cache

    monkeypatch.setattr(kernel_cache, "CACHE_DIR", None)
    monkeypatch.setattr(kernel_cache, "REFUSED", "FABPAT_CACHE=/x cannot be written, so numba keeps its own cache")
    monkeypatch.setattr(compiled, "_READY", [])
    monkeypatch.setattr(compiled, "kernels_cached", lambda: False)
    with news.listening(heard.append):
        compiled.ensure_kernels()
    assert heard[-1].endswith("; FABPAT_CACHE=/x cannot be written, so numba keeps its own cache)")


def test_the_cache_check_reads_numbas_index_files() -> None:
    """kernels_cached reads numba's index file of every kernel (a numba without them would leave the
    first compilation unannounced), and once the kernels are loaded the files are there."""
    from fabpat.shell import compiled

    assert all(isinstance(f._cache._cache_file._index_path, str) for f in compiled._CACHED)
    compiled.load_kernels()
    assert compiled.kernels_cached()


@needs_unshare
def test_kernels_that_cannot_be_kept_on_a_full_disk_are_one_line(tmp_path: Path) -> None:
    """The kernels' cache folder on a full disk: one line naming it and the way out (was: three tracebacks, and
    the full disk blamed on standard output)."""
    cache = tmp_path / "cache"
    res = in_small_tmpfs(cache, f"unset NUMBA_CACHE_DIR; FABPAT_CACHE={cache}/fabpat $FAB simulate-assembly "
                                f"{SMALL_SPEC} --h 7.5 --no-progress", size="8k")
    one_line_error(tmpfs_error(res), "cannot keep the solver's compiled kernels", "FABPAT_CACHE=off")


def test_a_solve_of_read_only_triangles_needs_no_kernel_compiled_after_the_warm_up() -> None:
    """load_kernels compiles every signature a solve calls: a mesh's triangles arrive read-only (a frozen
    problem's) and, passed as they are, were another type to numba, compiled silently in the first solve
    after an install (seconds) rather than with the announced rest."""
    from fabpat.shell.compiled import load_kernels
    from fabpat.shell.congruent import CongruentTriangles
    from fabpat.shell.kernels import element_kernels, shared_element_kernels

    load_kernels()
    before = (len(element_kernels.signatures), len(shared_element_kernels.signatures))
    X = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [2.0, 2.0, 0.1]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    F.setflags(write=False)
    R = expmap(np.full((4, 3), 0.01))
    CompiledTriangles(X, F, Material(), threads=1).tangents_at(X + 0.01, R)
    CongruentTriangles(X, F, Material(), np.arange(2), threads=1).tangents_at(X + 0.01, R)
    assert (len(element_kernels.signatures), len(shared_element_kernels.signatures)) == before


def _openblas_threads() -> list[int]:
    from threadpoolctl import ThreadpoolController

    return [int(c["num_threads"]) for c in ThreadpoolController().select(internal_api="openblas").info()]


def test_a_path_runs_on_one_openblas_thread_and_gives_the_callers_back(monkeypatch: pytest.MonkeyPatch) -> None:
    # OpenBLAS's workers spin ~0.1 s after a threaded call, on the cores the kernels and PARDISO need next:
    # the shipped sphere took 1.7 s with them, 1.3 s without (benchmarks/bench_assembly.py --solve)
    from threadpoolctl import threadpool_limits

    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.assembly.spec.load import parse_spec
    from fabpat.shell import linalg
    from fabpat.shell.compiled import solver_threads

    seen: list[list[int]] = []
    real = linalg.superlu

    def spy(K):  # type: ignore[no-untyped-def]
        seen.append(_openblas_threads())
        return real(K)

    monkeypatch.setattr(linalg, "superlu", spy)
    monkeypatch.setenv("FABPAT_LINEAR_SOLVER", "superlu")  # every factorisation through the spy
    strip = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 2},
             "patterns": {"groups": ["0x0488", "0x0508"], "group_columns": 1}, "plates": {"thickness": 0.8}}
    with threadpool_limits(2, user_api="blas"):
        assert _openblas_threads() and set(_openblas_threads()) == {2}
        with solver_threads(2):
            assert set(_openblas_threads()) == {1}
        assert set(_openblas_threads()) == {2}
        simulate_assembly(parse_spec(strip, "s.toml"), h=6.0)
        assert seen and all(set(s) == {1} for s in seen)
        assert set(_openblas_threads()) == {2}


def test_overlapping_blas_limits_of_two_threads_give_the_callers_setting_back() -> None:
    # each threadpoolctl limiter gives back what it found on entry: two blocks that overlap without nesting
    # (a design's beam fit beside a solve) left the process on one thread for good
    import threading

    from threadpoolctl import threadpool_limits

    from fabpat.shell.compiled import one_blas_thread

    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    inside: list[list[int]] = []

    def first() -> None:
        with one_blas_thread():
            a_in.set()
            b_in.wait(10)
        a_out.set()

    def second() -> None:
        a_in.wait(10)
        with one_blas_thread():
            b_in.set()
            a_out.wait(10)
            inside.append(_openblas_threads())  # still limited after the first block ended

    with threadpool_limits(2, user_api="blas"):
        ts = [threading.Thread(target=first), threading.Thread(target=second)]
        for t in ts:
            t.start()
        for t in ts:
            t.join(20)
        assert a_out.is_set() and b_in.is_set()
        assert len(inside) == 1 and set(inside[0]) == {1}
        assert set(_openblas_threads()) == {2}


def test_a_callers_mkl_limit_does_not_set_pardisos_threads_in_a_path() -> None:
    # threadpoolctl limits MKL with a thread-local count, which wins over PARDISO's domain count: a caller's
    # limit of 3 gave a small strip's path 3 PARDISO threads on 2 cores (3.3 s rather than 0.4 s)
    import ctypes

    from threadpoolctl import threadpool_limits

    from fabpat.shell.compiled import solver_threads
    from fabpat.shell.linalg import mkl

    lib = mkl()
    if lib is None:
        pytest.skip("MKL is not installed on this platform: PARDISO is not used")
    with threadpool_limits(3):
        assert lib.MKL_Domain_Get_Max_Threads(ctypes.c_int(4)) == 3  # the caller's limit reaches PARDISO
        with solver_threads(2):
            assert lib.MKL_Domain_Get_Max_Threads(ctypes.c_int(4)) == 2
        assert lib.MKL_Get_Max_Threads() == 3  # the caller's own limit is given back


def _child_strip(_: int) -> tuple[int, float]:
    import ctypes

    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.assembly.spec.load import parse_spec
    from fabpat.shell.linalg import mkl

    lib = mkl()
    pardiso = 1 if lib is None else int(lib.MKL_Domain_Get_Max_Threads(ctypes.c_int(4)))

    strip = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 2},
             "patterns": {"groups": ["0x0488", "0x0508"], "group_columns": 1}, "plates": {"thickness": 0.8}}
    return pardiso, float(simulate_assembly(parse_spec(strip, "s.toml"), h=6.0).fields()["energy"])


def test_a_child_forked_while_another_thread_solves_is_not_locked_out() -> None:
    # the child inherited the path's and the kernels' locks held by the parent's solving thread, and waited; and
    # the path's PARDISO threads (2), although a worker runs on one
    import multiprocessing as mp
    import threading

    from fabpat.shell import compiled, linked

    compiled.load_kernels()
    held, release = threading.Event(), threading.Event()

    def solving() -> None:  # stands for a path under way in another thread
        with linked._PATH_LOCK, compiled.kernel_lock(), compiled.solver_threads(2):
            held.set()
            release.wait(120)

    t = threading.Thread(target=solving)
    t.start()
    try:
        assert held.wait(10)
        with mp.get_context("fork").Pool(1) as pool:
            pardiso, energy = pool.map_async(_child_strip, [0]).get(timeout=120)[0]
    finally:
        release.set()
        t.join(10)
    assert np.isfinite(energy) and energy > 0.0
    assert pardiso == 1


def test_a_blas_block_left_in_a_forked_child_changes_nothing() -> None:
    # os.fork() inside a block: the child's fresh state has no user, and the block's end must not make it −1
    from fabpat.shell.compiled import _OneBlasThread

    b = _OneBlasThread()
    b.leave()
    assert b.users == 0
    b.enter()
    b.enter()
    b.leave()
    assert b.users == 1 and set(_openblas_threads()) == {1}
    b.leave()
    assert b.users == 0
