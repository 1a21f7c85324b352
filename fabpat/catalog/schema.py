"""The bottom of :mod:`fabpat.catalog`: its schema and where the built-in one lives (and, for the modules
above it, the catalog's error, :class:`fabpat.errors.CatalogError`).

The tables and their columns (:data:`PATTERN_COLUMNS`, :data:`RESULT_COLUMNS`, :data:`FAMILY_COLUMNS`,
see :mod:`fabpat.catalog`), the key of a row (:data:`KEY`), the set-up of the built-in catalog
(:data:`DEFAULT_SETUP`). Every other catalog module imports from this one and
this one imports none of them.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import TypedDict

from fabpat.errors import CatalogError  # noqa: F401 - the catalog modules import it from here

SCHEMA_VERSION = "1"
BUILTIN_NAME = "catalog.sqlite"

#: the default set-up of the built-in catalog (paper §4.1: hexagon of 36 mm edge, 2 mm PLA)
DEFAULT_SETUP = {"sides": 6, "depth": 2, "edge": 36.0, "thickness": 2.0, "weight": 0.2}



class Setup(TypedDict):
    """One set-up of a catalog (the key of its rows but the pattern ID): the polygon's ``sides``, the
    lattice ``depth``, ``edge`` (mm), plate ``thickness`` (mm) and bridge ``weight``."""

    sides: int
    depth: int
    edge: float
    thickness: float
    weight: float


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
#: ``family``: the results of a pattern's family members (:mod:`fabpat.patterns.variation`) other than the
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





def builtin_path() -> Path:
    """Path of the catalog shipped with the package (``fabpat/data/catalog.sqlite``)."""
    return Path(str(resources.files("fabpat") / "data" / BUILTIN_NAME))

