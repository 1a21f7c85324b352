"""The design search: full assembly solves of candidate strips, in parallel, refined from the reduced model.

Each candidate is one pattern per column. A solve (:func:`solve_candidate`) is the ``simulate-assembly``
strip path (:func:`fabpat.assembly.solve.strip.strip_setup` and :func:`~fabpat.assembly.solve.strip.run_strip`
with the spec's material, the default steps and imperfection), with the pins moved by the travel that
makes the target's span. Batches of independent candidates run on the sweep's engine (local worker
processes, or a dask.distributed scheduler).

Refinement (docs/design.md), from the best design so far, one batch per round:

1. **Curvature update** (one candidate): κ = M / EI column by column, so with the bending moments of
   the last solve each column's stiffness is scaled by its realised over its target turning
   (:func:`fabpat.design.strip.curvature_update`) and re-assigned with a free overall scale
   (:func:`fabpat.design.strip.assign`).
2. **Pattern search** (the rest of the batch): the worst-fitting columns each move by a step δ in
   log-stiffness (towards the corrected need), to the nearest candidate; δ halves after a round
   without improvement.

It stops when the budget is spent, or when δ is below the candidates' spacing and the update proposes
nothing new.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.choose.members import with_candidates
from fabpat.design.strip import assign, column_errors, column_turning, curvature_update, errors

__all__ = ["Evaluated", "Runner", "Search", "solve_candidate", "with_candidates"]

Arr = NDArray[np.float64]

#: first pattern-search step in log-stiffness (a factor e^0.25 ≈ 1.28 in stiffness)
FIRST_STEP = 0.25


def solve_candidate(spec: Any, patterns: tuple[str, ...], h: float, travel: float,
                    start: tuple[Any, ...] | None = None) -> dict[str, Any]:
    """One full strip solve: the face patterns ``patterns`` (candidate names: a family member is
    ``"ID bW"``, :func:`fabpat.assembly.choose.members.with_candidates`), mesh edge ``h`` mm, pins moved together by
    ``travel`` mm, warm-started from ``start`` (the ``state`` of an earlier solve of the same strip) if
    given. Returns plain data (it crosses process boundaries): ``x``, ``z`` the mid-line (mm,
    :func:`fabpat.design.strip.midline`), ``end_shortening`` (travel over the strip length, as
    ``simulate-assembly`` reads it), ``length`` (mm), ``seconds``, ``peak_strain`` (the largest principal
    surface strain), ``state`` (reference nodes, offsets, displacement, rotation), ``factorizations``,
    ``warm``. Raises SolverError, GeometryError."""
    from fabpat.assembly.solve.simulation import DEFAULT_STEPS
    from fabpat.assembly.solve.strip import IMPERFECTION, run_strip, strip_setup
    from fabpat.design.strip import midline

    t0 = time.perf_counter()
    mat = spec.material
    from fabpat.assembly.solve.model import warm_guess

    spec, ids = with_candidates(spec, patterns)
    setup = strip_setup(spec, ids, h=h, E=mat.youngs_modulus, nu=mat.poisson)
    es = travel / setup.length
    m = setup.model
    guess = None if start is None else warm_guess(*start, m.X, m.offsets)
    run = run_strip(setup, es, steps=DEFAULT_STEPS["honeycomb-strip"], imperfection=IMPERFECTION, start=guess)
    fin = run.result.final
    x, z = midline(setup, fin.displacement)
    return {"x": x, "z": z, "end_shortening": es, "length": setup.length, "seconds": time.perf_counter() - t0,
            "peak_strain": float(run.peak_strain),
            "state": (m.X, np.asarray(m.offsets), fin.displacement, fin.rotation),
            "factorizations": run.result.factorizations, "warm": run.result.warm}


@dataclass(frozen=True, eq=False)
class Evaluated:
    """A solved candidate: ``key`` the candidate index per column, errors in mm, the solve's data."""

    key: tuple[int, ...]
    rms: float
    max: float
    col_err: Arr
    turning: Arr  # realised downward turning per column, rad
    data: dict[str, Any]


