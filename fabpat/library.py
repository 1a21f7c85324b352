"""The library: every slice whose pattern is tileable and connected (paper §3.2).

Filters, vectorised over many candidate slices at once (rows of a (k, 4**depth) bool matrix):

* **Tileability** (the edge rule): of the ``2·2**depth − 1`` slice faces that touch the polygon edge,
  exactly the middle one is solid. Then the solid pattern meets each polygon edge only at its
  midpoint and every polygon corner is void, so any two patterns properly connect.
* **Connectedness**: the face–vertex incidence graph of the whole solid pattern (faces joined through
  shared vertices) has one component. It is checked on the full n-gon, not on the slice, because a
  connected slice can give a disconnected pattern and vice versa (paper Fig. 6).

Depth 2 gives 65 535 candidates, 512 pass the edge rule and 430 are connected for every n ≥ 3.
Depth ≥ 3 cannot be listed (2**49 configurations pass the edge rule at depth 3); :func:`sample_library`
draws uniformly among the configurations that pass the edge rule and rejects disconnected ones, so the
accepted patterns are uniform over the depth-3 library. Its acceptance rate is measured by
``python benchmarks/bench_library.py`` (the table's "acceptance" column: accepted / drawn).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

from fabpat.errors import PatternError
from fabpat.lattice import bits_to_id, check_depth, check_sides, edge_row, id_to_bits, n_faces
from fabpat.pattern import DEFAULT_EDGE, Pattern, pattern_topology

MAX_LISTED_DEPTH = 2  # 2**(4**3 − 15) configurations pass the edge rule at depth 3: sample instead


def is_tileable(bits: NDArray[np.bool_], depth: int) -> NDArray[np.bool_]:
    """(k,) bool: the edge rule for (k, 4**depth) slices."""
    row, middle = edge_row(depth)
    b = np.atleast_2d(bits)
    want = row == middle
    return np.all(b[:, row] == want, axis=1)


def is_connected(bits: NDArray[np.bool_], sides: int, depth: int) -> NDArray[np.bool_]:
    """(k,) bool: is the solid pattern of each slice one piece (face–vertex incidence graph)?

    All candidates go into one block-diagonal graph and one ``connected_components`` call, so the
    cost is a few sparse-matrix operations, not k Python graph searches.
    """
    b = np.atleast_2d(np.asarray(bits, dtype=bool))
    topo = pattern_topology(check_sides(sides), check_depth(depth))
    solid = b[:, topo.slice_face]  # (k, nf)
    k, nf = solid.shape
    nv = topo.n_vertices
    cand, face = np.nonzero(solid)
    face_node = cand * nf + face
    vert_node = k * nf + cand[:, None] * nv + topo.F[face]
    rows = np.repeat(face_node, 3)
    cols = vert_node.ravel()
    n_nodes = k * (nf + nv)
    G = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(n_nodes, n_nodes))
    _, labels = connected_components(G, directed=False)
    lab = np.where(solid, labels[: k * nf].reshape(k, nf), -1)
    big = np.iinfo(labels.dtype).max
    lo = np.where(solid, lab, big).min(axis=1)
    hi = lab.max(axis=1)
    return solid.any(axis=1) & (lo == hi)


def _all_bits(depth: int) -> NDArray[np.bool_]:
    M = n_faces(depth)
    values = np.arange(1, 2**M, dtype=np.int64)
    shifts = np.arange(M - 1, -1, -1, dtype=np.int64)
    return ((values[:, None] >> shifts) & 1).astype(bool)


@dataclass(frozen=True, eq=False)
class Library:
    """A set of valid slices for one polygon: ``bits`` (k, 4**depth) bool, in ID order."""

    sides: int
    depth: int
    bits: NDArray[np.bool_]
    candidates: int  # how many slices were examined (65 535 at depth 2; draws when sampled)

    def __len__(self) -> int:
        return int(self.bits.shape[0])

    @cached_property
    def ids(self) -> tuple[str, ...]:
        """Hex IDs of the library's patterns, in library order."""
        return tuple(bits_to_id(b) for b in self.bits)

    def __contains__(self, pattern_id: str) -> bool:
        try:
            bits = id_to_bits(pattern_id, self.depth)
        except PatternError:
            return False
        return bool(np.any(np.all(self.bits == bits, axis=1)))

    def pattern(self, pattern_id: str, edge: float = DEFAULT_EDGE) -> Pattern:
        """The pattern of an ID of this library; :class:`PatternError` if it is not in it."""
        bits = id_to_bits(pattern_id, self.depth)
        if not np.any(np.all(self.bits == bits, axis=1)):
            reason = "violates the edge rule" if not is_tileable(bits, self.depth)[0] else "is disconnected"
            raise PatternError(
                f"pattern {pattern_id} is not in the {self.sides}-gon depth-{self.depth} library ({reason}); "
                "run `fabpat library` for the valid IDs"
            )
        return Pattern.from_id(pattern_id, self.sides, self.depth, edge)

    def patterns(self, edge: float = DEFAULT_EDGE) -> list[Pattern]:
        """Every pattern of the library as a :class:`Pattern` with polygon edge ``edge`` mm."""
        return [Pattern.from_id(i, self.sides, self.depth, edge) for i in self.ids]


