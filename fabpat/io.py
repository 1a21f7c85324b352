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
    if not folder.exists():
        raise ExportError(f"cannot write {p}: folder {folder} does not exist")
    if not folder.is_dir():
        raise ExportError(f"cannot write {p}: {folder} is not a folder")
    if not os.access(folder, os.W_OK):
        raise ExportError(f"cannot write {p}: folder {folder} is not writable")
    if p.is_dir():
        raise ExportError(f"cannot write {p}: it is a directory")
    return p


def check_output_folder(path: str | os.PathLike[str], option: str = "--out") -> Path:
    """An output folder that may exist already (as a folder) and whose parent must exist.

    Like a file output, a folder is not created with missing parents: a typo in a path should not
    build a tree of folders somewhere. :class:`ExportError` otherwise.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ExportError(f"{option} {p} exists and is not a folder")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ExportError(f"cannot write {p}: folder {parent} does not exist")
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
            try:
                fd, name = tempfile.mkstemp(prefix=f".{t.stem}.", suffix=f".part{t.suffix}", dir=t.parent or ".")
            except OSError as e:  # a folder that exists but takes no files (/proc, a read-only mount, …)
                raise ExportError(f"cannot write {t}: {e.strerror or e}") from e
            os.close(fd)
            temps.append(Path(name))
        yield temps
        mode = 0o666 & ~_umask()  # mkstemp makes 0600 files; give them the user's usual permissions
        for tmp, t in zip(temps, targets, strict=True):
            try:
                os.chmod(tmp, mode)
                os.replace(tmp, t)
            except OSError as e:
                raise ExportError(f"cannot write {t}: {e.strerror or e}") from e
    finally:
        for tmp in temps:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
