"""The pattern library (``fabpat.patterns.library``): enumeration, connectedness, symmetry, metrics and sampling; deep
sampling is bounded and runs in small batches."""

import math
from pathlib import Path

import numpy as np
import pytest

from fabpat.errors import PatternError
from fabpat.patterns.lattice import Slice, polygon_vertices
from fabpat.patterns.library import enumerate_library, is_connected, is_tileable, sample_library
from fabpat.patterns.pattern import Pattern
from tests.helpers import refusal_in as one_line_error


@pytest.mark.parametrize("sides", range(3, 13))
def test_depth2_library_has_430_patterns(sides: int) -> None:
    lib = enumerate_library(sides, 2)
    assert lib.candidates == 65_535
    assert len(lib) == 430


def test_library_does_not_depend_on_n() -> None:
    assert enumerate_library(3, 2).ids == enumerate_library(7, 2).ids == enumerate_library(12, 2).ids


def test_depth1_library() -> None:
    lib = enumerate_library(6, 1)
    assert len(lib) == 2
    # the edge row's middle face (the central "down" triangle, face 2) is the only solid edge face
    assert set(lib.ids) == {"0x2", "0xa"}


def _components_by_bfs(pattern: Pattern) -> int:
    """Independent check: count components of solid faces joined through shared vertices."""
    faces = [set(f) for f in pattern.solid_faces.tolist()]
    seen: set[int] = set()
    comps = 0
    for start in range(len(faces)):
        if start in seen:
            continue
        comps += 1
        stack = [start]
        seen.add(start)
        while stack:
            a = stack.pop()
            for b in range(len(faces)):
                if b not in seen and faces[a] & faces[b]:
                    seen.add(b)
                    stack.append(b)
    return comps


def test_vectorised_connectedness_matches_bfs() -> None:
    rng = np.random.default_rng(0)
    bits = rng.random((300, 16)) < 0.5
    bits[:, 0] |= ~bits.any(axis=1)
    fast = is_connected(bits, 5, 2)
    slow = [_components_by_bfs(Pattern(Slice(2, b), 5)) == 1 for b in bits]
    assert fast.tolist() == slow
    assert 0 < fast.sum() < len(bits)  # the sample exercises both outcomes


def test_library_patterns_touch_each_edge_only_at_its_midpoint(hex_library) -> None:
    corners = polygon_vertices(6, 36.0)
    mids = (corners + np.roll(corners, -1, axis=0)) / 2
    for p in hex_library.patterns()[::17]:
        used = np.unique(p.solid_faces)
        for i in range(6):
            a, b = corners[i], corners[(i + 1) % 6]
            n = np.array([b[1] - a[1], a[0] - b[0]]) / 36.0
            on_edge = used[np.abs((p.V[used] - a) @ n) < 1e-9]
            assert len(on_edge) == 1
            assert np.allclose(p.V[on_edge[0]], mids[i])


@pytest.mark.parametrize("sides", [3, 5, 6, 8])
def test_rotational_symmetry(hex_library, sides: int) -> None:
    angle = 2 * math.pi / sides
    R = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    for pid in hex_library.ids[::7]:
        p = Pattern.from_id(pid, sides)
        cent = p.V[p.solid_faces].mean(axis=1)
        key = {tuple(np.round(c, 6)) for c in cent}
        rotated = {tuple(np.round(c, 6)) for c in cent @ R.T}
        assert key == rotated


def test_full_slice_metrics_match_regular_polygon_closed_forms() -> None:
    for sides in range(3, 13):
        L = 36.0
        p = Pattern(Slice(2, np.ones(16, bool)), sides, L)
        t = math.tan(math.pi / sides)
        area = sides * L**2 / (4 * t)
        J = sides * L**4 / (96 * t) * (3 / t**2 + 1)  # polar moment of a regular polygon about its centre
        m = p.metrics
        assert m.area == pytest.approx(area, rel=1e-9)
        assert m.perimeter == pytest.approx(sides * L, rel=1e-9)
        assert m.polar_moment == pytest.approx(J, rel=1e-9)
        assert m.ratio == pytest.approx(4 * math.pi * area / (sides * L) ** 2, rel=1e-9)


def test_metrics_scale_with_edge_length(hex_library) -> None:
    pid = hex_library.ids[100]
    a, b = Pattern.from_id(pid, 6, edge=10.0).metrics, Pattern.from_id(pid, 6, edge=30.0).metrics
    assert b.area == pytest.approx(9 * a.area)
    assert b.perimeter == pytest.approx(3 * a.perimeter)
    assert b.polar_moment == pytest.approx(81 * a.polar_moment)
    assert b.ratio == pytest.approx(a.ratio)


def test_depth3_sampler_is_valid_distinct_and_reproducible() -> None:
    s1 = sample_library(6, 3, 25, seed=7)
    s2 = sample_library(6, 3, 25, seed=7)
    s3 = sample_library(6, 3, 25, seed=8)
    assert s1.ids == s2.ids
    assert s1.ids != s3.ids
    assert len(set(s1.ids)) == 25
    assert np.all(is_tileable(s1.bits, 3))
    assert np.all(is_connected(s1.bits, 6, 3))
    for b in s1.bits[:5]:
        assert _components_by_bfs(Pattern(Slice(3, b), 6)) == 1


def test_depth2_sample_is_a_subset_of_the_library(hex_library) -> None:
    s = sample_library(6, 2, 40, seed=1)
    assert set(s.ids) <= set(hex_library.ids)
    with pytest.raises(PatternError):
        sample_library(6, 2, 431)


def test_unknown_id_is_rejected(hex_library) -> None:
    with pytest.raises(PatternError, match="not in the 6-gon"):
        hex_library.pattern("0x0001")
    assert "0x0001" not in hex_library
    assert hex_library.ids[0] in hex_library


def test_deep_sampling_is_bounded(tmp_path: Path) -> None:
    from fabpat.patterns.library import sample_library

    assert "[1, 6]" in one_line_error(tmp_path, "library", "--depth", "12", "--sample", "1")
    with pytest.raises(PatternError, match="above the limit of 50000000"):
        sample_library(6, 6, 10_000)


def test_sampling_in_small_batches(monkeypatch: pytest.MonkeyPatch) -> None:
    import fabpat.patterns.library as library

    full = library.sample_library(6, 3, 5, seed=3, method="rejection")
    monkeypatch.setattr(library, "MAX_BATCH_FACES", 10 * 6 * 4**3)  # 10 draws per batch instead of 4096
    small = library.sample_library(6, 3, 5, seed=3, method="rejection")
    assert len(small) == 5 and small.candidates % 10 == 0 and small.candidates < full.candidates
    assert library.is_connected(small.bits, 6, 3).all() and library.is_tileable(small.bits, 3).all()