@dataclass
class Runner:
    """Runs batches of candidate solves ``solve(spec, patterns, h, *extra)`` (default the strip's
    :func:`solve_candidate` with ``extra`` = (travel,)): ``workers`` local processes, or ``dask`` (a scheduler
    address); counts every solve and tells ``progress(solves done, elapsed s)`` after each. ``status(text)``
    hears what the solves are doing (each increment's λ and factorizations, :mod:`fabpat.shell.news`; from
    local worker processes through a pipe; a dask worker's solves say nothing) and which solves were
    abandoned. ``deadline`` (a ``time.perf_counter()`` time): no batch starts after it
    (:class:`fabpat.design.stop.OutOfTime`). ``failures``: every failed solve, its face patterns and reason."""

    spec: Any
    h: float
    extra: tuple[Any, ...]
    workers: int = 1
    dask: str | None = None
    progress: Callable[[int, float], None] | None = None
    solve: Callable[..., dict[str, Any]] = solve_candidate
    solves: int = 0
    t0: float = field(default_factory=time.perf_counter)
    status: Callable[[str], None] | None = None
    deadline: float | None = None
    failures: list[dict[str, Any]] = field(default_factory=list)

    def run(self, batch: list[tuple[str, ...]], extra: tuple[Any, ...] | None = None,
            on_result: Callable[[int, dict[str, Any] | BaseException], None] | None = None
            ) -> list[dict[str, Any] | BaseException]:
        """Solve every face-pattern tuple of ``batch`` (``extra`` replaces the runner's own extra arguments
        for this batch); a failed solve comes back as its exception. ``on_result(i, result)`` hears each
        solve as it finishes, so a run stopped in the middle of a batch keeps the solves it finished."""
        from fabpat.catalog.sweep import _dask_client, _run_dask, _run_local
        from fabpat.design.stop import OutOfTime

        if self.deadline is not None and time.perf_counter() >= self.deadline:
            raise OutOfTime
        more = self.extra if extra is None else extra
        jobs = [((self.spec, pats, self.h, *more), str(i)) for i, pats in enumerate(batch)]
        out: list[Any] = [None] * len(batch)
        first = self.solves + 1
        with solve_news(self.status, lambda: f"solve {first}" if len(batch) == 1 else
                        f"solves {first}–{first + len(batch) - 1}", self.workers > 1 and not self.dask):
            if self.workers > 1 and len(batch) > 1 and not self.dask:
                from fabpat.shell.compiled import ensure_kernels

                ensure_kernels()  # before the workers fork: they inherit the kernels rather than each compile them
            if self.dask:
                stream = _run_dask(self.solve, jobs, _dask_client(self.dask, 10.0))
            else:
                stream = _run_local(self.solve, jobs, min(self.workers, len(jobs)))
            for key, res in stream:
                i = int(key)
                out[i] = res
                self.solves += 1
                if isinstance(res, BaseException):
                    self._failed(batch[i], res)
                if on_result is not None:
                    on_result(i, res)
                if self.progress is not None:
                    self.progress(self.solves, time.perf_counter() - self.t0)
        return out

    def _failed(self, faces: tuple[str, ...], error: BaseException) -> None:
        from fabpat.errors import FabpatError

        reason = str(error) if isinstance(error, FabpatError) else f"{type(error).__name__}: {error}"
        self.failures.append({"patterns": sorted(set(faces)), "reason": reason})
        if self.status is not None:
            self.status(f"a solve was abandoned: {reason}")


@contextmanager
def solve_news(status: Callable[[str], None] | None, which: Callable[[], str], workers: bool) -> Iterator[None]:
    """Inside the block, the solver's news (:mod:`fabpat.shell.news`) goes to ``status`` as
    ``"<which()>: <news>"``; with ``workers`` (local worker processes, forked inside the block) their
    news comes through a pipe: each writes one short line at a time (atomic below PIPE_BUF) without ever
    waiting (a full pipe drops the line), and a thread here reads them."""
    from fabpat.shell import news

    if status is None:
        yield
        return
    if not workers:
        with news.listening(lambda text: status(f"{which()}: {text}")):
            yield
        return
    r, w = os.pipe()
    os.set_blocking(w, False)
    home = os.getpid()

    def forward(text: str) -> None:
        if os.getpid() == home:  # the parent's own news (the kernels' compilation before the pool forks)
            status(f"{which()}: {text}")
            return
        with contextlib.suppress(OSError):  # a full pipe (BlockingIOError) or a parent gone
            os.write(w, (f"{os.getpid()}\t{text}"[:500] + "\n").encode())

    stop = threading.Event()
    reader = threading.Thread(target=_read_news, args=(r, stop, status, which), daemon=True,
                              name="fabpat design: solver news")
    reader.start()
    try:
        with news.listening(forward):
            yield
    finally:
        stop.set()
        reader.join(timeout=1.0)
        os.close(w)
        if not reader.is_alive():
            os.close(r)


def _read_news(r: int, stop: threading.Event, status: Callable[[str], None], which: Callable[[], str]) -> None:
    """The pipe's reading end (:func:`solve_news`): the latest line of each read, as status."""
    buf = b""
    while not stop.is_set():
        ready, _, _ = select.select([r], [], [], 0.2)
        if not ready:
            continue
        try:
            chunk = os.read(r, 4096)
        except OSError:
            return
        if not chunk:
            return
        *lines, buf = (buf + chunk).split(b"\n")
        if lines:
            pid, _, text = lines[-1].decode("utf-8", "replace").partition("\t")
            status(f"{which()}: worker {pid}: {text}")


