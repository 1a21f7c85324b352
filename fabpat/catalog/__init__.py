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
  h_fine (``fabpat sweep --extrapolate``, :mod:`fabpat.simulation.convergence`) and the other fields are the
  h_fine mesh's (``seconds`` summed over both).

``input_hash`` digests every input that affects a result (the key, the material, h, nonlinear, the
solver version — which includes a digest of the source of every module the pipeline imports, see
:func:`fabpat.catalog.version.pipeline_modules`): a sweep skips a row whose stored hash equals the one
it would compute, so changing any input or the solver code recomputes exactly the affected rows.

Readers: :func:`open_catalog` (``None`` → the built-in catalog shipped in ``fabpat/data``),
:meth:`Catalog.pattern_rows` (one plain dict per pattern with ``energy_<scenario>`` and
``specific_stiffness_<scenario>`` columns, see :func:`fabpat.catalog.rows.specific_stiffness`),
:meth:`Catalog.query`,
:func:`energies` and :func:`polygon_energies` (one polygon's own energies, for the assembly rules).
Calling the module is :func:`catalog`: ``fabpat.catalog()`` → those rows as a list
(:class:`fabpat.catalog.rows.CatalogRows`: filter, sort, top N, ``to_dataframe()`` with pandas).

What is read back is checked as strictly as what a user types (a catalog is a file anyone can edit):
an energy must be a finite, positive number (a converged row must have one), a displacement and every
metric finite; a row that is not raises :class:`CatalogError` naming the catalog, the pattern, the
scenario and the value, so that no listing, picture or assembly rule ever uses it. A sweep recomputes
such rows (their stored hash is not trusted).

The package, each module importing only the ones listed before it:
:mod:`~fabpat.catalog.schema` (:class:`CatalogError`, the tables, the built-in catalog's path),
:mod:`~fabpat.catalog.version` (the solver version and input hashes),
:mod:`~fabpat.catalog.rows` (checks of stored values, finding rows, :class:`~fabpat.catalog.rows.CatalogRows`),
:mod:`~fabpat.catalog.sqlite_file` (checking, making and tidying the file on disk),
:mod:`~fabpat.catalog.store` (:class:`Catalog`, :func:`open_catalog`),
:mod:`~fabpat.catalog.read` (:func:`catalog`, :func:`energies`, :func:`polygon_energies`). This
package is their public face: the public names of each (of :mod:`~fabpat.catalog.rows`, the row checks,
:func:`~fabpat.catalog.rows.specific_stiffness` and :class:`~fabpat.catalog.rows.CatalogRows`) are also
``fabpat.catalog.<name>``.
"""

from __future__ import annotations

from fabpat._callable import make_callable
from fabpat.catalog.read import (
    catalog,
    default_depth,
    energies,
    held_setups,
    missing_polygon_message,
    no_filter_match_message,
    no_match_message,
    polygon_energies,
    require_depth,
    require_polygon,
)
from fabpat.catalog.rows import CatalogRows, check_row, pattern_problem, result_problem, specific_stiffness
from fabpat.catalog.schema import (
    ADDED_COLUMNS,
    BUILTIN_NAME,
    DEFAULT_SETUP,
    FAMILY_COLUMNS,
    FAMILY_KEY,
    KEY,
    METRICS,
    PATTERN_COLUMNS,
    RESULT_COLUMNS,
    SCHEMA_VERSION,
    CatalogError,
    builtin_path,
)
from fabpat.catalog.sqlite_file import LOCK_TIMEOUT
from fabpat.catalog.store import Catalog, open_catalog
from fabpat.catalog.version import input_hash, pipeline_modules, solver_version

__all__ = [
    "ADDED_COLUMNS", "BUILTIN_NAME", "DEFAULT_SETUP", "FAMILY_COLUMNS", "FAMILY_KEY", "KEY", "LOCK_TIMEOUT",
    "METRICS", "PATTERN_COLUMNS", "RESULT_COLUMNS", "SCHEMA_VERSION", "Catalog", "CatalogError", "CatalogRows",
    "builtin_path", "catalog", "check_row", "default_depth", "energies", "held_setups", "input_hash",
    "missing_polygon_message", "no_filter_match_message", "no_match_message", "open_catalog", "pattern_problem",
    "pipeline_modules",
    "polygon_energies", "require_depth", "require_polygon", "result_problem", "solver_version", "specific_stiffness",
]

make_callable(__name__, catalog)
