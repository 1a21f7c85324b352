"""The simulation catalog: an SQLite database of patterns and their scenario results (paper §4.2).

Two tables (stdlib :mod:`sqlite3`, no pandas):

* ``patterns``: one row per pattern and set-up — key ``(id, sides, depth, edge, thickness, weight)``;
  lattice metrics (area mm², perimeter mm, ratio, polar moment mm⁴), the same for the filleted
  outline, its ``min_width`` (mm), its SVG path data (``svg_path``, mm, y up; pictures in the browsing
  page) and ``error`` if filleting failed.
* ``results``: one row per pattern × scenario — the same key plus ``scenario``; material (E N/mm², nu),
  mesh size h (mm), ``energy`` (N·mm), ``max_displacement`` (mm), ``converged``, ``iterations``,
  ``seconds``, mesh size in nodes/elements, ``error`` (message of a deterministic failure: no
  convergence, unmeshable outline), ``solver_version``, ``input_hash`` and ``h_fine`` (mm): NULL for
  the energy of one mesh of size h; else the energy is Richardson-extrapolated from meshes h and
  h_fine (``fabpat sweep --extrapolate``, :mod:`fabpat.convergence`) and the other fields are the
  h_fine mesh's (``seconds`` summed over both).

``input_hash`` digests every input that affects a result (the key, the material, h, nonlinear, the
solver version — which includes a digest of the source of every module the pipeline imports, see
:func:`pipeline_modules`): a sweep skips a row whose stored hash equals the one it would compute, so
changing any input or the solver code recomputes exactly the affected rows.

Readers: :func:`open_catalog` (``None`` → the built-in catalog shipped in ``fabpat/data``),
:meth:`Catalog.pattern_rows` (one plain dict per pattern with ``energy_<scenario>`` columns),
:meth:`Catalog.query` and :func:`energies`. Calling the module is :func:`catalog`:
``fabpat.catalog()`` → those rows as a list, with ``to_dataframe()`` when pandas is installed.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import sqlite3
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from fabpat._callable import make_callable
from fabpat.errors import FabpatError

SCHEMA_VERSION = "1"
BUILTIN_NAME = "catalog.sqlite"
#: s: how long to wait for another process's lock on a catalog before calling it locked
LOCK_TIMEOUT = 30.0
_SQLITE_HEADER = b"SQLite format 3\x00"

#: the default set-up of the built-in catalog (paper §4.1: hexagon of 36 mm edge, 2 mm PLA)
DEFAULT_SETUP = {"sides": 6, "depth": 2, "edge": 36.0, "thickness": 2.0, "weight": 0.2}

KEY = ("id", "sides", "depth", "edge", "thickness", "weight")

PATTERN_COLUMNS: dict[str, str] = {
    "id": "TEXT NOT NULL", "sides": "INTEGER NOT NULL", "depth": "INTEGER NOT NULL", "edge": "REAL NOT NULL",
    "thickness": "REAL NOT NULL", "weight": "REAL NOT NULL",
    "area": "REAL", "perimeter": "REAL", "ratio": "REAL", "polar_moment": "REAL",
    "filleted_area": "REAL", "filleted_perimeter": "REAL", "filleted_ratio": "REAL",
    "filleted_polar_moment": "REAL", "min_width": "REAL", "svg_path": "TEXT", "error": "TEXT",
    "input_hash": "TEXT NOT NULL",
}
RESULT_COLUMNS: dict[str, str] = {
    "id": "TEXT NOT NULL", "sides": "INTEGER NOT NULL", "depth": "INTEGER NOT NULL", "edge": "REAL NOT NULL",
    "thickness": "REAL NOT NULL", "weight": "REAL NOT NULL", "scenario": "TEXT NOT NULL",
    "E": "REAL NOT NULL", "nu": "REAL NOT NULL", "h": "REAL NOT NULL", "nonlinear": "INTEGER NOT NULL",
    "energy": "REAL", "max_displacement": "REAL", "converged": "INTEGER NOT NULL", "iterations": "INTEGER",
    "seconds": "REAL", "nodes": "INTEGER", "elements": "INTEGER", "error": "TEXT",
    "solver_version": "TEXT NOT NULL", "input_hash": "TEXT NOT NULL", "computed_at": "TEXT NOT NULL",
    "h_fine": "REAL",
}
#: columns added after schema 1 was released: a catalog without them is still sound (its rows read as
#: NULL there, i.e. the single-mesh default); opening it for writing adds them (``ALTER TABLE … ADD``)
ADDED_COLUMNS: dict[str, tuple[str, ...]] = {"patterns": (), "results": ("h_fine",)}
#: metrics copied from ``patterns`` into the wide rows of :meth:`Catalog.pattern_rows`
METRICS = ("area", "perimeter", "ratio", "polar_moment", "filleted_area", "filleted_perimeter", "filleted_ratio",
           "filleted_polar_moment", "min_width")

# The results depend on the code of these modules and of every fabpat module they import (found by
# reading their import statements): that code's digest is part of the solver version, so a code change
# invalidates stored results instead of silently mixing them, and an unrelated module does not.
_PIPELINE_ROOTS = ("fabpat.library", "fabpat.fillet", "fabpat.mesh", "fabpat.scenarios", "fabpat.convergence")
# Writers and pictures that pipeline objects reach for on request (``FilletedPattern.export``,
# ``ScenarioResult.to_vtu``, notebook pictures) never change a stored number: not part of the digest.
_OUTPUT_ONLY = ("fabpat.exchange", "fabpat.cad", "fabpat.pictures", "fabpat.plots", "fabpat.io")


class CatalogError(FabpatError):
    """A catalog file that is missing, not a fabpat catalog, or from an incompatible schema."""


def pipeline_modules(roots: Sequence[str] = _PIPELINE_ROOTS) -> list[Path]:
    """Source files of ``roots`` and of every fabpat module they import, directly or not (sorted).

    Imports are read from the source (``ast``), including the lazy ones inside functions; the
    output-only modules (:data:`_OUTPUT_ONLY`: file writers, pictures) are left out.
    """
    import ast

    base = Path(str(resources.files("fabpat")))

    def path_of(module: str) -> Path | None:
        parts = module.split(".")[1:]
        if not parts:
            return base / "__init__.py"
        for cand in (base.joinpath(*parts[:-1], parts[-1] + ".py"), base.joinpath(*parts, "__init__.py")):
            if cand.is_file():
                return cand
        return None

    seen: dict[str, Path] = {}
    todo = list(roots)
    while todo:
        mod = todo.pop()
        if any(mod == o or mod.startswith(o + ".") for o in _OUTPUT_ONLY):
            continue
        path = path_of(mod)
        if mod in seen or path is None:
            continue
        seen[mod] = path
        parts = mod.split(".")
        todo.extend(".".join(parts[:k]) for k in range(2, len(parts)))  # importing a.b.c runs a.b's __init__
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("fabpat"):
                todo.append(node.module)
                todo.extend(f"{node.module}.{a.name}" for a in node.names)  # `from fabpat.shell import solve`
            elif isinstance(node, ast.Import):
                todo.extend(a.name for a in node.names if a.name.startswith("fabpat"))
    return sorted(set(seen.values()))


@cache
def solver_version() -> str:
    """``fabpat <version>+<digest>``: the package version and a digest of the pipeline's source files
    (:func:`pipeline_modules`) and of the mesher's version (another Delaunay mesh, another energy)."""
    from fabpat import __version__

    base = Path(str(resources.files("fabpat")))
    h = hashlib.sha256()
    for f in pipeline_modules():
        h.update(f.relative_to(base).as_posix().encode())
        h.update(f.read_bytes())
    try:
        from importlib.metadata import version

        h.update(version("triangle").encode())
    except Exception:  # noqa: BLE001 - metadata missing in odd installs: the digest still covers the code
        pass
    return f"fabpat {__version__}+{h.hexdigest()[:12]}"


