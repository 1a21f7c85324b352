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
:func:`fabpat.catalog_version.pipeline_modules`): a sweep skips a row whose stored hash equals the one
it would compute, so changing any input or the solver code recomputes exactly the affected rows.

Readers: :func:`open_catalog` (``None`` → the built-in catalog shipped in ``fabpat/data``),
:meth:`Catalog.pattern_rows` (one plain dict per pattern with ``energy_<scenario>`` and
``specific_stiffness_<scenario>`` columns, see :func:`fabpat.catalog_rows.specific_stiffness`),
:meth:`Catalog.query`,
:func:`energies` and :func:`polygon_energies` (one polygon's own energies, for the assembly rules).
Calling the module is :func:`catalog`: ``fabpat.catalog()`` → those rows as a list
(:class:`fabpat.catalog_rows.CatalogRows`: filter, sort, top N, ``to_dataframe()`` with pandas).

What is read back is checked as strictly as what a user types (a catalog is a file anyone can edit):
an energy must be a finite, positive number (a converged row must have one), a displacement and every
metric finite; a row that is not raises :class:`CatalogError` naming the catalog, the pattern, the
scenario and the value, so that no listing, picture or assembly rule ever uses it. A sweep recomputes
such rows (their stored hash is not trusted).
"""

from __future__ import annotations

import contextlib
import errno
import os
import sqlite3
import stat
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from fabpat._callable import make_callable
from fabpat.catalog_rows import check_row, pattern_problem, result_problem, specific_stiffness
from fabpat.catalog_version import input_hash, pipeline_modules, solver_version  # noqa: F401 - part of this API
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
#: ``family``: the results of a pattern's family members (:mod:`fabpat.variation`) other than the
#: paper's (whose results are in ``results``), one row per member × scenario, with the member's
#: ``min_width`` (mm) and ``filleted_area`` (mm²); key: ``results``' plus ``bridge_weight``. A table added
#: after schema 1: a catalog without it is sound (it holds no family), opening it for writing adds it.
FAMILY_COLUMNS: dict[str, str] = {**RESULT_COLUMNS, "bridge_weight": "REAL NOT NULL", "min_width": "REAL",
                                  "filleted_area": "REAL"}
FAMILY_KEY = (*KEY, "bridge_weight", "scenario")
#: columns added after schema 1 was released: a catalog without them is still sound (its rows read as
#: NULL there, i.e. the single-mesh default); opening it for writing adds them (``ALTER TABLE … ADD``)
ADDED_COLUMNS: dict[str, tuple[str, ...]] = {"patterns": (), "results": ("h_fine",)}
#: metrics copied from ``patterns`` into the wide rows of :meth:`Catalog.pattern_rows`
METRICS = ("area", "perimeter", "ratio", "polar_moment", "filleted_area", "filleted_perimeter", "filleted_ratio",
           "filleted_polar_moment", "min_width")

class CatalogError(FabpatError, ValueError):
    """A catalog file that is missing, not a fabpat catalog, from an incompatible schema or holding a
    bad value; a bad filter or query argument (a ``ValueError`` too, as before it was one of these)."""


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
        table("family", FAMILY_COLUMNS, FAMILY_KEY),
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
        """Distinct (sides, depth, edge, thickness, weight) set-ups with their pattern counts.
        :class:`CatalogError` if a stored key is not a valid one (text, a negative edge, …)."""
        rows = self.query("SELECT sides, depth, edge, thickness, weight, COUNT(*) AS patterns FROM patterns "
                          "GROUP BY sides, depth, edge, thickness, weight ORDER BY sides, depth, edge")
        for r in rows:
            problem = pattern_problem(r)
            if problem:
                raise CatalogError(f"catalog {self.path} holds a bad set-up: {problem}; the file was edited or "
                                   "damaged: give another --db")
        return rows

    def results(self, scenario: str | None = None, **setup: object) -> list[dict[str, object]]:
        """Rows of ``results`` (long form), optionally filtered by scenario and key columns; every
        column of :data:`RESULT_COLUMNS` is a key (None where a catalog made before it has none).
        :class:`CatalogError` for an unknown filter or a bad stored value (see the module notes)."""
        where, params = _where({**setup, **({"scenario": scenario} if scenario else {})})
        rows = self.query(f"SELECT * FROM results{where} ORDER BY sides, depth, edge, thickness, weight, id, "
                          "scenario", params)
        for r in rows:
            check_row(self.path, r, METRICS)
        return [{**r, **{c: None for c in ADDED_COLUMNS["results"] if c not in r}} for r in rows]

    def pattern_rows(self, *, pictures: bool = False, **setup: object) -> list[dict[str, object]]:
        """One dict per pattern (wide form): key, metrics and, per scenario, ``energy_<s>`` (N·mm),
        ``max_displacement_<s>`` (mm), ``converged_<s>`` and ``specific_stiffness_<s>``
        (1/(N·mm³), :func:`~fabpat.catalog_rows.specific_stiffness`); None where no result is stored.

        ``setup`` filters by key columns (e.g. ``sides=6``); ``pictures`` adds ``svg_path``.
        :class:`CatalogError` for an unknown filter or a bad stored value (see the module notes).
        """
        where, params = _where(setup)
        cols = ", ".join([*KEY, *METRICS, *(("svg_path",) if pictures else ())])
        rows = self.query(f"SELECT {cols} FROM patterns{where} ORDER BY sides, depth, edge, thickness, weight, id",
                          params)
        scen = self.scenarios()
        by_key = {tuple(r[k] for k in KEY): r for r in rows}
        for r in rows:
            check_row(self.path, r, METRICS)
            for s in scen:
                r[f"energy_{s}"] = r[f"max_displacement_{s}"] = r[f"converged_{s}"] = None
        res = self.query(f"SELECT {', '.join(KEY)}, scenario, energy, max_displacement, converged FROM results"
                         f"{where}", params)
        for q in res:
            r = by_key.get(tuple(q[k] for k in KEY))
            if r is not None:
                check_row(self.path, q, METRICS)
                s = q["scenario"]
                r[f"energy_{s}"] = q["energy"] if q["converged"] else None
                r[f"max_displacement_{s}"] = q["max_displacement"] if q["converged"] else None
                r[f"converged_{s}"] = bool(q["converged"])
        for r in rows:
            for s in scen:
                r[f"specific_stiffness_{s}"] = specific_stiffness(r[f"energy_{s}"], r["filleted_area"])  # type: ignore[arg-type]
        return rows

    def number_columns(self, long: bool = False) -> list[str]:
        """The numeric columns of :meth:`pattern_rows` (``long``: of :meth:`results`) that rows can be
        filtered and sorted by (:func:`fabpat.catalog_rows.find_rows`), for this catalog's scenarios."""
        if long:
            return [c for c, t in RESULT_COLUMNS.items() if t.split()[0] in ("REAL", "INTEGER")]
        per = [f"{p}_{s}" for s in self.scenarios() for p in ("energy", "max_displacement", "specific_stiffness")]
        return [*KEY[1:], *METRICS, *per]

    def has_family(self) -> bool:
        """Whether this catalog has a ``family`` table (one made before it existed has none until a sweep
        writes to it)."""
        return bool(self.query("SELECT name FROM sqlite_master WHERE type = 'table' AND name = 'family'"))

    def family(self, scenario: str | None = None, **setup: object) -> list[dict[str, object]]:
        """Rows of ``family`` (long form, as :meth:`results` plus ``bridge_weight``, ``min_width`` mm and
        ``filleted_area`` mm²), optionally filtered by scenario and key columns; [] without the table.
        :class:`CatalogError` for an unknown filter or a bad stored value."""
        if not self.has_family():
            return []
        where, params = _where({**setup, **({"scenario": scenario} if scenario else {})}, extra=("bridge_weight",))
        rows = self.query(f"SELECT * FROM family{where} ORDER BY sides, depth, edge, thickness, weight, id, "
                          "scenario, bridge_weight", params)
        for r in rows:
            check_row(self.path, r, ("min_width", "filleted_area"))
        return rows

    def stored_hashes(self, sides: int, depth: int, edge: float, thickness: float, weight: float,
                      bridge_weight: float = 1.0) -> tuple[dict[str, str], dict[tuple[str, str], str]]:
        """Input hashes of one set-up: {id: pattern hash}, {(id, scenario): result hash}. A row holding a
        bad value (see the module notes) is left out, so a sweep recomputes it rather than trust it.
        A family member (``bridge_weight`` ≠ 1) has result hashes in ``family`` and no pattern hashes."""
        p = (sides, depth, edge, thickness, weight)
        cond = "sides = ? AND depth = ? AND edge = ? AND thickness = ? AND weight = ?"
        if bridge_weight != 1.0:
            if not self.has_family():
                return {}, {}
            rows = self.query(f"SELECT * FROM family WHERE {cond} AND bridge_weight = ?", (*p, bridge_weight))
            return {}, {(str(r["id"]), str(r["scenario"])): str(r["input_hash"]) for r in rows
                        if not result_problem(r)}
        pats = {str(r["id"]): str(r["input_hash"])
                for r in self.query(f"SELECT {', '.join(KEY)}, {', '.join(METRICS)}, input_hash FROM patterns "
                                    f"WHERE {cond}", p) if not pattern_problem(r, METRICS)}
        res = {(str(r["id"]), str(r["scenario"])): str(r["input_hash"])
               for r in self.query(f"SELECT * FROM results WHERE {cond}", p) if not result_problem(r)}
        return pats, res

    # ------------------------------------------------------------------------------ writing

    def write_rows(self, rows: Iterable[Mapping[str, object]]) -> int:
        """Insert or replace rows in ONE transaction (all or nothing); returns how many.

        Each row names its table in ``row["table"]`` ("patterns", "results" or "family"); other keys are
        columns.
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
                    cols = {"patterns": PATTERN_COLUMNS, "results": RESULT_COLUMNS, "family": FAMILY_COLUMNS}.get(
                        str(table))
                    if cols is None:
                        raise CatalogError(f"unknown table {table!r}: rows go to 'patterns', 'results' or 'family'")
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
        """Close the SQLite connection. A writable catalog is left as ONE file out of WAL mode: if
        :meth:`finish` was not called or a failure (a full disk that refused SQLite's ``-shm`` index,
        say) kept it from leaving WAL mode, the ``-wal``/``-shm`` files are folded back and removed and
        the mode left, provided no other process has the catalog open. With ``failed``, a catalog this
        call created that holds no pattern yet is removed too."""
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


def _where(filters: Mapping[str, object], extra: Sequence[str] = ()) -> tuple[str, list[object]]:
    allowed = set(KEY) | {"scenario", *extra}
    bad = set(filters) - allowed
    if bad:
        raise CatalogError(f"cannot filter by {', '.join(sorted(bad))}; use {', '.join(sorted(allowed))}")
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
    3. A new catalog is built under a temporary name next to ``path`` and hard-linked into place when
       complete; the link fails if another process made the file meanwhile, and that catalog is then
       opened instead (two sweeps starting together share one catalog, neither replaces the other's).
       So a full disk or a kill leaves no empty or half-made file, and leaving the returned catalog's
       ``with`` block by an exception before any pattern is stored removes it again. An empty (0-byte)
       regular file counts as no catalog yet: readers refuse it as such, ``write=True`` makes the
       catalog in it, in place, in one SQLite transaction (so two writers cannot both make it).
    4. Anything that is not absent or a regular file (a folder, FIFO, device, socket; a symbolic link
       is followed and its target checked) is refused and never renamed over: ``--db /dev/zero`` must
       not replace the device with a file.

    Raises :class:`CatalogError` naming the real cause: missing, not a regular file, read-only, locked
    (for longer than :data:`LOCK_TIMEOUT`), disk full, damaged (with the ``sqlite3 FILE .recover``
    hint), not a fabpat catalog, or another schema.
    """
    p = builtin_path() if path is None else Path(path)
    if write and path is None:
        raise CatalogError("the built-in catalog is read-only here; give --db FILE")
    _refuse_special(p)
    if not write:
        if not p.is_file():
            what = "the built-in catalog" if path is None else "catalog"
            raise CatalogError(f"{what} {p} does not exist; create one with `fabpat sweep --db {p}`")
        if p.stat().st_size == 0:  # not damaged: a catalog not made yet (sweep makes one in it, as in a missing file)
            raise CatalogError(f"catalog {p} is an empty file (0 bytes), not a catalog yet; create one with "
                               f"`fabpat sweep --db {p}`")
        return Catalog(p, _checked_connection(p), False)
    if p.is_symlink():  # write the file it points to: SQLite's -wal/-shm files live next to that one
        p = Path(os.path.realpath(p))
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise CatalogError(f"cannot create catalog {p}: folder {folder} does not exist")
    created = replaced_empty = False
    if not p.exists():
        created = _create(p, folder)  # False: another process made it just now; use that one
    if not created:
        _refuse_special(p)
        if p.stat().st_size == 0:  # an empty file is a catalog not made yet
            _check_writable(p, folder)
            created = replaced_empty = _create_in_place(p)
        if not created:
            _checked_connection(p).close()  # read-only: a foreign or damaged file is refused unchanged
            _check_writable(p, folder)
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
        # a catalog made before the family table existed gains it; no write otherwise (two writers
        # opening one new catalog at once must not queue on a needless write lock)
        if not conn.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'family'").fetchone():
            with conn:
                conn.execute(_create_sql()[3])
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


#: the readers built on this module, in fabpat.catalog_read (which imports this one): part of this
#: module's API, imported on first use (PEP 562), as the package's own names are
_READERS = ("catalog", "energies", "polygon_energies", "require_polygon", "missing_polygon_message",
            "no_match_message", "held_setups")


def __getattr__(name: str) -> object:
    if name in _READERS:
        from fabpat import catalog_read

        return getattr(catalog_read, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


make_callable(__name__, "fabpat.catalog_read:catalog")
