"""The sleeve angles of a closed design (``--vary`` with ``angles``), after the pattern search.

Order of work (method: :mod:`fabpat.design.angles`): the best pattern design is solved again at its printed
angles in the angle model (warm-started from its own closed state), its adjoint gradient is checked against
central differences of full solves on :data:`fabpat.design.angles.CHECK_DIRECTIONS` random directions (on top
of the budget, as the baselines are: design.json's ``gradient_check``), L-BFGS-B moves the angles within
``[sleeve] angle_range`` until J stops falling or the angles' share of the budget is spent, and the best angles,
rounded to the spec's 0.1°, are solved once more through the spec (``[sleeve] angles``) as the kit will be
built. Every full solve is counted in ``solves``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from fabpat.design.angles import SPEC_STEP, AngleSearch, angle_model, gradient_check, optimise_angles
from fabpat.design.closed import ClosedEvaluated, solve_closed
from fabpat.design.search import Runner, solve_news

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.assembly.spec.types import AssemblySpec
    from fabpat.design.target import ClosedTarget

Arr = NDArray[np.float64]

#: with ``angles`` varied, the share of ``--max-solves`` (rounded down) left to the angles after the patterns
ANGLE_SHARE = 1 / 2


#: the smallest relative gain in the design error for which the angles are kept (round-off is ~1e-12)
KEEP_GAIN = 1e-6


def angle_budget(max_solves: int) -> int:
    """The solves of ``max_solves`` that the angles get (:data:`ANGLE_SHARE`); the patterns get the rest."""
    return int(max_solves * ANGLE_SHARE)


@dataclass
class AnglePhase:
    """What the angle phase found so far: ``record`` (design.json's ``angles`` section), ``best`` the design
    with its angles (None until the final solve), ``angles`` {joint label: degrees} of that design,
    ``gradient_check`` the largest relative error of the check (None until it ran)."""

    record: dict[str, Any] = field(default_factory=dict)
    best: ClosedEvaluated | None = None
    angles: dict[str, float] = field(default_factory=dict)
    gradient_check: float | None = None


def _counted(runner: Runner) -> tuple[Callable[[], None], Callable[[], None]]:
    """(before, after): before a solve, stop at the runner's deadline; after it, count it and tell the
    runner's progress."""
    from fabpat.design.stop import OutOfTime

    def before() -> None:
        if runner.deadline is not None and time.perf_counter() >= runner.deadline:
            raise OutOfTime

    def after() -> None:
        runner.solves += 1
        if runner.progress is not None:
            runner.progress(runner.solves, time.perf_counter() - runner.t0)

    return before, after


def vary_angles(phase: AnglePhase, tgt: ClosedTarget, spec: AssemblySpec, best: ClosedEvaluated, h: float, budget: int,
                runner: Runner, axis: Arr) -> None:
    """Run the angle phase (module doc) from the pattern design ``best`` of ``spec`` (its AssemblySpec) with
    ``budget`` solves for the search, filling ``phase`` as it goes (a stop keeps what is in it). Raises
    SolverError from a failed solve, OutOfTime or KeyboardInterrupt to stop."""
    t0 = time.perf_counter()
    faces = list(best.data["faces"])
    model = angle_model(spec, faces, h)
    lo, hi = (math.radians(v) for v in spec.sleeve.angle_range)
    before, after = _counted(runner)
    search = AngleSearch(model, tgt, axis, before=before, after=after)
    with solve_news(runner.status, lambda: f"angles, solve {runner.solves + 1}", False):
        J, g = search.evaluate(model.angle0)  # the pattern design again, in the angle model
        assert search.best is not None
        run, fit = search.best[2], search.best[3]
        phase.record.update(before_relative_rms=float(fit.relative_rms), joints=len(model.labels))
        check = gradient_check(model, model.angle0, run, tgt, axis, g, solved=after)
        phase.gradient_check = float(check["max_relative_error"])
        phase.record["gradient_check"] = check
        optimise_angles(search, model.angle0, (lo, hi), budget - 2)  # the start and the final solve are in it
        phase.record["search"] = [dict(h) for h in search.history]
        deg = np.clip(np.round(np.degrees(search.best[0]) / SPEC_STEP) * SPEC_STEP, *spec.sleeve.angle_range)
        angles = {lab: float(round(a, 6)) for lab, a in zip(model.labels, deg, strict=True)}
        final_spec = replace(spec, sleeve=replace(spec.sleeve, angles=tuple(angles.items())))
        m, fin = search.best[2].setup.model, search.best[2].result.final
        before()
        res = solve_closed(final_spec, tuple(faces), h, (m.X, np.asarray(m.offsets), fin.displacement, fin.rotation))
        after()
    ev = ClosedEvaluated(best.key, tgt.fit(res["P"], axis), res, res["peak_strain"] > model.strain_limit)
    phase.record.update(after_relative_rms=float(ev.fit.relative_rms), seconds=time.perf_counter() - t0,
                        continuous_relative_rms=float(search.best[3].relative_rms))
    # kept only for a real gain: angles all left at [sleeve] angle give the same solve to round-off, and would add
    # 90 spec entries and part names for nothing
    if ev.score < best.score * (1.0 - KEEP_GAIN):
        phase.best, phase.angles = ev, angles
