"""The closed-tiling design run behind :func:`fabpat.design.design` (method: :mod:`fabpat.design.closed`).

Order of work: the face groups and candidate pools, then one batch of the baselines (the base spec's
own patterns, ``spec`` or ``rule``; one single pattern on every face, ``single``), the space-filling
start designs, the Bayesian-optimisation rounds, and the record. With a pattern per face (``per`` "face") the
search runs over the face groups first, as ``per`` "group" does with the same budget, and then per face from the
groups' best design (:meth:`fabpat.design.closed.ClosedSearch.seeded`: every group solve is a face solve too, and
only changes of the best design are proposed) for :func:`face_budget` more solves; a face change is kept only when
its full solve is better, so a design per face is never worse than the design per group. The baselines' solves
come on top of the budget, as for a strip; every solve is counted in ``solves``. A design that does not vary its
patterns solves the base spec's own patterns alone (no ``single`` baseline, no pattern search) and leaves the budget
to the angles.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from fabpat.design.base import DesignBase, base_faces
from fabpat.design.closed import (
    MEMBER_SHARE,
    ClosedEvaluated,
    ClosedSearch,
    design_axis,
    face_groups,
    pattern_features,
    solve_closed,
)
from fabpat.design.search import Runner
from fabpat.design.stop import nothing_solved, until_stopped
from fabpat.design.target import ClosedTarget


def _single_key(search: ClosedSearch) -> tuple[int, ...] | None:
    """The single-pattern baseline: the paper's member in every group's pool nearest the pools' median
    features (a family member is no single pattern of the catalog)."""
    common = {pid for pid in search.pools[0][0] if " " not in pid}
    for ids, _ in search.pools[1:]:
        common &= set(ids)
    if not common:
        return None

    def cost(pid: str) -> float:
        return float(sum(np.linalg.norm(F[ids.index(pid)]) for ids, F in search.pools))

    pid = min(sorted(common), key=cost)
    return tuple(ids.index(pid) for ids, _ in search.pools)


#: with ``--per face``, the per-face refinement's solves after the group search, as a share of the patterns' budget
#: (rounded down), on top of it as the baselines are: the group search keeps its whole budget, so a design per face
#: is the design per group or one a solve showed better
FACE_SHARE = 1 / 3


def face_budget(max_solves: int) -> int:
    """The solves of the per-face refinement after a group search of ``max_solves`` (:data:`FACE_SHARE`)."""
    return int(max_solves * FACE_SHARE)


def design_closed(tgt: ClosedTarget, base: DesignBase, h: float, max_solves: int, tolerance: float, runner: Runner,
                  t0: float, result: Callable[..., Any], per: str = "face", angles: bool = False,
                  own: tuple[str, list[str]] | None = None, patterns: bool = True) -> Any:
    """Design a closed tiling for ``tgt`` (module doc) with ``runner`` (its deadline and a signal stop the
    search early, :mod:`fabpat.design.stop`); ``result`` builds the DesignResult. ``per``: a pattern per face
    group (polygon and latitude band: :func:`fabpat.design.closed.face_groups`) or per ``"face"``. ``angles``:
    then the best design's sleeve angles (:mod:`fabpat.design.closed_angles`), with
    :func:`~fabpat.design.closed_angles.angle_budget` of ``max_solves``. ``own``: the base spec's own choice
    (:func:`fabpat.design.base.base_faces` of the base before any mapping; None: of ``base``). ``patterns``
    False: ``own`` is the design's patterns (no pattern search; the angles get all of ``max_solves``). Raises
    SpecError (``patterns`` False and no ``own``), SolverError (nothing solved)."""
    from fabpat.assembly.place.placement import build_tiling
    from fabpat.design.closed_angles import AnglePhase, angle_budget, vary_angles
    from fabpat.errors import SpecError

    assert base.rows is not None
    skel = build_tiling(base.spec)
    groups, sides = face_groups(skel.V, skel.faces, tgt.bands)
    pool = {n: pattern_features(base.rows[n]) for n in set(sides)}
    runner.solve = solve_closed
    axis = design_axis(skel.V, skel.faces)
    search = ClosedSearch([pool[s] for s in sides], groups, sides, tgt, axis, base.spec.material.strain_limit,
                          base.max_distinct, runner)
    faces_search = None
    if per == "face":  # every face its own group, refined from the groups' best (module doc)
        face_sides = [len(loop) for loop in skel.faces]
        faces_search = ClosedSearch([pool[s] for s in face_sides], list(range(len(skel.faces))), face_sides, tgt, axis,
                                    base.spec.material.strain_limit, base.max_distinct, runner)
    labels = list(skel.labels)
    runs: dict[str, ClosedEvaluated] = {}
    way = base_faces(base) if own is None else own
    if not patterns and way is None:
        raise SpecError(f"{base.spec.source}: --vary without patterns keeps the base spec's patterns: name them in "
                        "its [patterns]")
    asked = max_solves  # the user's --max-solves, as messages quote it
    for_angles = (angle_budget(max_solves) if patterns else max_solves) if angles else 0
    max_solves -= for_angles

    def work() -> None:  # every solve finished is kept in runs and search.seen, stopped or not
        _baselines(search, way, runner, tgt, runs, single=patterns)
        if not patterns:  # the base's own patterns are the design
            return
        budget = max_solves + runner.solves
        members = search.has_members()
        if members:  # the paper's members first, then the best design's own families (closed module doc)
            search.papers_only()
        search.evaluate([k for k in search.start()][: max(0, budget - runner.solves)])
        search.refine(budget - (int(max_solves * MEMBER_SHARE) if members else 0), max(2, runner.workers))
        if members and search.best is not None:
            search.around_best()
            search.refine(budget, max(2, runner.workers))
        if faces_search is not None and search.best is not None:
            faces_search.seeded(search)
            faces_search.refine(runner.solves + face_budget(max_solves), max(2, runner.workers))

    stopped = until_stopped(work, runner.deadline)
    if faces_search is not None and faces_search.best is not None:  # per face: the groups' solves are in it
        search = faces_search
        groups = list(range(len(skel.faces)))
    candidates = [ev for ev in (search.best, *runs.values()) if ev is not None]
    if not candidates:
        nothing_solved(stopped, runner.solves, runner.failures, h)
    best = min(candidates, key=lambda ev: ev.score)
    phase = AnglePhase()
    if angles and stopped is None:
        patterns_best = best
        stopped = until_stopped(lambda: vary_angles(phase, tgt, base.spec, patterns_best, h, for_angles, runner,
                                                    search.axis), runner.deadline)
        if phase.best is not None:
            best = phase.best
    faces = list(best.data["faces"])
    rec = _record(tgt, base, best, labels, faces, runner.solves, time.perf_counter() - t0, tolerance, runs)
    if angles:
        rec["angles"] = phase.record
        rec["gradient_check"] = phase.gradient_check
        rec["sleeve_angles"] = phase.angles
    rec["history"] = [_brief(ev, labels) for ev in search.seen.values() if ev is not None]
    rec["candidates"] = {POLYGONS.get(n, f"{n}-gon"): _pool_counts(base.rows[n])
                         for n in sorted(base.rows, reverse=True)}
    if base.notes:
        rec["notes"] = list(base.notes)
    if stopped is not None:
        rec["stopped_by"] = stopped
    warning = None if rec["reachable"] else _unreachable(rec, tolerance, asked, best, patterns)
    return result(rec, base, tgt, best, labels, groups, warning, runs)


def _float(v: float | None) -> float | None:
    """A read-out that may be None (a tube has no sphere: JSON null)."""
    return None if v is None else float(v)


#: polygon names of design.json's ``candidates``
POLYGONS = {6: "hexagon", 5: "pentagon"}


def _pool_counts(rows: list[dict[str, Any]]) -> dict[str, int]:
    """How many candidates a polygon had: ``patterns`` (the paper's members) and ``members`` (family
    members, :mod:`fabpat.assembly.choose.members`)."""
    members = sum(1 for r in rows if "bridge_weight" in r)
    return {"patterns": len(rows) - members, "members": members}


def _baselines(search: ClosedSearch, way: tuple[str, list[str]] | None, runner: Runner, tgt: ClosedTarget,
               runs: dict[str, ClosedEvaluated], single: bool = True) -> None:
    """Solve the baselines in one batch into ``runs``: the base spec's own patterns ``way`` (``spec`` or ``rule``,
    :func:`fabpat.design.base.base_faces`) and, with ``single``, the ``single`` pattern; a base choice that is not
    one pattern per group (per-face tiles) is solved as given."""
    keyed: dict[str, tuple[int, ...]] = {}
    given: dict[str, tuple[str, ...]] = {}
    if way is not None:
        key = search.key_of(way[1])
        if key is None:
            given[way[0]] = tuple(way[1])
        else:
            keyed[way[0]] = key
    one = _single_key(search) if single else None
    if one is not None:
        keyed["single"] = one
    try:
        search.evaluate(list(keyed.values()))
    finally:  # a stop in the batch keeps the baselines that finished
        runs.update({name: ev for name, k in keyed.items() if (ev := search.seen.get(k)) is not None})
    for name, faces in given.items():
        res = runner.run([faces])[0]
        if not isinstance(res, BaseException):
            runs[name] = ClosedEvaluated((), tgt.fit(res["P"], search.axis), res,
                                         res["peak_strain"] > search.strain_limit)


def _group_ids(faces: list[str], labels: list[str]) -> dict[str, str]:
    """{label prefix or label: ID}: one entry per polygon when all its faces agree, else per face."""
    out: dict[str, str] = {}
    for prefix, name in (("H", "hexagon"), ("P", "pentagon")):
        ids = {f for f, lab in zip(faces, labels, strict=True) if lab.startswith(prefix)}
        if len(ids) == 1:
            out[name] = next(iter(ids))
        else:
            out.update({lab: f for f, lab in zip(faces, labels, strict=True) if lab.startswith(prefix)})
    return out


def _brief(ev: ClosedEvaluated, labels: list[str]) -> dict[str, Any]:
    """One solve of the search for design.json's ``history``."""
    return {"patterns": _group_ids(list(ev.data["faces"]), labels),
            "relative_rms": float(ev.fit.relative_rms), "peak_strain": float(ev.data["peak_strain"])}


