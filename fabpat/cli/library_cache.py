"""The cache of ``fabpat library``'s filleted columns: a convenience, never trusted, never fatal.

Filleting the 430 patterns and measuring their min_width takes seconds, so the columns are kept in a
JSON file per exact list of patterns and pipeline code (:func:`cache_path`). Whatever is read back
is checked as strictly as user input (:func:`read_cache`): the exact schema (a list of one object
per requested pattern, in order, with its ``id`` and the five columns), finite positive numbers, a
bounded size, a regular file (a FIFO or a link to ``/dev/zero`` is never opened for reading). On
any mismatch the cache is ignored and the columns recomputed. A cache that cannot be written
(read-only home, a full disk, the path is a device) costs one warning per process, not the command.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path

from fabpat.errors import FabpatError

Job = tuple[str, int, int, float, float]  # (id, sides, depth, edge, weight)

#: the filleted columns, as :meth:`fabpat.geometry.fillet.FilletedPattern.catalog_columns` names them
COLUMNS = ("filleted_area", "filleted_perimeter", "filleted_ratio", "filleted_polar_moment", "min_width")
#: bumped when the file's layout changes, so an old file is another key and never read
LAYOUT = 2
#: bytes per pattern a cache may hold: a row is about 170 bytes of JSON
MAX_ROW_BYTES = 1024

_warned: list[str] = []  # the write warning is given once per process


def cache_path(jobs: Sequence[Job]) -> Path | None:
    """Where the filleted columns of this exact list are cached, or None when caching is off.

    Keyed by the list, the file layout and :func:`fabpat.catalog.solver_version` (the version plus a
    digest of the pipeline's source), so an edited fillet or min-width code never reads an old cache.
    ``$FABPAT_CACHE`` (or ``$XDG_CACHE_HOME/fabpat``, default ``~/.cache/fabpat``); ``FABPAT_CACHE=off``
    disables it, and so does a home folder that cannot be found.
    """
    from fabpat.catalog import solver_version

    root = os.environ.get("FABPAT_CACHE")
    if root == "off":
        return None
    try:
        base = Path(root) if root else Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "fabpat"
    except RuntimeError:  # no home folder to put it in: no cache
        return None
    key = hashlib.sha1(repr((solver_version(), LAYOUT, list(jobs))).encode()).hexdigest()[:20]
    return base / f"library-{key}.json"


def _number(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0


def _valid_row(row: object, pid: str) -> bool:
    if not isinstance(row, dict) or set(row) != {"id", *COLUMNS} or row["id"] != pid:
        return False
    # ratio = 4πA/P² is at most 1 (a disc); every other column is a positive length, area or moment
    return all(_number(row[c]) for c in COLUMNS) and row["filleted_ratio"] <= 1


def read_cache(path: Path | None, jobs: Sequence[Job]) -> list[dict[str, float]] | None:
    """The cached columns of ``jobs`` (one dict of :data:`COLUMNS` per job, in order), or None when
    there is no cache or it is not exactly what :func:`write_cache` writes for these jobs."""
    from fabpat.io import read_input

    if path is None:
        return None
    try:
        data = json.loads(read_input(path, "the library cache", MAX_ROW_BYTES * len(jobs) + 4096))
    except (FabpatError, OSError, ValueError, RecursionError):  # missing, not a file, too large, not JSON
        return None
    if not isinstance(data, list) or len(data) != len(jobs):
        return None
    if not all(_valid_row(row, job[0]) for row, job in zip(data, jobs, strict=True)):
        return None
    return [{c: float(row[c]) for c in COLUMNS} for row in data]


def write_cache(path: Path | None, jobs: Sequence[Job], rows: Sequence[dict[str, float]],
                warn: Callable[[str], None]) -> None:
    """Store ``rows`` (the columns of ``jobs``) at ``path`` atomically; on failure remove the folders it
    made for ``path`` (if still empty), call ``warn`` once per process with one line naming the path and
    the reason, and go on."""
    from fabpat.io import atomic_outputs

    if path is None:
        return
    data = [{"id": job[0], **{c: row[c] for c in COLUMNS}} for job, row in zip(jobs, rows, strict=True)]
    missing = [d for d in (path.parent, *path.parent.parents) if not d.exists()]  # deepest first
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_outputs(path) as (tmp,):
            tmp.write_text(json.dumps(data, allow_nan=False), encoding="utf-8")
    except (FabpatError, OSError, ValueError) as e:
        for folder in missing:  # the folders made for it go again (a full disk left an empty cache folder)
            try:
                folder.rmdir()  # only if empty: never what another process put there meanwhile
            except OSError:
                break
        if not _warned:
            _warned.append(str(path))
            # fabpat's own errors already say "cannot write <path>: why"
            text = str(e) if isinstance(e, FabpatError) else f"cannot write {path}: {e.strerror or e}"
            warn(f"the library cache was not saved: {text} (the listing is complete; FABPAT_CACHE=DIR "
                 "puts the cache elsewhere, FABPAT_CACHE=off turns it off)")
