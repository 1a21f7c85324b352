"""The learned response's plate model (fabpat.catalog.response_plate) and the response's accuracy on depth-3
hexagons that it never saw (benchmarks/data/depth3-hexagons-heldout.sqlite)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import spearmanr

import fabpat
from fabpat.catalog import response as R
from fabpat.catalog import response_file as RF
from fabpat.catalog import response_plate as P
from fabpat.patterns.lattice import id_to_bits
from fabpat.patterns.library import sample_library

HELD_OUT = Path(__file__).parents[1] / "benchmarks" / "data" / "depth3-hexagons-heldout.sqlite"
REFERENCE = Path(__file__).parents[1] / "benchmarks" / "data" / "plate-features-80351af.json"
ENERGIES = ("energy_cantilever", "energy_cylinder", "energy_dome")


def _full_stiffness(solid: np.ndarray, t: P.PlateTopology) -> np.ndarray:
    """The plate's (nv, nv) stiffness on every vertex of the polygon, assembled by numpy from the hinges and
    necks (no symmetry used); a unit diagonal for vertices no solid face moves."""
    nv = t.rep.size
    K = np.zeros((nv, nv))
    for h in np.flatnonzero(solid[t.hinge_faces].all(axis=1)):
        v, r = t.hinge_vertices[h], t.hinge_row[h]
        np.add.at(K, (v[:, None], v[None, :]), t.hinge_k[h] * np.outer(r, r))
    for h in np.flatnonzero(solid[t.neck_faces].all(axis=1)):
        v, r = t.neck_vertices[h], t.neck_rows[h]
        np.add.at(K, (v[:, None], v[None, :]), t.neck_k[h] * (r.T @ r))
    used = np.zeros(nv, dtype=bool)
    used[t.face[solid].ravel()] = True
    K[~used, ~used] = 1.0
    return K


def _pin(K: np.ndarray, iface: np.ndarray, clamp: bool) -> None:
    """The module doc's supports: the outer vertex fixed, the inner ones level (or fixed: ``clamp``)."""
    o, a, b = iface[1:]
    for v in (o, a, b):
        K[v, v] += P.PENALTY
    if not clamp:
        K[a, b] -= P.PENALTY
        K[b, a] -= P.PENALTY


def _full_compliances(solid: np.ndarray, t: P.PlateTopology) -> list[float]:
    """Log cantilever, cylinder and dome compliances solved on the whole polygon by numpy's dense solver."""
    n, K = len(t.iface), _full_stiffness(solid, t)
    out = []
    for pinned, clamp, loads in (([0], True, None), ([0, n // 2], False, P.CYLINDER), (range(n), False, P.DOME)):
        A, f = K.copy(), np.zeros(len(K))
        for i in pinned:
            _pin(A, t.iface[i], clamp)
            if loads is not None:
                f[t.iface[i, 1:]] += loads * t.moment[i]
        if loads is None:
            f[t.iface[n // 2, 1]] = P.FORCE
        out.append(np.log(0.5 * f @ np.linalg.solve(A, f)))
    return out


@pytest.mark.parametrize("sides, depth", [(6, 3), (5, 3), (7, 3), (6, 2), (3, 2)])
def test_the_mode_by_mode_solves_are_the_whole_polygons(sides: int, depth: int) -> None:
    """The compliances from the Fourier modes of the polygon's rotations and the condensed interfaces are
    those of the whole polygon's system (odd and even polygons: an odd one has no alternating mode)."""
    ids = sample_library(sides, depth, 5, seed=3).ids
    bits = np.array([id_to_bits(i, depth) for i in ids])
    t = P.plate_topology(sides, depth)
    got = P.plate_features(bits, sides, depth)[:, :3]
    want = [_full_compliances(b[t.slice_face], t) for b in bits]
    assert np.allclose(got, want, rtol=0, atol=1e-6)  # the penalties (1e6) limit the agreement


def test_the_features_are_those_of_the_full_polygon_solves() -> None:
    """The four features against the previous implementation's outputs (skyline solves on every vertex of the
    polygon, benchmarks/data/plate-features-80351af.json) on seeded samples: equal but for round-off, which the
    penalties (1e6) bring to ~1e-7 in the logarithms (the same code against numpy's LU differs as much)."""
    data = json.loads(REFERENCE.read_text())
    assert len(data["sets"]) == 4
    for block in data["sets"]:
        sides, depth = block["sides"], block["depth"]
        bits = np.array([id_to_bits(i, depth) for i in block["ids"]])
        got = P.plate_features(bits, sides, depth)
        assert np.allclose(got, block["features"], rtol=0, atol=1e-6), (sides, depth)


def test_more_material_is_never_more_compliant() -> None:
    """Adding a solid cell adds hinges and necks (stiffness) and no load: no scenario's compliance grows."""
    ids = sample_library(6, 3, 30, seed=5).ids
    base = np.array([id_to_bits(i, 3) for i in ids])
    more = base.copy()
    rng = np.random.default_rng(0)
    for row in more:
        row[rng.choice(np.flatnonzero(~row[:49]))] = True  # a cell off the edge row, so the pattern stays tileable
    a, b = P.plate_features(base, 6, 3), P.plate_features(more, 6, 3)
    assert np.all(b[:, :3] <= a[:, :3] + 1e-9)
    assert np.any(b[:, :3] < a[:, :3] - 1e-3)


def test_the_features_do_not_depend_on_the_batch() -> None:
    ids = sample_library(6, 3, 40, seed=7).ids
    bits = np.array([id_to_bits(i, 3) for i in ids])
    together = P.plate_features(bits, 6, 3)
    alone = np.vstack([P.plate_features(bits[k: k + 1], 6, 3) for k in range(len(bits))])
    assert np.isfinite(together).all() and np.allclose(together, alone, rtol=0, atol=1e-9)


def test_depth_3_energies_of_patterns_it_never_saw() -> None:
    """The built-in response against 200 seeded random depth-3 hexagons swept apart from its training rows
    (fabpat sweep --depth 3 --sample 200 --seed 20261208): rank correlation ≥ 0.95 and median relative error
    ≤ 5 % per scenario, and its 90 % intervals hold 85–95 % of the truths."""
    trained = RF.response(6).ids
    rows = [r for r in fabpat.catalog(HELD_OUT, sides=6) if r["depth"] == 3 and r["id"] not in trained]
    ids, Y = R.training_arrays(rows)
    assert len(ids) >= 190
    p = fabpat.predict(ids, 6)
    inside = []
    for j, name in enumerate(ENERGIES):
        rho = spearmanr(p.values[name], Y[:, j]).statistic
        median = np.median(np.abs(p.values[name] / Y[:, j] - 1))
        assert rho >= 0.95, (name, rho)
        assert median <= 0.05, (name, median)
        inside.append((p.intervals[name][:, 0] <= Y[:, j]) & (Y[:, j] <= p.intervals[name][:, 1]))
    assert 0.85 <= np.mean(inside) <= 0.95