def _summary(ev: ClosedEvaluated, faces: list[str], labels: list[str]) -> dict[str, Any]:
    ids = sorted(set(faces))
    what: dict[str, Any] = {"pattern": ids[0]} if len(ids) == 1 else {"patterns": _group_ids(faces, labels)}
    return {**what, "rms_error": ev.rms, "max_error": ev.max, "relative_rms": float(ev.fit.relative_rms),
            "peak_strain": float(ev.data["peak_strain"]), "sphericity_rms": _float(ev.data["sphericity_rms"])}


def _record(tgt: ClosedTarget, base: DesignBase, best: ClosedEvaluated, labels: list[str], faces: list[str],
            solves: int, seconds: float, tolerance: float, runs: dict[str, ClosedEvaluated]) -> dict[str, Any]:
    rel = float(best.fit.relative_rms)
    baselines = {}
    for name, ev in runs.items():
        baselines[name] = _summary(ev, list(ev.data["faces"]), labels)
    return {
        "target": tgt.source, "kind": base.spec.tiling.kind,
        "patterns": dict(zip(labels, faces, strict=True)),
        "rms_error": best.rms, "max_error": best.max, "relative_rms": rel, "scale": float(best.fit.scale),
        "radius": float(best.fit.radius), "sphericity_rms": _float(best.data["sphericity_rms"]),
        "peak_strain": float(best.data["peak_strain"]), "strain_limit": base.spec.material.strain_limit,
        "solves": solves, "seconds": seconds, "reachable": bool(rel <= tolerance and not best.over_limit),
        "tolerance": tolerance, "baselines": baselines,
    }