def enumerate_library(sides: int = 6, depth: int = 2) -> Library:
    """Every tileable, connected slice of a depth (≤ 2): 430 for depth 2, 2 for depth 1."""
    n, d = check_sides(sides), check_depth(depth)
    if d > MAX_LISTED_DEPTH:
        raise PatternError(
            f"depth {d} has 2**{n_faces(d)} − 1 slices and cannot be listed; use sampling (--sample N --seed S)"
        )
    bits = _all_bits(d)
    bits = bits[is_tileable(bits, d)]
    bits = bits[is_connected(bits, n, d)]
    bits.setflags(write=False)
    return Library(n, d, bits, candidates=2 ** n_faces(d) - 1)


def sample_library(sides: int, depth: int, count: int, seed: int = 0, batch: int = 4096) -> Library:
    """``count`` distinct valid slices drawn uniformly from the library (any depth).

    Free faces (all but the edge row) are fair coin flips, the edge row is fixed by the edge rule,
    disconnected draws are rejected, duplicates dropped; reproducible for a given ``seed``.
    """
    n, d = check_sides(sides), check_depth(depth)
    if count < 1:
        raise PatternError(f"sample size must be ≥ 1, got {count}")
    if d <= MAX_LISTED_DEPTH:
        full = enumerate_library(n, d)
        if count > len(full):
            raise PatternError(f"depth {d} has only {len(full)} patterns, cannot sample {count}")
    rng = np.random.default_rng(seed)
    row, middle = edge_row(d)
    M = n_faces(d)
    chosen: dict[bytes, NDArray[np.bool_]] = {}
    drawn = 0
    while len(chosen) < count:
        b = rng.random((batch, M)) < 0.5
        b[:, row] = False
        b[:, middle] = True
        drawn += batch
        for row_bits in b[is_connected(b, n, d)]:
            key = np.packbits(row_bits).tobytes()
            if key not in chosen:
                chosen[key] = row_bits
                if len(chosen) == count:
                    break
        if drawn > 10_000 * max(count, 100):
            raise PatternError(f"sampling found only {len(chosen)} of {count} patterns")
    bits = np.array(list(chosen.values()), dtype=bool)
    bits.setflags(write=False)
    return Library(n, d, bits, candidates=drawn)


def get_pattern(pattern_id: str, sides: int = 6, depth: int = 2, edge: float = DEFAULT_EDGE) -> Pattern:
    """The pattern of a valid ID; :class:`PatternError` naming the problem otherwise.

    Depth ≤ 2 looks the ID up in the listed library; deeper IDs are checked by the two filters.
    """
    if check_depth(depth) <= MAX_LISTED_DEPTH:
        return enumerate_library(sides, depth).pattern(pattern_id, edge)
    bits = id_to_bits(pattern_id, depth)
    if not is_tileable(bits, depth)[0]:
        raise PatternError(f"pattern {pattern_id} violates the edge rule (not tileable)")
    if not is_connected(bits, sides, depth)[0]:
        raise PatternError(f"pattern {pattern_id} is disconnected in the {sides}-gon")
    return Pattern.from_id(pattern_id, sides, depth, edge)
