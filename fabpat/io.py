"""Atomic file output: a file appears under its name only when it is complete.

Every writer in fabpat goes through :func:`atomic_outputs`, so an error (bad input found late, a
crash, Ctrl-C) never leaves a partial or half-written file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from fabpat.errors import ExportError


def check_writable(path: str | os.PathLike[str]) -> Path:
    """The path, if its folder exists and is writable; :class:`ExportError` otherwise."""
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise ExportError(f"cannot write {p}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise ExportError(f"cannot write {p}: folder {folder} is not writable")
    if p.is_dir():
        raise ExportError(f"cannot write {p}: it is a directory")
    return p


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_outputs(*paths: str | os.PathLike[str]) -> Iterator[list[Path]]:
    """Yield temporary paths next to each target; rename them all only if the block succeeds.

    >>> with atomic_outputs("a.svg", "b.png") as (tmp_svg, tmp_png):
    ...     tmp_svg.write_text(...)   # doctest: +SKIP
    """
    targets = [check_writable(p) for p in paths]
    temps: list[Path] = []
    try:
        for t in targets:
            # keep the real suffix last: writers that pick the format from the suffix still work
            fd, name = tempfile.mkstemp(prefix=f".{t.stem}.", suffix=f".part{t.suffix}", dir=t.parent or ".")
            os.close(fd)
            temps.append(Path(name))
        yield temps
        mode = 0o666 & ~_umask()  # mkstemp makes 0600 files; give them the user's usual permissions
        for tmp, t in zip(temps, targets, strict=True):
            os.chmod(tmp, mode)
            os.replace(tmp, t)
    finally:
        for tmp in temps:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
