"""Progress of long work on stderr: a rich bar on a terminal, a plain line every few seconds elsewhere.

A command wraps its work in :class:`Progress` and tells it what it is doing
(:meth:`Progress.update`, e.g. from a solver's progress callback) and what it has finished
(:meth:`Progress.item`). On a terminal the bar (a spinner, the current step, a bar when the amount of
work is known, the elapsed time) is redrawn by rich and vanishes at the end. Anywhere else (a pipe, a
CI log, a notebook's captured stderr) a background thread prints one plain line at most every
``interval`` seconds, such as ``fabpat: simulate-assembly: 40 % of the end shortening, 35 s``: the
first once the work has run for ``interval`` seconds, then every ``interval`` seconds with the latest
state (also while a blocking call gives no news: the line then says how long it has run), and a last
one (``…: done, 95 s``) when work that printed anything ends. Work shorter than ``interval`` prints
nothing, so a quick command, or a refusal in its first seconds, keeps stderr to its result or its one
error line; finished items are printed only once the lines have started, for the same reason. Stdout
is never touched: it carries the commands' data.

``interval`` is :data:`DEFAULT_INTERVAL` seconds unless the environment variable
:data:`INTERVAL_VARIABLE` (``FABPAT_PROGRESS_INTERVAL``) gives another number of seconds ≥ 0 (0:
a line for every update); ``enabled=False`` (a command's ``--no-progress``) prints nothing at all.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
from types import TracebackType
from typing import IO, TYPE_CHECKING

from fabpat.errors import RangeError

if TYPE_CHECKING:  # pragma: no cover
    from rich.progress import Progress as Bar
    from rich.progress import TaskID

#: environment variable: seconds between two plain progress lines (a number ≥ 0)
INTERVAL_VARIABLE = "FABPAT_PROGRESS_INTERVAL"
#: seconds between two plain progress lines: often enough to show a run is alive in a CI log, rarely
#: enough that a 2-minute solve writes about two dozen lines
DEFAULT_INTERVAL = 5.0
#: longest interval accepted from the environment (s): a day; longer is surely a typo
MAX_INTERVAL = 86_400.0


def progress_interval() -> float:
    """Seconds between plain lines: :data:`INTERVAL_VARIABLE` if set, else :data:`DEFAULT_INTERVAL`.

    Raises :class:`~fabpat.errors.RangeError` (one line) for a value that is not a number in
    [0, :data:`MAX_INTERVAL`]."""
    raw = os.environ.get(INTERVAL_VARIABLE)
    if raw is None or not raw.strip():
        return DEFAULT_INTERVAL
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not 0.0 <= value <= MAX_INTERVAL:  # NaN fails too
        raise RangeError(f"{INTERVAL_VARIABLE} = {raw!r} must be a number of seconds in [0, {MAX_INTERVAL:g}]")
    return value


class Progress:
    """Context manager showing the progress of one command's work on stderr (see the module docstring).

    ``command`` names the work in every line (``fabpat: <command>: …``); ``total`` is the amount of work
    (in whatever unit :meth:`update`'s ``done`` counts; None when unknown: a spinner, no bar);
    ``enabled`` False prints nothing; ``stream`` (default ``sys.stderr`` when entered) and ``terminal``
    (default: whether rich sees a terminal there) are for tests; ``interval`` (s) defaults to
    :func:`progress_interval`. Raises RangeError for a bad interval.
    """

    def __init__(self, command: str, *, total: float | None = None, enabled: bool = True,
                 stream: IO[str] | None = None, terminal: bool | None = None,
                 interval: float | None = None) -> None:
        self.command = command
        self.total = total
        self.enabled = enabled
        self.interval = progress_interval() if interval is None and enabled else (interval or 0.0)
        self._stream = stream
        self._terminal = terminal
        self._text = "working"
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar: Bar | None = None
        self._task: TaskID | None = None  # set with _bar
        self._t0 = 0.0
        self._printed = 0
        self._last = -math.inf

    # -- the caller's side ---------------------------------------------------------------------------

    def update(self, text: str, done: float | None = None) -> None:
        """What the work is doing now (``text``, the plain line's and the bar's words, e.g. ``"40 % of
        the end shortening"``) and, given a ``total``, how much of it is done (the bar's fill, in the
        unit of ``total``)."""
        if not self.enabled:
            return
        with self._lock:
            self._text = text
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, description=text,  # completed None: left as it is
                             completed=done if done is not None and self.total else None)
        elif self.interval == 0:
            self._line()

    def item(self, text: str) -> None:
        """A finished piece of the work (e.g. one scenario): its own line, once lines have started."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.console.print(f"{self.command}: {text}", highlight=False, markup=False)
            return
        with self._lock:
            started = self._printed > 0 or self._elapsed() >= self.interval
        if started:
            self._write(f"fabpat: {self.command}: {text}, {self._elapsed():.0f} s")

    # -- the context manager -------------------------------------------------------------------------

    def __enter__(self) -> Progress:
        self._t0 = time.monotonic()
        if not self.enabled:
            return self
        if self._stream is None:
            self._stream = sys.stderr
        if self._terminal is None:
            from rich.console import Console

            self._terminal = Console(file=self._stream).is_terminal
        if self._terminal:
            self._start_bar()
        else:
            self._thread = threading.Thread(target=self._beat, name=f"fabpat progress: {self.command}", daemon=True)
            self._thread.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        if self._bar is not None:
            self._bar.stop()
        elif self.enabled and kind is None and self._printed:
            self._write(f"fabpat: {self.command}: done, {self._elapsed():.0f} s")

    # -- inside ----------------------------------------------------------------------------------------

    def _start_bar(self) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            ProgressColumn,
            SpinnerColumn,
            TaskProgressColumn,
            TextColumn,
            TimeElapsedColumn,
        )
        from rich.progress import Progress as Bar

        columns: list[ProgressColumn] = [SpinnerColumn(), TextColumn(f"{self.command}: {{task.description}}")]
        if self.total:
            columns += [BarColumn(), TaskProgressColumn()]
        self._bar = Bar(*columns, TimeElapsedColumn(), console=Console(file=self._stream, stderr=True),
                        transient=True)
        self._bar.start()
        self._task = self._bar.add_task(self._text, total=self.total or None)

    def _elapsed(self) -> float:
        return time.monotonic() - self._t0

    def _beat(self) -> None:
        """The plain lines' timer: one line every ``interval`` s from the first ``interval`` s on (every
        second with ``interval`` 0, whose updates are printed as they come)."""
        period = self.interval if self.interval > 0 else 1.0
        while not self._stop.wait(min(period, 1.0) / 4):
            now = self._elapsed()
            if now >= self.interval and now - self._last >= period:
                self._line()

    def _line(self) -> None:
        with self._lock:
            text = self._text
        self._write(f"fabpat: {self.command}: {text}, {self._elapsed():.0f} s")

    def _write(self, line: str) -> None:
        with self._lock:
            self._printed += 1
            self._last = self._elapsed()
            stream = self._stream or sys.stderr
            try:
                stream.write(line + "\n")
                stream.flush()
            except (OSError, ValueError):  # a closed or broken stderr: progress is a convenience
                pass
