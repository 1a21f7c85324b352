"""Kit GLB files are y-up, as glTF says (§3.4), so a flat panel opens lying flat in Blender and a cap's
dome opens apex up; panel.glb has named nodes and a material like every other kit GLB.

The files are read as a viewer reads them: the JSON chunk by hand (the root node's matrix, names,
materials) and the scene with its node transforms applied by trimesh.
"""

from __future__ import annotations

import functools
import io
import json
import struct
from pathlib import Path

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")



def chosen_panel(spec):  # noqa: ANN001, ANN201 - a test's shorthand
    """The panel of ``spec`` with the patterns its ``[patterns]`` choose."""
    from fabpat.assembly.choose.choice import face_patterns
    from fabpat.assembly.place.panel import build_panel

    return build_panel(spec, face_patterns(spec))

def glb_json(data: bytes) -> dict:
    """The JSON chunk of a binary glTF 2.0 file (§4.4: 12-byte header, then chunks)."""
    magic, version, _ = struct.unpack_from("<4sII", data, 0)
    length, kind = struct.unpack_from("<I4s", data, 12)
    assert magic == b"glTF" and version == 2 and kind == b"JSON"
    return json.loads(data[20:20 + length])


def root_turn(gltf: dict) -> np.ndarray:
    """(3, 3) rotation of the scene's one top node (glTF matrices are column-major)."""
    (top,) = gltf["scenes"][gltf.get("scene", 0)]["nodes"]
    node = gltf["nodes"][top]
    M = np.array(node["matrix"], dtype=float).reshape(4, 4).T
    return M[:3, :3]


def assert_z_goes_up(gltf: dict) -> None:
    """The model's +z ends up along glTF's up axis +y; x stays."""
    R = root_turn(gltf)
    assert R @ [0, 0, 1] == pytest.approx([0, 1, 0], abs=1e-12)
    assert R @ [1, 0, 0] == pytest.approx([1, 0, 0], abs=1e-12)


def test_panel_glb_lies_flat_with_a_named_node_and_a_material(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from fabpat.assembly.kit.panel import write_glb
    from fabpat.assembly.spec.load import parse_spec

    spec = parse_spec({"name": "little panel", "tiling": {"kind": "panel", "edge": 36.0, "rows": 1, "columns": 1},
                       "patterns": {"tiles": [["0x0488"]]}, "plates": {"thickness": 2.0},
                       "sheet": {"width": 300.0, "height": 200.0}}, "panel.toml")
    path = tmp_path / "panel.glb"
    monkeypatch.setattr("fabpat.assembly.place.parts.CHECK_TOLERANCE", 0.5)  # a coarse mesh: the same file, faster
    panel = chosen_panel(spec)
    write_glb(panel, path)
    data = path.read_bytes()
    gltf = glb_json(data)
    assert_z_goes_up(gltf)
    names = [n.get("name") for n in gltf["nodes"]]
    assert "little panel" in names and "panel" in names
    assert len(gltf["materials"]) == 1 and "baseColorFactor" in gltf["materials"][0]["pbrMetallicRoughness"]
    mesh = trimesh.load(io.BytesIO(data), file_type="glb", force="mesh")  # node transforms applied
    lo, hi = mesh.bounds
    assert hi[1] - lo[1] == pytest.approx(0.002, abs=1e-9)  # the 2 mm thickness is along y, the up axis
    assert hi[0] - lo[0] > 0.05 and hi[2] - lo[2] > 0.05  # the hexagon spreads in x and z
    flat = np.abs(mesh.face_normals[:, 1]) > 1.0 - 1e-9  # faces looking up or down
    # top and bottom are the part's two faces (m²), the rest is its 2 mm rim
    assert mesh.area_faces[flat].sum() == pytest.approx(2e-6 * panel.outline.area, rel=0.01)  # 0.5 mm chords


def test_cap_glb_opens_apex_up(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.place.parts import PartLibrary
    from fabpat.assembly.show import export
    from fabpat.assembly.spec.load import parse_spec

    spec = parse_spec({"name": "cap", "tiling": {"kind": "hex-cap", "rings": 1, "centre": 5, "edge": 36.0},
                       "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"}, "plates": {"thickness": 1.0},
                       "sleeve": {"angle": "dihedral"}})
    monkeypatch.setattr(export, "scene", functools.partial(export.scene, tolerance=0.5))  # coarse meshes: faster
    export.write_glb(PartLibrary(*plan(spec)), tmp_path / "cap.glb")
    data = (tmp_path / "cap.glb").read_bytes()
    assert_z_goes_up(glb_json(data))
    sc = trimesh.load(io.BytesIO(data), file_type="glb")
    centre = {}
    for node in sc.graph.nodes_geometry:
        T, g = sc.graph[node]
        if node[0] in "HP":
            centre[node] = trimesh.transform_points(sc.geometry[g].vertices, T).mean(axis=0)
    assert len(centre) == 6
    apex = centre.pop("P1")
    assert apex[[0, 2]] == pytest.approx([0, 0], abs=1e-6)  # on the vertical axis
    assert all(c[1] < apex[1] - 0.005 for c in centre.values())  # every hexagon at least 5 mm below it
