"""``design``: a target shape in, one pattern per tile out (the Python front door of ``fabpat design``).

Order of work: read and check the target and the base spec (every refusal before the first solve),
fix the end shortening from the target's span, solve the baselines (one parallel batch), design on
the elastica and correct it with each solve (:mod:`fabpat.design.mapping`), polish with the pattern
search (:mod:`fabpat.design.search`), then write the outputs (:mod:`fabpat.design.outputs`) if ``out``
is given.
"""

from __future__ import annotations

import math
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from fabpat.design.base import DesignBase, base_faces, load_base
from fabpat.design.beam import Elastica
from fabpat.design.mapping import space_mapping
from fabpat.design.search import Evaluated, Runner, Search
from fabpat.design.stop import nothing_solved, stop_phrase, until_stopped
from fabpat.design.strip import column_needs, column_turning, errors, pin_length
from fabpat.design.target import ClosedTarget, StripTarget, TargetError, read_target, require_match

#: largest relative difference between the target's arc length and the strip's pin-to-pin length
#: before the target is refused (the strip is inextensible: its mid-line keeps its length)
ARC_TOLERANCE = 0.02
#: default solve budget of the search (the baselines come on top): a strip's, a closed tiling's
#: (no reduced model guides it: docs/design.md)
MAX_SOLVES = 12
MAX_SOLVES_CLOSED = 60  # 40 over the paper's members and 20 around the best (closed.MEMBER_SHARE)
#: default reachability tolerance: relative_rms (rms error over the span) at most 1 %
TOLERANCE = 0.01


@dataclass(frozen=True, eq=False)
class DesignResult:
    """The design: ``record`` the design.json fields, ``spec`` the design's AssemblySpec, ``base``,
    ``target`` (as designed, after any scaling), ``best`` the solved design, ``labels`` the plate labels,
    ``warning`` the one-line unreachable warning (None when reachable)."""

    record: dict[str, Any]
    base: DesignBase
    target: StripTarget | ClosedTarget
    best: Any  # Evaluated (strip) or fabpat.design.closed.ClosedEvaluated
    labels: list[str]
    face_col: list[int]  # strip: each face's column; closed: each face's group
    warning: str | None
    baseline_runs: dict[str, Evaluated] = field(default_factory=dict)
    #: extra files written beside design.toml, by name (a mapped tiling's mesh)
    files: dict[str, bytes] = field(default_factory=dict)

    def write(self, out: str | os.PathLike[str], kit: bool = False) -> list[str]:
        """Write design.toml, design.json, design.png (and with ``kit`` the kit in out/kit) atomically;
        returns the files written, relative to ``out``."""
        from fabpat.design.outputs import write_design

        return write_design(self, out, kit)


def _geometry(base: DesignBase, pattern: str, h: float) -> tuple[float, list[str], list[int], tuple[float, ...]]:
    """Pin-to-pin length (mm), plate labels, the column of each face and the columns' edges in arc length
    from the fixed pin (mm: 0, the midpoints between neighbouring columns' centres, the length), from one
    placement."""
    from fabpat.assembly.place.placement import build_tiling
    from fabpat.assembly.solve.strip import strip_setup
    from fabpat.design.search import with_candidates

    n = len(build_tiling(base.spec).faces)
    spec, ids = with_candidates(base.spec, [pattern] * n)
    setup = strip_setup(spec, ids, h=h)
    grid = build_tiling(spec).grid
    assert grid is not None
    face_col = [int(g[1]) for g in grid]
    m = setup.model
    left = float(m.X[setup.left, 0].mean())
    cx = np.array([m.X[m.offsets[f]:m.offsets[f + 1], 0].mean() for f in range(n)]) - left
    centres = [float(cx[[f for f in range(n) if face_col[f] == c]].mean()) for c in range(max(face_col) + 1)]
    length = pin_length(setup)
    edges = (0.0, *(0.5 * (a + b) for a, b in zip(centres[:-1], centres[1:], strict=True)), length)
    return length, [p.label for p in setup.model.plates], face_col, edges


