"""Standard output as an output: what a command prints (``fabpat catalog --format csv > rows.csv``) must
arrive whole, or the command fails with one line naming it, as a file output does (:mod:`fabpat.io`).

A write to a full disk or device (``/dev/full``) raises ENOSPC without a file name, and a regular file at
the process's size limit (``ulimit -f``) takes a short write whose rest Python's text layer drops
silently; :func:`check_stdout`, called by the CLI after every command, and :func:`stdout_error`, for the
``OSError`` of a write, turn both into a :class:`~fabpat.errors.WriteFailed` naming standard output and
what is behind it.
"""

from __future__ import annotations

import errno
import io
import os
import stat
import sys

from fabpat.errors import WriteFailed
from fabpat.io import NO_ROOM, file_size_limit, too_large_text


def stdout_name() -> str:
    """What standard output is, for a message: the file or device behind it (``/proc/self/fd/1``) or
    ``standard output``."""
    try:
        return f"standard output ({os.readlink('/proc/self/fd/1')})"
    except OSError:
        return "standard output"


def stdout_error(e: OSError) -> WriteFailed | None:
    """The :class:`WriteFailed` naming standard output for ``e``, an ``OSError`` without a file name
    that says the output has no room (a full disk or ``/dev/full``: ENOSPC; the file size limit: EFBIG),
    which only a write to a stream raises once fabpat's own files name themselves; else None."""
    if e.filename is not None or e.errno not in NO_ROOM:
        return None
    why = too_large_text(e.strerror) if e.errno == errno.EFBIG else e.strerror or os.strerror(e.errno or 0)
    return WriteFailed(e.errno, why, stdout_name())


def check_stdout() -> None:
    """Flush standard output and raise :class:`WriteFailed` (naming it) if what was printed did not all
    arrive: the flush fails (``/dev/full``), or the regular file behind it reached the file size limit.
    Python's text layer drops the rest of a short write silently (``fabpat catalog --format csv >
    out.csv`` under ``ulimit -f`` exited 0 with a cut file), so the size is checked too."""
    stream = sys.stdout
    if stream is None:
        return
    try:
        stream.flush()
    except OSError as e:
        raise stdout_error(e) or e from None
    try:
        st = os.fstat(stream.fileno())
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return  # not a file descriptor (a test's captured output)
    limit = file_size_limit()
    if stat.S_ISREG(st.st_mode) and limit is not None and st.st_size >= limit:
        raise WriteFailed(errno.EFBIG, too_large_text(None), stdout_name())