@dataclass
class Search:
    """State of one design search over ``ids`` (candidate IDs sorted stiff-last: ascending 1/U) with
    ``log_s`` their log-stiffnesses log(1/U); ``columns`` of the strip, face → column ``face_col``."""

    target_x: Arr
    target_z: Arr
    ids: list[str]
    log_s: Arr
    columns: int
    face_col: list[int]
    max_distinct: int | None
    runner: Runner
    seen: dict[tuple[int, ...], Evaluated | None] = field(default_factory=dict)
    best: Evaluated | None = None

    def faces(self, key: tuple[int, ...]) -> tuple[str, ...]:
        """Face patterns of a candidate (every tile of a column the same)."""
        return tuple(self.ids[key[c]] for c in self.face_col)

    def evaluate(self, keys: list[tuple[int, ...]]) -> list[Evaluated | None]:
        """Solve the candidates not seen yet (one batch, warm-started from the best strip so far: measured on
        the 1 × 3 test strip, 11 factorizations instead of 147); None for a failed solve."""
        new = list(dict.fromkeys(k for k in keys if k not in self.seen))
        warm = None if self.best is None else (self.runner.extra + (self.best.data["state"],))
        self.runner.run([self.faces(k) for k in new], warm, lambda i, res: self._record(new[i], res))
        return [self.seen[k] for k in keys]

    def _record(self, k: tuple[int, ...], res: dict[str, Any] | BaseException) -> None:
        """One finished solve of candidate ``k`` (None for a failed one); updates ``best``."""
        if isinstance(res, BaseException):
            self.seen[k] = None
            return
        rms, mx, e = errors(res["x"], res["z"], self.target_x, self.target_z)
        ev = Evaluated(k, rms, mx, column_errors(self.target_x, e, self.columns),
                       column_turning(res["x"], res["z"], self.columns), res)
        self.seen[k] = ev
        if self.best is None or ev.rms < self.best.rms:
            self.best = ev

    def corrected(self, ev: Evaluated, target_turning: Arr) -> tuple[tuple[int, ...], Arr]:
        """The curvature update of ``ev`` (step 1 of the module doc): the candidate assigned to the
        corrected log-stiffnesses, and those (on the candidates' log scale)."""
        need = self.log_s[list(ev.key)] + curvature_update(ev.turning, target_turning)
        idx, b = assign(need, self.log_s, self.max_distinct)
        return tuple(int(i) for i in idx), need + b

    def move(self, key: tuple[int, ...], c: int, value: float) -> tuple[int, ...] | None:
        """``key`` with column c moved to the candidate nearest log-stiffness ``value``, staying within
        max_distinct (else to the nearest pattern already used); None if nothing changes."""
        ls = self.log_s
        j = int(np.argmin(np.abs(ls - value)))
        if j == key[c]:  # a step smaller than the spacing there: the next candidate that way
            j = int(np.clip(j + (1 if value > ls[j] else -1), 0, len(ls) - 1))
        used = set(key)
        others = set(key[:c] + key[c + 1:])
        if self.max_distinct is not None and j not in others and len(others) >= self.max_distinct:
            pool = sorted(others, key=lambda i: abs(ls[i] - value))
            j = pool[0]
        if j == key[c] or (j not in used and self.max_distinct is not None
                           and len(others | {j}) > self.max_distinct):
            return None
        return key[:c] + (j,) + key[c + 1:]

    def refine(self, target_turning: Arr, budget: int, batch: int) -> None:
        """Rounds of update + pattern search (module doc) until ``budget`` solves are spent or nothing new
        is proposed with the step below the candidates' spacing."""
        step = FIRST_STEP
        spacing = float(np.min(np.diff(self.log_s))) if len(self.log_s) > 1 else math.inf
        while self.runner.solves < budget and self.best is not None:
            best = self.best
            room = min(batch, budget - self.runner.solves)
            update, need = self.corrected(best, target_turning)
            props = [] if update in self.seen else [update]
            for c in np.argsort(-best.col_err, kind="stable"):
                if len(props) >= room:
                    break
                cur = float(self.log_s[best.key[c]])
                d = need[c] - cur
                for sign in ([np.sign(d)] if abs(d) > 1e-12 else [1.0, -1.0]):
                    k = self.move(best.key, int(c), cur + sign * step)
                    if k is not None and k not in self.seen and k not in props and len(props) < room:
                        props.append(k)
            if not props:
                if step <= spacing:
                    return
                step /= 2
                continue
            self.evaluate(props)
            if self.best is best:
                if step <= spacing and update in self.seen:
                    return
                step = max(step / 2, spacing)
