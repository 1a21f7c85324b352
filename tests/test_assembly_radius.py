"""``tiling.radius``: a closed tiling sized by the radius its plates should lie at, not by their edge.

The checks are independent of the sizing code: the placed plates (:func:`fabpat.assembly.place.placement.place`)
are sampled at random, area-weighted, and their mean distance from the centre (or the tube's axis) is
compared with the radius asked; a truncated icosahedron's skeleton is compared with its closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.assembly.place.placement import place, radius_line
from fabpat.assembly.spec.load import parse_spec
from fabpat.errors import SpecError
from fabpat.patterns.lattice import polygon_vertices


def spec_of(tiling: dict[str, object], angle: str = "flat") -> dict[str, object]:
    patterns = {"hexagon": "0x0488"} if tiling["kind"] == "hex-tube" else {"hexagon": "0x0488", "pentagon": "0x0508"}
    return {"tiling": tiling, "patterns": patterns, "sleeve": {"angle": angle}}


def sampled_radius(asm, axis: np.ndarray | None, per_triangle: int = 4000) -> float:
    """Mean distance of random points spread uniformly over the placed plates' mid-surfaces."""
    rng = np.random.default_rng(7)
    centre = asm.skeleton.V.mean(axis=0)
    total = weight = 0.0
    for p in asm.plates:
        C = polygon_vertices(p.type.sides, asm.plate_edge)
        for a, b in zip(C, np.roll(C, -1, axis=0), strict=True):
            u = rng.random((per_triangle, 2))
            flip = u.sum(axis=1) > 1
            u[flip] = 1 - u[flip]
            q = u[:, :1] * a + u[:, 1:] * b  # the polygon's centre is the plate frame's origin
            Q = np.column_stack([q, np.full(len(q), 0.5 * asm.spec.plates.thickness), np.ones(len(q))])
            d = (p.transform @ Q.T).T[:, :3] - centre
            if axis is not None:
                d -= np.outer(d @ axis, axis)
            area = 0.5 * abs(a[0] * b[1] - a[1] * b[0])
            total += area * float(np.linalg.norm(d, axis=1).mean())
            weight += area
    return total / weight


def placed(data: dict[str, object]):
    spec = parse_spec(data, "radius.toml")
    faces = spec.tiling.skeleton().faces
    return spec, place(spec, ["0x0488" if len(f) == 6 else "0x0508" for f in faces])


@pytest.mark.parametrize(("tiling", "axis", "rel"), [
    ({"kind": "truncated-icosahedron", "radius": 100.0}, None, 1e-9),
    # nearly regular faces: plates at their face's best fit, set back by their sleeve part's one setback,
    # not exactly the face's polygon shrunk about its centroid that the sizing assumes
    ({"kind": "goldberg", "m": 2, "radius": 150.0}, None, 1e-3),
    ({"kind": "hex-tube", "rows": 8, "columns": 3, "radius": 90.0}, np.array([1.0, 0.0, 0.0]), 1e-3),
])
def test_the_plates_lie_at_the_radius_asked(tiling: dict[str, object], axis: np.ndarray | None, rel: float) -> None:
    spec, asm = placed(spec_of(tiling))
    assert spec.tiling.radius == tiling["radius"]
    assert asm.plate_edge == spec.tiling.edge
    got = asm.placed_radius(axis)
    assert sampled_radius(asm, axis) == pytest.approx(got, rel=2e-4)  # random sampling's error: ~3e-5
    assert got == pytest.approx(float(tiling["radius"]), rel=rel)


def test_a_sized_truncated_icosahedron_has_the_closed_form_skeleton() -> None:
    spec, asm = placed(spec_of({"kind": "truncated-icosahedron", "radius": 100.0}, angle="dihedral"))
    E = asm.skeleton.edge_length()
    circumradius = E / 4 * math.sqrt(58 + 18 * math.sqrt(5))  # of the truncated icosahedron of edge E
    assert np.linalg.norm(asm.skeleton.V - asm.skeleton.V.mean(axis=0), axis=1) == pytest.approx(circumradius)
    # the plates lie inside the skeleton's vertices (set back, on the faces): a smaller mean distance
    assert 0.9 * circumradius < 100.0 < circumradius
    assert radius_line(asm) == (f"tiling.radius = 100 mm: plate edge {spec.tiling.edge:.4f} mm puts the plates' "
                                f"mid-surfaces 100.0000 mm from the centre as placed")


def test_twice_the_radius_is_twice_the_placed_size_not_twice_the_edge() -> None:
    small, a = placed(spec_of({"kind": "truncated-icosahedron", "radius": 100.0}))
    large, b = placed(spec_of({"kind": "truncated-icosahedron", "radius": 200.0}))
    assert b.placed_radius() == pytest.approx(2 * a.placed_radius(), rel=1e-9)
    # the sleeves' allowance between plate and skeleton edge does not scale
    allowance = a.skeleton.edge_length() - small.tiling.edge
    assert b.skeleton.edge_length() - large.tiling.edge == pytest.approx(allowance, rel=1e-9)
    assert large.tiling.edge > 2 * small.tiling.edge
    assert "the sleeves bend them as they close" in radius_line(a)


@pytest.mark.parametrize(("tiling", "message"), [
    ({"kind": "goldberg", "m": 2, "radius": 90.0, "edge": 30.0}, "tiling.radius and tiling.edge both size the tiling"),
    # the window starts at the smallest plate edge a sleeve fits on (placement.check_geometry: 3.795 mm
    # with the default sleeve and w = 0.2), not at the edge range's 1 mm
    ({"kind": "goldberg", "m": 2, "radius": 3.0}, "tiling.radius = 3 mm is out of reach: plate edges of 3.795 … "
     "1000 mm make this tiling 14.32 … 2738 mm in radius with these sleeves: give a radius in that range"),
    ({"kind": "truncated-icosahedron", "radius": 20000.0}, "tiling.radius = 20000 is out of range"),
    ({"kind": "truncated-icosahedron"}, "tiling.edge is missing: give tiling.edge (the plate edge, mm) or "
     "tiling.radius"),
    ({"kind": "hex-cap", "rings": 2, "radius": 100.0}, 'tiling.radius is only for kind = "truncated-icosahedron"'),
    ({"kind": "honeycomb-strip", "rows": 1, "columns": 3, "radius": 100.0}, "tiling.radius is only for kind"),
    ({"kind": "truncated-icosahedron", "radius": "big"}, "tiling.radius must be a number"),
    ({"kind": "truncated-icosahedron", "radius": -5.0}, "tiling.radius = -5 is out of range"),
])
def test_bad_radius_is_one_line(tiling: dict[str, object], message: str) -> None:
    with pytest.raises(SpecError, match=None) as e:
        parse_spec(spec_of(tiling), "radius.toml")
    assert message in str(e.value), str(e.value)
    assert len(str(e.value).splitlines()) == 1  # not also "missing key tiling.edge"


def test_a_radius_beyond_the_old_edge_range_is_reached() -> None:
    """1500 mm is above the edge's 1000 mm but inside what plate edges reach (the window's message)."""
    spec, asm = placed(spec_of({"kind": "truncated-icosahedron", "radius": 1500.0}))
    assert asm.placed_radius() == pytest.approx(1500.0, rel=1e-9) and spec.tiling.edge < 1000.0
