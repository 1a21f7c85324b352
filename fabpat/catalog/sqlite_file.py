"""The catalog file on disk: checking an existing file, making a new one, tidying up after SQLite.

Below :mod:`fabpat.catalog.store` (which opens catalogs with these): :func:`connect` (the one way a
catalog is opened read-only or read-write), the checks that refuse a file unchanged (not SQLite, not
fabpat's, another schema, damaged, not a regular file, read-only), the making of a new catalog that
appears only complete, leaving WAL mode as one file again, and the one-line :class:`CatalogError`
naming the real cause of an SQLite or OS error (read-only, locked, disk full, damaged).
"""

from __future__ import annotations

import contextlib
import errno
import os
import sqlite3
import stat
import tempfile
from collections.abc import Sequence
from pathlib import Path

from fabpat.catalog.schema import (
    ADDED_COLUMNS,
    FAMILY_COLUMNS,
    FAMILY_KEY,
    KEY,
    PATTERN_COLUMNS,
    RESULT_COLUMNS,
    SCHEMA_VERSION,
    CatalogError,
)

#: s: how long to wait for another process's lock on a catalog before calling it locked
LOCK_TIMEOUT = 30.0
_SQLITE_HEADER = b"SQLite format 3\x00"


def connect(p: Path, mode: str) -> sqlite3.Connection:
    """An SQLite connection to the catalog file ``p`` in URI ``mode`` (``ro``: a reader never creates or
    modifies the file; ``rw``), waiting up to :data:`LOCK_TIMEOUT` for another process's lock."""
    return sqlite3.connect(f"{p.resolve().as_uri()}?mode={mode}", uri=True, timeout=LOCK_TIMEOUT)


def _create_sql() -> list[str]:
    def table(name: str, cols: dict[str, str], key: Sequence[str]) -> str:
        body = ", ".join(f"{c} {t}" for c, t in cols.items())
        return f"CREATE TABLE IF NOT EXISTS {name} ({body}, PRIMARY KEY ({', '.join(key)}))"

    return [
        "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
        table("patterns", PATTERN_COLUMNS, KEY),
        table("results", RESULT_COLUMNS, (*KEY, "scenario")),
        table("family", FAMILY_COLUMNS, FAMILY_KEY),
    ]


def _checked_connection(p: Path) -> sqlite3.Connection:
    """A read-only connection to ``p`` once it is known to be a sound fabpat catalog of this schema."""
    try:
        with p.open("rb") as f:
            head = f.read(len(_SQLITE_HEADER))
    except OSError as e:
        raise CatalogError(f"cannot read catalog {p}: {e.strerror or e}") from e
    if head != _SQLITE_HEADER:
        raise CatalogError(f"{p} is not a fabpat catalog: not an SQLite database (or its header is damaged; "
                           f"if it was a catalog, try `sqlite3 {p} .recover`); give another --db")
    side = [p.with_name(p.name + s) for s in ("-wal", "-shm")]
    had = [f.exists() for f in side]
    try:
        conn = connect(p, "ro")  # a reader never modifies the file (but SQLite makes a WAL file's -wal/-shm)
    except sqlite3.Error as e:
        _remove_new_side_files(side, had)
        raise _cause(e, p, "open") from e
    try:
        _check_schema(conn, p)
    except BaseException:
        conn.close()
        _remove_new_side_files(side, had)
        raise
    return conn


def _remove_new_side_files(side: list[Path], had: list[bool]) -> None:
    """Remove the ``-wal``/``-shm`` files (``side``) that opening a refused file made (``had``: which
    existed before): a foreign database in WAL mode is refused unchanged, with nothing left next to it.
    A ``-wal`` is removed only while empty (a read-only connection writes nothing into it)."""
    for f, existed in zip(side, had, strict=True):
        if existed:
            continue
        try:
            if f.name.endswith("-wal") and f.stat().st_size:
                continue
            f.unlink()
        except OSError:
            pass