def _check_arc(target: StripTarget, length: float, scale_target: bool) -> tuple[StripTarget, float]:
    arc = target.arc_length
    if abs(arc - length) <= ARC_TOLERANCE * length:
        return target, 1.0
    if not scale_target:
        raise TargetError(f"target {target.source}: its arc length {arc:.1f} mm differs from the strip's pin-to-pin "
                          f"length {length:.1f} mm by more than {ARC_TOLERANCE:.0%} (the strip is inextensible): "
                          "give a target of that length or use --scale-target")
    factor = length / arc
    return target.scaled(factor), factor


def unvaried_note(tgt: object, vary_words: tuple[str, ...] | list[str]) -> str | None:
    """The note saying which asked-for ``--vary`` words this search keeps fixed (None: none), for design.json and
    the dry run's plan alike: a closed target's angles are varied (fabpat.design.closed_angles); a strip's
    angles and the thickness are not. Said, not silently dropped: the search's variables are the patterns (and
    a closed target's shapes)."""
    closed = isinstance(tgt, ClosedTarget)
    fixed = [w for w in ("angles", "thickness") if w in vary_words and not (w == "angles" and closed)]
    if not fixed:
        return None
    keeps = {"angles": "a strip's joints are flat and straight: its sleeves keep their flat angle",
             "thickness": "the plates keep the base's [plates] thickness (give [plates] thicknesses in the spec to "
                          "set them)"}
    return f"{' and '.join(fixed)}: not varied by this search; {'; '.join(keeps[w] for w in fixed)}"


def checked_inputs(target: object, spec: object, out: str | os.PathLike[str] | None, per: object, vary: object,
                   scale_target: bool) -> tuple[StripTarget | ClosedTarget, DesignBase, str, tuple[str, ...]]:
    """What :func:`design` and its dry run (:mod:`fabpat.design.dry_run`) check before the first solve, in this
    order: ``spec`` a path, the output folder ``out`` (None: none), ``per`` and the ``vary`` words
    (:mod:`fabpat.design.mapped`), the target, the base spec and that they match, ``shapes`` only for a closed
    target, ``scale_target`` only for a strip, and a closed design without ``patterns`` keeping a base that
    names its patterns. Returns (target, base, per, vary words; a sphere drops ``shapes``: its base faces are
    a sphere's already). Raises SpecError, TargetError, ExportError (one line each)."""
    from fabpat.design.mapped import DEFAULT_VARY_STRIP, read_per, read_vary
    from fabpat.errors import ExportError, SpecError
    from fabpat.validate import check_path

    if not isinstance(spec, str | os.PathLike):
        raise SpecError(f"spec must be the path of a TOML spec file, got {type(spec).__name__}")
    if out is not None:
        from fabpat.design.outputs import check_design_out

        check_path(out, "out", error=ExportError)
        check_design_out(out)
    per_word = read_per(per)
    read_vary(vary, True)  # its words checked before the target is read
    tgt = read_target(target)
    vary_words = read_vary(vary, isinstance(tgt, ClosedTarget) and not tgt.open) if vary is not None or \
        isinstance(tgt, ClosedTarget) else DEFAULT_VARY_STRIP
    base = load_base(spec)
    require_match(tgt, base.spec.source, base.spec.tiling.kind)
    if not isinstance(tgt, ClosedTarget):
        if "shapes" in vary_words:
            raise SpecError("--vary shapes maps a closed tiling onto its target; a strip's plates are its own "
                            "(leave shapes out)")
        if "patterns" not in vary_words:  # its angles and thickness are kept: nothing would be varied
            raise SpecError("a strip's design varies its patterns: --vary must include patterns (a strip's "
                            "sleeves keep their flat angle and its plates the [plates] thickness)")
        return tgt, base, per_word, vary_words
    if scale_target:
        raise SpecError("scale_target applies to strip targets (a closed target has no size: the plates fix it)")
    if "patterns" not in vary_words and base.way is None:
        raise SpecError(f"{base.spec.source}: --vary without patterns keeps the base spec's patterns: name them in "
                        "its [patterns]")
    if "shapes" in vary_words and tgt.open:
        raise SpecError(f"--vary shapes maps a closed tiling onto its target; an open tiling ({base.spec.tiling.kind}) "
                        "keeps its own faces: give --vary among patterns, angles, thickness")
    if "shapes" in vary_words and tgt.kind == "sphere":  # the base's faces are a sphere's already: kept, and
        vary_words = tuple(w for w in vary_words if w != "shapes")  # their plates stay a few part types
    return tgt, base, per_word, vary_words


