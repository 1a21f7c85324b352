"""The machinery of reading a spec (:mod:`fabpat.assembly.spec.load`): its file, its tables, its problems.

Inside :func:`fabpat.assembly.spec.load.parse_spec` every problem of a spec is collected (:data:`COLLECTED`)
instead of raised, so one run reports them all, one line each (:class:`SpecProblems`); a
:class:`Table` notes a key's problem and goes on with a fallback value, and :meth:`Table.settle`
stops a table before a check that would read one. A spec file is read only if it is a regular file
of at most :data:`MAX_SPEC_BYTES` (:func:`read_spec_file`).
"""

from __future__ import annotations

import math
import os
import stat
import tomllib
from collections.abc import Callable, Mapping
from contextvars import ContextVar
from pathlib import Path
from typing import Any, TypeVar

from fabpat.errors import RangeError, SpecError
from fabpat.validate import RANGES, check

#: largest spec file read (bytes): the shipped specs are 1–3 kB; a larger file is not a spec (or is
#: /dev/zero), and reading it whole would only use memory
MAX_SPEC_BYTES = 1024 * 1024
_T = TypeVar("_T")


class SpecProblems(SpecError):
    """Every problem found in one spec, one line each (``problems``); ``str()`` is a first line counting
    them followed by the problems, or the one problem alone."""

    def __init__(self, problems: list[str] | tuple[str, ...], source: str = "<spec>") -> None:
        self.problems = tuple(problems)
        head = [] if len(self.problems) == 1 else [f"{source}: {len(self.problems)} problems in the spec:"]
        super().__init__("\n".join([*head, *self.problems]))


def problems_of(e: SpecError) -> tuple[str, ...]:
    """The one-line problems an error stands for: a :class:`SpecProblems`' lines, or its own message."""
    return e.problems if isinstance(e, SpecProblems) else (str(e),)


#: the problems of the spec ``parse_spec`` is reading (None outside it: a table then raises at once)
COLLECTED: ContextVar[list[str] | None] = ContextVar("fabpat_spec_problems", default=None)


class Settled(Exception):
    """A table stops being read: its problems are already collected (see :meth:`Table.settle`)."""


class Table:
    """One TOML table being read: remembers the keys used so unknown keys can be reported.

    Inside ``parse_spec`` a key's problem is noted and reading goes on with a fallback value, so one run
    reports every problem of the spec; :meth:`settle` stops the table before a check that would
    read a fallback. Outside it (no collector) the first problem is raised, one line."""

    def __init__(self, source: str, name: str, data: object, allowed: tuple[str, ...]) -> None:
        if not isinstance(data, Mapping):
            raise SpecError(f"{source}: [{name}] must be a table")
        self.source, self.name, self.data = source, name, dict(data)
        self.problems: list[str] = []
        self._collected = COLLECTED.get()
        for key in self.data:
            if key not in allowed:
                self.note(SpecError(f"{source}: unknown key {name}.{key_text(key)} (allowed: {', '.join(allowed)})"),
                          None)

    def fail(self, key: str, message: str) -> SpecError:
        """The error for ``key``: ``<source>: <table>.<key> <message>``."""
        return SpecError(f"{self.source}: {self.name}.{key} {message}")

    def note(self, e: SpecError, fallback: _T) -> _T:
        """Collect the problem ``e`` and go on with ``fallback`` (outside ``parse_spec``: raise it)."""
        if self._collected is None:
            raise e
        self.problems.extend(problems_of(e))
        self._collected.extend(problems_of(e))
        return fallback

    def settle(self) -> None:
        """Stop reading this table if it has problems (they are collected already)."""
        if self.problems:
            raise Settled

    def has(self, key: str) -> bool:
        """Whether the table sets ``key``."""
        return key in self.data

    def only_for(self, key: str, process: str | None, needed: str) -> None:
        """A key read only for one ``plates.process`` is an error elsewhere, like a key of another tiling
        (``process`` None: plates.process itself is wrong, so nothing is said)."""
        if key in self.data and process is not None and process != needed:
            self.note(self.fail(key, f"does not apply to plates.process = {process!r} (it goes with "
                                     f"plates.process = {needed!r})"), None)

    def number(self, key: str, default: float | None, range_name: str) -> float:
        """A finite number in ``fabpat.validate.RANGES[range_name]`` (the same check as the CLI's)."""
        if key not in self.data:
            if default is None:
                return self.note(SpecError(f"{self.source}: missing key {self.name}.{key} (a number in "
                                           f"{RANGES[range_name].describe()})"), math.nan)
            return default
        try:
            return check(range_name, self.data[key], f"{self.name}.{key}")
        except RangeError as e:
            return self.note(SpecError(f"{self.source}: {e}"), math.nan if default is None else default)

    def integer(self, key: str, default: int | None, minimum: int = 1, top: int | None = None) -> int:
        """An integer from ``minimum`` to ``top`` (default: the ``strip_cells`` range's top, fabpat.validate)."""
        top = int(RANGES["strip_cells"].high) if top is None else top
        if key not in self.data:
            if default is None:
                return self.note(SpecError(f"{self.source}: missing key {self.name}.{key} (an integer in "
                                           f"[{minimum}, {top}])"), minimum)
            return default
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, int) or not minimum <= v <= top:
            return self.note(self.fail(key, f"= {show(v)} must be an integer in [{minimum}, {top}]"),
                             minimum if default is None else default)
        return int(v)

    def choice(self, key: str, allowed: tuple[str, ...], default: str | None) -> str:
        """One of ``allowed`` (``default`` when absent; None: the key is required)."""
        if key not in self.data:
            if default is None:
                return self.note(SpecError(f"{self.source}: missing key {self.name}.{key} (one of: "
                                           f"{', '.join(allowed)})"), allowed[0])
            return default
        v = self.data[key]
        if v not in allowed:
            return self.note(self.fail(key, f"= {show(v)} is not allowed: choose one of {', '.join(allowed)}"),
                             allowed[0] if default is None else default)
        return str(v)

    def boolean(self, key: str, default: bool) -> bool:
        """``true`` or ``false`` (``default`` when absent)."""
        v = self.data.get(key, default)
        if not isinstance(v, bool):
            return self.note(self.fail(key, f"= {show(v)} must be true or false"), default)
        return v

    def pair(self, key: str, default: tuple[float, float], allowed: str,
             ok: Callable[[float, float], bool]) -> tuple[float, float]:
        """Two numbers ``[low, high]`` (``default`` when absent) for which ``ok(low, high)`` holds (a NaN fails
        every comparison); ``allowed`` says what is allowed, in the message."""
        if key not in self.data:
            return default
        v = self.data[key]
        numbers = isinstance(v, list) and len(v) == 2 and all(
            not isinstance(x, bool) and isinstance(x, int | float) for x in v)
        if not numbers or not ok(float(v[0]), float(v[1])):
            return self.note(self.fail(key, f"= {show(v)} must be {allowed}"), default)
        return float(v[0]), float(v[1])

    def labelled(self, key: str, what: str) -> dict[str, float]:
        """A table ``{label = number, …}`` of finite numbers (empty when absent); ``what`` names the labels."""
        v = self.data.get(key, {})
        if not isinstance(v, Mapping) or not all(
                not isinstance(x, bool) and isinstance(x, int | float) and math.isfinite(x) for x in v.values()):
            return self.note(self.fail(key, f"= {show(v)} must be a table {{{what} label = number, …}}"), {})
        return {str(k): float(x) for k, x in v.items()}

    def string(self, key: str) -> str | None:
        """A string, or None when absent."""
        v = self.data.get(key)
        if v is not None and not isinstance(v, str):
            return self.note(self.fail(key, f"= {show(v)} must be a string"), None)
        return v


