"""The kit's prediction: the assembly in use, solved in the shell solver before any file is written.

Used by :func:`fabpat.assembly.kit.build.assemble` for every kit whose plates are loaded in use
(:func:`predicted`): a closed assembly whose sleeves are printed at another angle than their joints'
dihedral (:func:`bent`) is closed by them (:mod:`fabpat.assembly.solve.closure`); a honeycomb strip is
pushed together by its end pins, by :func:`fabpat.assembly.solve.strip.kit_end_shortening` of its
length, as ``simulate-assembly`` does (:mod:`fabpat.assembly.solve.strip`). :func:`predict` runs that
at mesh edge ``h`` and turns it into the preview's plain data (:mod:`fabpat.assembly.solve.preview`);
:func:`strain_problems` refuses plates over ``[material] strain_limit`` (or, forced, warns);
:func:`choose_roundest` is ``rule = "roundest"``: it closes the sphere with each candidate pattern pair
(:func:`fabpat.assembly.choose.rules.similar_pairs`) and keeps the roundest (smallest ``sphericity_rms``)
whose plates all stay under the strain limit.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fabpat.assembly.place.placement import Assembly
from fabpat.assembly.spec.load import AssemblySpec
from fabpat.errors import ExportError, FabpatError
from fabpat.simulation.mesh import ASSEMBLY_MAX_ELEMENTS

if TYPE_CHECKING:
    from fabpat.assembly.place.placement import PlateType
    from fabpat.assembly.solve.closure import ClosureRun
    from fabpat.assembly.solve.preview import PredictedShape
    from fabpat.assembly.solve.strip import StripRun
    from fabpat.geometry.fillet import FilletedPattern
    from fabpat.geometry.outline import Outline

    #: the kit's FilletedPattern per plate type, when it has made them
    Filleted = dict[PlateType, FilletedPattern]

#: default mesh edge (mm) of the kit's closure prediction, the simulate-assembly default: the shipped
#: sphere's whole kit takes 26 s on the shared 2-core machine with it, and h = 2 or 1.5 move the radius
#: by < 0.02 % and sphericity_rms by < 2 % (docs/fabrication-files.md)
PREDICT_H = 3.0
#: a sleeve whose printed angle differs from its joint's dihedral by more than this (rad) bends plates
BENT_TOLERANCE = 1e-9


def bent(assembly: Assembly) -> bool:
    """True when the plates bend as the sleeves close the object: some sleeve is printed at an angle other
    than its joint's dihedral, or the tiling is placed at its faces' best fit (the sleeves' mismatch is
    closed by bending, whatever their angles)."""
    return (assembly.spec.tiling.fit == "best"
            or any(abs(s.angle - s.dihedral) > BENT_TOLERANCE for s in assembly.sleeves))


def predicted(assembly: Assembly) -> bool:
    """True when the kit's plates are loaded in use, so :func:`predict` checks them: bent sleeves close the
    object (:func:`bent`), or the assembly is a strip whose end pins push it together."""
    return bent(assembly) or assembly.spec.tiling.kind == "honeycomb-strip"


def use(spec: AssemblySpec) -> str:
    """What loads the plates in use, for messages: "the sleeves close the object" or "its end pins push
    the strip together by 10 % of its length"."""
    if spec.tiling.kind != "honeycomb-strip":
        return "the sleeves close the object"
    from fabpat.assembly.solve.strip import kit_end_shortening

    return f"its end pins push the strip together by {100 * kit_end_shortening(spec):g} % of its length"


@dataclass(frozen=True, eq=False)
class Prediction:
    """The kit's closure (or a strip's push): ``run`` (a ClosureRun or StripRun), ``shape`` (a
    PredictedShape), ``fit`` (the :func:`~fabpat.assembly.solve.preview.joint_fit` of the printed sleeves, mm),
    ``h`` (mm), ``seconds``, and ``record``: its ``prediction.json`` fields
    (:func:`fabpat.assembly.solve.result.prediction_record`), computed once here for the file and the caller."""

    run: StripRun | ClosureRun
    shape: PredictedShape
    fit: tuple[float, float]
    h: float
    seconds: float
    record: dict[str, Any]


def _outlines(filleted: Filleted | None) -> dict[tuple[str, int, float], Outline] | None:
    """The kit's outlines by (pattern ID, sides, bridge weight), as the size check looks them up."""
    if filleted is None:
        return None
    return {(pt.pattern_id, pt.sides, pt.bridge_weight): fp.outline for pt, fp in filleted.items()}