def input_hash(inputs: Mapping[str, object]) -> str:
    """A 16-hex-digit SHA-256 of a flat mapping of inputs (keys sorted; floats by ``repr``)."""
    text = json.dumps({k: inputs[k] for k in sorted(inputs)}, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def builtin_path() -> Path:
    """Path of the catalog shipped with the package (``fabpat/data/catalog.sqlite``)."""
    return Path(str(resources.files("fabpat") / "data" / BUILTIN_NAME))


def _create_sql() -> list[str]:
    def table(name: str, cols: dict[str, str], key: Sequence[str]) -> str:
        body = ", ".join(f"{c} {t}" for c, t in cols.items())
        return f"CREATE TABLE IF NOT EXISTS {name} ({body}, PRIMARY KEY ({', '.join(key)}))"

    return [
        "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
        table("patterns", PATTERN_COLUMNS, KEY),
        table("results", RESULT_COLUMNS, (*KEY, "scenario")),
    ]


@dataclass(eq=False)
class Catalog:
    """An open catalog database. Use as a context manager or call :meth:`close`."""

    path: Path
    conn: sqlite3.Connection
    writable: bool
    #: made by this :func:`open_catalog` call: removed again (or emptied, if it replaced an empty file) on
    #: close after an error if it holds no pattern
    created: bool = False
    replaced_empty: bool = False

    # ------------------------------------------------------------------------------ reading

    def query(self, sql: str, params: Sequence[object] | Mapping[str, object] = ()) -> list[dict[str, object]]:
        """Run a read query; one plain dict per row (column name → value). :class:`CatalogError` if the
        file turns out damaged or locked (the cause named, see :func:`open_catalog`)."""
        try:
            cur = self.conn.execute(sql, params)
            names = [d[0] for d in cur.description or ()]
            return [dict(zip(names, row, strict=True)) for row in cur.fetchall()]
        except sqlite3.Error as e:
            raise _cause(e, self.path, "read") from e

    def scenarios(self) -> list[str]:
        """Scenario names present in ``results``, in the paper's order first."""
        from fabpat.scenarios import SCENARIOS

        found = {r["scenario"] for r in self.query("SELECT DISTINCT scenario FROM results")}
        return [s for s in SCENARIOS if s in found] + sorted(str(s) for s in found - set(SCENARIOS))

    def setups(self) -> list[dict[str, object]]:
        """Distinct (sides, depth, edge, thickness, weight) set-ups with their pattern counts."""
        return self.query("SELECT sides, depth, edge, thickness, weight, COUNT(*) AS patterns FROM patterns "
                          "GROUP BY sides, depth, edge, thickness, weight ORDER BY sides, depth, edge")

    def results(self, scenario: str | None = None, **setup: object) -> list[dict[str, object]]:
        """Rows of ``results`` (long form), optionally filtered by scenario and key columns; every
        column of :data:`RESULT_COLUMNS` is a key (None where a catalog made before it has none)."""
        where, params = _where({**setup, **({"scenario": scenario} if scenario else {})})
        rows = self.query(f"SELECT * FROM results{where} ORDER BY sides, depth, edge, thickness, weight, id, "
                          "scenario", params)
        return [{**r, **{c: None for c in ADDED_COLUMNS["results"] if c not in r}} for r in rows]

    def pattern_rows(self, *, pictures: bool = False, **setup: object) -> list[dict[str, object]]:
        """One dict per pattern (wide form): key, metrics and, per scenario, ``energy_<s>`` (N·mm),
        ``max_displacement_<s>`` (mm) and ``converged_<s>``; None where no result is stored.

        ``setup`` filters by key columns (e.g. ``sides=6``); ``pictures`` adds ``svg_path``.
        """
        where, params = _where(setup)
        cols = ", ".join([*KEY, *METRICS, *(("svg_path",) if pictures else ())])
        rows = self.query(f"SELECT {cols} FROM patterns{where} ORDER BY sides, depth, edge, thickness, weight, id",
                          params)
        scen = self.scenarios()
        by_key = {tuple(r[k] for k in KEY): r for r in rows}
        for r in rows:
            for s in scen:
                r[f"energy_{s}"] = r[f"max_displacement_{s}"] = r[f"converged_{s}"] = None
        res = self.query(f"SELECT {', '.join(KEY)}, scenario, energy, max_displacement, converged FROM results"
                         f"{where}", params)
        for q in res:
            r = by_key.get(tuple(q[k] for k in KEY))
            if r is not None:
                s = q["scenario"]
                r[f"energy_{s}"] = q["energy"] if q["converged"] else None
                r[f"max_displacement_{s}"] = q["max_displacement"] if q["converged"] else None
                r[f"converged_{s}"] = bool(q["converged"])
        return rows

    def stored_hashes(self, sides: int, depth: int, edge: float, thickness: float,
                      weight: float) -> tuple[dict[str, str], dict[tuple[str, str], str]]:
        """Input hashes of one set-up: {id: pattern hash}, {(id, scenario): result hash}."""
        p = (sides, depth, edge, thickness, weight)
        cond = "sides = ? AND depth = ? AND edge = ? AND thickness = ? AND weight = ?"
        pats = {str(r["id"]): str(r["input_hash"])
                for r in self.query(f"SELECT id, input_hash FROM patterns WHERE {cond}", p)}
        res = {(str(r["id"]), str(r["scenario"])): str(r["input_hash"])
               for r in self.query(f"SELECT id, scenario, input_hash FROM results WHERE {cond}", p)}
        return pats, res

    # ------------------------------------------------------------------------------ writing

    def write_rows(self, rows: Iterable[Mapping[str, object]]) -> int:
        """Insert or replace rows in ONE transaction (all or nothing); returns how many.

        Each row names its table in ``row["table"]`` ("patterns" or "results"); other keys are columns.
        A SIGKILL during the call leaves either all of these rows or none of them (SQLite atomic commit);
        so does a full disk, which raises :class:`CatalogError` saying so (earlier commits are kept).
        """
        if not self.writable:
            raise CatalogError(f"catalog {self.path} is open read-only")
        n = 0
        try:
            with self.conn:  # BEGIN … COMMIT, or ROLLBACK on error
                for row in rows:
                    table = row["table"]
                    cols = PATTERN_COLUMNS if table == "patterns" else RESULT_COLUMNS if table == "results" else None
                    if cols is None:
                        raise ValueError(f"unknown table {table!r}")
                    names = [c for c in cols if c in row]
                    self.conn.execute(f"INSERT OR REPLACE INTO {table} ({', '.join(names)}) "
                                      f"VALUES ({', '.join('?' * len(names))})", [row[c] for c in names])
                    n += 1
        except sqlite3.Error as e:
            raise _cause(e, self.path, "store results in") from e
        return n

    def finish(self) -> None:
        """Fold the write-ahead log into the main file and leave WAL mode, so the catalog is ONE file
        that opens read-only anywhere (a WAL-mode file needs a writable ``-shm`` next to it)."""
        if self.writable:
            # a reader still open elsewhere keeps WAL mode (busy): harmless, the next finish() retries
            with contextlib.suppress(sqlite3.OperationalError):
                self.conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
                self.conn.execute("PRAGMA journal_mode=DELETE")

    def close(self, failed: bool = False) -> None:
        """Close the SQLite connection. A writable catalog is left as ONE file: if a failure (a full
        disk that refused SQLite's ``-shm`` index, say) kept :meth:`finish` from leaving WAL mode, the
        ``-wal``/``-shm`` files are folded back and removed, provided no other process has the catalog
        open. With ``failed``, a catalog this call created that holds no pattern yet is removed too."""
        self.conn.close()
        if self.writable:
            _tidy(self.path, remove_empty=failed and self.created, keep_file=self.replaced_empty)

    def __enter__(self) -> Catalog:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(failed=exc_type is not None)


def _tidy(p: Path, remove_empty: bool, keep_file: bool = False) -> None:
    """Leave WAL mode and remove ``p``'s ``-wal``/``-shm`` files (and ``p`` itself if ``remove_empty``
    and it has no pattern; with ``keep_file`` it is emptied to 0 bytes instead, as it was), only while
    holding SQLite's exclusive lock: every WAL-mode connection holds a shared lock on the file, so
    getting the exclusive one proves nobody else uses them."""
    side = [p.with_name(p.name + s) for s in ("-wal", "-shm")]
    if not remove_empty and not any(f.exists() for f in side):
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


def _where(filters: Mapping[str, object]) -> tuple[str, list[object]]:
    allowed = set(KEY) | {"scenario"}
    bad = set(filters) - allowed
    if bad:
        raise ValueError(f"cannot filter by {', '.join(sorted(bad))}; use {', '.join(sorted(allowed))}")
    items = [(k, v) for k, v in filters.items() if v is not None]
    if not items:
        return "", []
    return " WHERE " + " AND ".join(f"{k} = ?" for k, _ in items), [v for _, v in items]


def open_catalog(path: str | Path | None = None, *, write: bool = False) -> Catalog:
    """Open a catalog: ``None`` → the built-in one (read-only); ``write=True`` creates it if missing.

    The one way fabpat opens a catalog file (sweep, catalog, browse, plot, the assembly rules):

    1. An existing file is first opened read-only (SQLite URI ``mode=ro``) and checked — an SQLite
       file, fabpat's ``meta`` table, this :data:`SCHEMA_VERSION`, every table and column, and
       ``PRAGMA quick_check``. A file that fails is refused *unchanged* (no tables added, no WAL switch).
    2. Only then, for ``write=True``, is it opened read-write and switched to WAL journaling with
       ``synchronous=NORMAL``: every commit survives a crash or kill of the process (only a power loss
       can lose the last commits), and readers never block the writer.
    3. A new catalog is built under a temporary name next to ``path`` and linked into place when
       complete, so a full disk or a kill leaves no empty or half-made file; leaving the returned
       catalog's ``with`` block by an exception before any pattern is stored removes it again.
       An empty (0-byte) file counts as no catalog yet: readers refuse it as such, ``write=True``
       makes the catalog in it.

    Raises :class:`CatalogError` naming the real cause: missing, read-only, locked (for longer than
    :data:`LOCK_TIMEOUT`), disk full, damaged (with the ``sqlite3 FILE .recover`` hint), not a fabpat
    catalog, or another schema.
    """
    p = builtin_path() if path is None else Path(path)
    if write and path is None:
        raise CatalogError("the built-in catalog is read-only here; give --db FILE")
    if p.is_dir():
        raise CatalogError(f"cannot use {p} as a catalog: it is a folder")
    if not write:
        if not p.is_file():
            what = "the built-in catalog" if path is None else "catalog"
            raise CatalogError(f"{what} {p} does not exist; create one with `fabpat sweep --db {p}`")
        if p.stat().st_size == 0:  # not damaged: a catalog not made yet (sweep makes one in it, as in a missing file)
            raise CatalogError(f"catalog {p} is an empty file (0 bytes), not a catalog yet; create one with "
                               f"`fabpat sweep --db {p}`")
        return Catalog(p, _checked_connection(p), False)
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise CatalogError(f"cannot create catalog {p}: folder {folder} does not exist")
    replaced_empty = p.exists() and p.stat().st_size == 0  # an empty file is a catalog not made yet
    created = replaced_empty or not p.exists()
    if created:
        _create(p, folder)
    else:
        _checked_connection(p).close()  # read-only: a foreign or damaged file is refused unchanged
        if not os.access(p, os.W_OK) or not os.access(folder, os.W_OK):
            where = p if not os.access(p, os.W_OK) else f"folder {folder} (SQLite writes its journal there)"
            raise CatalogError(f"catalog {p} is read-only: cannot write {where}; give another --db")
    try:
        conn = sqlite3.connect(f"{p.resolve().as_uri()}?mode=rw", uri=True, timeout=LOCK_TIMEOUT)
    except sqlite3.Error as e:
        raise _cause(e, p, "open") from e
    cat = Catalog(p, conn, True, created, replaced_empty)
    try:
        conn.execute("PRAGMA journal_mode=WAL")
        conn.execute("PRAGMA synchronous=NORMAL")
        conn.execute("SELECT COUNT(*) FROM meta").fetchone()  # WAL's -shm index is made now: a full disk shows here
        for table, added in ADDED_COLUMNS.items():  # a catalog made before these columns existed
            have = {str(r[1]) for r in conn.execute(f"PRAGMA table_info({table})")}
            for c in added:
                if c not in have:
                    with conn:
                        kind = (PATTERN_COLUMNS if table == "patterns" else RESULT_COLUMNS)[c]
                        conn.execute(f"ALTER TABLE {table} ADD COLUMN {c} {kind}")
    except sqlite3.Error as e:
        cat.close(failed=True)  # back to one file as it was, no -wal/-shm
        raise _cause(e, p, "write to") from e
    return cat


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
    try:
        # mode=ro: a reader never creates or modifies the file
        conn = sqlite3.connect(f"{p.resolve().as_uri()}?mode=ro", uri=True, timeout=LOCK_TIMEOUT)
    except sqlite3.Error as e:
        raise _cause(e, p, "open") from e
    try:
        _check_schema(conn, p)
    except BaseException:
        conn.close()
        raise
    return conn


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
        for table, columns in (("patterns", PATTERN_COLUMNS), ("results", RESULT_COLUMNS)):
            have = {str(r[1]) for r in conn.execute(f"PRAGMA table_info({table})")}
            lost = [c for c in columns if c not in have and c not in ADDED_COLUMNS[table]]
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


def _create(p: Path, folder: Path) -> None:
    """Make a new, empty catalog at ``p`` (missing or an empty file): built under a temporary name and
    linked into place only when complete, so a full disk leaves nothing behind."""
    from fabpat.io import file_mode, remove_stale_temps, temp_prefix

    remove_stale_temps(folder)
    try:
        fd, name = tempfile.mkstemp(prefix=temp_prefix(p.name), suffix=".part", dir=folder)
    except OSError as e:
        raise _os_cause(e, p, "create") from e
    os.close(fd)
    tmp = Path(name)
    try:
        conn = sqlite3.connect(tmp)
        try:
            for sql in _create_sql():
                conn.execute(sql)
            with conn:
                conn.execute("INSERT INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,))
        finally:
            conn.close()
        os.chmod(tmp, file_mode())  # mkstemp makes 0600 files; give the user's usual permissions
        if p.exists():  # an empty file: replace it
            os.replace(tmp, p)
        else:
            try:
                os.link(tmp, p)  # fails if another process created p meanwhile: never replace its catalog
            except FileExistsError:
                raise CatalogError(f"cannot create catalog {p}: another process created it just now; "
                                   "run again") from None
            except OSError:  # a file system without hard links
                os.replace(tmp, p)
    except sqlite3.Error as e:
        raise _cause(e, p, "create") from e
    except OSError as e:
        raise _os_cause(e, p, "create") from e
    finally:
        for junk in (tmp, tmp.with_name(tmp.name + "-journal")):
            with contextlib.suppress(OSError):
                junk.unlink()


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


@cache
def _builtin_energies(scenario: str, sides: int, depth: int, edge: float, thickness: float,
                      weight: float) -> tuple[tuple[str, float], ...]:
    with open_catalog(None) as cat:
        return tuple(_energy_items(cat, scenario, sides, depth, edge, thickness, weight))


def _energy_items(cat: Catalog, scenario: str, sides: int, depth: int, edge: float, thickness: float,
                  weight: float) -> Iterator[tuple[str, float]]:
    for r in cat.query("SELECT id, energy FROM results WHERE scenario = ? AND sides = ? AND depth = ? AND edge = ? "
                       "AND thickness = ? AND weight = ? AND converged = 1 ORDER BY id",
                       (scenario, sides, depth, edge, thickness, weight)):
        yield str(r["id"]), float(r["energy"])  # type: ignore[arg-type]


def energies(catalog: Catalog | str | Path | None, scenario: str, sides: int = 6, *, depth: int = 2,
             edge: float = 36.0, thickness: float = 2.0, weight: float = 0.2) -> dict[str, float]:
    """Total strain energy (N·mm) of every converged pattern in one scenario: {pattern ID: energy}.

    ``catalog``: an open :class:`Catalog`, a path, or None for the built-in catalog (cached).
    Lower energy = stiffer pattern (constant loads, paper §5). Empty if the scenario was not simulated.
    """
    from fabpat.scenarios import SCENARIOS

    if scenario not in SCENARIOS:
        raise ValueError(f"unknown scenario {scenario!r}; expected one of {', '.join(SCENARIOS)}")
    args = (scenario, sides, depth, float(edge), float(thickness), float(weight))
    if catalog is None:
        return dict(_builtin_energies(*args))
    if isinstance(catalog, Catalog):
        return dict(_energy_items(catalog, *args))
    with open_catalog(catalog) as cat:
        return dict(_energy_items(cat, *args))


class CatalogRows(list[dict[str, object]]):
    """The rows of :func:`catalog`: a list of dicts (one per pattern), plus :meth:`to_dataframe`."""

    def to_dataframe(self) -> Any:
        """A pandas ``DataFrame`` of the rows, indexed by pattern ID. Needs pandas
        (``pip install 'fabpat[pandas]'``); raises :class:`CatalogError` without it."""
        try:
            import pandas as pd
        except ImportError:
            raise CatalogError("to_dataframe needs pandas: pip install 'fabpat[pandas]'") from None
        return pd.DataFrame(list(self)).set_index("id", drop=False)


def catalog(path: str | Path | None = None, *, sides: int | None = None, **setup: object) -> CatalogRows:
    """The rows of a catalog (``None``: the built-in one) — ``fabpat.catalog()``.

    One dict per pattern (see :meth:`Catalog.pattern_rows`): ``id``, the set-up (``sides``, ``depth``,
    ``edge`` mm, ``thickness`` mm, ``weight``), lattice and filleted metrics (mm², mm, mm⁴),
    ``min_width`` (mm) and per scenario ``energy_<scenario>`` (N·mm) and ``max_displacement_<scenario>``
    (mm). ``sides`` and other set-up keys filter the rows. Raises :class:`CatalogError`.
    """
    bad = sorted(set(setup) - set(KEY[1:]))
    if bad:
        raise CatalogError(f"unknown catalog filter {bad[0]!r}: choose from {', '.join(KEY[1:])}")
    if path is not None and not isinstance(path, str | os.PathLike):
        raise CatalogError(f"path must be a catalog file name or None (the built-in one), got {path!r}")
    for key, value in (("sides", sides), *setup.items()):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int | float)):
            raise CatalogError(f"catalog filter {key} must be a number, got {value!r}")
    if sides is not None:
        setup["sides"] = sides
    with open_catalog(path) as cat:
        rows = cat.pattern_rows(**setup)
        if not rows and setup:
            raise CatalogError(no_match_message(cat, setup))
        return CatalogRows(rows)


def no_match_message(cat: Catalog, setup: dict[str, object]) -> str:
    """Why a filter found no rows: the filter, and the set-ups (sides, depth, edge mm, thickness mm,
    weight, pattern count) the catalog does hold, so an empty answer is never mistaken for an empty
    catalog."""
    held = "; ".join(
        f"sides={s['sides']} depth={s['depth']} edge={s['edge']:g} thickness={s['thickness']:g} "
        f"weight={s['weight']:g} ({s['patterns']} patterns)"
        for s in cat.setups()
    )
    asked = " ".join(f"{k}={v}" for k, v in setup.items())
    return f"no patterns with {asked} in {cat.path}; it holds {held or 'nothing'}"


make_callable(__name__, catalog)