def design(target: Any, spec: str | os.PathLike[str], *, out: str | os.PathLike[str] | None = None,
           h: float = 3.0, max_solves: int | None = None, tolerance: float = TOLERANCE, scale_target: bool = False,
           workers: int = 1, dask: str | None = None, kit: bool = False,
           progress: Callable[[int, float], None] | None = None, max_minutes: float | None = None,
           status: Callable[[str], None] | None = None, per: str = "face",
           vary: str | list[str] | tuple[str, ...] | None = None) -> DesignResult:
    """Design an assembly whose predicted shape matches ``target``: one pattern per tile.

    ``target``: for a honeycomb-strip spec a CSV path (header x,z, mm) or an (n, 2) array of (x, z) mm; for a
    closed tiling (:data:`fabpat.design.base.CLOSED_KINDS`) "sphere", "ellipsoid:A,B,C" or a surface mesh file
    (OBJ, STL, PLY; :mod:`fabpat.design.closed`); for a hex-cap "cap:H", for a hex-tube "revolution:R0,…,Rk"
    (:mod:`fabpat.design.revolution`); a path that exists is a file, whatever its name
    (:func:`fabpat.design.target.read_target`); ``spec``: the base spec (TOML path; :mod:`fabpat.design.base`).
    ``h`` mesh edge (mm) of every solve; ``max_solves`` the search's budget of full assembly solves (the baselines come
    on top; default :data:`MAX_SOLVES` for a strip, :data:`MAX_SOLVES_CLOSED` for a closed tiling);
    ``tolerance``: reachable when relative_rms (rms over the span, or over the radius) ≤ it; ``scale_target``
    scales a strip target whose arc length is off by > 2 % to the strip's length; ``workers`` local processes
    or ``dask`` a scheduler address for the parallel solves; ``out`` writes the outputs there (``kit``: also
    ``fabpat assemble`` into out/kit); ``progress(solves, seconds)`` after every solve; ``status(text)`` hears
    what the solves are doing (increment, λ, factorizations; the kernels' first compilation; an abandoned
    solve and why).

    ``per`` ("face" or "group"): a closed design's pattern per face (the group search, then per face from its best:
    :mod:`fabpat.design.closed_api`), or per face group (polygon and latitude band,
    :func:`fabpat.design.closed.face_groups`); ``vary``: the design variables, words of
    :data:`fabpat.design.mapped.VARY` (a comma-separated string or a list; default ``shapes,patterns`` for a closed
    target, ``patterns,angles`` for a strip). With ``shapes`` a closed design's tiling is the base's mapped onto the
    target and relaxed into flat, nearly regular faces, its plates shaped to them (:mod:`fabpat.design.mapped`);
    a strip's shapes are its target's and take no ``shapes``. Without ``patterns`` a closed design keeps the base
    spec's own patterns (its ``spec`` or ``rule`` baseline, the only patterns solved; a base that names none is
    refused before any solve), and ``angles`` get the whole budget.

    Stopping early (:mod:`fabpat.design.stop`): a Ctrl-C (KeyboardInterrupt; SIGTERM under the CLI) or the
    time budget ``max_minutes`` (minutes from the call) ends the search, and the best design of the
    solves finished so far is returned (and written to ``out``) with ``record["interrupted"]`` True,
    ``record["stopped_by"]`` ("SIGINT", "SIGTERM" or "max_minutes") and the reason in ``warning``; a
    stop before any solve finished re-raises the KeyboardInterrupt, or raises SolverError for the budget.
    ``record["interrupted"]`` is False for a finished run; ``record["abandoned"]`` lists the solves that
    failed (their distinct patterns and the solver's reason, e.g. a path that stalled).

    Raises TargetError, SpecError (bad input, one line, before the first solve: a target or spec that is a FIFO
    or device, too large, or of a tiling kind a design does not take), SolverError (no candidate converged, or the
    budget ran out before any did), ExportError (outputs).
    """
    from fabpat.errors import SpecError

    t0 = time.perf_counter()
    import fabpat.design.ranges  # noqa: F401 - registers max_solves' and design_tolerance's ranges
    from fabpat.validate import check

    if max_solves is not None:
        max_solves = int(check("max_solves", max_solves, "max_solves", error=SpecError))
    if max_minutes is not None:
        max_minutes = check("max_minutes", max_minutes, "max_minutes", error=SpecError)
    workers = int(check("workers", workers, "workers", error=SpecError))
    tolerance = check("design_tolerance", tolerance, "tolerance", error=SpecError)
    h = check("h", h, "h", error=SpecError)
    for name, flag in (("scale_target", scale_target), ("kit", kit)):
        if not isinstance(flag, bool):
            raise SpecError(f"{name} must be True or False, got {flag!r}")
    if kit and out is None:
        raise SpecError("kit=True writes the kit into out/kit: give out as well")
    if dask is not None and not isinstance(dask, str):
        raise SpecError(f"dask must be a scheduler address such as 'tcp://host:8786' or None, "
                        f"got {type(dask).__name__}")
    for name, fn in (("progress", progress), ("status", status)):
        if fn is not None and not callable(fn):
            raise SpecError(f"{name} must be a callable or None, got {type(fn).__name__}")
    tgt, base, per, vary_words = checked_inputs(target, spec, out, per, vary, scale_target)
    deadline = None if max_minutes is None else t0 + 60.0 * max_minutes
    runner = Runner(base.spec, h, (), workers, dask, progress, status=status, deadline=deadline)
    if isinstance(tgt, ClosedTarget):
        from fabpat.design.closed_api import design_closed

        mapped = None
        own = base_faces(base)  # before the mapping: a mapped base's patterns are a placeholder
        if "shapes" in vary_words:
            from fabpat.design.mapped import mapped_base

            base, mapped = mapped_base(tgt, base)
            runner = Runner(base.spec, h, (), workers, dask, progress, status=status, deadline=deadline)
        try:
            res = design_closed(tgt, base, h, MAX_SOLVES_CLOSED if max_solves is None else max_solves, tolerance,
                                runner, t0, DesignResult, per=per, angles="angles" in vary_words, own=own,
                                patterns="patterns" in vary_words)
        finally:  # the mapped mesh's temporary folder: design.toml's own copy is written with the outputs
            if mapped is not None:
                shutil.rmtree(mapped.folder, ignore_errors=True)
        res.record["per"] = per
        if mapped is not None:
            res.record["face_irregularity"] = mapped.face_irregularity
            res.record["mapped"] = {"file": "mapped.obj", "planarity": mapped.planarity,
                                    "distance_rms": mapped.distance_rms, "seconds": mapped.seconds}
            res = replace(res, files={"mapped.obj": mapped.obj})
    else:
        res = _design_strip(tgt, base, h, MAX_SOLVES if max_solves is None else max_solves, tolerance,
                            scale_target, runner, t0)
    res.record["vary"] = list(vary_words)
    res.record["variables"] = _variables(res, vary_words)
    unvaried = unvaried_note(tgt, vary_words)
    if unvaried is not None:
        res.record.setdefault("notes", []).append(unvaried)
    stopped = res.record.get("stopped_by")
    res.record["interrupted"] = stopped is not None
    res.record["abandoned"] = list(runner.failures)
    if stopped is not None:
        phrase = stop_phrase(stopped, runner.solves, max_minutes)
        res = replace(res, warning=phrase if res.warning is None else f"{phrase}; {res.warning}")
    res.record["h"] = h  # every solve's mesh edge (mm): the kit's prediction (--kit) uses it too
    if out is not None:
        res.write(out, kit)
    return res


