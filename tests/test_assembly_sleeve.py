"""The sleeve connector: exact B-rep, slot sizes, web, printability, angles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.assembly.place.sleeve import Sleeve
from fabpat.assembly.surface.joints import required_setback
from fabpat.assembly.surface.tiling import HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL
from fabpat.errors import GeometryError

ANGLES = [math.pi, HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL]


@pytest.mark.parametrize("phi", ANGLES)
def test_sleeve_solid_is_valid_with_exact_volume(phi: float) -> None:
    from fabpat.exchange.cad import volume

    s = Sleeve(phi, required_setback(phi, 2.0, 0.2, 1.2))
    solid = s.solid()  # BRepCheck-valid or GeometryError
    assert volume(solid) == pytest.approx(s.volume(), rel=1e-9)
    assert s.web() == pytest.approx(1.2, abs=1e-9)  # the setback is the smallest that leaves the wall


@pytest.mark.parametrize("phi", ANGLES)
def test_slot_geometry_and_angle(phi: float) -> None:
    s = Sleeve(phi, 1.5, thickness=2.0, clearance=0.2, slot_length=4.75, wall=1.2, depth=3.0)
    assert s.slot_width == pytest.approx(2.2)
    assert s.length == pytest.approx(4.75 + 2 * 1.2)
    a, b = s.direction(0), s.direction(1)
    assert math.acos(float(a @ b)) == pytest.approx(phi, abs=1e-12)  # the slots hold the plates at φ
    for side in (0, 1):
        S = s.slot(side)
        d, n = s.direction(side), s.plate_normal(side)
        width = (S @ n).max() - (S @ n).min()
        assert width == pytest.approx(2.2)
        assert (S @ d).max() - (S @ d).min() == pytest.approx(3.0 + 0.1)  # depth + clearance/2 at the bottom
        assert abs(float(d @ n)) < 1e-12


def test_sleeve_prints_on_a_flat_face() -> None:
    from fabpat.assembly.place.parts import triangulate

    s = Sleeve(HEX_PENT_DIHEDRAL, required_setback(HEX_PENT_DIHEDRAL, 2.0, 0.2, 1.2))
    V, F = triangulate(s.solid(), 0.01)
    T = s.print_transform()
    assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3)) and np.linalg.det(T[:3, :3]) == pytest.approx(1.0)
    W = V @ T[:3, :3].T + T[:3, 3]
    assert W[:, 2].min() == pytest.approx(0.0, abs=1e-9)
    # the triangles on z = 0 cover the whole cross-section: the part stands on a full flat face
    on_bed = np.all(np.abs(W[F][:, :, 2]) < 1e-9, axis=1)
    tri = W[F[on_bed]]
    area = 0.5 * np.abs(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]).sum()
    assert area == pytest.approx(s.section_area(), rel=1e-9)


def test_too_small_setback_is_refused() -> None:
    with pytest.raises(GeometryError, match="web"):
        Sleeve(HEX_HEX_DIHEDRAL, 0.5)


def test_required_setback_flat_closed_form() -> None:
    # flat joint: the two slot bottoms are 2 (g − c/2) apart, which must equal the wall
    assert required_setback(math.pi, 2.0, 0.2, 1.2) == pytest.approx(0.1 + 0.6)
