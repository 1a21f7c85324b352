"""Whether the plates' necks fit the sleeves' slots: the part of a plate's outline within a slot's depth
of its polygon edge must stay inside the slot's length, with :data:`NECK_CLEARANCE` to spare (the
slot's end walls would cut it otherwise), and what to change when it does not (sleeve.margin or
sleeve.depth, measured on the outlines). Lengths in mm.
"""

from __future__ import annotations

import math

import numpy as np

from fabpat.assembly.place.placement import Assembly, PlateType
from fabpat.assembly.place.shaped import ShapedPlateType, is_shaped
from fabpat.assembly.surface.joints import setback
from fabpat.errors import SpecError
from fabpat.geometry.fillet import FilletedPattern, interface_half_length
from fabpat.geometry.outline import Outline

NECK_CLEARANCE = 0.05  # mm: least gap required between the neck and a slot's end wall


def neck_half_width(outline: Outline, edge_y: float, depth: float, reach: float) -> float:
    """Largest |x| of the plate outline within ``depth`` mm of polygon edge 0 and |x| ≤ ``reach``.

    ``edge_y`` is the y of edge 0 (−apothem); edge 0 is centred on x = 0, so this is how far the
    material spreads along the edge inside the slot region (flattened within 0.005 mm). Only the
    flattened vertices count, not where a chord crosses the depth line: at the slot's mouth the
    outline may widen past the slot by a sliver (0.01 mm on the shipped sphere's pentagon, no volume
    the interference check sees; 0.04 mm and 0.0013 mm³ on a cube's 90° joint, which that check refuses
    with its hint to raise ``sleeve.margin``).
    """
    best = 0.0
    for P in outline.flatten(0.005):
        d = P[:, 1] - edge_y
        m = (d <= depth) & (np.abs(P[:, 0]) <= reach)
        if m.any():
            best = max(best, float(np.abs(P[m, 0]).max()))
    return best


def neck_extent(outline: Outline, edge_y: float, depth: float, reach: float) -> float:
    """Largest |x| (mm) of the plate material's boundary within ``depth`` mm of polygon edge 0 and
    |x| ≤ ``reach``, the outline flattened within 0.005 mm: as :func:`neck_half_width`, but each chord
    clipped to that region, so that where a chord crosses the depth line counts too (an upper bound
    of what the slot's end walls meet; the advice of :func:`neck_advice` is measured with it)."""
    best = 0.0
    for P in outline.flatten(0.005):
        a = P
        b = np.roll(P, -1, axis=0)  # every chord, the closing one included
        if np.allclose(P[0], P[-1]):
            a, b = P[:-1], P[1:]
        t0, t1 = np.zeros(len(a)), np.ones(len(a))
        # Liang–Barsky: each side of the region is c0 + t c1 ≤ 0 along the chord a + t (b − a), t ∈ [0, 1]
        dy, dx = b[:, 1] - a[:, 1], b[:, 0] - a[:, 0]
        for c0, c1 in ((a[:, 1] - edge_y - depth, dy), (a[:, 0] - reach, dx), (-a[:, 0] - reach, -dx)):
            flat = c1 == 0.0
            t1 = np.where(flat & (c0 > 0.0), -1.0, t1)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.where(flat, 0.0, -c0 / np.where(flat, 1.0, c1))
            t1 = np.where(~flat & (c1 > 0.0), np.minimum(t1, t), t1)
            t0 = np.where(~flat & (c1 < 0.0), np.maximum(t0, t), t0)
        keep = t0 <= t1
        if keep.any():
            x = np.concatenate([a[keep, 0] + t0[keep] * dx[keep], a[keep, 0] + t1[keep] * dx[keep]])
            best = max(best, float(np.abs(x).max()))
    return best