def close(spec: AssemblySpec, ids: list[str], h: float, progress: Callable[[float], None] | None = None,
          assembly: Assembly | None = None, filleted: Filleted | None = None) -> ClosureRun:
    """The ClosureRun of the spec with face pattern IDs ``ids`` at mesh edge h (mm), checked against
    ``[material] strain_limit``; ``assembly`` and ``filleted``: the kit's placement and outlines, if made
    (nothing is placed or filleted again). Raises GeometryError (h too coarse) or SolverError (path lost)."""
    from fabpat.assembly.solve.closure import closure_setup, run_closure
    from fabpat.assembly.solve.sizing import check_assembly_size

    check_assembly_size(spec, ids, h, ASSEMBLY_MAX_ELEMENTS, option="the limit of a kit's prediction, ≈ 8 GB",
                        h_name="--predict-h", outlines=_outlines(filleted))
    setup = closure_setup(spec, ids, h=h, placed=assembly, filleted=filleted)
    return run_closure(setup, strain_limit=spec.material.strain_limit, progress=progress)


def finish(run: StripRun | ClosureRun, assembly: Assembly, h: float, seconds: float) -> Prediction:
    """The :class:`Prediction` of a ClosureRun of ``assembly`` (its sleeve types the printed ones)."""
    from fabpat.assembly.solve.preview import joint_fit, predicted_shape
    from fabpat.assembly.solve.result import prediction_record

    fit = joint_fit(run, assembly.sleeve_types, [s.kind for s in assembly.sleeves])
    record = prediction_record(run, seconds, h, assembly.spec.tiling.kind)
    return Prediction(run, predicted_shape(run, assembly), fit, h, seconds, record)


def push(spec: AssemblySpec, ids: list[str], h: float, progress: Callable[[float], None] | None = None,
         assembly: Assembly | None = None, filleted: Filleted | None = None) -> StripRun:
    """The StripRun of a strip spec with face pattern IDs ``ids`` at mesh edge h (mm): the end pins pushed
    together by :func:`fabpat.assembly.solve.strip.kit_end_shortening` of the length, as ``simulate-assembly``
    does with its defaults, checked against ``[material] strain_limit``; ``assembly`` and ``filleted`` as
    :func:`close`. Raises GeometryError (h too coarse, mesh too large) or SolverError (path lost,
    implausible result)."""
    from fabpat.assembly.solve.sizing import check_assembly_size
    from fabpat.assembly.solve.strip import kit_end_shortening, run_strip, strip_setup

    check_assembly_size(spec, ids, h, ASSEMBLY_MAX_ELEMENTS, option="the limit of a kit's prediction, ≈ 8 GB",
                        h_name="--predict-h", outlines=_outlines(filleted))
    mat = spec.material
    setup = strip_setup(spec, ids, h=h, E=mat.youngs_modulus, nu=mat.poisson, placed=assembly, filleted=filleted)
    return run_strip(setup, kit_end_shortening(spec), progress=progress, strain_limit=mat.strain_limit)


def predict(spec: AssemblySpec, assembly: Assembly, h: float,
            progress: Callable[[float], None] | None = None, filleted: Filleted | None = None) -> Prediction:
    """Solve the placed ``assembly`` in use (:func:`predicted`: closed by its sleeves, or a strip pushed
    together) at mesh edge h (mm); ``progress(λ)`` per report step. The assembly itself is solved, not
    placed again, with ``filleted`` (the kit's FilletedPattern per plate type) meshed if given."""
    t0 = time.perf_counter()
    ids = [p.type.pattern_id for p in assembly.plates]
    if spec.tiling.kind == "honeycomb-strip":
        run: StripRun | ClosureRun = push(spec, ids, h, progress, assembly, filleted)
    else:
        run = close(spec, ids, h, progress, assembly, filleted)
    return finish(run, assembly, h, time.perf_counter() - t0)


def strain_problems(spec: AssemblySpec, run: StripRun | ClosureRun, force: bool) -> list[str]:
    """Refuse (ExportError, one line naming the worst plate, its peak strain and the limit) a kit whose
    plates would exceed ``material.strain_limit``, or with ``force`` one warning line per such plate,
    worst first."""
    over = sorted(run.over_limit, key=lambda k: -run.plate_peak_strain[k])
    if not over:
        return []
    lim = run.strain_limit
    if not force:
        more = f" (and {len(over) - 1} more plates)" if len(over) > 1 else ""
        fix = ("other patterns, thinner plates or sleeve.angle" if spec.tiling.kind != "honeycomb-strip"
               else "other patterns or thinner plates")
        raise ExportError(f"{spec.source}: plate {over[0]} would reach a peak strain of "
                          f"{run.plate_peak_strain[over[0]]:.4g} when {use(spec)}, over "
                          f"material.strain_limit = {lim:g}{more}: choose {fix}, or give --force to build the kit "
                          "anyway")
    return [f"plate {k}: predicted peak strain {run.plate_peak_strain[k]:.4g} exceeds material.strain_limit = "
            f"{lim:g} (built anyway: --force)" for k in over]


