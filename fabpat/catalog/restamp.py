"""Carrying a catalog's stored results over to a new solver version without recomputing them.

The solver version (:func:`fabpat.catalog.solver_version`) names the code a stored result came from,
and every row's input hash includes it, so a sweep recomputes a row whose version differs. When only
the way the version is *computed* changes (as when it stopped hashing which file holds which
statement: :mod:`fabpat.catalog.version`), the code that ran is the same and the stored numbers stand:
:func:`restamp` rewrites each row's version and input hash instead of 16 000 solves (about 3 h on the
2-core machine). It proves nothing about the code: the caller states that the pipeline under ``old``
and under ``new`` is one program, and it checks that every row really was stored under ``old``.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import tempfile
from dataclasses import dataclass
from pathlib import Path

from fabpat.catalog import CatalogError, solver_version
from fabpat.catalog.sweep import SweepSetup, fine_mesh, pattern_hash, result_hash

_KEY = ("id", "sides", "depth", "edge", "thickness", "weight")


@dataclass(frozen=True)
class RestampReport:
    """Rows rewritten per table (``patterns``, ``results``, ``family``) and the two versions."""

    rows: dict[str, int]
    old: str
    new: str


def restamp(db: str | Path, old: str, new: str | None = None) -> RestampReport:
    """Rewrite the catalog file ``db`` from solver version ``old`` to ``new`` (default: this code's).

    Every row of ``patterns``, ``results`` and ``family`` must hold the input hash that ``old`` gives its
    inputs, and every results and family row the version ``old``; then each hash is recomputed with
    ``new`` and the file replaced at once (a copy, then rename). Raises CatalogError naming the first
    row that was not stored under ``old`` (nothing is written), or for a file that is not a catalog.
    """
    new = solver_version() if new is None else new
    path = Path(db)
    if not path.is_file():
        raise CatalogError(f"{path}: no such catalog file")
    fd, tmp = tempfile.mkstemp(suffix=".sqlite", dir=path.parent)
    os.close(fd)
    try:
        shutil.copyfile(path, tmp)
        shutil.copymode(path, tmp)  # mkstemp makes it private: the catalog keeps its own permissions
        con = sqlite3.connect(tmp)
        con.row_factory = sqlite3.Row
        counts = _rewrite(con, old, new)
        con.commit()
        con.execute("VACUUM")
        con.close()
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return RestampReport(counts, old, new)


def _rewrite(con: sqlite3.Connection, old: str, new: str) -> dict[str, int]:
    counts: dict[str, int] = {}
    try:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    except sqlite3.DatabaseError as e:
        raise CatalogError(f"not a catalog: {e}") from e
    for table in ("patterns", "results", "family"):
        if table not in tables:
            continue
        rows = con.execute(f"SELECT rowid, * FROM {table}").fetchall()  # noqa: S608 - a fixed table name
        # the meshes rows store, and the sweep's default set-ups: rows whose every neck lowered the mesh
        # (a depth-3 sample) store none of the set-up's own h, which their hash keeps
        setups = sorted({float(r["h"]) for r in rows if "h" in r.keys() and r["h"] is not None}
                        | {float(SweepSetup().h or 0.0), float(SweepSetup(extrapolate=False).h or 0.0)}, reverse=True)
        updates = []
        for r in rows:
            where = f"{table} row {dict(zip(_KEY, (r[k] for k in _KEY), strict=True))}"
            if table == "patterns":
                ok = pattern_hash(*(r[k] for k in _KEY), old) == r["input_hash"]
                fresh = pattern_hash(*(r[k] for k in _KEY), new) if ok else None
            else:
                if r["solver_version"] != old:
                    raise CatalogError(f"{where} has solver version {r['solver_version']!r}, not {old!r}")
                fresh = _retag(r, new, setups)
            if fresh is None:
                raise CatalogError(f"{where}: its input hash is not the one {old!r} gives its inputs")
            updates.append((fresh, r["rowid"]))
        con.executemany(f"UPDATE {table} SET input_hash = ? WHERE rowid = ?", updates)  # noqa: S608
        if table != "patterns":
            con.execute(f"UPDATE {table} SET solver_version = ?", (new,))  # noqa: S608
        counts[table] = len(updates)
    return counts


def _retag(row: sqlite3.Row, new: str, setups: list[float]) -> str | None:
    """The input hash of a results or family row under ``new``, or None if no set-up reproduces its stored
    hash under its own version. Each set-up mesh size of ``setups`` (mm) is tried: a row stores the mesh
    it used, which a narrow neck lowers below the set-up's, while its hash keeps the set-up's
    (:func:`fabpat.catalog.sweep.simulate_pattern`)."""
    bw = float(row["bridge_weight"]) if "bridge_weight" in row.keys() else 1.0
    old = row["solver_version"]
    for h in setups:
        for h_fine in ((None, fine_mesh(h)) if row["h_fine"] is not None else (None,)):
            args = (row["id"], row["sides"], row["depth"], row["edge"], row["thickness"], row["weight"], row["E"],
                    row["nu"], h, row["scenario"])
            if result_hash(*args, old, h_fine, bw) == row["input_hash"]:
                return result_hash(*args, new, h_fine, bw)
    return None
