"""An open catalog (:class:`Catalog`: reading its tables, writing rows) and :func:`open_catalog`, the
one way fabpat opens a catalog file.

Built on :mod:`fabpat.catalog.schema` (the tables), :mod:`fabpat.catalog.rows` (checks of stored values)
and :mod:`fabpat.catalog.sqlite_file` (the file on disk); :mod:`fabpat.catalog.read` reads energies and
rows with it. What the tables hold: :mod:`fabpat.catalog`.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from fabpat.catalog.rows import check_row, pattern_problem, result_problem, specific_stiffness, stored_float
from fabpat.catalog.schema import (
    ADDED_COLUMNS,
    FAMILY_COLUMNS,
    KEY,
    METRICS,
    PATTERN_COLUMNS,
    RESULT_COLUMNS,
    CatalogError,
    builtin_path,
)
from fabpat.catalog.sqlite_file import (
    _cause,
    _check_writable,
    _checked_connection,
    _create,
    _create_in_place,
    _create_sql,
    _refuse_special,
    _tidy,
    connect,
)


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
        from fabpat.simulation.scenarios import SCENARIOS

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
        :class:`CatalogError` for an unknown filter or a bad stored value (see :mod:`fabpat.catalog`)."""
        where, params = _where({**setup, **({"scenario": scenario} if scenario else {})})
        rows = self.query(f"SELECT * FROM results{where} ORDER BY sides, depth, edge, thickness, weight, id, "
                          "scenario", params)
        for r in rows:
            check_row(self.path, r, METRICS)
        return [{**r, **{c: None for c in ADDED_COLUMNS["results"] if c not in r}} for r in rows]

    def pattern_rows(self, *, pictures: bool = False, **setup: object) -> list[dict[str, object]]:
        """One dict per pattern (wide form): key, metrics and, per scenario, ``energy_<s>`` (N·mm),
        ``max_displacement_<s>`` (mm), ``converged_<s>`` and ``specific_stiffness_<s>``
        (1/(N·mm³), :func:`~fabpat.catalog.rows.specific_stiffness`); None where no result is stored.

        ``setup`` filters by key columns (e.g. ``sides=6``); ``pictures`` adds ``svg_path``.
        :class:`CatalogError` for an unknown filter or a bad stored value (see :mod:`fabpat.catalog`).
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
            wide = by_key.get(tuple(q[k] for k in KEY))
            if wide is not None:
                check_row(self.path, q, METRICS)
                sc = str(q["scenario"])
                wide[f"energy_{sc}"] = q["energy"] if q["converged"] else None
                wide[f"max_displacement_{sc}"] = q["max_displacement"] if q["converged"] else None
                wide[f"converged_{sc}"] = bool(q["converged"])
        for r in rows:
            for s in scen:
                r[f"specific_stiffness_{s}"] = specific_stiffness(stored_float(r[f"energy_{s}"]),
                                                                  stored_float(r["filleted_area"]))
        return rows

    def number_columns(self, long: bool = False) -> list[str]:
        """The numeric columns of :meth:`pattern_rows` (``long``: of :meth:`results`) that rows can be
        filtered and sorted by (:func:`fabpat.catalog.rows.find_rows`), for this catalog's scenarios."""
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
        bad value (see :mod:`fabpat.catalog`) is left out, so a sweep recomputes it rather than trust it.
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
       file, fabpat's ``meta`` table, this :data:`~fabpat.catalog.schema.SCHEMA_VERSION`, every table and
       column, and ``PRAGMA quick_check``. A file that fails is refused *unchanged* (no tables added, no WAL switch).
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
    (for longer than :data:`~fabpat.catalog.sqlite_file.LOCK_TIMEOUT`), disk full, damaged (with the
    ``sqlite3 FILE .recover`` hint), not a fabpat catalog, or another schema.
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
        conn = connect(p, "rw")
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