def grip_problems(spec: AssemblySpec, fit: tuple[float, float], force: bool) -> list[str]:
    """Refuse (ExportError, one line) a kit whose predicted shape leaves interface nodes off their slots —
    farther from a slot's mid-plane than the slot's play (``sleeve.clearance`` / 2) or outside the slot
    (more than 1e-6 mm) — or with ``force`` return that line as a warning. ``fit``: the prediction's
    (mid-plane, outside) distances in mm (:func:`fabpat.assembly.solve.preview.joint_fit`). Round-off on an exact
    tiling, where every plate sits in its slots as placed; the check that matters on a best-fit tiling,
    whose plates reach their slots only in the closed shape."""
    play = 0.5 * spec.sleeve.clearance
    if fit[0] <= play + 1e-9 and fit[1] <= 1e-6:  # round-off allowed: a clearance of 0 holds a node 1e-14 mm off
        return []
    line = (f"{spec.source}: in the predicted shape the plates leave their slots (interface nodes "
            f"{fit[0]:.3g} mm from a slot's mid-plane, sleeve.clearance / 2 = {play:g} mm; {fit[1]:.3g} mm "
            "outside a slot)")
    if not force:
        raise ExportError(f"{line}: choose a larger sleeve.clearance or sleeve.margin, or give --force to build "
                          "the kit anyway")
    return [f"{line} (built anyway: --force)"]


def choose_roundest(spec: AssemblySpec, pairs: list[tuple[str, str]], faces: list[int], h: float, force: bool,
                    fits: Callable[[AssemblySpec, list[str]], None],
                    progress: Callable[[float], None] | None = None) -> tuple[list[str], ClosureRun, float, list[dict]]:
    """``rule = "roundest"``: close the object with every (hexagon, pentagon) of ``pairs`` and keep the
    roundest (smallest ``sphericity_rms``) whose plates all stay under ``material.strain_limit``.

    A pair's entries are pattern IDs or family members' names (``"0x0488 b0.63"``: the plate is that member,
    :func:`fabpat.assembly.choose.members.with_candidates`). ``faces`` are the tiling's polygon sizes (face order);
    ``fits(spec, ids)`` (the spec with the pair's members, the face pattern IDs) raises a FabpatError when a
    pair cannot be built (e.g. a neck wider than its slot): that pair is reported and skipped, as is a pair
    whose closure fails. ``progress(f)``, f from 0 to 1 over all pairs. Returns (the chosen face names, its
    ClosureRun, its seconds, one record per pair tried: ``hexagon``, ``pentagon`` (names) and either ``radius``
    (mm), ``sphericity_rms``, ``sphericity_max``, ``peak_strain``, ``plates_over_limit``, ``seconds`` or
    ``error``; ``chosen`` true for the kept one). With no pair under the limit it raises ExportError, or
    with ``force`` keeps the roundest of all; with no pair that closes it raises ExportError naming the
    first failure.
    """
    from fabpat.assembly.choose.members import with_candidates

    tried: list[dict] = []
    runs: list[tuple[list[str], ClosureRun, float, dict]] = []
    for i, (hid, pid) in enumerate(pairs):
        names = [hid if n == 6 else pid for n in faces]
        member_spec, ids = with_candidates(spec, names)
        rec: dict[str, Any] = {"hexagon": hid, "pentagon": pid}
        tell = None if progress is None else (lambda lam, i=i: progress((i + lam) / len(pairs)))
        t0 = time.perf_counter()
        try:
            fits(member_spec, ids)
            run = close(member_spec, ids, h, tell)
        except FabpatError as e:
            rec["error"] = str(e)
        else:
            seconds = time.perf_counter() - t0
            rec.update(radius=run.radius, sphericity_rms=run.sphericity_rms, sphericity_max=run.sphericity_max,
                       peak_strain=run.peak_strain, plates_over_limit=len(run.over_limit), seconds=round(seconds, 3))
            runs.append((names, run, seconds, rec))
        rec["chosen"] = False
        tried.append(rec)
    if not runs:
        raise ExportError(f"{spec.source}: patterns.rule = 'roundest': none of the {len(pairs)} candidate pairs "
                          f"closes ({tried[0]['hexagon']}/{tried[0]['pentagon']}: {tried[0]['error']})")
    ok = [r for r in runs if not r[1].over_limit]
    if not ok and not force:
        best = min(runs, key=lambda r: r[1].peak_strain)
        raise ExportError(f"{spec.source}: patterns.rule = 'roundest': none of the {len(runs)} candidate pairs that "
                          f"close stays under material.strain_limit = {spec.material.strain_limit:g} (lowest peak "
                          f"strain {best[1].peak_strain:.4g}, hexagon {best[3]['hexagon']} / pentagon "
                          f"{best[3]['pentagon']}): raise patterns.candidates or the limit, or give --force to build "
                          "the roundest anyway")
    # a candidate no sphere describes (radius None: fabpat.assembly.solve.closure.shape_sphere) is the least round
    ids, run, seconds, rec = min(ok or runs, key=lambda r: math.inf if r[1].sphericity_rms is None
                                 else r[1].sphericity_rms)
    rec["chosen"] = True
    return ids, run, seconds, tried
