"""Warm starts (simulate_assembly(spec, start=…)): a one-pattern-changed sphere and strip reach the cold
start's equilibrium with at most 35 % of its factorizations (h = 6 mm); a start of another tiling is
refused."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from fabpat.assembly.solve.simulation import simulate_assembly
from fabpat.assembly.spec.load import PatternSpec, load_spec
from fabpat.errors import SpecError
from tests.helpers import SPHERE_H, flat_sphere

ROOT = Path(__file__).resolve().parents[1]
SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
STRIP = ROOT / "assemblies" / "test-small.toml"


@pytest.mark.slow
def test_warm_start_reaches_the_cold_equilibrium_in_fewer_factorizations() -> None:
    """The sphere with its pentagon pattern changed, warm-started from the shipped sphere's closed state
    (simulate_assembly(spec, start=…)), reaches the cold start's equilibrium (nodes within 1e-5 mm) in
    fewer factorizations: 7 against 11. The cold closure is itself one increment now (closure.
    CLOSURE_FIRST_STEP; it took 20 factorizations in 4), so the warm start gains only its nearer first
    guess, not the path. The shipped sphere's closure is the one the sphere-closure tests share
    (tests.helpers.flat_sphere, h = 6 mm)."""
    spec = load_spec(SPHERE)
    other = dataclasses.replace(spec, patterns=PatternSpec(polygons=((6, "0x0488"), (5, "0x1c08"))))
    shipped = flat_sphere()
    cold = simulate_assembly(other, h=SPHERE_H)
    warm = simulate_assembly(other, h=SPHERE_H, start=shipped)
    fc, fw = cold.fields(), warm.fields()
    assert fw["warm_start"] is True and fc["warm_start"] is False
    assert fw["factorizations"] <= 0.7 * fc["factorizations"], (fw["factorizations"], fc["factorizations"])
    n = len(cold.model.X)
    moved = np.abs(warm.run.x[:n] - cold.run.x[:n]).max()
    assert moved < 1e-5, moved
    assert fw["sphericity_rms"] == pytest.approx(fc["sphericity_rms"], rel=1e-6)
    with pytest.raises(SpecError, match="same tiling"):
        simulate_assembly(STRIP, h=6.0, start=shipped)


@pytest.mark.slow
def test_strip_warm_start_from_a_one_column_change() -> None:
    """test-small (1 × 3) with its middle column changed, warm-started from the original strip's arch:
    the same equilibrium (nodes within 1e-4 mm, the arch's peak to 1e-6) in a third of the factorizations
    or fewer (measured: 11 against 120; 147 before the path's predictor reused the last factorization)."""
    spec = load_spec(STRIP)
    shipped = simulate_assembly(spec, h=6.0)
    groups = list(spec.patterns.groups)
    groups[1] = "0x2a88"
    other = dataclasses.replace(spec, patterns=PatternSpec(groups=tuple(groups), group_columns=1))
    cold = simulate_assembly(other, h=6.0)
    warm = simulate_assembly(other, h=6.0, start=shipped)
    fc, fw = cold.fields(), warm.fields()
    assert fw["warm_start"] is True
    assert fw["factorizations"] <= 0.35 * fc["factorizations"], (fw["factorizations"], fc["factorizations"])
    n = len(cold.model.X)
    moved = np.abs(warm.run.result.final.displacement[:n] - cold.run.result.final.displacement[:n]).max()
    assert moved < 1e-4, moved
    assert fw["peak"] == pytest.approx(fc["peak"], rel=1e-6)
    with pytest.raises(SpecError, match="same tiling"):
        simulate_assembly(spec, h=6.0, start="previous.json")
