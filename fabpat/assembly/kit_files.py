"""The kit's files: every output of :func:`fabpat.assembly.build.assemble` written into a folder.

Not atomic on its own: ``assemble`` passes a temporary folder that becomes ``--out`` only when
everything succeeded. With bent sleeves (:func:`fabpat.assembly.predict.bent`) the STEP and 3DM hold
the distinct flat parts side by side (``parts.step``, ``parts.3dm``: :func:`fabpat.assembly.export.
flat_layout`) and the GLB, PNG, ``predicted.stl`` and ``prediction.json`` show the predicted shape
(:mod:`fabpat.assembly.preview`), or are left out without a prediction. A strip's ``assembly.*`` show
it flat, as assembled, and its prediction (the end pins pushing it together) adds ``prediction.json``,
``predicted.stl``, ``predicted.glb`` and ``predicted.png``.

With a time stamp (``fabpat assemble --timestamp``) every file is byte-reproducible: the same spec gives the
same bytes in every run. A measured duration is not reproducible, so then ``prediction.json`` leaves out its
``seconds`` (how long the solver ran), as do the manifest's ``candidates`` (:func:`without_durations`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from fabpat.assembly.placement import Assembly
from fabpat.assembly.predict import Prediction
from fabpat.assembly.provenance import PatternRecord
from fabpat.assembly.spec import AssemblySpec

PREDICTION = "prediction.json"
#: the fields of a record that are measured durations (s), left out of a kit written with a time stamp
DURATIONS = ("seconds",)


def without_durations(record: dict[str, Any], timestamp: str | None) -> dict[str, Any]:
    """``record`` as a kit file holds it: without a ``timestamp`` as it is, with one (a reproducible kit)
    without its :data:`DURATIONS`, which differ from run to run (a copy; ``record`` is left unchanged)."""
    if timestamp is None:
        return record
    return {k: v for k, v in record.items() if k not in DURATIONS}


def write_all(spec: AssemblySpec, lib: Any, nesting: Any, net: Any, check_lines: list[str], tmp: Path,
              tell: Callable[[str], None], timestamp: str | None, bent_sleeves: bool = False,
              prediction: Prediction | None = None, candidates: list[dict[str, Any]] | None = None,
              patterns: Sequence[PatternRecord] = ()) -> list[str]:
    """Write every requested file into ``tmp``; returns their paths relative to it. ``patterns``: the
    plates' pattern records for the BOM (:mod:`fabpat.assembly.provenance`).

    With ``bent_sleeves`` the STEP and 3DM hold the flat parts side by side (``parts.*``) and the GLB,
    PNG (and ``predicted.stl``, ``prediction.json``) show the ``prediction``, or are left out without it.
    ``timestamp`` (ISO 8601, checked by the caller) makes every file byte-reproducible (module docstring).
    """
    from fabpat.assembly import export

    asm: Assembly = lib.assembly
    f = spec.formats
    files: list[str] = []
    stl_files: dict[str, str] = {}
    sheet_files: list[str] = []
    layout = export.flat_layout(lib) if bent_sleeves else None
    if prediction is not None:
        from fabpat.assembly.preview import write_predicted_stl

        record = without_durations(prediction.record, timestamp)
        (tmp / PREDICTION).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        write_predicted_stl(prediction.shape, lib, tmp / "predicted.stl", spec.mesh_tolerance)
        files += [PREDICTION, "predicted.stl"]
    if "step" in f:
        tell("STEP")
        name = "parts.step" if bent_sleeves else "assembly.step"
        export.write_step_assembly(lib, tmp / name, spec.name, timestamp, layout)
        files.append(name)
    if "stl" in f:
        tell("STL")
        (tmp / "parts").mkdir()
        for key, path in export.write_part_stls(lib, tmp / "parts", spec.mesh_tolerance).items():
            stl_files[key] = f"parts/{path.name}"
        files += list(stl_files.values())
    show = not bent_sleeves or prediction is not None
    if "glb" in f and show:
        tell("GLB")
        from fabpat.assembly.parts import CHECK_TOLERANCE
        from fabpat.assembly.preview import write_predicted_glb

        if prediction is not None and bent_sleeves:
            write_predicted_glb(prediction.shape, lib, tmp / "assembly.glb", spec.name, CHECK_TOLERANCE)
        else:
            export.write_glb(lib, tmp / "assembly.glb")
        files.append("assembly.glb")
        if prediction is not None and not bent_sleeves:  # a loaded strip: as assembled, and in use
            write_predicted_glb(prediction.shape, lib, tmp / "predicted.glb", spec.name, CHECK_TOLERANCE)
            files.append("predicted.glb")
    if "3dm" in f:
        tell("3DM")
        from fabpat.assembly.export import write_3dm

        name = "parts.3dm" if bent_sleeves else "assembly.3dm"
        write_3dm(lib, tmp / name, spec.mesh_tolerance, layout, timestamp=timestamp)
        files.append(name)
    if "dxf" in f:
        tell("sheets")
        from fabpat.assembly.sheets import write_sheets

        (tmp / "sheets").mkdir()
        sheet_files = [f"sheets/{n}" for n in write_sheets(asm, nesting, tmp / "sheets", lib.filleted, timestamp)]
        files += sheet_files
    if "svg" in f:
        tell("net SVG")
        from fabpat.assembly.export import colours
        from fabpat.assembly.net import net_svg

        cols = colours(lib)
        svg = net_svg(net, [p.label for p in asm.plates], [p.edge_labels for p in asm.plates],
                      f"{spec.name}: net", [cols[p.type.label] for p in asm.plates])
        (tmp / "net.svg").write_text(svg, encoding="utf-8")
        files.append("net.svg")
    if "png" in f and show:
        tell("PNG")
        from fabpat.assembly.preview import prediction_title, render_predicted_png

        if prediction is not None and bent_sleeves:
            render_predicted_png(prediction.shape, lib, tmp / "assembly.png",
                                 prediction_title(spec.name, prediction.run, prediction.h))
        else:
            from fabpat.assembly.render import render_png

            render_png(lib, tmp / "assembly.png", spec.name)
        files.append("assembly.png")
        if prediction is not None and not bent_sleeves:
            render_predicted_png(prediction.shape, lib, tmp / "predicted.png",
                                 prediction_title(spec.name, prediction.run, prediction.h))
            files.append("predicted.png")
    if "bom" in f:
        tell("BOM")
        from fabpat.assembly.bom import bom_csv, bom_markdown, bom_rows

        rows = bom_rows(lib, stl_files, nesting, sheet_files, patterns)
        (tmp / "bom.csv").write_text(bom_csv(rows), encoding="utf-8")
        moments = prediction.run.sleeve_moments if prediction is not None else None
        md = bom_markdown(lib, rows, nesting, check_lines, moments, candidates, patterns)
        (tmp / "bom.md").write_text(md, encoding="utf-8")
        files += ["bom.csv", "bom.md"]
    return files
