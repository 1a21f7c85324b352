"""Pattern choice from energies: grading rule and similar pairs (no catalog needed)."""

from __future__ import annotations

import math

import pytest

from fabpat.assembly import rules
from fabpat.assembly.build import face_patterns
from fabpat.assembly.spec import parse_spec
from fabpat.errors import SpecError
from fabpat.library import enumerate_library


def fake_energies(ids: list[str], lo: float = 1.0, hi: float = 1000.0) -> dict[str, float]:
    """Energies spread geometrically from lo to hi over the IDs (a deterministic stand-in catalog)."""
    n = len(ids)
    return {pid: lo * (hi / lo) ** (k / (n - 1)) for k, pid in enumerate(ids)}


def test_graded_is_ordered_stiff_to_soft_and_well_separated() -> None:
    ids = [f"0x{k:04x}" for k in range(1, 201)]
    e = fake_energies(ids)
    picks = rules.graded(e, 5)
    assert len(set(picks)) == 5
    energies = [e[p] for p in picks]
    assert energies == sorted(energies)  # stiff (small energy) first
    assert rules.separation(e, picks) > 3.0  # ~ (1000 · 0.9)^(1/4) over the trimmed range


def test_graded_refuses_crowded_catalogs() -> None:
    e = {f"0x{k:04x}": 10.0 + 0.01 * k for k in range(20)}
    with pytest.raises(SpecError, match="too close"):
        rules.graded(e, 5)
    with pytest.raises(SpecError, match="fewer than"):
        rules.graded({"0x0001": 1.0, "0x0002": 2.0}, 5)


def test_graded_ignores_non_finite_energies() -> None:
    e = fake_energies([f"0x{k:04x}" for k in range(1, 51)])
    e["0xdead"] = math.inf
    e["0xbeef"] = float("nan")
    assert not {"0xdead", "0xbeef"} & set(rules.graded(e, 4))


def test_similar_pair() -> None:
    hexa = {"0x0001": 1.0, "0x0002": 5.0, "0x0003": 10.0, "0x0004": 50.0, "0x0005": 100.0}
    h, p = rules.similar_pair(hexa)
    assert h == "0x0003" and p in ("0x0002", "0x0004") and h != p
    penta = {"0x0001": 9.0, "0x0003": 10.0, "0x0005": 30.0}
    assert rules.similar_pair(hexa, penta) == ("0x0003", "0x0001")  # nearest other ID in the pentagon scenario


def test_strip_grading_through_the_spec() -> None:
    ids = list(enumerate_library(6, 2).ids)
    e = fake_energies(ids)
    spec = parse_spec({
        "tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 2, "columns": 15},
        "patterns": {"rule": "graded", "scenario": "cylinder", "count": 5, "group_columns": 3},
        "sheet": {"width": 600.0, "height": 400.0},
    })
    faces = face_patterns(spec, lambda sides: e)
    assert len(faces) == 30
    columns = [faces[2 * c] for c in range(15)]  # faces are column-major, two rows
    assert all(faces[2 * c] == faces[2 * c + 1] for c in range(15))
    groups = [columns[3 * g] for g in range(5)]
    assert len(set(groups)) == 5 and all(columns[3 * g + k] == groups[g] for g in range(5) for k in range(3))
    assert [e[g] for g in groups] == sorted(e[g] for g in groups)  # stiff end at column 0


def test_sphere_similar_energy_through_the_spec() -> None:
    ids = list(enumerate_library(6, 2).ids)
    spec = parse_spec({
        "tiling": {"kind": "truncated-icosahedron", "edge": 36.0},
        "patterns": {"rule": "similar-energy"},
        "sheet": {"width": 600.0, "height": 400.0},
    })
    faces = face_patterns(spec, lambda sides: fake_energies(ids) if sides == 6 else {})
    assert len(set(faces[:20])) == 1 and len(set(faces[20:])) == 1 and faces[0] != faces[20]
