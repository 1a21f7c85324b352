"""Where numba keeps the compiled kernels of :mod:`fabpat.shell.kernels`: a folder of the user's cache.

numba's default is a ``__pycache__`` beside the source, which an installed package may not be allowed to
write (a system site-packages, a read-only container image): every process would then compile the
kernels again (about 10 s on the 2-core machine). So, unless ``NUMBA_CACHE_DIR`` is set already, the
kernels go to ``$FABPAT_CACHE/numba`` (``$XDG_CACHE_HOME/fabpat/numba``, by default
``~/.cache/fabpat/numba``), created on demand. A folder that cannot be created or written, or
``FABPAT_CACHE=off``, leaves numba's own choice (beside the source, else numba's user-wide cache).

numba reads the folder when a cached function is defined, so :func:`choose_cache_dir` runs before
:mod:`fabpat.shell.kernels` is imported (this module imports nothing but the standard library).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

#: environment variable numba reads for its cache folder (a user's setting is kept)
NUMBA_VARIABLE = "NUMBA_CACHE_DIR"


def default_cache_dir() -> Path | None:
    """The kernels' folder in the user's cache (module doc), or None with ``FABPAT_CACHE=off`` or no home."""
    root = os.environ.get("FABPAT_CACHE")
    if root == "off":
        return None
    try:
        base = Path(root) if root else Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "fabpat"
    except RuntimeError:  # no home folder
        return None
    return base / "numba"


def _writable(folder: Path) -> bool:
    """Whether ``folder`` exists (created if need be) and a file can be made in it."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".fabpat-probe-"):
            pass
    except OSError:
        return False
    return True


#: why the folder ``FABPAT_CACHE`` names is not used (it cannot be made or written), or None: said with the
#: first compilation (:func:`fabpat.shell.compiled.ensure_kernels`), so a setting is not dropped silently
REFUSED: str | None = None


def choose_cache_dir() -> str | None:
    """Set numba's cache folder (module doc) unless the user has; returns the folder in use, or None
    when numba keeps its own choice (:data:`REFUSED` then says why, when ``FABPAT_CACHE`` named a folder).
    Safe to call again (the first choice stays)."""
    global REFUSED
    chosen = os.environ.get(NUMBA_VARIABLE)
    if not chosen:
        folder = default_cache_dir()
        if folder is None or not _writable(folder):
            if folder is not None and os.environ.get("FABPAT_CACHE"):
                REFUSED = f"FABPAT_CACHE={os.environ['FABPAT_CACHE']} cannot be written, so numba keeps its own cache"
            return None
        chosen = os.environ[NUMBA_VARIABLE] = str(folder)
    numba = sys.modules.get("numba")
    if numba is not None:  # imported already (by another package): its config was read at import
        numba.config.CACHE_DIR = chosen
    return chosen


def remove_empty_folders() -> None:
    """Remove the folders under the chosen cache folder (and it) that hold nothing: what a kernel save that
    failed (a full disk) leaves behind."""
    chosen = os.environ.get(NUMBA_VARIABLE)
    if not chosen or chosen != CACHE_DIR:  # only a folder fabpat chose, never the user's own
        return
    for folder, _, _ in sorted(os.walk(chosen), key=lambda w: -len(w[0])):
        try:
            os.rmdir(folder)  # fails, as wanted, on a folder that still holds anything
        except OSError:
            pass


CACHE_DIR = choose_cache_dir()
