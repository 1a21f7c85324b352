"""``fabpat design --dry-run``: what a design would start from, in seconds and before any shell solve.

Everything :func:`fabpat.design.design` checks before its first solve is checked here the same way and in
the same order (:func:`fabpat.design.api.checked_inputs`: the output folder, ``per`` and ``vary``, the target,
the base spec; then the arc length of a strip target, or a closed target's tiling mapped onto it with
``shapes``: :func:`fabpat.design.mapped.map_base`, seconds, no solve), and the numbers that decide whether
the run is worth its hours are reported:

* a strip: the pin-to-pin length and the end shortening that makes the target's span, the target's
  scale (``--scale-target``), and the **elastica's predicted peak strain**: the strip's reduced model
  (:mod:`fabpat.design.beam`) fitted to the target, its sharpest bend κ as a solid plate's surface
  strain κ t / 2 (t the plates' thickness). A pattern's bars concentrate the bending, so the shell
  solves' peak strain is higher (a lower bound: a target already over the strain limit here is out of
  reach with any pattern);
* a closed tiling: the target fitted to the vertices of the kit's polyhedron (its skeleton, mm): the
  scale (mm per target unit), radius and relative rms, where the closure starts from (the flat plates
  bent by straight sleeves land near it, not on it: the solves decide); the face groups and the
  candidates per polygon; with ``shapes`` the mapped tiling's ``face_irregularity`` and ``planarity``.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from fabpat.design.base import DesignBase
from fabpat.design.target import ClosedTarget, StripTarget, TargetError


def dry_run(target: Any, spec: str | os.PathLike[str], *, out: str | os.PathLike[str] | None = None,
            h: float = 3.0, scale_target: bool = False, per: str = "face",
            vary: str | list[str] | tuple[str, ...] | None = None) -> dict[str, Any]:
    """The plan of :func:`fabpat.design.design` for these arguments (module doc) as plain data: ``kind``,
    ``target``, and for a strip ``pin_length`` (mm), ``span`` (mm), ``end_shortening``, ``scale``,
    ``elastica_peak_strain`` (its κ t / 2 at the sharpest bend), ``strain_limit``, ``thickness`` (mm),
    ``columns``; for a closed tiling ``scale`` (mm per target unit), ``radius`` (mm), ``relative_rms`` of
    the target fitted to the polyhedron's vertices, ``groups`` (face groups) and ``candidates``, with ``shapes``
    ``face_irregularity`` and ``planarity`` of the mapped tiling (as design.json's); ``vary`` (the words the
    design would use, :func:`fabpat.design.design`), for a closed tiling ``per``, and where the search keeps an
    asked-for word fixed, ``notes`` (the line design.json's ``notes`` will hold). Writes nothing. Raises what
    design raises before its first solve: TargetError, SpecError, ExportError."""
    from fabpat.design.api import checked_inputs, unvaried_note
    from fabpat.errors import SpecError
    from fabpat.validate import check

    h = check("h", h, "h", error=SpecError)
    if not isinstance(scale_target, bool):
        raise SpecError(f"scale_target must be True or False, got {scale_target!r}")
    tgt, base, per, words = checked_inputs(target, spec, out, per, vary, scale_target)
    plan = _closed_plan(tgt, base, "shapes" in words) if isinstance(tgt, ClosedTarget) else \
        _strip_plan(tgt, base, h, scale_target)
    unvaried = unvaried_note(tgt, words)
    per_of = {"per": per} if isinstance(tgt, ClosedTarget) else {}  # a strip has no faces to group
    return {**plan, **per_of, "vary": list(words), **({"notes": [unvaried]} if unvaried else {})}


def _strip_plan(strip: StripTarget, base: DesignBase, h: float, scale_target: bool) -> dict[str, Any]:
    from fabpat.design.api import _check_arc, _geometry
    from fabpat.design.beam import Elastica

    ids = sorted(base.energies, key=lambda k: (-base.energies[k], k))  # as the design orders them
    length, _, face_col, edges = _geometry(base, ids[len(ids) // 2], h)
    source = strip.source
    strip, scale = _check_arc(strip, length, scale_target)
    travel = length - strip.span
    if not travel > 0:
        raise TargetError(f"target {source}: its span {strip.span:.1f} mm is not shorter than the strip's "
                          f"pin-to-pin length {length:.1f} mm: the pins must move together to bend it")
    thickness = base.spec.plates.thickness
    kappa, how = _elastica_curvature(Elastica(length, edges), strip, base, ids)
    return {"kind": base.spec.tiling.kind, "target": source, "columns": max(face_col) + 1, "pin_length": length,
            "span": strip.span, "end_shortening": travel / length, "scale": scale,
            "elastica_peak_strain": 0.5 * kappa * thickness, "elastica": how, "thickness": thickness,
            "strain_limit": base.spec.material.strain_limit}


def _elastica_curvature(beam: Any, strip: StripTarget, base: DesignBase, ids: list[str]) -> tuple[float, str]:
    """The largest curvature (1/mm) of the elastica fitted to the target with the candidates' stiffness
    range, and how it was found ("fitted"; "target" when the elastica cannot follow the target: then the
    target's own curvature)."""
    from fabpat.design.beam import fit_stiffness
    from fabpat.errors import SolverError

    log_s = -np.log([base.energies[k] for k in ids])
    u = log_s - log_s[len(ids) // 2]
    lo, hi = np.full(beam.columns, float(u[0])), np.full(beam.columns, float(u[-1]))
    try:
        fitted = fit_stiffness(beam, strip.span, strip.x, strip.z, np.zeros(beam.columns), lo, hi)
        _, _, theta = beam.solve(fitted, strip.span)
        ds = beam.length / len(theta)
        return float(np.abs(np.diff(theta)).max() / ds), "fitted"
    except SolverError:
        t = np.unwrap(np.arctan2(np.diff(strip.z), np.diff(strip.x)))
        s = np.hypot(np.diff(strip.x), np.diff(strip.z))
        return float(np.max(np.abs(np.diff(t)) / (0.5 * (s[:-1] + s[1:])))), "target"


def _closed_plan(tgt: ClosedTarget, base: DesignBase, shapes: bool) -> dict[str, Any]:
    from fabpat.assembly.place.placement import build_tiling, printed_angles
    from fabpat.assembly.surface.joints import skeleton_edge
    from fabpat.design.closed import design_axis, face_groups
    from fabpat.design.closed_api import POLYGONS, _pool_counts

    assert base.rows is not None
    spec = base.spec
    skel = build_tiling(spec)  # edge 1: scaled to the kit's skeleton edge (mm), as the placement does
    E = skeleton_edge(skel, spec.tiling.edge, spec.plates.thickest, spec.sleeve.clearance, spec.sleeve.wall,
                      printed_angles(spec, skel))
    fit = tgt.fit(E * np.asarray(skel.V, dtype=np.float64), design_axis(skel.V, skel.faces))
    groups, _ = face_groups(skel.V, skel.faces, tgt.bands)
    mapped: dict[str, Any] = {}
    if shapes:  # as the design maps it before its first solve (it refuses a face too far from regular)
        from fabpat.design.mapped import map_base

        m = map_base(tgt, base)
        mapped = {"face_irregularity": m.face_irregularity, "planarity": m.planarity}
    return {**mapped, "kind": base.spec.tiling.kind, "target": tgt.source, "scale": float(fit.scale),
            "radius": float(fit.radius), "relative_rms": float(fit.relative_rms), "groups": len(set(groups)),
            "faces": len(skel.faces), "candidates": {POLYGONS.get(n, f"{n}-gon"): _pool_counts(base.rows[n])
                                                     for n in sorted(base.rows, reverse=True)},
            "strain_limit": base.spec.material.strain_limit}