def neck_advice(assembly: Assembly, filleted: dict[PlateType, FilletedPattern]) -> str:
    """What to change so that every plate's neck fits its slots (:func:`check_necks`), measured with
    :func:`neck_extent`: "raise sleeve.margin to ≥ M or lower sleeve.depth to ≤ D", either alone when the
    other cannot help, or "no sleeve.margin or sleeve.depth fits" (mm, M rounded up and D down to 0.01).

    M is the smallest margin whose slots hold every neck at the spec's depth: a longer slot is a longer
    sleeve, whose end walls reach farther along the edge, where some plates (a triangle's) widen as
    fast, so M is found as the fixed point of "the margin the necks within this sleeve's reach need",
    and given only if such a sleeve still fits on the plate edge (:func:`check_geometry`) and clears
    the sleeve of the plate's next edge at their corner. D is the largest depth at the spec's margin
    whose slots hold every neck, given only if every plate still enters by ``sleeve.wall``. Measured
    on an octahedron of 36 mm triangles (0x0488, depth 3): the old advice "margin ≥ 4.83" asked for
    8.40 next and never settled; M = 20.18 settles but its sleeves meet at the corners, so only
    D = 1.33 is given, and that kit builds (``tests/test_assembly_mesh_fixes.py``).
    """
    spec, skel, e = assembly.spec, assembly.skeleton, assembly.plate_edge
    s, E = spec.sleeve, skel.edge_length()
    interface = 2.0 * interface_half_length(e, weight=spec.plates.weight)
    pairs = [(sl, pt, filleted[pt].outline, setback(pt.sides, E, e), e / (2.0 * math.tan(math.pi / pt.sides)))
             for sl in assembly.sleeve_types.values() for pt in assembly.plate_types]

    def margin_needed(margin: float) -> float:
        reach = 0.5 * (interface + margin) + s.wall + 1.0
        return max(2.0 * (neck_extent(o, -ap, sl.arm_end - g, reach) + NECK_CLEARANCE) - interface
                   for sl, _, o, g, ap in pairs)

    margin = s.margin
    for _ in range(200):
        need = margin_needed(margin)
        if need <= margin + 1e-9:
            break
        margin = need
    # the sleeve must fit on the plate edge, and two sleeves of one plate must not meet at its corner: in
    # the plate's plane a sleeve covers its slot arm (out to arm_end from the edge line) over its length,
    # and two arms at a corner of interior angle α meet unless each ends ≥ arm_end / tan(α/2) from it
    corner = max(sl.arm_end / math.tan(0.5 * math.pi * (pt.sides - 2) / pt.sides) for sl, pt, *_ in pairs)
    margin_max = min(e - 2.0 * interface_half_length(e, weight=spec.plates.weight),
                     E - 2.0 * (corner + NECK_CLEARANCE) - interface) - 2.0 * s.wall
    raise_to = math.ceil(margin * 100.0 - 1e-6) / 100.0 if margin_max >= margin else None

    def fits(depth: float) -> bool:
        return all(neck_extent(o, -ap, sl.setback + depth - g, 0.5 * sl.length + 1.0)
                   <= 0.5 * sl.slot_length - NECK_CLEARANCE for sl, _, o, g, ap in pairs)

    spread = max((sl.setback + 0.0 - g for sl, _, _, g, _ in pairs), default=0.0)  # ≤ 0: g ≥ the part's setback
    d_min = s.wall - min(spread, 0.0)
    lo, hi = d_min, s.depth
    lower_to = None
    if lo <= hi and fits(lo):
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if fits(mid) else (lo, mid)
        lower_to = math.floor(lo * 100.0 + 1e-6) / 100.0
        lower_to = lower_to if lower_to >= d_min - 1e-9 and fits(lower_to) else None
    advice = []
    if raise_to is not None:
        advice.append(f"raise sleeve.margin to ≥ {raise_to:.2f}")
    if lower_to is not None:
        advice.append(f"lower sleeve.depth to ≤ {lower_to:.2f}")
    return " or ".join(advice) or ("no sleeve.margin or sleeve.depth fits (the neck is wider than any slot that "
                                   "fits on the edge): choose another pattern or a larger tiling.edge")


def check_necks(assembly: Assembly, filleted: dict[PlateType, FilletedPattern]) -> None:
    """SpecError if a plate's neck is wider than its slot anywhere within the slot's depth; the message
    ends with :func:`neck_advice`. A shaped plate's joints are checked one by one
    (:func:`check_shaped_necks`)."""
    skel, e = assembly.skeleton, assembly.plate_edge
    for key, sleeve in assembly.sleeve_types.items():
        for pt in assembly.plate_types:
            if is_shaped(pt):
                continue
            fp = filleted[pt]
            inside = sleeve.arm_end - setback(pt.sides, skel.edge_length(), e)  # depth of the plate in the slot
            apothem = e / (2.0 * math.tan(math.pi / pt.sides))
            half = neck_half_width(fp.outline, -apothem, inside, 0.5 * sleeve.length + 1.0)
            room = 0.5 * sleeve.slot_length - NECK_CLEARANCE
            if half > room:
                raise SpecError(
                    f"{assembly.spec.source}: the {pt.label} neck is {2 * half:.2f} mm wide {inside:.2f} mm into "
                    f"the {key} slot, longer than the slot ({sleeve.slot_length:.2f} mm): "
                    f"{neck_advice(assembly, filleted)}"
                )
    check_shaped_necks(assembly, filleted)


def check_shaped_necks(asm: Assembly, filleted: dict[PlateType, FilletedPattern]) -> None:
    """SpecError if a shaped plate's neck, within its slot's depth of each of its joints, reaches within
    :data:`NECK_CLEARANCE` of the slot's end walls (as :func:`check_necks` checks a
    regular plate's edge 0, here on every joint in the sleeve's own frame: the slot is centred on the
    union of the joint's two interfaces, not on this plate's)."""
    E, e = asm.skeleton.edge_length(), asm.plate_edge
    for s in asm.sleeves:
        sleeve = asm.sleeve_types[s.kind]
        X, origin = s.transform[:3, 0], s.transform[:3, 3]
        for p, i in s.plates:
            plate = asm.plates[p]
            pt = plate.type
            if not isinstance(pt, ShapedPlateType):
                continue
            C = pt.polygon
            a, b = C[i], C[(i + 1) % len(C)]
            t = (b - a) / np.linalg.norm(b - a)
            inward = np.array([-t[1], t[0]])
            R, shift = plate.transform[:3, :3], plate.transform[:3, 3]
            sign = 1.0 if float((R[:, :2] @ t) @ X) >= 0.0 else -1.0
            mid = float((R[:, :2] @ (0.5 * (a + b)) + shift - origin) @ X)
            inside = sleeve.arm_end - setback(pt.sides, E, e)  # how deep the plate enters the slot
            room = 0.5 * sleeve.slot_length - NECK_CLEARANCE
            worst = 0.0
            for P in filleted[pt].outline.flatten(0.005):
                x = mid + sign * ((P - 0.5 * (a + b)) @ t)  # along the sleeve, from its centre
                m = ((P - 0.5 * (a + b)) @ inward <= inside) & (np.abs(x) <= 0.5 * sleeve.length + 1.0)
                if m.any():
                    worst = max(worst, float(np.abs(x[m]).max()))
            if worst > room:
                raise SpecError(f"{asm.spec.source}: the {pt.label} neck reaches {worst:.2f} mm from the centre of "
                                f"sleeve {s.label} ({s.kind}) {inside:.2f} mm into its slot, past the slot's "
                                f"{0.5 * sleeve.slot_length:.2f} mm: raise sleeve.margin or lower sleeve.depth")
