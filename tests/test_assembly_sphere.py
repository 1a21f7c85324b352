"""The truncated icosahedron assembled: 32 plates, 90 sleeves at the right angles, no interference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.assembly.kit.build import plan
from fabpat.assembly.place.checks import check_assembly, interface_midpoints, intersections
from fabpat.assembly.place.parts import PartLibrary
from fabpat.assembly.place.placement import setback
from fabpat.assembly.spec.load import parse_spec
from fabpat.assembly.surface.tiling import HEX_HEX_DIHEDRAL, HEX_PENT_DIHEDRAL
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
    from fabpat.assembly.show.export import read_step_solids, write_step_assembly

    path = tmp_path / "sphere.step"
    write_step_assembly(sphere, path, "sphere")
    solids, names = read_step_solids(path)
    assert solids == 122
    assert len(names) == 122 and {"H01", "P12", "E01", "E90"} <= set(names)


def test_step_names_read_back_as_written(sphere: PartLibrary, tmp_path) -> None:
    """Every placed part: an instance named by its label, of a product "H01 hex 0x0488" (unique, so
    FreeCAD's label renumbering never touches it), holding the shared part product named with its
    parameters — read back with OCCT's XDE reader (STEPCAFControl_Reader), as FreeCAD reads STEP."""
    from fabpat.assembly.show.export import read_step_tree, write_step_assembly

    path = tmp_path / "sphere.step"
    write_step_assembly(sphere, path, "truncated-icosahedron")
    root, rows, solids = read_step_tree(path)
    assert root == "truncated-icosahedron" and solids == 122
    expected = [(label, f"{label} {key}", sphere.name(key)) for label, key, _ in sphere.placed()]
    assert sorted(rows) == sorted(expected)
    assert ("H01", "H01 hex 0x0488", "fabpat 0x0488 n6 e36mm t2mm w0.2") in rows
    assert len({product for _, product, _ in rows}) == 122  # one product per placed part
    text = path.read_text(errors="replace")
    assert text.count("MANIFOLD_SOLID_BREP") == 4  # each exact solid once: 2 plates, 2 sleeves
    assert "COLOUR_RGB('',0.949019" in text  # first palette colour #f2a541 (242/255), as in assembly.png


def _glb_json(path) -> dict:
    """The JSON chunk of a binary glTF 2.0 file (glTF 2.0 spec §4.4: 12-byte header, then chunks)."""
    import json
    import struct

    data = path.read_bytes()
    magic, version, _ = struct.unpack_from("<4sII", data, 0)
    length, kind = struct.unpack_from("<I4s", data, 12)
    assert magic == b"glTF" and version == 2 and kind == b"JSON"
    return json.loads(data[20:20 + length])


def test_glb_of_the_sphere_in_metres_with_shared_meshes(sphere: PartLibrary, tmp_path) -> None:
    """glTF's unit is the metre: the sphere is 0.187 m across, its 122 parts use 4 meshes, and the
    materials are the picture's colours. The outermost points are the hex–hex sleeves: the skeleton's
    bounding cube has half-side 3φ/2 · E (vertices (0, ±1, ±3φ) · E/2), the sleeve adds its profile."""
    import trimesh

    from fabpat.assembly.place.parts import apply
    from fabpat.assembly.show.export import PALETTE, SLEEVE_COLOUR, write_glb

    path = tmp_path / "sphere.glb"
    write_glb(sphere, path)
    gltf = _glb_json(path)
    assert len(gltf["meshes"]) == 4
    placed = [n for n in gltf["nodes"] if "mesh" in n]
    assert len(placed) == 122 and {n["name"] for n in placed} >= {"H01", "P12", "E01", "E90"}
    assert len(gltf["accessors"]) <= 2 * 4  # positions and indices of the 4 meshes, nothing copied

    def linear(hex_colour: str) -> list[float]:  # inverse sRGB transfer function, IEC 61966-2-1
        return [((int(hex_colour[i:i + 2], 16) / 255 + 0.055) / 1.055) ** 2.4 for i in (1, 3, 5)]

    colours = sorted(tuple(round(c, 2) for c in m["pbrMetallicRoughness"]["baseColorFactor"][:3])
                     for m in gltf["materials"])
    want = sorted(tuple(round(c, 2) for c in linear(h)) for h in (PALETTE[0], PALETTE[1], SLEEVE_COLOUR, SLEEVE_COLOUR))
    assert colours == want

    extents = trimesh.load(path).extents  # metres
    far = max(float(np.abs(apply(T, sphere.mesh(key)[0])).max()) for _, key, T in sphere.placed())  # mm
    assert extents == pytest.approx([2 * far / 1000] * 3, rel=1e-6)
    E = sphere.assembly.skeleton.edge_length()
    cube = 3 * (1 + math.sqrt(5)) / 2 * E / 2  # mm: 91.27 for E = 37.61
    assert 2 * cube / 1000 < extents[0] < 2 * (cube + 3.0) / 1000  # a sleeve reaches less than 3 mm out
    assert extents[0] == pytest.approx(0.187, abs=0.0005)


def test_too_deep_sleeve_is_a_spec_error() -> None:
    data = dict(SPHERE, sleeve={"depth": 5.0})
    with pytest.raises(SpecError, match="sleeve.margin"):
        plan(parse_spec(data))
