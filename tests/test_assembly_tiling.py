"""Skeleton tilings: truncated icosahedron counts and dihedral angles, honeycomb strips."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.assembly.surface.tiling import (
    HEX_HEX_DIHEDRAL,
    HEX_PENT_DIHEDRAL,
    honeycomb_strip,
    truncated_icosahedron,
)
from fabpat.patterns.lattice import polygon_vertices


@pytest.fixture(scope="module")
def ti():
    return truncated_icosahedron(36.0)


def test_truncated_icosahedron_counts(ti) -> None:
    assert len(ti.V) == 60
    assert len(ti.edges) == 90
    assert len(ti.faces) == 32
    assert int((ti.sides == 6).sum()) == 20 and int((ti.sides == 5).sum()) == 12
    assert len(ti.V) - len(ti.edges) + len(ti.faces) == 2  # Euler: a closed surface of genus 0
    assert len(ti.interior_edges) == 90 and len(ti.boundary_edges) == 0


def test_truncated_icosahedron_is_regular(ti) -> None:
    L = np.linalg.norm(ti.V[ti.edges[:, 1]] - ti.V[ti.edges[:, 0]], axis=1)
    assert np.allclose(L, 36.0, atol=1e-9)
    r = np.linalg.norm(ti.V, axis=1)  # every vertex on one sphere: circumradius (e/4)·√(58 + 18√5)
    assert np.allclose(r, 9.0 * math.sqrt(58 + 18 * math.sqrt(5)), atol=1e-9)
    # each vertex joins two hexagons and one pentagon
    for v in range(60):
        kinds = sorted(len(f) for f in ti.faces if v in f)
        assert kinds == [5, 6, 6]


def test_dihedral_angles_match_closed_forms(ti) -> None:
    assert math.degrees(HEX_HEX_DIHEDRAL) == pytest.approx(138.19, abs=5e-3)
    assert math.degrees(HEX_PENT_DIHEDRAL) == pytest.approx(142.62, abs=5e-3)
    assert HEX_HEX_DIHEDRAL == pytest.approx(math.acos(-math.sqrt(5) / 3), abs=1e-15)
    for k in range(90):
        kinds = sorted(len(ti.faces[f]) for f, _ in ti.edge_faces[k])
        want = HEX_HEX_DIHEDRAL if kinds == [6, 6] else HEX_PENT_DIHEDRAL
        assert kinds in ([6, 6], [5, 6])
        assert ti.dihedral[k] == pytest.approx(want, abs=1e-12)
    kinds = [tuple(sorted(len(ti.faces[f]) for f, _ in ti.edge_faces[k])) for k in range(90)]
    assert kinds.count((6, 6)) == 30 and kinds.count((5, 6)) == 60


def test_normals_point_outward_and_frames_map_plates_onto_faces(ti) -> None:
    assert np.all(np.einsum("ij,ij->i", ti.normals, ti.centroids) > 0)
    for f, loop in enumerate(ti.faces):
        P = polygon_vertices(len(loop), 36.0)
        W = np.c_[P, np.zeros(len(P))] @ ti.frames()[f][:3, :3].T + ti.frames()[f][:3, 3]
        assert np.allclose(W, ti.V[list(loop)], atol=1e-9)


def test_honeycomb_strip_shares_edges() -> None:
    s = honeycomb_strip(2, 15, 36.0)
    assert len(s.faces) == 30
    # interior edges: (rows − 1) per column + (2·rows − 1) between neighbouring columns
    assert len(s.interior_edges) == 15 * 1 + 14 * 3
    assert np.allclose(s.V[:, 2], 0.0) and np.allclose(s.dihedral, math.pi)
    assert s.grid is not None and s.grid[:, 1].max() == 14
    one = honeycomb_strip(1, 3, 36.0)
    assert len(one.interior_edges) == 2 and len(one.V) == 14


def test_strip_rejects_empty() -> None:
    with pytest.raises(ValueError):
        honeycomb_strip(0, 3)
