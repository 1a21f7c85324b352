"""What ``fabpat assemble`` returns, and the fabrication checks every kit makes of its plates; shared by
the kit of plates and sleeves (:mod:`fabpat.assembly.kit.build`) and the one-piece panel
(:mod:`fabpat.assembly.kit.panel`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from fabpat.assembly.place.placement import PlateType
from fabpat.assembly.spec.load import AssemblySpec
from fabpat.assembly.spec.sheet import sheet_of
from fabpat.geometry.fillet import FilletedPattern


class KitReport(Protocol):
    """What a kit's checks measured, as lines (:class:`fabpat.assembly.place.checks.CheckReport`,
    :class:`fabpat.assembly.kit.panel.PanelReport`)."""

    def lines(self) -> list[str]:
        """The report as ``fabpat assemble`` prints it and the manifest stores it."""
        ...


@dataclass(frozen=True)
class AssembleResult:
    """What :func:`assemble` wrote: ``out`` folder, ``files`` relative to it, the checks' report;
    ``prediction`` the ``prediction.json`` record (None without a prediction) and ``notes`` the check
    lines after the parts' report, as the manifest's ``checks`` holds them: the size ``tiling.radius``
    chose, the sheets, the net and the prediction's summary (radius, sphericity, peak strain, how the
    sleeves fit the bent joints)."""

    out: Path
    files: tuple[str, ...]
    report: KitReport  # the kit's checks (CheckReport) or a panel's (PanelReport)
    sheets: int
    warnings: tuple[str, ...] = ()
    prediction: dict[str, Any] | None = None
    notes: tuple[str, ...] = ()


def fabrication_problems(spec: AssemblySpec, filleted: dict[PlateType, FilletedPattern]) -> list[str]:
    """The checks ``fabpat export`` makes, for every distinct plate of the kit: one message per plate
    whose narrowest feature is below its process limit (``plates.process``: print → 0.8 mm, laser →
    2 × ``sheet.kerf``; :func:`fabpat.exchange.registry.width_warnings`)."""
    from fabpat.exchange.registry import width_warnings

    formats = ["stl"] if spec.plates.process == "print" else ["dxf"]  # the export formats of that process
    kerf = sheet_of(spec).kerf
    out = []
    for pt, fp in sorted(filleted.items(), key=lambda item: item[0].label):
        out += [f"plate {pt.label}: {m} (plates.process = {spec.plates.process!r}, tiling.edge = "
                f"{spec.tiling.edge:g} mm)" for m in width_warnings(fp.outline, formats, kerf)]
    return out
