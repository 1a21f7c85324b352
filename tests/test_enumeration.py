"""The pruned enumeration (``fabpat.patterns.enumeration``) and the library count
(``fabpat.patterns.count``), checked against the n-gon filters of ``fabpat.patterns.library``, which build
the whole polygon's face–vertex graph and share no code with the frontier programme."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chisquare

from fabpat.errors import PatternError
from fabpat.patterns.count import count_patterns, wilson_interval
from fabpat.patterns.enumeration import count_library, enumeration, free_faces
from fabpat.patterns.lattice import bits_to_id, edge_row, n_faces
from fabpat.patterns.library import is_connected, is_tileable, sample_library

POLYGONS = (3, 4, 5, 6, 7, 8, 12)


def _edge_rule_draws(depth: int, count: int, density: float, seed: int) -> np.ndarray:
    """(count, 4**depth) slices that pass the edge rule, free faces solid with probability ``density``."""
    rng = np.random.default_rng(seed)
    b = rng.random((count, n_faces(depth))) < density
    row, middle = edge_row(depth)
    b[:, row] = False
    b[:, middle] = True
    return b


@pytest.mark.parametrize("sides", POLYGONS)
def test_depth1_and_depth2_counts_are_the_papers(sides: int) -> None:
    assert count_library(sides, 1) == 2
    assert count_library(sides, 2) == 430  # paper §3.2; checked facts: 430 for n = 3 … 8 and 12


def test_depth2_listing_equals_the_brute_force_over_all_slices() -> None:
    """Every one of the 2^16 − 1 depth-2 slices through the two n-gon filters, for each polygon: the same
    430 slices, in the same (ID) order, as the enumeration reads off its states."""
    M = n_faces(2)
    values = np.arange(1, 2**M, dtype=np.int64)
    every = ((values[:, None] >> np.arange(M - 1, -1, -1)) & 1).astype(bool)
    tileable = every[is_tileable(every, 2)]
    assert len(tileable) == 2 ** free_faces(2) == 512
    for sides in POLYGONS:
        brute = tileable[is_connected(tileable, sides, 2)]
        assert np.array_equal(enumeration(sides, 2).all_bits(), brute), sides


def test_depth2_library_is_built_without_a_filter(monkeypatch: pytest.MonkeyPatch) -> None:
    """No candidate is drawn and rejected: the listing never calls the n-gon filters."""
    import fabpat.patterns.library as library

    def refuse(*args: object) -> None:
        raise AssertionError("the listing filtered candidates")

    monkeypatch.setattr(library, "is_connected", refuse)
    monkeypatch.setattr(library, "is_tileable", refuse)
    lib = library.enumerate_library(9, 2)
    assert len(lib) == 430 and list(lib.ids) == sorted(lib.ids)


@pytest.mark.parametrize("sides", [3, 5, 6, 12])
def test_membership_agrees_with_the_ngon_filter_at_depth3(sides: int) -> None:
    """The programme's verdict on single slices (its steps walked with all faces fixed) equals the
    connectivity of the real n-gon pattern, on sparse, even and dense random slices."""
    E = enumeration(sides, 3)
    b = np.concatenate([_edge_rule_draws(3, 120, p, seed=sides) for p in (0.35, 0.5, 0.7)])
    expected = is_connected(b, sides, 3)
    assert 0.1 < expected.mean() < 0.9  # both outcomes are exercised
    assert [E.contains(x) for x in b] == expected.tolist()


@pytest.mark.parametrize("seed", [0, 1])
def test_depth3_counts_of_completions_match_a_brute_force(seed: int) -> None:
    """Fix a valid depth-3 pattern's first 39 faces; the 2^10 ways to label the last 10 free faces (39–48)
    are checked on the hexagon and the pentagon: the programme's count of completions is exact."""
    pattern = enumeration(6, 3).sample(1, seed)[0]
    b = np.tile(pattern, (1024, 1))
    b[:, 39:49] = ((np.arange(1024)[:, None] >> np.arange(10)) & 1).astype(bool)
    for sides in (5, 6):
        brute = int(is_connected(b, sides, 3).sum())
        assert enumeration(sides, 3).count_prefix(pattern[:39]) == brute
        assert 0 < brute < 1024


def test_depth3_count_does_not_depend_on_n_and_matches_the_acceptance_rate() -> None:
    # every finished pattern winds g = 1 times (g = 0 is cut): a g ≥ 2 would make the count depend on n
    assert set(enumeration(6, 3).table.final_g) == {1}
    five, six = count_library(5, 3), count_library(6, 3)
    assert five == six == count_library(3, 3) == count_library(12, 3)
    draws = 2000  # an independent estimate: the share of uniform edge-rule slices that are connected
    accepted = int(is_connected(_edge_rule_draws(3, draws, 0.5, seed=11), 6, 3).sum())
    low, high = wilson_interval(accepted, draws, z=4.0)
    assert low < six / 2 ** free_faces(3) < high