def key_text(key: object) -> str:
    """A table key as a message shows it: itself when it is plain text, else its short repr."""
    return key if isinstance(key, str) and key.isprintable() and 0 < len(key) <= 60 else show(key)


def show(value: object, limit: int = 60) -> str:
    """``repr(value)`` for a message, cut to ``limit`` characters (a pasted table or a deep list stays one
    short line)."""
    try:
        text = repr(value)
    except RecursionError:
        text = f"<a {type(value).__name__} nested too deep>"
    return text if len(text) <= limit else text[: limit - 1] + "…"


def read_spec_file(path: str | os.PathLike[str]) -> tuple[Path, dict[str, Any]]:
    """(the path, its decoded TOML) of a spec file; :class:`SpecError` (one line) if ``path`` is not a path,
    not a regular file (a folder, FIFO or device is refused before it is read: a FIFO is opened without
    waiting for a writer), larger than :data:`MAX_SPEC_BYTES`, not UTF-8 (a byte-order mark is fine) or
    not TOML (nesting too deep included)."""
    if isinstance(path, bytes) or not isinstance(path, str | os.PathLike):
        raise SpecError(f"a spec must be the path of a TOML file (str or os.PathLike), got {type(path).__name__}")
    p = Path(path)
    try:
        with open(p, "rb", opener=_nonblocking) as f:  # a FIFO must not block: it is refused below
            info = os.fstat(f.fileno())
            if not stat.S_ISREG(info.st_mode):
                raise SpecError(f"{p}: not a regular file (a folder, FIFO or device cannot be a spec)")
            if info.st_size > MAX_SPEC_BYTES:
                raise SpecError(f"{p}: {info.st_size} bytes is larger than a spec can be (at most "
                                f"{MAX_SPEC_BYTES} bytes)")
            raw = f.read(MAX_SPEC_BYTES + 1)
    except OSError as e:
        raise SpecError(f"cannot read spec {p}: {e.strerror or e}") from e
    if len(raw) > MAX_SPEC_BYTES:  # it grew while being read
        raise SpecError(f"{p}: larger than a spec can be (at most {MAX_SPEC_BYTES} bytes)")
    try:
        text = raw.decode("utf-8-sig")  # Windows editors save UTF-8 with a byte-order mark
    except UnicodeDecodeError as e:
        raise SpecError(f"{p}: not a UTF-8 text file") from e
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SpecError(f"{p}: invalid TOML: {e}") from e
    except RecursionError as e:
        raise SpecError(f"{p}: invalid TOML: nested too deep to be a spec") from e
    return p, data


def _nonblocking(path: str, flags: int) -> int:
    """``open`` without blocking on a FIFO that has no writer (a regular file is unaffected)."""
    return os.open(path, flags | getattr(os, "O_NONBLOCK", 0))