def _variables(res: DesignResult, vary: tuple[str, ...]) -> dict[str, int]:
    """design.json ``variables``: how many of each kind the design chose — ``patterns`` (distinct pattern slots:
    faces or face groups, a strip's faces), ``shapes`` (the mapped tiling's free vertex coordinates), ``angles``
    and ``thickness`` (sleeves and plates given their own; 0 when not varied)."""
    out = {"patterns": len(set(res.face_col)) if "patterns" in vary else 0,
           "shapes": 3 * len(res.files and res.base.spec.tiling.vertices or ()) if "shapes" in vary else 0,
           "angles": len(res.record.get("sleeve_angles") or ()) if "angles" in vary else 0, "thickness": 0}
    return out


def _design_strip(strip: StripTarget, base: DesignBase, h: float, max_solves: int, tolerance: float,
                  scale_target: bool, runner: Runner, t0: float) -> DesignResult:
    """The strip design (module doc), stopped early by a signal or the runner's deadline (:mod:`fabpat.design.stop`)."""
    tgt = strip
    ids = sorted(base.energies, key=lambda k: (-base.energies[k], k))  # ascending stiffness 1/U
    log_s = -np.log([base.energies[k] for k in ids])
    length, labels, face_col, edges = _geometry(base, ids[len(ids) // 2], h)
    strip, scale = _check_arc(strip, length, scale_target)
    travel = length - strip.span
    if not travel > 0:
        raise TargetError(f"target {strip.source}: its span {strip.span:.1f} mm is not shorter than the strip's "
                          f"pin-to-pin length {length:.1f} mm: the pins must move together to bend it")
    columns = max(face_col) + 1
    runner.extra = (travel,)
    search = Search(strip.x, strip.z, ids, log_s, columns, face_col, base.max_distinct, runner)
    needs = column_needs(strip.x, strip.z, columns)
    single = (len(ids) // 2,) * columns  # a uniform elastica's shape does not depend on its stiffness
    baselines: dict[str, Any] = {}
    runs: dict[str, Evaluated] = {}
    way = base_faces(base)

    def work() -> None:  # the solves: every one finished is kept in runs and search.seen, stopped or not
        ev = search.evaluate([single])[0]
        if ev is not None:
            runs["single"] = ev
            baselines["single"] = _summary(ev, strip.span, {"pattern": ids[single[0]]})
        if way is not None:
            rule = _solve_faces(runner, way[1], strip)
            if rule is not None:
                runs["rule"] = rule
                baselines[way[0]] = _summary(rule, strip.span, dict(zip(labels, way[1], strict=True)))
        extra = runner.solves  # the baselines' solves come on top of the budget (as --max-solves' help says)
        if ev is not None:
            space_mapping(search, Elastica(length, edges), ev, strip.span, max_solves + extra)
        search.refine(column_turning(strip.x, strip.z, columns), max_solves + extra, max(2, runner.workers))

    stopped = until_stopped(work, runner.deadline)
    best = search.best
    if best is None and "rule" not in runs:
        nothing_solved(stopped, runner.solves, runner.failures, h)
    faces = [] if best is None else [ids[best.key[face_col[f]]] for f in range(len(labels))]
    if "rule" in runs and (best is None or runs["rule"].rms < best.rms) and way is not None:  # the best of every solve
        best, faces = runs["rule"], list(way[1])
    assert best is not None
    rec = _record(strip, tgt, base, best, labels, faces, runner.solves, time.perf_counter() - t0,
                  tolerance, scale, length, baselines)
    if stopped is not None:
        rec["stopped_by"] = stopped
    warning = None if rec["reachable"] else _unreachable(rec, needs, log_s, base, tolerance, max_solves)
    return DesignResult(rec, base, strip, best, labels, face_col, warning, runs)


def _solve_faces(runner: Runner, faces: list[str], strip: StripTarget) -> Evaluated | None:
    res = runner.run([tuple(faces)])[0]
    if isinstance(res, BaseException):
        return None
    rms, mx, _ = errors(res["x"], res["z"], strip.x, strip.z)
    return Evaluated((), rms, mx, np.zeros(0), np.zeros(0), res)


def _summary(ev: Evaluated, span: float, what: dict[str, str]) -> dict[str, Any]:
    return {**({"pattern": what["pattern"]} if "pattern" in what else {"patterns": what}),
            "rms_error": ev.rms, "max_error": ev.max, "relative_rms": ev.rms / span}


def _record(strip: StripTarget, tgt: Any, base: DesignBase, best: Evaluated, labels: list[str], faces: list[str],
            solves: int, seconds: float, tolerance: float, scale: float, length: float,
            baselines: dict[str, Any]) -> dict[str, Any]:
    rel = best.rms / strip.span
    return {
        "target": tgt.source, "kind": base.spec.tiling.kind,
        "patterns": dict(zip(labels, faces, strict=True)),
        "rms_error": best.rms, "max_error": best.max, "relative_rms": rel,
        "end_shortening": best.data["end_shortening"], "scale": scale, "solves": solves, "seconds": seconds,
        "reachable": bool(rel <= tolerance and best.data["peak_strain"] <= base.spec.material.strain_limit),
        "peak_strain": best.data["peak_strain"], "strain_limit": base.spec.material.strain_limit,
        "tolerance": tolerance, "span": strip.span, "pin_length": length,
        "strip_length": best.data["length"], "baselines": baselines,
    }


def _unreachable(rec: dict[str, Any], needs: np.ndarray, log_s: np.ndarray, base: DesignBase, tolerance: float,
                 max_solves: int) -> str:
    """The one warning line: how far the design is and what limits it."""
    head = (f"target not reached: rms error {rec['rms_error']:.3g} mm is {rec['relative_rms']:.2%} of the span "
            f"(tolerance {tolerance:.2%})")
    if rec["peak_strain"] > rec["strain_limit"]:
        if rec["relative_rms"] <= tolerance:
            head = (f"the shape is reached (rms error {rec['relative_rms']:.2%} of the span) but the kit cannot be "
                    "built")
        return (f"{head}: the design strains its plates to {rec['peak_strain']:.2%}, over the strain limit "
                f"{rec['strain_limit']:.2%} ([material] strain_limit; thinner plates strain less)")
    bad = [str(c) for c in range(len(needs)) if needs[c] == math.inf]
    fin = needs[np.isfinite(needs)]
    have = math.exp(float(log_s[-1] - log_s[0]))
    if bad:
        why = (f"column(s) {', '.join(bad)} of the target turn the wrong way or not at all, which a pinned strip "
               "(moment = thrust × deflection) cannot do with any pattern")
    elif len(fin) > 1 and math.exp(float(np.ptp(fin))) > have:
        why = (f"the target needs a column stiffness ratio of {math.exp(float(np.ptp(fin))):.3g}, the stiffest and "
               f"softest candidates make at most {have:.3g}")
    elif base.max_distinct is not None:
        why = f"at most patterns.max_distinct = {base.max_distinct} distinct patterns"
    else:
        why = f"the best of {rec['solves']} solves (--max-solves {max_solves}); more solves may get closer"
    return f"{head}: {why}"
