"""``rule = "roundest"``: choose the sphere's hexagon/pentagon pair in the shell solver, not by energy alone.

The paper (§5) picks two patterns "with similar strain energy" in the Dome scenario so that the
joined plates bend into a sphere "without distortions". Similar Dome energy is a proxy: the Dome
scenario loads a plate by moments on all its interfaces, while on the sphere each plate's interfaces
are turned by the sleeves. This rule takes the ``candidates`` best pairs by the energy rule
(:func:`fabpat.assembly.rules.similar_pairs`), closes the sphere with each
(:func:`fabpat.assembly.closure.run_closure`) and keeps the one with the smallest ``sphericity_rms``
among those whose peak strain stays under ``material.strain_limit``. Every pair tried is reported
(:class:`PairTrial`) in the kit's manifest and BOM.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from fabpat.assembly.placement import build_tiling
from fabpat.errors import FabpatError, SpecError

#: mesh edge (mm) of the trial closures: the radius and sphericity of the shipped sphere change by
#: < 0.5 % and < 10 % between h = 3 and the finer meshes (docs/assembly-solver.md), enough to rank pairs
TRIAL_H = 3.0


@dataclass(frozen=True)
class PairTrial:
    """One closed sphere of the roundest rule: the pair, its catalog energies (N·mm) and ratio
    (≥ 1), and the closure's ``radius`` (mm), ``sphericity_rms``, ``peak_strain``; ``error`` is the
    one-line reason when the closure failed (then the numbers are None)."""

    hexagon: str
    pentagon: str
    energy_hexagon: float
    energy_pentagon: float
    energy_ratio: float
    radius: float | None
    sphericity_rms: float | None
    peak_strain: float | None
    over_limit: bool
    error: str | None = None

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (JSON-ready)."""
        return asdict(self)


def roundest_pair(spec: Any, pairs: list[tuple[str, str]], hexagon: dict[str, float],
                  pentagon: dict[str, float], *, h: float = TRIAL_H,
                  progress: Callable[[int, int], None] | None = None) -> tuple[tuple[str, str], list[PairTrial]]:
    """The roundest pair under the strain limit, and every trial (in the order of ``pairs``).

    ``spec``: the AssemblySpec (its sleeve angle, plates and material are used); ``hexagon`` and
    ``pentagon``: catalog energies (N·mm) of the IDs, for the report. ``progress(k, total)`` is told
    before trial k. Raises SpecError if no pair closes under the limit (naming the best one tried).
    """
    from fabpat.assembly.closure import closure_setup, run_closure

    faces = build_tiling(spec).faces
    limit = spec.material.strain_limit
    trials = []
    for k, (hid, pid) in enumerate(pairs):
        if progress is not None:
            progress(k, len(pairs))
        eh, ep = float(hexagon[hid]), float(pentagon.get(pid, hexagon.get(pid, float("nan"))))
        ratio = max(eh, ep) / min(eh, ep)
        try:
            run = run_closure(closure_setup(spec, [hid if len(f) == 6 else pid for f in faces], h=h),
                              strain_limit=limit)
        except FabpatError as e:
            trials.append(PairTrial(hid, pid, eh, ep, ratio, None, None, None, False, str(e)))
            continue
        trials.append(PairTrial(hid, pid, eh, ep, ratio, run.radius, run.sphericity_rms, run.peak_strain,
                                run.peak_strain > limit))
    ok = [t for t in trials if t.error is None and not t.over_limit]
    if not ok:
        closed = [t for t in trials if t.error is None]
        best = min(closed, key=lambda t: t.peak_strain or 0.0) if closed else None
        why = (f"the least strained, {best.hexagon}/{best.pentagon}, reaches {best.peak_strain:.3g}" if best
               else "none of them closed")
        raise SpecError(f"{spec.source}: patterns.rule = \"roundest\": none of the {len(pairs)} pairs tried stays "
                        f"under material.strain_limit = {limit:g} ({why}); raise patterns.candidates or the limit, "
                        "or name the patterns")
    best = min(ok, key=lambda t: (t.sphericity_rms, t.hexagon, t.pentagon))
    return (best.hexagon, best.pentagon), trials
