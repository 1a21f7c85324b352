"""Copy simulated depth-3 patterns into the built-in catalog (how its depth-3 rows were made).

Run: ``python benchmarks/ship_depth3.py SOURCE.sqlite [SOURCE.sqlite …]`` — every depth-3 pattern of each source
catalog with its three scenarios stored and its Cylinder energy converged (the scenario the depth-3 rows serve:
the strips' designs and the range ``--learn`` widens), at the default set-up (36 mm, 2 mm, w = 0.2), with its
stored metrics, outline and results, goes into ``fabpat/data/catalog.sqlite`` (a pattern already there is
replaced). A scenario that did not converge keeps its row with its error and no energy, as every sweep stores it:
the softest depth-3 patterns snap under the Dome's load (a load-controlled solve cannot follow that).
Refused, with nothing written, if a source's rows come from another solver version than the built-in catalog's
(rows of one catalog share one solver; restamp first, as ``fabpat.catalog.restamp`` says). Afterwards refit the
learned response: ``python benchmarks/fit_response.py --write``.

The shipped rows were made by ``fabpat sweep --depth 3`` (docs/learned-response.md, "The shipped depth-3
patterns"): a seeded uniform sample and the patterns ``--learn`` chose.
"""

from __future__ import annotations

import argparse
import sqlite3
from pathlib import Path

from fabpat.catalog.read import builtin_path
from fabpat.catalog.schema import DEFAULT_SETUP

KEY = ("id", "sides", "depth", "edge", "thickness", "weight")


def _complete(src: sqlite3.Connection) -> list[tuple[object, ...]]:
    """Keys of the source's depth-3 patterns at the default set-up with three scenarios stored, Cylinder converged."""
    return src.execute(
        "SELECT id, sides, depth, edge, thickness, weight FROM results WHERE depth = 3 AND edge = ? AND "
        "thickness = ? AND weight = ? GROUP BY id, sides, depth, edge, thickness, weight "
        "HAVING COUNT(*) = 3 AND SUM(converged * (scenario = 'cylinder')) = 1",
        (DEFAULT_SETUP["edge"], DEFAULT_SETUP["thickness"], DEFAULT_SETUP["weight"])).fetchall()


def ship(sources: list[Path], target: Path) -> dict[str, int]:
    """Copy the complete depth-3 patterns of ``sources`` into ``target``; {source name: patterns copied}.
    SystemExit with one line if a source's solver version differs from the target's."""
    dst = sqlite3.connect(target)
    versions = {r[0] for r in dst.execute("SELECT DISTINCT solver_version FROM results")}
    copied: dict[str, int] = {}
    with dst:
        for source in sources:
            src = sqlite3.connect(source)
            theirs = {r[0] for r in src.execute("SELECT DISTINCT solver_version FROM results WHERE depth = 3")}
            if theirs - versions:
                raise SystemExit(f"{source}: rows of {', '.join(sorted(theirs - versions))}, the built-in catalog's "
                                 f"are {', '.join(sorted(versions))}: restamp or re-sweep first")
            keys = _complete(src)
            for table in ("patterns", "results"):
                cols = [r[1] for r in dst.execute(f"PRAGMA table_info({table})")]
                names = ", ".join(cols)
                marks = ", ".join("?" * len(cols))
                where = " AND ".join(f"{k} = ?" for k in KEY)
                for key in keys:
                    for row in src.execute(f"SELECT {names} FROM {table} WHERE {where}", key).fetchall():
                        dst.execute(f"INSERT OR REPLACE INTO {table} ({names}) VALUES ({marks})", row)
            copied[source.name] = len(keys)
            src.close()
    dst.close()
    return copied


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sources", nargs="+", type=Path, help="catalogs a `fabpat sweep --depth 3` filled")
    a = ap.parse_args()
    for name, n in ship(a.sources, builtin_path()).items():
        print(f"{name}: {n} depth-3 patterns copied into the built-in catalog")


if __name__ == "__main__":
    main()
