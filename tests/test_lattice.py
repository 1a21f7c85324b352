import numpy as np
import pytest

from fabpat.errors import PatternError
from fabpat.patterns.lattice import bits_to_id, edge_row, id_to_bits, normalize_id, slice_lattice


@pytest.mark.parametrize("depth", [1, 2, 3])
def test_slice_faces_tile_the_triangle(depth: int) -> None:
    IJ, F = slice_lattice(depth)
    N = 2**depth
    assert len(F) == 4**depth
    # every face has lattice area 1/2 and is counter-clockwise
    a, b, c = IJ[F[:, 0]], IJ[F[:, 1]], IJ[F[:, 2]]
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    assert np.all(cross == 1)
    # the last row touches the base line i + j = N; its middle face touches it in one vertex only
    row, middle = edge_row(depth)
    assert len(row) == 2 * N - 1
    on_base = (IJ[F].sum(axis=2) == N).sum(axis=1)
    assert on_base[middle] == 1
    assert set(np.flatnonzero(on_base > 0)) == set(row.tolist())


def test_depth2_ordering_is_rows_from_apex() -> None:
    IJ, F = slice_lattice(2)
    rows = IJ[F].sum(axis=2).min(axis=1)
    assert rows.tolist() == [0] + [1] * 3 + [2] * 5 + [3] * 7


@pytest.mark.parametrize("depth", [1, 2, 3])
def test_id_round_trip(depth: int) -> None:
    rng = np.random.default_rng(depth)
    for _ in range(50):
        bits = rng.random(4**depth) < 0.5
        bits[0] = True
        pid = bits_to_id(bits)
        assert len(pid) == 2 + 4 ** (depth - 1)
        assert np.array_equal(id_to_bits(pid, depth), bits)
        assert normalize_id(pid.upper().replace("0X", ""), depth) == pid


def test_face_zero_is_most_significant_bit() -> None:
    bits = np.zeros(16, bool)
    bits[0] = True
    assert bits_to_id(bits) == "0x8000"
    bits[:] = False
    bits[15] = True
    assert bits_to_id(bits) == "0x0001"


@pytest.mark.parametrize("bad", ["0xzz", "12345", "0x000", "", "0x0000"])
def test_bad_ids(bad: str) -> None:
    with pytest.raises(PatternError):
        id_to_bits(bad, 2)
