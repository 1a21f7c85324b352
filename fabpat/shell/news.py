"""What the solver is doing, in words, for whoever listens: a command's progress line.

A path (:func:`fabpat.shell.linked.solve_path`) tells every increment (``increment 23, λ = 0.62,
57 factorizations``) and the kernels' first compilation (:func:`fabpat.shell.compiled.ensure_kernels`);
a command that shows progress listens with :func:`listening` around its work. Nobody listening costs
nothing. The listeners are per process: a worker process's solver tells its own (the design loop
forwards them to its parent, :mod:`fabpat.design.search`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

_LISTENERS: list[Callable[[str], None]] = []


@contextmanager
def listening(listener: Callable[[str], None]) -> Iterator[None]:
    """Call ``listener(text)`` with the solver's news inside the block (several listeners may listen)."""
    _LISTENERS.append(listener)
    try:
        yield
    finally:
        _LISTENERS.remove(listener)


def tell(text: str) -> None:
    """Tell every listener ``text`` (one short phrase, no command name: the listener adds its own)."""
    for listener in list(_LISTENERS):
        listener(text)


def listened() -> bool:
    """Whether anybody listens (a caller may then skip composing its news)."""
    return bool(_LISTENERS)
