"""The truncated icosahedron assembled: 32 plates, 90 sleeves at the right angles, no interference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.assembly.build import plan
from fabpat.assembly.checks import check_assembly, interface_midpoints, intersections
from fabpat.assembly.parts import PartLibrary
from fabpat.assembly.placement import setback
from fabpat.assembly.spec import parse_spec
from fabpat.assembly.tiling import HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL
from fabpat.errors import GeometryError, SpecError

SPHERE = {
    "tiling": {"kind": "truncated-icosahedron", "edge": 36.0},
    "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"},
    "sheet": {"width": 600.0, "height": 400.0},
}


@pytest.fixture(scope="module")
def sphere() -> PartLibrary:
    return PartLibrary(*plan(parse_spec(SPHERE)))


def test_counts(sphere: PartLibrary) -> None:
    asm = sphere.assembly
    assert len(asm.plates) == 32 and len(asm.sleeves) == 90 and len(asm.skeleton.V) == 60
    assert asm.counts() == {"hex 0x0488": 20, "pent 0x0508": 12, "S-HH": 30, "S-HP": 60}
    assert sum(p.label.startswith("H") for p in asm.plates) == 20
    # every plate edge carries the label of the sleeve on it, each label on exactly two plates
    labels = [lab for p in asm.plates for lab in p.edge_labels]
    assert len(labels) == 180 and all(labels.count(s.label) == 2 for s in asm.sleeves)


def test_sleeve_angles(sphere: PartLibrary) -> None:
    types = sphere.assembly.sleeve_types
    assert types["S-HH"].dihedral == pytest.approx(HEX_HEX_DIHEDRAL, abs=1e-12)
    assert types["S-HP"].dihedral == pytest.approx(HEX_PENT_DIHEDRAL, abs=1e-12)
    for s in sphere.assembly.sleeves:
        (fa, _), (fb, _) = s.plates
        na = sphere.assembly.plates[fa].transform[:3, 2]
        nb = sphere.assembly.plates[fb].transform[:3, 2]
        # plates of a joint are tilted by π − φ: the sleeve holds them at the dihedral angle
        assert math.acos(float(np.clip(na @ nb, -1, 1))) == pytest.approx(math.pi - types[s.kind].dihedral, abs=1e-9)
        assert np.allclose(s.transform[:3, :3] @ s.transform[:3, :3].T, np.eye(3), atol=1e-12)


def test_skeleton_leaves_every_web_at_least_a_wall(sphere: PartLibrary) -> None:
    asm = sphere.assembly
    E = asm.skeleton.edge_length()
    assert 36.0 < E < 38.0
    assert setback(5, E, 36.0) == pytest.approx(asm.sleeve_types["S-HP"].setback)  # pentagons set the size
    for sl in asm.sleeve_types.values():
        assert sl.web() >= 1.2 - 1e-9


def test_sleeves_sit_on_interface_midpoints(sphere: PartLibrary) -> None:
    err, depth = interface_midpoints(sphere)
    assert err < 1e-9
    assert 2.5 < depth <= 3.0 + 1e-9


def test_no_interference_in_3d(sphere: PartLibrary) -> None:
    report = check_assembly(sphere)
    assert report.max_overlap <= 1e-6
    assert report.pairs_tested > 90 * 2  # each sleeve against its two plates at least
    assert report.min_plate_sleeve_gap == pytest.approx(0.1, abs=0.02)  # clearance/2, up to the 0.02 mm mesh


def test_interference_is_detected(sphere: PartLibrary) -> None:
    asm = sphere.assembly
    moved = asm.plates[0].transform.copy()
    moved[:3, 3] += 2.0 * moved[:3, 0]  # slide H01 by 2 mm in its plane: it hits a sleeve wall
    from dataclasses import replace

    plates = (replace(asm.plates[0], transform=moved), *asm.plates[1:])
    bad = PartLibrary(replace(asm, plates=plates), sphere.filleted)
    bad._meshes.update(sphere._meshes)  # reuse the meshes: only placements changed
    with pytest.raises(GeometryError, match="intersect"):
        intersections(bad)
    with pytest.raises(GeometryError, match="interface midpoint"):
        interface_midpoints(bad)


def test_step_assembly_of_the_sphere_reimports(sphere: PartLibrary, tmp_path) -> None:
    from fabpat.assembly.export import read_step_solids, write_step_assembly

    path = tmp_path / "sphere.step"
    write_step_assembly(sphere, path, "sphere")
    solids, names = read_step_solids(path)
    assert solids == 122
    assert len(names) == 122 and {"H01", "P12", "E01", "E90"} <= set(names)


def test_too_deep_sleeve_is_a_spec_error() -> None:
    data = dict(SPHERE, sleeve={"depth": 5.0})
    with pytest.raises(SpecError, match="sleeve.margin"):
        plan(parse_spec(data))
