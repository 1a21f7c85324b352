"""``assemble``: one spec in, a folder with everything needed to fabricate and assemble out.

Order of work: choose the patterns (the catalog only if the spec names a rule), fillet each distinct
plate, place plates and sleeves, nest the sheets, unfold the net, run every check — all before the
first file is written, so a bad spec costs no disk writes. Files are then written into a temporary
folder next to ``--out`` and renamed to it at the very end: on any error the temporary folder is
removed and ``--out`` is left as it was (an earlier ``assemble`` output there is replaced only on
success, and only if it holds nothing but the files its manifest lists with their SHA-256, unchanged;
any other existing folder is refused: :mod:`fabpat.assembly.kit.folder`).

Folder contents: ``assembly.step``, ``parts/*.stl``, ``assembly.glb``, ``assembly.3dm`` (Rhino: a layer
and a block per part type, block instances), ``sheets/sheet-NN.dxf``,
``net.svg``, ``assembly.png``, ``bom.csv``, ``bom.md`` (each as the spec's formats ask) and
``manifest.json`` (files, counts, check results), written by :func:`fabpat.assembly.kit.files.write_all`.

**Bent sleeves** (``[sleeve] angle`` other than the joints' dihedral angles, e.g. the paper's sphere of
straight sleeves): the plates bend when the sleeves close the object, so the kit predicts that shape
first (:mod:`fabpat.assembly.solve.closure`, mesh edge ``predict_h``, default :func:`default_predict_h`) and refuses
a kit whose plates would exceed ``[material] strain_limit`` (``force`` builds it with a warning per
plate). The kit then holds ``prediction.json`` (the ``simulate-assembly`` fields), ``predicted.stl``
(the predicted object as closed meshes), ``assembly.glb``/``assembly.png`` of the predicted shape
(:mod:`fabpat.assembly.solve.preview`), and the exact flat parts side by side as ``parts.step`` and
``parts.3dm`` instead of ``assembly.step``/``assembly.3dm`` (flat parts placed on the polyhedron are
not the object). Without the prediction (``predict=False``, ``--no-predict``) nothing shows the
assembled shape: ``assembly.glb``/``assembly.png``/``predicted.stl`` are not written and the manifest
says so.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fabpat.assembly.choose.choice import candidate_pairs, face_patterns, with_members
from fabpat.assembly.choose.provenance import pattern_records
from fabpat.assembly.kit.files import PREDICTION, KitOutput, without_durations, write_all
from fabpat.assembly.kit.folder import GENERATOR, MANIFEST, check_out, write_kit
from fabpat.assembly.kit.result import AssembleResult, fabrication_problems
from fabpat.assembly.place.checks import check_assembly
from fabpat.assembly.place.necks import check_necks
from fabpat.assembly.place.placement import (
    Assembly,
    PlateType,
    build_tiling,
    check_geometry,
    radius_line,
    sleeve_kinds,
)
from fabpat.assembly.solve.predict import (
    BENT_TOLERANCE,
    PREDICT_H,
    Prediction,
    bent,
    finish,
    grip_problems,
    predicted,
    strain_problems,
    use,
)
from fabpat.assembly.solve.predict import predict as predict_kit
from fabpat.assembly.spec.load import AssemblySpec, load_spec
from fabpat.errors import ExportError, SpecError
from fabpat.geometry.fillet import interface_half_length

if TYPE_CHECKING:
    from fabpat.assembly.choose.provenance import PatternRecord
    from fabpat.assembly.kit.net import Net
    from fabpat.assembly.place.checks import CheckReport
    from fabpat.assembly.place.nesting import Nesting
    from fabpat.assembly.place.parts import PartLibrary
    from fabpat.assembly.solve.closure import ClosureRun
    from fabpat.geometry.fillet import FilletedPattern

NOT_NEEDED = "not needed: the sleeves are at the dihedral angles (the plates stay flat)"
SKIPPED = "skipped (--no-predict)"


def plan(spec: AssemblySpec, energies: Callable[[int], dict[str, float]] | None = None,
         progress: Callable[[str], None] | None = None,
         ids: list[str] | None = None) -> tuple[Assembly, dict[PlateType, FilletedPattern]]:
    """The placed assembly and the filleted outline of each distinct plate; no B-rep, no files.

    ``ids``: the face pattern IDs, if already chosen (else :func:`face_patterns`, progress step
    "patterns"). Raises :class:`SpecError` when a plate's neck does not fit the sleeve's slot.
    """
    from fabpat.assembly.place.shaped import place_assembly, plate_outline

    tell = progress or (lambda _step: None)
    check_geometry(spec)
    if ids is None:
        tell("patterns")
        ids = face_patterns(spec, energies)
    tell("placement")
    assembly = place_assembly(spec, ids)
    filleted = {pt: plate_outline(pt, assembly.plate_edge, spec.plates.weight, spec.source)
                for pt in assembly.plate_types}
    check_necks(assembly, filleted)
    return assembly, filleted


# -- the whole thing --------------------------------------------------------------------------------


def bends(spec: AssemblySpec) -> bool:
    """:func:`bent` from the spec alone, without placing anything: a best-fit tiling, or a joint whose
    sleeve is printed at another angle than its skeleton's dihedral (:func:`sleeve_kinds`; neither depends
    on the patterns or the scale). Raises :class:`SpecError` as :func:`check_geometry`."""
    check_geometry(spec)
    if spec.tiling.fit == "best":
        return True
    kinds = sleeve_kinds(spec, build_tiling(spec))
    return any(abs(angle - dihedral) > BENT_TOLERANCE for _, dihedral, angle in kinds.values())


def default_predict_h(spec: AssemblySpec) -> float:
    """The kit's default prediction mesh edge (mm): :data:`~fabpat.assembly.solve.predict.PREDICT_H`, or the
    largest h the interfaces allow when that is smaller (small plates;
    :data:`fabpat.assembly.solve.model.MAX_H_PER_INTERFACE` × the interface segment 2d)."""
    from fabpat.assembly.solve.model import MAX_H_PER_INTERFACE

    segment = 2.0 * interface_half_length(spec.tiling.edge, weight=spec.plates.weight)
    return min(PREDICT_H, MAX_H_PER_INTERFACE * segment)


def predicts(spec: AssemblySpec) -> bool:
    """:func:`~fabpat.assembly.solve.predict.predicted` from the spec alone: a strip, or bent sleeves
    (:func:`bends`)."""
    return spec.tiling.kind == "honeycomb-strip" or bends(spec)


def steps(spec: AssemblySpec, predict: bool = True) -> list[str]:
    """Names of the progress steps for this spec, in order (``predict``: as :func:`assemble`'s).

    With ``rule = "roundest"`` the prediction (every candidate's closure) comes right after "patterns":
    it chooses them."""
    f = spec.formats
    if spec.tiling.panel:
        from fabpat.assembly.kit.panel import panel_steps

        return panel_steps(spec)
    names = ["patterns", "placement", "nesting", "net", "checks"]
    show = True
    if predicts(spec) and predict:
        names.insert(1 if spec.patterns.rule == "roundest" else len(names), "prediction")
    if bends(spec):
        show = predict  # no prediction: no picture of the assembled shape
    names += [n for n, want in (("STEP", "step"), ("STL", "stl"), ("GLB", "glb"), ("3DM", "3dm"),
                                ("sheets", "dxf"),
                                ("net SVG", "svg"), ("PNG", "png"), ("BOM", "bom"))
              if want in f and (show or n not in ("GLB", "PNG"))]
    return names


def assemble(spec: AssemblySpec | str | os.PathLike[str], out: str | os.PathLike[str],
             progress: Callable[[str], None] | None = None, timestamp: str | None = None,
             energies: Callable[[int], dict[str, float]] | None = None, force: bool = False,
             predict: bool = True, predict_h: float | None = None,
             predict_progress: Callable[[float], None] | None = None) -> AssembleResult:
    """Build and check the assembly of ``spec``, then write every requested output into ``out``.

    ``progress(step)`` is called as each step of :func:`steps` starts. ``timestamp`` fixes the
    STEP header time (ISO 8601, checked first). Plates too narrow for their process
    (:func:`fabrication_problems`, the checks of ``fabpat export``) are refused with an
    :class:`ExportError`, or with ``force`` built anyway and listed in ``AssembleResult.warnings``.

    With bent sleeves (:func:`bent`) and ``predict``, the closure is solved at mesh edge ``predict_h``
    (mm; default :func:`default_predict_h`; ``predict_progress(λ)`` after each report step of it)
    before any file is written; plates whose peak strain exceeds ``[material] strain_limit`` are
    refused with an :class:`ExportError` naming the worst, or with ``force`` listed in the warnings.
    ``rule = "roundest"`` closes the sphere with each of its ``patterns.candidates`` pairs
    (:func:`candidate_pairs`) and builds the roundest under the limit
    (:func:`fabpat.assembly.solve.predict.choose_roundest`; the pairs tried go to the manifest's
    ``candidates`` and the BOM); it needs bent sleeves and ``predict``. Raises :class:`SpecError` /
    :class:`GeometryError` (``predict_h`` too coarse) / :class:`ExportError` / :class:`SolverError` (the
    closure's path lost); on any error ``out`` is untouched and no temporary folder is left.
    """
    timestamp, spec = _checked_call(spec, out, timestamp, force, predict, predict_h,
                                    progress=progress, energies=energies, predict_progress=predict_progress)
    if spec.tiling.panel:  # one part, no sleeves: fabpat.assembly.kit.panel
        from fabpat.assembly.kit.panel import assemble_panel

        return assemble_panel(spec, Path(out), progress or (lambda _step: None), timestamp, energies, force)
    out = Path(out)
    if predict_h is None:
        predict_h = default_predict_h(spec)
    tell = progress or (lambda _step: None)
    kit = _build(spec, energies, tell, predict, predict_h, force, predict_progress)
    if kit.tried is not None:  # with a time stamp, a reproducible kit: no solver durations in the manifest and BOM
        kit.tried = [without_durations(rec, timestamp) for rec in kit.tried]

    def write(tmp: Path) -> tuple[list[str], dict[str, object]]:
        output = KitOutput(kit.spec, kit.lib, kit.nesting, kit.net, kit.check_lines, timestamp, bent(kit.assembly),
                           kit.prediction, kit.tried, kit.records)
        files = write_all(output, tmp, tell)
        return files, _manifest(kit, files)

    files = write_kit(out, write)
    record = kit.prediction.record if kit.prediction is not None else None
    sheets = kit.nesting.n_sheets if kit.nesting else 0
    return AssembleResult(out, (*files, MANIFEST), kit.report, sheets, tuple(kit.problems), record,
                          tuple(kit.check_lines[kit.first_note:]))


def _checked_call(spec: AssemblySpec | str | os.PathLike[str], out: object, timestamp: str | None, force: object,
                  predict: object, predict_h: float | None, **callables: object) -> tuple[str | None, AssemblySpec]:
    """:func:`assemble`'s arguments checked before any work (one line each, :class:`SpecError` or the
    timestamp's :class:`ExportError`): the normalised timestamp and the spec (read if a path)."""
    from fabpat.exchange.step import check_timestamp

    timestamp = check_timestamp(timestamp)
    for name, value in (("force", force), ("predict", predict)):
        if not isinstance(value, bool):
            raise SpecError(f"{name} must be True or False, got {value!r}")
    for name, fn in callables.items():
        if fn is not None and not callable(fn):
            raise SpecError(f"{name} must be a callable or None, got {type(fn).__name__}")
    if predict_h is not None:
        from fabpat.validate import check

        check("h", predict_h, "predict_h (--predict-h)")
        if not predict:
            raise SpecError("predict_h (--predict-h) is the mesh of the prediction, which predict = False "
                            "(--no-predict) skips: give one or the other")
    if not isinstance(spec, AssemblySpec):
        if not isinstance(spec, str | os.PathLike):
            raise SpecError(f"spec must be an AssemblySpec or the path of a TOML spec file, got {type(spec).__name__}")
        spec = load_spec(spec, need_sheet=True)
    if spec.sheet is None:
        raise SpecError(f"{spec.source}: missing table [sheet] (fabpat assemble nests the plates on this laser sheet "
                        "or print bed: give its width and height)")
    if spec.tiling.panel and predict_h is not None:
        raise SpecError(f"{spec.source}: predict_h (--predict-h) is the mesh of a kit's prediction, and a panel's "
                        "kit has none: `fabpat simulate-assembly` pushes a panel together")
    if not isinstance(out, str | os.PathLike) or not str(out):
        raise SpecError(f"out must be the path of the kit's folder, got {out!r}")
    if not spec.tiling.panel:
        check_out(Path(out))
    if predict_h is not None and predict and not spec.tiling.panel and predicts(spec):
        # before any work: a mesh too coarse for the interfaces cannot predict
        from fabpat.assembly.solve.model import check_h
        from fabpat.errors import GeometryError

        try:
            check_h(predict_h, spec.tiling.edge, spec.plates.weight)
        except GeometryError as e:
            raise GeometryError(f"{spec.source}: predict_h (--predict-h): {e}") from e
    return timestamp, spec


@dataclass(eq=False)
class _Kit:
    """Everything :func:`assemble` builds and checks before the first file is written."""

    spec: AssemblySpec
    assembly: Assembly
    lib: PartLibrary
    nesting: Nesting | None  # None: no format needs the sheets
    net: Net | None  # None: no svg
    report: CheckReport
    check_lines: list[str]
    first_note: int  # the check lines from here on are told on the terminal too
    problems: list[str]
    prediction: Prediction | None
    status: str
    records: list[PatternRecord]
    tried: list[dict[str, Any]] | None


def _build(spec: AssemblySpec, energies: Callable[[int], dict[str, float]] | None, tell: Callable[[str], None],
           predict: bool, predict_h: float, force: bool, predict_progress: Callable[[float], None] | None) -> _Kit:
    """The patterns chosen, the parts placed once (:func:`plan`), nested, unfolded, checked and predicted."""
    from fabpat.assembly.kit.net import unfold
    from fabpat.assembly.kit.sheets import nest_plates
    from fabpat.assembly.place.nesting import check_nesting
    from fabpat.assembly.place.parts import PartLibrary

    f = spec.formats
    spec = with_members(spec, energies)  # bridge_weight = "rule": every face's family member, once
    ids: list[str] | None = None
    chosen: tuple[ClosureRun, float] | None = None
    tried: list[dict[str, Any]] | None = None
    chose: list[str] = []
    if spec.patterns.rule == "roundest":  # its pair, and with bridge_weight = "rule" their members, in the spec
        spec, ids, chosen, tried, chose = _roundest(spec, energies, tell, predict, predict_h, force, predict_progress)
    assembly, filleted = plan(spec, energies, tell, ids)
    problems = fabrication_problems(spec, filleted)
    if problems and not force:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ExportError(f"{spec.source}: {problems[0]}{more}: choose a larger tiling.edge or other patterns, "
                          "or give --force to build the kit anyway")
    lib = PartLibrary(assembly, filleted)
    tell("nesting")
    nesting = nest_plates(assembly) if ("dxf" in f or "bom" in f) else None
    sheet_gap = check_nesting(nesting) if nesting is not None else math.inf
    tell("net")
    net = unfold(assembly.skeleton) if "svg" in f else None
    tell("checks")
    report = check_assembly(lib)
    problems += report.shallow  # plates that enter their slots much less than sleeve.depth: a warning each
    check_lines = report.lines()
    first_note = len(check_lines)
    if spec.tiling.radius is not None:
        check_lines.append(radius_line(assembly))
    if nesting is not None:
        gap = f"{sheet_gap:.2f} mm" if math.isfinite(sheet_gap) else "one plate per sheet"
        check_lines.append(f"{nesting.n_sheets} sheet(s), no overlaps: smallest gap between plates {gap}")
    if net is not None:
        check_lines.append(f"net without overlaps ({len(net.folds)} folds)")
    prediction: Prediction | None = None
    if predicted(assembly) and predict:
        if chosen is None:
            tell("prediction")
            prediction = predict_kit(spec, assembly, predict_h, predict_progress, lib.filleted)
        else:
            prediction = finish(chosen[0], assembly, predict_h, chosen[1])
        problems += strain_problems(spec, prediction.run, force) + grip_problems(spec, prediction.fit, force)
        check_lines += prediction_notes(prediction) + chose
    elif predicted(assembly):  # the plates bend but nothing checked how far: say so where the user looks
        grip = (" (nor whether the plates reach their slots: they sit only at their faces' best fit)"
                if spec.tiling.fit == "best" else "")
        problems.append(f"material.strain_limit = {spec.material.strain_limit:g} not checked: the prediction was "
                        f"skipped (--no-predict), and the plates bend when {use(spec)}{grip}")
    status = (NOT_NEEDED if not predicted(assembly) else PREDICTION if prediction is not None else SKIPPED)
    return _Kit(spec, assembly, lib, nesting, net, report, check_lines, first_note, problems, prediction, status,
                pattern_records(spec, assembly.plate_types), tried)


def _manifest(kit: _Kit, files: list[str]) -> dict[str, object]:
    """The kit's ``manifest.json`` (its ``sha256`` filled in by :func:`fabpat.assembly.kit.folder.write_kit`)."""
    spec, assembly = kit.spec, kit.assembly
    manifest: dict[str, object] = {
        "generator": GENERATOR, "spec": spec.name, "source": spec.source, "files": files,
        "counts": assembly.counts(), "patterns": [r.as_dict() for r in kit.records],
        "sheets": kit.nesting.n_sheets if kit.nesting else 0,
        "skeleton_edge_mm": round(assembly.skeleton.edge_length(), 6),
        "plate_edge_mm": round(assembly.plate_edge, 6), "checks": kit.check_lines,
        "warnings": kit.problems, "prediction": kit.status, "sha256": None}
    if kit.tried is not None:
        manifest["candidates"] = kit.tried
    if bent(assembly):
        manifest["shape"] = (f"assembly.glb, assembly.png and predicted.stl show the predicted bent shape "
                             f"({PREDICTION}); parts.step and parts.3dm hold the flat parts" if kit.prediction else
                             "not predicted (--no-predict): no file shows the assembled shape; the flat parts "
                             "bend when the sleeves close the object (parts.step, parts.3dm)")
    elif predicted(assembly):
        manifest["shape"] = (f"assembly.* show the flat strip as assembled; predicted.glb, predicted.png and "
                             f"predicted.stl show it when {use(spec)} ({PREDICTION})" if kit.prediction else
                             "not predicted (--no-predict): assembly.* show the flat strip as assembled, no file "
                             f"shows it when {use(spec)}")
    return manifest


def prediction_notes(prediction: Prediction) -> list[str]:
    """The check lines of a kit's prediction: its shape (a closure's radius and sphericity, a strip's arch),
    peak strain and largest sleeve moment, then how well the printed sleeves grip the deformed plates."""
    run, h, fit = prediction.run, prediction.h, prediction.fit
    from fabpat.assembly.solve.closure import ClosureRun, sphere_text

    if isinstance(run, ClosureRun):  # a sphere's radius, a tube's cylinder or why neither
        shape = sphere_text(run)
    else:
        shape = (f"pushed together by {100 * run.end_shortening:g} % of its length: arch {run.max_deflection:.1f} mm "
                 f"high, peak at {run.peak:.3f} of the length, reaction {run.reaction:.3g} N")
    moment = max(run.sleeve_moments.values(), default=0.0)
    return [f"predicted shape (h = {h:g} mm): {shape}, peak strain {run.peak_strain:.4g} on {run.peak_strain_plate} "
            f"(material.strain_limit = {run.strain_limit:g}), largest sleeve moment {moment:.3g} N·mm",
            f"predicted shape: sleeves grip the deformed plates, interface nodes within {fit[0]:.1e} mm of their "
            f"slots' mid-planes and {fit[1]:.1e} mm of the slots"]


def _roundest(spec: AssemblySpec, energies: Callable[[int], dict[str, float]] | None, tell: Callable[[str], None],
              predict: bool, h: float, force: bool, progress: Callable[[float], None] | None
              ) -> tuple[AssemblySpec, list[str], tuple[ClosureRun, float], list[dict[str, Any]], list[str]]:
    """``rule = "roundest"``: the candidates' closures (:func:`fabpat.assembly.solve.predict.choose_roundest`);
    returns the spec with the chosen pair's members (:func:`fabpat.assembly.choose.members.with_candidates`), the chosen
    face IDs, (its ClosureRun, seconds), the pairs tried, and the check lines: the pair kept and what the
    candidates lacked (a polygon without family rows)."""
    from fabpat.assembly.choose.members import with_candidates
    from fabpat.assembly.solve.predict import choose_roundest

    src = spec.source
    if not bends(spec):
        raise SpecError(f"{src}: patterns.rule = 'roundest' compares the bent spheres of its candidates, but "
                        f"sleeve.angle = {spec.sleeve.angle!r} leaves the plates flat: use rule = "
                        "'similar-energy' or sleeve.angle = 'flat'")
    if not predict:
        raise SpecError(f"{src}: patterns.rule = 'roundest' chooses the patterns by predicting the closed sphere: "
                        "drop --no-predict or use rule = 'similar-energy'")
    tell("patterns")
    lines: list[str] = []
    pairs = candidate_pairs(spec, energies, lines)
    tell("prediction")
    faces = [len(f) for f in build_tiling(spec).faces]

    def fits(candidate: AssemblySpec, ids: list[str]) -> None:  # a pair the kit would refuse is not a candidate
        problems = fabrication_problems(candidate, plan(candidate, ids=ids)[1])
        if problems and not force:
            raise ExportError(problems[0])

    names, run, seconds, tried = choose_roundest(spec, pairs, faces, h, force, fits, progress)
    kept = next(t for t in tried if t["chosen"])
    lines.insert(0, f"patterns.rule = 'roundest': kept hexagon {kept['hexagon']} / pentagon {kept['pentagon']}, the "
                    f"roundest of {len(tried)} pairs (sphericity rms {100 * kept['sphericity_rms']:.3f} %)")
    spec, ids = with_candidates(spec, names)
    return spec, ids, (run, seconds), tried, lines