def _check_schema(conn: sqlite3.Connection, p: Path) -> None:
    try:
        tables = {str(r[0]) for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if "meta" not in tables:
            raise CatalogError(f"{p} is not a fabpat catalog (an SQLite database without fabpat's meta table: "
                               f"tables {', '.join(sorted(tables)) or 'none'}); give another --db")
        version = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
        if version is None:
            raise CatalogError(f"{p} is not a fabpat catalog (its meta table has no schema_version); "
                               "give another --db")
        if str(version[0]) != SCHEMA_VERSION:
            raise CatalogError(f"{p} has catalog schema {version[0]}, expected {SCHEMA_VERSION} (another fabpat "
                               f"version): move it away or give another --db, and `fabpat sweep` makes a new one")
        checked = [("patterns", PATTERN_COLUMNS), ("results", RESULT_COLUMNS)]
        if "family" in tables:  # optional: added after schema 1
            checked.append(("family", FAMILY_COLUMNS))
        for table, columns in checked:
            have = {str(r[1]) for r in conn.execute(f"PRAGMA table_info({table})")}
            lost = [c for c in columns if c not in have and c not in ADDED_COLUMNS.get(table, ())]
            if lost:
                what = f"table {table} is missing" if not have else f"table {table} has no column {', '.join(lost)}"
                raise CatalogError(f"catalog {p} is damaged: {what}; move it away and re-create it with "
                                   f"`fabpat sweep --db {p}`")
        problems = [str(r[0]) for r in conn.execute("PRAGMA quick_check(3)")]
    except sqlite3.Error as e:
        raise _cause(e, p, "read") from e
    if problems != ["ok"]:
        raise CatalogError(f"catalog {p} is damaged ({problems[0]}): try `sqlite3 {p} .recover` "
                           "to save what is left, or give another --db")


def _kind(p: Path) -> str | None:
    """What ``p`` is, if it is neither absent nor a regular file (a symbolic link is followed)."""
    try:
        mode = os.stat(p).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None  # absent (a dangling link too): a catalog can be made there
    except OSError as e:
        raise _os_cause(e, p, "open") from e
    kinds = ((stat.S_ISREG, None), (stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
             (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
    return next((k for test, k in kinds if test(mode)), "not a regular file")


def _refuse_special(p: Path) -> None:
    """:class:`CatalogError` if ``p`` exists and is not a regular file (through a symbolic link too)."""
    kind = _kind(p)
    if kind is not None:
        link = f" (a symbolic link to {os.path.realpath(p)})" if p.is_symlink() else ""
        raise CatalogError(f"cannot use {p}{link} as a catalog: it is {kind}, not a regular file; "
                           "give another --db")


def _check_writable(p: Path, folder: Path) -> None:
    if not os.access(p, os.W_OK) or not os.access(folder, os.W_OK):
        where = p if not os.access(p, os.W_OK) else f"folder {folder} (SQLite writes its journal there)"
        raise CatalogError(f"catalog {p} is read-only: cannot write {where}; give another --db")


def _initialise(conn: sqlite3.Connection, statements: Sequence[str]) -> None:
    for sql in statements:
        conn.execute(sql)
    conn.execute("INSERT INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,))


def _create_in_place(p: Path) -> bool:
    """Make the catalog inside the empty file ``p`` in one transaction; False if another process made
    it meanwhile (its tables are there once this one gets SQLite's write lock: nothing is replaced)."""
    statements = _create_sql()
    try:
        conn = sqlite3.connect(f"{p.resolve().as_uri()}?mode=rw", uri=True, timeout=LOCK_TIMEOUT,
                               isolation_level=None)
        try:
            conn.execute("BEGIN IMMEDIATE")  # waits for a writer making it now, then sees its tables
            if conn.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()[0]:
                conn.execute("ROLLBACK")
                return False
            _initialise(conn, statements)
            conn.execute("COMMIT")
            return True
        finally:
            conn.close()  # without COMMIT: rolled back, the file empty as it was
    except sqlite3.Error as e:
        raise _cause(e, p, "create") from e


def _create(p: Path, folder: Path) -> bool:
    """Make a new catalog at the missing path ``p``: built under a temporary name and hard-linked into
    place only when complete (a full disk leaves nothing behind). False if another process created
    ``p`` meanwhile: the link refuses to replace it, and the caller opens that catalog instead."""
    from fabpat.io import file_mode, remove_stale_temps, temp_prefix

    remove_stale_temps(folder)
    try:
        fd, name = tempfile.mkstemp(prefix=temp_prefix(p.name), suffix=".part", dir=folder)
    except OSError as e:
        raise _os_cause(e, p, "create") from e
    os.close(fd)
    tmp = Path(name)
    try:
        conn = sqlite3.connect(tmp, isolation_level=None)
        try:
            conn.execute("BEGIN")
            _initialise(conn, _create_sql())
            conn.execute("COMMIT")
        finally:
            conn.close()
        os.chmod(tmp, file_mode())  # mkstemp makes 0600 files; give the user's usual permissions
        try:
            os.link(tmp, p)  # atomic, and fails if p exists: never replace another process's catalog
        except FileExistsError:
            return False
        except OSError as e:
            if e.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EMLINK):
                raise
            return _create_exclusive(p)  # a file system without hard links (FAT, some network shares)
        return True
    except sqlite3.Error as e:
        raise _cause(e, p, "create") from e
    except OSError as e:
        raise _os_cause(e, p, "create") from e
    finally:
        for junk in (tmp, tmp.with_name(tmp.name + "-journal")):
            with contextlib.suppress(OSError):
                junk.unlink()


def _create_exclusive(p: Path) -> bool:
    """Without hard links: claim ``p`` as an empty file (``O_EXCL``: fails if it exists) and make the
    catalog in it (:func:`_create_in_place`); an empty file left by a failure is "no catalog yet"."""
    from fabpat.io import file_mode

    try:
        os.close(os.open(p, os.O_WRONLY | os.O_CREAT | os.O_EXCL, file_mode()))
    except FileExistsError:
        return False
    try:
        return _create_in_place(p)
    except BaseException:
        with contextlib.suppress(OSError):
            if p.stat().st_size == 0:
                p.unlink()
        raise


def _os_cause(e: OSError, p: Path, doing: str) -> CatalogError:
    if e.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)):
        return CatalogError(f"cannot {doing} catalog {p}: the disk is full; free space and run again")
    if e.errno in (errno.EROFS, errno.EACCES, errno.EPERM):
        return CatalogError(f"cannot {doing} catalog {p}: {e.strerror} (read-only); give another --db")
    return CatalogError(f"cannot {doing} catalog {p}: {e.strerror or e}")


def _disk_full(p: Path) -> bool:
    """Whether the file system of catalog ``p`` is (nearly) full: SQLite reports a -shm file that cannot
    grow as a plain I/O error, so the free space is asked (see :func:`fabpat.io.writer_failed`)."""
    from fabpat.io import FULL_BELOW

    try:
        st = os.statvfs(p.parent if str(p.parent) else ".")
    except OSError:
        return False
    return st.f_bavail * st.f_frsize < FULL_BELOW


def _cause(e: sqlite3.Error, p: Path, doing: str) -> CatalogError:
    """One line naming the real cause of an SQLite error on catalog ``p`` (read-only, locked, full, …)."""
    name = str(getattr(e, "sqlite_errorname", "") or "")
    if name.startswith("SQLITE_READONLY"):
        return CatalogError(f"catalog {p} is read-only ({e}): cannot {doing} it; give another --db")
    if name.startswith(("SQLITE_BUSY", "SQLITE_LOCKED")):
        return CatalogError(f"catalog {p} is locked by another process (a running sweep?) for more than "
                            f"{LOCK_TIMEOUT:g} s: wait for it to finish, or give another --db")
    if name.startswith("SQLITE_FULL") or (name.startswith("SQLITE_IOERR") and _disk_full(p)):
        if doing == "create":
            return CatalogError(f"cannot create catalog {p}: the disk is full: free space and run again")
        # a sweep's read can need disk too (the WAL index): whatever was being done, results cannot be stored
        return CatalogError(f"cannot store results in catalog {p}: the disk is full; every row committed before "
                            "is kept: free space and run again")
    if name.startswith(("SQLITE_CORRUPT", "SQLITE_NOTADB")):
        return CatalogError(f"catalog {p} is damaged ({e}): try `sqlite3 {p} .recover` to save what is left, "
                            "or give another --db")
    if name.startswith("SQLITE_CANTOPEN"):
        return CatalogError(f"cannot open catalog {p} ({e}): check the file and its folder's permissions")
    return CatalogError(f"cannot {doing} catalog {p}: {e}")


def _tidy(p: Path, remove_empty: bool, keep_file: bool = False) -> None:
    """Leave WAL mode and remove ``p``'s ``-wal``/``-shm`` files (and ``p`` itself if ``remove_empty``
    and it has no pattern; with ``keep_file`` it is emptied to 0 bytes instead, as it was), only while
    holding SQLite's exclusive lock: every WAL-mode connection holds a shared lock on the file, so
    getting the exclusive one proves nobody else uses them."""
    side = [p.with_name(p.name + s) for s in ("-wal", "-shm")]
    if not remove_empty and not any(f.exists() for f in side) and not _in_wal_mode(p):
        return
    with contextlib.suppress(sqlite3.Error, OSError):
        # EXCLUSIVE locking keeps the WAL index in memory: this works where the -shm file could not grow
        conn = sqlite3.connect(f"{p.resolve().as_uri()}?mode=rw", uri=True, timeout=0)
        try:
            conn.execute("PRAGMA locking_mode=EXCLUSIVE")
            # in WAL mode, this first read takes the file's EXCLUSIVE lock (busy if anyone else has it open)
            empty = conn.execute("SELECT COUNT(*) FROM patterns").fetchone()[0] == 0
            side[1].unlink(missing_ok=True)  # unused under the lock; on a full disk its space is needed next
            if conn.execute("PRAGMA journal_mode=DELETE").fetchone()[0] != "delete":  # checkpoints, removes -wal
                return
            side[0].unlink(missing_ok=True)
            if remove_empty and empty:
                conn.execute("BEGIN EXCLUSIVE")  # a catalog that never was in WAL mode: take the lock now
                if keep_file:
                    os.truncate(p, 0)
                else:
                    p.unlink()
                conn.rollback()
        finally:
            conn.close()


def _in_wal_mode(p: Path) -> bool:
    """Whether the file's header says WAL mode (bytes 18–19 = 2, 2): SQLite removes the -wal/-shm files
    when the last connection closes, but the mode stays, and a reader would then make them again."""
    try:
        with p.open("rb") as f:
            return f.read(20)[18:20] == b"\x02\x02"
    except OSError:
        return False