def _unreachable(rec: dict[str, Any], tolerance: float, max_solves: int, best: ClosedEvaluated,
                 patterns: bool = True) -> str:
    head = (f"target not reached: rms error {rec['rms_error']:.3g} mm is {rec['relative_rms']:.2%} of the radius "
            f"(tolerance {tolerance:.2%})")
    if best.over_limit and rec["relative_rms"] <= tolerance:
        head = (f"the shape is reached (rms error {rec['relative_rms']:.2%} of the radius) but the kit cannot be "
                "built")
    errs = [h["relative_rms"] for h in rec["history"]] if rec.get("history") else [rec["relative_rms"]]
    if best.over_limit:
        why = (f"the closest design found strains its plates to {rec['peak_strain']:.2%}, over the strain limit "
               f"{rec['strain_limit']:.2%} (thinner plates, [plates] thickness, strain less)")
    elif not patterns:
        why = "the base spec's own patterns, kept (--vary without patterns): add patterns to --vary to search them"
    else:
        why = (f"the best of {rec['solves']} solves (--max-solves {max_solves}; the baselines, the per-face "
               f"refinement and the gradient check come on top), whose designs ranged from {min(errs):.2%} to "
               f"{max(errs):.2%} of the radius: more solves may get closer, but the patterns move a tiling's "
               "shape only that much; a shape far from its own assembled shape needs another tiling or other "
               "sleeve angles")
    return f"{head}: {why}"
