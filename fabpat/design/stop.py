"""How a design run stops early and keeps what it finished: Ctrl-C, SIGTERM or its time budget.

A design is a series of full solves, each minutes long at h = 3 mm; the best design so far is worth
keeping when the run is stopped. :func:`until_stopped` runs the search and reports why it stopped
instead of losing it: the caller then writes the best design so far, with ``"interrupted": true`` in
design.json. A Ctrl-C reaches the search as KeyboardInterrupt, and so does SIGTERM under the CLI
(:func:`fabpat.interrupts.on_sigterm`); the time budget (``--max-minutes``) rings as :class:`OutOfTime`,
raised in the main thread by a SIGALRM timer, so a solve in progress (in this process or in a worker,
which the runner then stops) is cut off rather than awaited. Outside the main thread, where no signal
can be handled, the budget is checked before each batch of solves (:class:`fabpat.design.search.Runner`).
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, NoReturn

#: why a run stopped, as design.json's ``stopped_by`` names it
SIGINT, SIGTERM, BUDGET = "SIGINT", "SIGTERM", "max_minutes"


class OutOfTime(BaseException):  # noqa: N818 - not an error: the budget the caller set is spent
    """The time budget is spent (``max_minutes``). A BaseException, like KeyboardInterrupt, so that no
    ``except Exception`` on the way (a failed solve is reported per candidate) swallows it."""


@contextmanager
def time_budget(deadline: float | None) -> Iterator[None]:
    """Raise :class:`OutOfTime` in this (main) thread at ``time.perf_counter()`` = ``deadline``; nothing
    without a deadline, outside the main thread or without ``signal.setitimer`` (see the module doc)."""
    if deadline is None or threading.current_thread() is not threading.main_thread() \
            or not hasattr(signal, "setitimer"):
        yield
        return

    def ring(signum: int, frame: object) -> None:
        raise OutOfTime

    before = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, max(deadline - time.perf_counter(), 1e-3))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, before)


def until_stopped(work: Callable[[], None], deadline: float | None) -> str | None:
    """Run ``work()``; None when it finished, else why it stopped: :data:`SIGINT` (Ctrl-C),
    :data:`SIGTERM` or :data:`BUDGET` (``deadline``, a ``time.perf_counter()`` time, passed)."""
    from fabpat.interrupts import interrupt_status

    try:
        with time_budget(deadline):
            work()
    except OutOfTime:
        return BUDGET
    except KeyboardInterrupt:
        return SIGTERM if interrupt_status()[0] == "terminated" else SIGINT
    return None


def stop_phrase(stopped: str, solves: int, max_minutes: float | None) -> str:
    """The warning's words for a run that stopped early (``stopped`` from :func:`until_stopped`)."""
    why = {SIGINT: "stopped by Ctrl-C (SIGINT)", SIGTERM: "stopped by SIGTERM",
           BUDGET: f"stopped when its time budget of {max_minutes or 0:g} minutes ran out"}[stopped]
    return f"{why} after {solves} solves: the best design so far is written (design.json: \"interrupted\": true)"


def nothing_solved(stopped: str | None, solves: int, failures: list[dict[str, Any]], h: float) -> NoReturn:
    """No design to keep: a signal's interrupt goes on (KeyboardInterrupt: nothing is written); a spent
    budget, or a search whose every solve failed, is a SolverError naming the solves' fate, unless every solve
    failed for a mesh edge too coarse for the spec's interfaces: a GeometryError saying the h to use."""
    from fabpat.errors import SolverError

    if stopped is not None and stopped != BUDGET:
        raise KeyboardInterrupt
    why = f"; the last was abandoned: {failures[-1]['reason']}" if failures else ""
    if failures and all(str(f.get("reason", "")).startswith("mesh too coarse") for f in failures):
        from fabpat.errors import GeometryError

        # the mesh edge, not the search, is what failed: said as simulate-assembly says it
        raise GeometryError(f"no design can be solved at h = {h:g} mm: {failures[-1]['reason']}")
    if stopped == BUDGET:
        raise SolverError(f"the time budget ran out before any design was solved ({solves} solves finished{why})")
    raise SolverError(f"no candidate design converged in {solves} solves (h = {h:g} mm){why}")
