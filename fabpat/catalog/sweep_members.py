"""``fabpat sweep`` as a whole: the set-ups of the members it sweeps, their sweeps in turn, one report,
and what the catalog holds afterwards.

A plain sweep is one set-up (the paper's fillets, or the one member ``--variation bridge_weight=W``);
``--family`` sweeps the paper's and every standard member (:data:`fabpat.catalog.sweep.FAMILY_SAMPLES`) in
turn, then the adaptive midpoints (:func:`fabpat.catalog.sweep.refine_family`). Each member is a resumable
sweep of its own (:func:`fabpat.catalog.sweep.run_sweep`); :func:`sweep_members` adds their reports into one.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path

from fabpat.catalog import open_catalog
from fabpat.catalog.sweep import FAMILY_SAMPLES, SweepReport, SweepSetup, refine_family, run_sweep


def member_setups(setup: SweepSetup, family: bool) -> list[SweepSetup]:
    """The set-ups a sweep runs, in order: ``setup`` itself, or with ``family`` the paper's member
    (bridge_weight 1) and then each of :data:`~fabpat.catalog.sweep.FAMILY_SAMPLES`.

    Also refuses, before anything is computed, a sweep whose finer meshes could pass the element limit
    that protects every worker's memory (a sweep has no ``--max-elements``): GeometryError naming the h
    that fits, as :func:`fabpat.simulation.mesh_size.check_polygon_elements`.
    """
    from fabpat.simulation.mesh import DEFAULT_MAX_ELEMENTS, check_polygon_elements

    h = float(setup.h) if setup.h is not None else 0.0  # SweepSetup resolved it: never None here
    check_polygon_elements(setup.sides, setup.edge, h, DEFAULT_MAX_ELEMENTS, fine_ratio=(setup.h_fine or h) / h,
                           option="fixed for sweeps")
    if not family:
        return [setup]
    return [dataclasses.replace(setup, bridge_weight=w) for w in (1.0, *FAMILY_SAMPLES)]


def merge_reports(reports: Sequence[SweepReport]) -> SweepReport:
    """One report of several sweeps (of one list of patterns): counts, crashes and seconds added, the first
    one's ``patterns`` and ``rows``. Raises ValueError for no report (a caller's bug)."""
    if not reports:
        raise ValueError("merge_reports needs at least one report")
    first = reports[0]
    out = dataclasses.replace(first, crashed=list(first.crashed))
    for other in reports[1:]:
        out.computed += other.computed
        out.failed_rows += other.failed_rows
        out.skipped += other.skipped
        out.crashed += other.crashed
        out.seconds += other.seconds
    return out


def sweep_members(db: str | Path, ids: Sequence[str], setups: Sequence[SweepSetup], *, family: bool = False,
                  workers: int | None = None, dask: str | None = None, force: bool = False,
                  progress: Callable[[int, int], None] | None = None,
                  tell: Callable[[str], None] | None = None) -> tuple[SweepReport, int]:
    """Sweep ``ids`` into catalog ``db`` under each of ``setups`` in turn (:func:`member_setups`), then with
    ``family`` the adaptive refinements of the first one's family (:func:`~fabpat.catalog.sweep.refine_family`).

    ``tell`` gets one line per member when there are several, and one per refinement; ``progress``,
    ``workers``, ``dask``, ``force``: as :func:`~fabpat.catalog.sweep.run_sweep`. Returns the merged report
    (:func:`merge_reports`) and how many sweeps made it (members and refinements). Raises as ``run_sweep``;
    an interrupt (KeyboardInterrupt) propagates with every finished pattern stored.
    """
    reports = []
    for k, member in enumerate(setups):
        if len(setups) > 1 and tell is not None:
            tell(f"bridge_weight = {member.bridge_weight:g} ({k + 1} of {len(setups)})")
        reports.append(run_sweep(db, ids, member, workers=workers, dask=dask, force=force, progress=progress))
    if family:
        reports += refine_family(db, ids, setups[0], workers=workers, dask=dask, force=force, progress=progress,
                                 tell=tell)
    return merge_reports(reports), len(reports)


def mixed_energies(db: str | Path, setup: SweepSetup) -> tuple[int, int]:
    """(one-mesh, extrapolated) counts of the results of ``setup``'s polygon, depth and plate in catalog
    ``db``. Both nonzero: the catalog mixes energies that do not rank together (one-mesh energies are
    1.5–11 % low, docs/accuracy.md), as a sample sweep into a full catalog can make. Raises CatalogError
    for an unreadable ``db``."""
    with open_catalog(db) as cat:
        (row,) = cat.query("SELECT SUM(h_fine IS NULL) AS one, SUM(h_fine IS NOT NULL) AS two FROM results WHERE "
                           "sides = ? AND depth = ? AND edge = ? AND thickness = ? AND weight = ?",
                           (setup.sides, setup.depth, float(setup.edge), float(setup.thickness),
                            float(setup.weight)))
    one, two = row["one"], row["two"]  # SQL SUM: an integer, or NULL over no rows
    return one if isinstance(one, int) else 0, two if isinstance(two, int) else 0
