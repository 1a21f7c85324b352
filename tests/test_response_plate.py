"""The learned response's plate model (fabpat.catalog.response_plate) and the response's accuracy on depth-3
hexagons that it never saw (benchmarks/data/depth3-hexagons-heldout.sqlite)."""

from __future__ import annotations

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
ENERGIES = ("energy_cantilever", "energy_cylinder", "energy_dome")


def _full_dome(solid: np.ndarray, t: P.PlateTopology) -> float:
    """The dome's compliance solved on every vertex of the polygon (no symmetry used), numpy's solver."""
    nv = t.first.size
    K = np.zeros((nv, nv))
    P._bending(solid, t.hinge_faces, t.hinge_vertices, t.hinge_row, t.hinge_k, t.neck_faces, t.neck_vertices,
               t.neck_rows, t.neck_k, np.arange(nv), np.arange(t.hinge_k.size), np.ones(t.hinge_k.size),
               np.arange(t.neck_k.size), np.ones(t.neck_k.size), K)
    P._unit_unused(solid, t.face, np.arange(nv), K, 1)
    f = np.zeros(nv)
    for i in range(len(t.iface)):
        P._pin(K, t.iface[i], False)
        f[t.face[t.iface[i, 0]]] += P.DOME * t.moment[i]
    K = np.tril(K) + np.tril(K, -1).T
    return 0.5 * float(f @ np.linalg.solve(K, f))


@pytest.mark.parametrize("sides, depth", [(6, 3), (5, 3), (6, 2)])
def test_the_one_fan_dome_is_the_whole_polygons_dome(sides: int, depth: int) -> None:
    ids = sample_library(sides, depth, 5, seed=3).ids
    bits = np.array([id_to_bits(i, depth) for i in ids])
    t = P.plate_topology(sides, depth)
    got = P.plate_features(bits, sides, depth)[:, 2]
    want = [np.log(_full_dome(b[t.slice_face], t)) for b in bits]
    assert np.allclose(got, want, rtol=0, atol=1e-6)  # the penalties (1e6) limit the agreement


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
