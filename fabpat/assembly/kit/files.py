"""The kit's files: every output of :func:`fabpat.assembly.kit.build.assemble` written into a folder.

Not atomic on its own: ``assemble`` passes a temporary folder that becomes ``--out`` only when
everything succeeded. With bent sleeves (:func:`fabpat.assembly.solve.predict.bent`) the STEP and 3DM hold
the distinct flat parts side by side (``parts.step``, ``parts.3dm``: :func:`fabpat.assembly.show.export.
flat_layout`) and the GLB, PNG, ``predicted.stl`` and ``prediction.json`` show the predicted shape
(:mod:`fabpat.assembly.solve.preview`), or are left out without a prediction. A strip's ``assembly.*`` show
it flat, as assembled, and its prediction (the end pins pushing it together) adds ``prediction.json``,
``predicted.stl``, ``predicted.glb`` and ``predicted.png``.

With a time stamp (``fabpat assemble --timestamp``) every file is byte-reproducible: the same spec gives the
same bytes in every run. A measured duration is not reproducible, so then ``prediction.json`` leaves out its
``seconds`` (how long the solver ran), as do the manifest's ``candidates`` (:func:`without_durations`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.choose.provenance import PatternRecord
from fabpat.assembly.place.placement import Assembly
from fabpat.assembly.solve.predict import Prediction
from fabpat.assembly.spec.load import AssemblySpec

if TYPE_CHECKING:
    from fabpat.assembly.kit.net import Net
    from fabpat.assembly.place.nesting import Nesting
    from fabpat.assembly.place.parts import PartLibrary

PREDICTION = "prediction.json"
#: the fields of a record that are measured durations (s), left out of a kit written with a time stamp
DURATIONS = ("seconds",)


def without_durations(record: dict[str, Any], timestamp: str | None) -> dict[str, Any]:
    """``record`` as a kit file holds it: without a ``timestamp`` as it is, with one (a reproducible kit)
    without its :data:`DURATIONS`, which differ from run to run (a copy; ``record`` is left unchanged)."""
    if timestamp is None:
        return record
    return {k: v for k, v in record.items() if k not in DURATIONS}


@dataclass(eq=False)
class KitOutput:
    """What the kit's writers read (:data:`WRITERS`): the spec, the parts (``lib``, a
    :class:`~fabpat.assembly.place.parts.PartLibrary`), the sheets' ``nesting``, the ``net``, the check lines, the
    ``timestamp`` (ISO 8601 or None), whether the sleeves bend the plates, the ``prediction``, the roundest
    rule's ``candidates``, the plates' pattern records; and what earlier writers wrote that the BOM lists
    (``stl_files`` {part key: path}, ``sheet_files``)."""

    spec: AssemblySpec
    lib: PartLibrary
    nesting: Nesting | None  # None: no format needs the sheets
    net: Net | None  # None: no svg
    check_lines: list[str]
    timestamp: str | None
    bent_sleeves: bool
    prediction: Prediction | None
    candidates: list[dict[str, Any]] | None
    patterns: Sequence[PatternRecord]
    stl_files: dict[str, str] = field(default_factory=dict)
    sheet_files: list[str] = field(default_factory=list)

    @property
    def shows_shape(self) -> bool:
        """Whether the GLB and PNG can show the object: flat as assembled, or bent as predicted."""
        return not self.bent_sleeves or self.prediction is not None

    @property
    def layout(self) -> list[tuple[str, str, NDArray[np.float64]]] | None:
        """With bent sleeves, the distinct flat parts side by side (``parts.step``, ``parts.3dm``)."""
        from fabpat.assembly.show.export import flat_layout

        return flat_layout(self.lib) if self.bent_sleeves else None


def _prediction(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.solve.preview import write_predicted_stl

    assert k.prediction is not None
    record = without_durations(k.prediction.record, k.timestamp)
    (tmp / PREDICTION).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    write_predicted_stl(k.prediction.shape, k.lib, tmp / "predicted.stl", k.spec.mesh_tolerance)
    return [PREDICTION, "predicted.stl"]


def _step(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.show.export import write_step_assembly

    name = "parts.step" if k.bent_sleeves else "assembly.step"
    write_step_assembly(k.lib, tmp / name, k.spec.name, k.timestamp, k.layout)
    return [name]


def _stl(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.show.export import write_part_stls

    (tmp / "parts").mkdir()
    for key, path in write_part_stls(k.lib, tmp / "parts", k.spec.mesh_tolerance).items():
        k.stl_files[key] = f"parts/{path.name}"
    return list(k.stl_files.values())


def _glb(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.place.parts import CHECK_TOLERANCE
    from fabpat.assembly.show.export import write_glb
    from fabpat.assembly.solve.preview import write_predicted_glb

    if k.prediction is not None and k.bent_sleeves:
        write_predicted_glb(k.prediction.shape, k.lib, tmp / "assembly.glb", k.spec.name, CHECK_TOLERANCE)
    else:
        write_glb(k.lib, tmp / "assembly.glb")
    if k.prediction is None or k.bent_sleeves:
        return ["assembly.glb"]
    # a loaded strip: as assembled, and in use
    write_predicted_glb(k.prediction.shape, k.lib, tmp / "predicted.glb", k.spec.name, CHECK_TOLERANCE)
    return ["assembly.glb", "predicted.glb"]


def _3dm(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.show.export import write_3dm

    name = "parts.3dm" if k.bent_sleeves else "assembly.3dm"
    write_3dm(k.lib, tmp / name, k.spec.mesh_tolerance, k.layout, timestamp=k.timestamp)
    return [name]


def _sheets(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.kit.sheets import write_sheets

    assert k.nesting is not None  # nested whenever dxf is asked for (fabpat.assembly.kit.build)
    (tmp / "sheets").mkdir()
    names = write_sheets(k.lib.assembly, k.nesting, tmp / "sheets", k.lib.filleted, k.timestamp)
    k.sheet_files = [f"sheets/{n}" for n in names]
    return k.sheet_files


def _net(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.kit.net import net_svg
    from fabpat.assembly.show.export import colours

    assert k.net is not None  # unfolded whenever svg is asked for (fabpat.assembly.kit.build)
    asm: Assembly = k.lib.assembly
    cols = colours(k.lib)
    svg = net_svg(k.net, [p.label for p in asm.plates], [p.edge_labels for p in asm.plates],
                  f"{k.spec.name}: net", [cols[p.type.label] for p in asm.plates])
    (tmp / "net.svg").write_text(svg, encoding="utf-8")
    return ["net.svg"]


def _png(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.show.render import render_png
    from fabpat.assembly.solve.preview import prediction_title, render_predicted_png

    p = k.prediction
    if p is not None and k.bent_sleeves:
        render_predicted_png(p.shape, k.lib, tmp / "assembly.png", prediction_title(k.spec.name, p.run, p.h))
    else:
        render_png(k.lib, tmp / "assembly.png", k.spec.name)
    if p is None or k.bent_sleeves:
        return ["assembly.png"]
    render_predicted_png(p.shape, k.lib, tmp / "predicted.png", prediction_title(k.spec.name, p.run, p.h))
    return ["assembly.png", "predicted.png"]


def _bom(k: KitOutput, tmp: Path) -> list[str]:
    from fabpat.assembly.kit.bom import bom_csv, bom_markdown, bom_rows

    rows = bom_rows(k.lib, k.stl_files, k.nesting, k.sheet_files, k.patterns)
    (tmp / "bom.csv").write_text(bom_csv(rows), encoding="utf-8")
    moments = k.prediction.run.sleeve_moments if k.prediction is not None else None
    md = bom_markdown(k.lib, rows, k.nesting, k.check_lines, moments, k.candidates, k.patterns)
    (tmp / "bom.md").write_text(md, encoding="utf-8")
    return ["bom.csv", "bom.md"]


#: format (``output.formats``) → (progress step, writer, whether it needs the object's shape), in the order
#: written: the BOM last, since it lists the STL and sheet files written before it
WRITERS: dict[str, tuple[str, Callable[[KitOutput, Path], list[str]], bool]] = {
    "step": ("STEP", _step, False), "stl": ("STL", _stl, False), "glb": ("GLB", _glb, True),
    "3dm": ("3DM", _3dm, False), "dxf": ("sheets", _sheets, False), "svg": ("net SVG", _net, False),
    "png": ("PNG", _png, True), "bom": ("BOM", _bom, False)}


def write_all(kit: KitOutput, tmp: Path, tell: Callable[[str], None]) -> list[str]:
    """Write every file ``kit.spec``'s formats ask for into ``tmp`` (the prediction's first, then
    :data:`WRITERS` in order, ``tell(step)`` before each); returns their paths relative to ``tmp``.

    With bent sleeves the STEP and 3DM hold the flat parts side by side (``parts.*``) and the GLB and
    PNG (and ``predicted.stl``, ``prediction.json``) show the prediction, or are left out without it.
    A ``timestamp`` (ISO 8601, checked by the caller) makes every file byte-reproducible (module docstring).
    """
    files = _prediction(kit, tmp) if kit.prediction is not None else []
    for fmt, (step, writer, needs_shape) in WRITERS.items():
        if fmt in kit.spec.formats and (kit.shows_shape or not needs_shape):
            tell(step)
            files += writer(kit, tmp)
    return files
