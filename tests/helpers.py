"""Small helpers shared by several test modules."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
FLAT_SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
#: mm: the mesh of the shared sphere closure. A closure costs about the same from h = 7.5 to 3 (6–7 s idle:
#: the interfaces' refinement dominates the mesh), so the saving is in closing it once, not coarser.
SPHERE_H = 6.0


@functools.cache
def flat_sphere() -> Any:
    """The shipped sphere (``assemblies/truncated-icosahedron.toml``: the paper's pair, straight sleeves)
    closed by ``simulate_assembly`` at :data:`SPHERE_H`, once per test process: the sphere-closure, warm-start,
    prediction and polyhedra tests all read this one closure. Callers must not modify it."""
    from fabpat.assembly.simulation import simulate_assembly
    from fabpat.assembly.spec import load_spec

    return simulate_assembly(load_spec(FLAT_SPHERE), h=SPHERE_H)