def test_rank_and_unrank_are_inverse_in_id_order() -> None:
    E = enumeration(6, 2)
    listed = E.all_bits()
    ids = [bits_to_id(E.unrank(r)) for r in range(E.total)]
    assert ids == [bits_to_id(b) for b in listed] and ids == sorted(ids)
    assert [E.rank(b) for b in listed] == list(range(E.total))
    E3 = enumeration(6, 3)
    for r in [0, 1, E3.total // 3, E3.total - 1]:
        assert E3.rank(E3.unrank(r)) == r
    assert bits_to_id(E3.unrank(0)) < bits_to_id(E3.unrank(1)) < bits_to_id(E3.unrank(E3.total - 1))
    with pytest.raises(PatternError, match="rank must be"):
        E.unrank(E.total)
    with pytest.raises(PatternError, match="not a connected"):
        E.rank(np.zeros(16, bool))


def test_exact_sampler_is_uniform_over_the_430() -> None:
    """43 000 draws with replacement: every pattern expected 100 times; a chi-square test over the 430
    (a draw is a uniform rank, unranked: the ranks' spread and unranking's bijection make it uniform)."""
    E = enumeration(6, 2)
    counts = np.bincount(E.ranks(43_000, seed=5, distinct=False), minlength=430)
    drawn = np.bincount([E.rank(E.unrank(r)) for r in range(430)], minlength=430)
    assert drawn.tolist() == [1] * 430  # unranking is a bijection onto the library
    assert chisquare(counts).pvalue > 1e-3


def test_exact_depth3_sample_is_valid_distinct_and_follows_the_face_marginals() -> None:
    E = enumeration(6, 3)
    s = sample_library(6, 3, 2000, seed=4, method="exact")
    assert s.candidates == 2000 and len(set(s.ids)) == 2000
    assert is_tileable(s.bits, 3).all() and is_connected(s.bits, 6, 3).all()
    # P(face 0 solid) = count of patterns with face 0 solid / total, from the counts; the draws follow it
    p = E.count_prefix([True]) / E.total
    assert abs(s.bits[:, 0].mean() - p) < 4 * np.sqrt(p * (1 - p) / 2000)


def test_auto_sampling_is_exact_at_depth3_from_its_threshold(monkeypatch: pytest.MonkeyPatch) -> None:
    import fabpat.patterns.library as library

    monkeypatch.setattr(library, "EXACT_SAMPLE_FROM", 20)
    exact = library.sample_library(6, 3, 20, seed=3)
    assert exact.candidates == 20  # nothing drawn and rejected
    assert exact.ids == library.sample_library(6, 3, 20, seed=3, method="exact").ids
    assert library.sample_library(6, 3, 19, seed=3).candidates % 4096 == 0  # below it: rejection batches
    assert library.sample_library(6, 2, 30, seed=3).candidates % 4096 == 0  # depth 2 keeps its seeds' samples


def test_sampling_methods() -> None:
    lib = sample_library(6, 2, 30, seed=2, method="exact")
    assert set(lib.ids) <= {bits_to_id(b) for b in enumeration(6, 2).all_bits()}
    assert len(set(lib.ids)) == 30
    with pytest.raises(PatternError, match="only 430 patterns"):
        sample_library(6, 2, 431, method="exact")
    with pytest.raises(PatternError, match="auto, exact, rejection"):
        sample_library(6, 3, 2, method="fast")
    with pytest.raises(PatternError, match="too deep to enumerate"):
        sample_library(6, 4, 2, method="exact")
    with pytest.raises(PatternError, match="sample size"):
        enumeration(6, 2).sample(0)
    with pytest.raises(PatternError, match="seed"):
        enumeration(6, 2).sample(3, seed=-1)


def test_big_uniform_integers_stay_below_and_spread() -> None:
    from fabpat.patterns.enumeration import _below

    rng = np.random.default_rng(0)
    big = 2**70 + 3  # beyond numpy's int64: drawn from random bytes
    draws = [_below(rng, big) for _ in range(2000)]
    assert all(0 <= x < big for x in draws) and max(draws) > big // 2 > min(draws)
    small = np.bincount([_below(rng, 5) for _ in range(5000)], minlength=5)
    assert chisquare(small).pvalue > 1e-3 and len(small) == 5


def test_count_is_exact_to_depth3_and_an_estimate_beyond() -> None:
    exact = count_patterns(6, 3)
    assert exact.exact and exact.low == exact.count == exact.high == count_library(6, 3)
    assert exact.edge_rule_slices == 2**49
    est = count_patterns(6, 3, draws=2000, seed=1)  # the estimate's own interval holds the exact count
    assert not est.exact and est.low < exact.count < est.high and "estimate" in est.method
    deep = count_patterns(5, 4, draws=200)
    assert not deep.exact and deep.low <= deep.count <= deep.high <= deep.edge_rule_slices == 2**225
    with pytest.raises(PatternError, match="depth"):
        count_library(6, 4)
    with pytest.raises(PatternError, match="sides"):
        count_patterns(2, 3)
