"""The library: every slice whose pattern is tileable and connected (paper §3.2).

Filters, vectorised over many candidate slices at once (rows of a (k, 4**depth) bool matrix):

* **Tileability** (the edge rule): of the ``2·2**depth − 1`` slice faces that touch the polygon edge,
  exactly the middle one is solid. Then the solid pattern meets each polygon edge only at its
  midpoint and every polygon corner is void, so any two patterns properly connect.
* **Connectedness**: the face–vertex incidence graph of the whole solid pattern (faces joined through
  shared vertices) has one component. It is checked on the full n-gon, not on the slice, because a
  connected slice can give a disconnected pattern and vice versa (paper Fig. 6).

Calling the module is :func:`library`: ``fabpat.library(sides=6, depth=2, edge=36.0)`` → a
:class:`Library`, iterable (its patterns), indexable by ID (or position) and sized; :func:`pattern`
(also ``fabpat.pattern(...)``) checks one ID and infers its depth from its length.

Depth 2 gives 65 535 candidates, 512 pass the edge rule and 430 are connected for every n ≥ 3.
:func:`enumerate_library` lists them with the pruned enumeration of :mod:`fabpat.patterns.enumeration`,
which builds only valid patterns (no candidate is drawn and rejected); the two filters above stay as the
independent check of single slices (:func:`get_pattern`) and of the enumeration itself (tests).
Depth ≥ 3 cannot be listed (2**49 configurations pass the edge rule at depth 3, 442 048 129 028 432 of
them connected: :func:`fabpat.patterns.enumeration.count_library`). :func:`sample_library` draws large
depth-3 samples exactly (uniform ranks of the enumeration, unranked; :data:`EXACT_SAMPLE_FROM`), and
everything else by rejection: uniform draws among the configurations that pass the edge rule,
disconnected ones rejected, so the accepted patterns are uniform too (depth ≤ 2 thus keeps the samples
its seeds always gave). Both samplers and the acceptance rate are measured by
``python benchmarks/bench_library.py``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

from fabpat._callable import make_callable
from fabpat.errors import PatternError
from fabpat.patterns.enumeration import MAX_ENUMERATED_DEPTH, enumeration
from fabpat.patterns.lattice import bits_to_id, check_depth, check_sides, depth_of_id, edge_row, id_to_bits, n_faces
from fabpat.patterns.pattern import DEFAULT_EDGE, Pattern, pattern_topology
from fabpat.validate import check, check_size

HTML_ROWS = 10  # patterns shown by Library._repr_html_ (a notebook cell, not a report)

MAX_LISTED_DEPTH = 2  # 2**(4**3 − 15) configurations pass the edge rule at depth 3: sample instead

#: How :func:`sample_library` draws: the enumeration's exact ranks, rejection of disconnected coin
#: flips, or whichever suits the depth.
SAMPLE_METHODS = ("auto", "exact", "rejection")

#: From this many depth-3 samples on, ``method="auto"`` draws them exactly. The exact sampler first
#: builds the enumeration's 55 502 states (0.5–1.3 s), then takes ~60 µs per sample; rejection takes
#: ~0.3–0.5 s per batch of 4 096 draws, ~3 200 patterns. Measured in fresh processes on the loaded
#: 2-core machine (best of 4, rejection / exact): 1 sample 0.56 / 1.29 s, 1 000: 0.63 / 1.49 s,
#: 5 000: 1.09 / 1.46 s, 10 000: 2.13 / 1.62 s, 20 000: 3.83 / 1.85 s. Rejection needs a third batch
#: from about 6 500 patterns on; from there the exact sampler is faster.
EXACT_SAMPLE_FROM = 6500

#: Pattern faces (samples × sides × 4**depth) one sampling may produce (the patterns drawn are
#: filleted, listed or simulated next): 5e7, e.g. 8 000 hexagon patterns at depth 5.
MAX_SAMPLE_CELLS = 50_000_000

#: Pattern faces in one draw batch: the connectivity graph needs ≈ 100 bytes per face (measured:
#: 1024 draws of depth-5 hexagon patterns, 6.3e6 faces, 690 MB peak), so 1.6e7 faces stay near
#: 1.6 GB. Batches keep 4096 draws up to depth 4 (seeds reproduce earlier samples), fewer beyond.
MAX_BATCH_FACES = 16_000_000


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


@dataclass(frozen=True, eq=False)
class Library:
    """A set of valid slices for one polygon: ``bits`` (k, 4**depth) bool, in ID order.

    ``len(lib)`` patterns; ``for p in lib`` yields :class:`~fabpat.patterns.pattern.Pattern` objects of edge
    ``edge`` (mm); ``lib["0x0488"]`` is the pattern of an ID, ``lib[0]`` the first one. A missing ID,
    a position out of range or another key raises :class:`PatternError`.
    """

    sides: int
    depth: int
    bits: NDArray[np.bool_]
    candidates: int  # how many slices were examined (65 535 at depth 2; draws when sampled)
    edge: float = DEFAULT_EDGE  # mm: polygon edge of the patterns it hands out

    def __len__(self) -> int:
        return int(self.bits.shape[0])

    def __iter__(self) -> Iterator[Pattern]:
        return (Pattern.from_id(i, self.sides, self.depth, self.edge) for i in self.ids)

    def __getitem__(self, key: str | int) -> Pattern:
        if isinstance(key, str):
            return self.pattern(key)
        if isinstance(key, int | np.integer) and not isinstance(key, bool):
            if not -len(self) <= key < len(self):
                raise PatternError(f"pattern index {key} out of range: the library has {len(self)} patterns")
            return Pattern.from_id(self.ids[key], self.sides, self.depth, self.edge)
        raise PatternError(f"index a library by pattern ID (e.g. '0x0488') or position, not {type(key).__name__}")

    @cached_property
    def ids(self) -> tuple[str, ...]:
        """Hex IDs of the library's patterns, in library order."""
        return tuple(bits_to_id(b) for b in self.bits)

    def __contains__(self, pattern_id: object) -> bool:
        try:
            bits = id_to_bits(str(pattern_id), self.depth)
        except PatternError:
            return False
        return bool(np.any(np.all(self.bits == bits, axis=1)))

    def pattern(self, pattern_id: str, edge: float | None = None) -> Pattern:
        """The pattern of an ID of this library (``edge`` mm, default the library's); :class:`PatternError`
        if it is not in it."""
        bits = id_to_bits(pattern_id, self.depth)
        if not np.any(np.all(self.bits == bits, axis=1)):
            reason = "violates the edge rule" if not is_tileable(bits, self.depth)[0] else "is disconnected"
            raise PatternError(
                f"pattern {pattern_id} is not in the {self.sides}-gon depth-{self.depth} library ({reason}); "
                "run `fabpat library` for the valid IDs"
            )
        return Pattern.from_id(pattern_id, self.sides, self.depth, self.edge if edge is None else edge)

    def patterns(self, edge: float | None = None) -> list[Pattern]:
        """Every pattern of the library as a :class:`Pattern` with polygon edge ``edge`` mm (default the
        library's)."""
        e = self.edge if edge is None else edge
        return [Pattern.from_id(i, self.sides, self.depth, e) for i in self.ids]

    def __repr__(self) -> str:
        return f"Library(sides={self.sides}, depth={self.depth}, edge={self.edge:g} mm, {len(self)} patterns)"

    def _repr_html_(self) -> str:
        """A small table for notebooks: the first patterns with their lattice metrics."""
        from html import escape

        head = "".join(f"<th>{h}</th>" for h in ("ID", "area (mm²)", "perimeter (mm)", "ratio"))
        rows = []
        for i in self.ids[:HTML_ROWS]:
            m = Pattern.from_id(i, self.sides, self.depth, self.edge).metrics
            rows.append(f"<tr><td><code>{i}</code></td><td>{m.area:.1f}</td><td>{m.perimeter:.1f}</td>"
                        f"<td>{m.ratio:.3f}</td></tr>")
        more = len(self) - HTML_ROWS
        tail = f'<tr><td colspan="4">… and {more} more</td></tr>' if more > 0 else ""
        return (f"<table><caption>{escape(repr(self))}</caption><thead><tr>{head}</tr></thead>"
                f"<tbody>{''.join(rows)}{tail}</tbody></table>")


def enumerate_library(sides: int = 6, depth: int = 2, edge: float = DEFAULT_EDGE) -> Library:
    """Every tileable, connected slice of a depth (≤ 2) in ID order: 430 for depth 2, 2 for depth 1.

    Read off the pruned enumeration (:mod:`fabpat.patterns.enumeration`): only valid slices are built.
    ``candidates`` is still the size of the space they are chosen from, 2**(4**depth) − 1. Raises
    :class:`PatternError` for a bad polygon, depth or edge, or a depth too large to list.
    """
    n, d = check_sides(sides), check_depth(depth)
    if d > MAX_LISTED_DEPTH:
        raise PatternError(
            f"depth {d} has 2**{n_faces(d)} − 1 slices and cannot be listed; sample it "
            "(--sample N --seed S; in Python sample=N, seed=S) or count it (--count)"
        )
    bits = enumeration(n, d).all_bits()
    bits.setflags(write=False)
    return Library(n, d, bits, candidates=2 ** n_faces(d) - 1, edge=_check_edge(edge))


def sample_library(
    sides: int, depth: int, count: int, seed: int = 0, batch: int = 4096, edge: float = DEFAULT_EDGE,
    method: str = "auto",
) -> Library:
    """``count`` distinct valid slices drawn uniformly from the library (any depth).

    ``method="exact"`` (depth ≤ :data:`~fabpat.patterns.enumeration.MAX_ENUMERATED_DEPTH`): uniform
    ranks of the pruned enumeration, unranked (:meth:`~fabpat.patterns.enumeration.Enumeration.sample`);
    nothing is rejected and ``candidates`` is ``count``. ``method="rejection"``: free faces (all but the
    edge row) are fair coin flips, the edge row is fixed by the edge rule, disconnected draws are
    rejected, duplicates dropped; ``candidates`` counts the draws. ``"auto"`` is exact at depth 3 from
    :data:`EXACT_SAMPLE_FROM` samples on, where it is measured faster, and rejection otherwise (depth
    ≤ 2 keeps the samples its seeds always gave; deeper libraries cannot be enumerated). Both are
    uniform over the library; each is reproducible for a ``seed``.
    Rejection draws ``batch`` at a time, fewer at large depth so that one batch's connectivity graph
    stays below :data:`MAX_BATCH_FACES` pattern faces; ``count`` × sides × 4**depth faces above
    :data:`MAX_SAMPLE_CELLS` is refused. Raises PatternError for bad sizes, seeds, methods or IDs.
    """
    n, d = check_sides(sides), check_depth(depth)
    count = int(check("sample", count, "sample size", error=PatternError))
    seed = int(check("seed", seed, error=PatternError))
    faces = n * n_faces(d)
    check_size(count * faces, MAX_SAMPLE_CELLS, f"pattern faces of {count} samples at depth {d} ({faces} each)",
               "a fixed limit: sample fewer patterns", error=PatternError)
    if method not in SAMPLE_METHODS:
        raise PatternError(f"sampling method {method!r} is unknown; choose one of {', '.join(SAMPLE_METHODS)}")
    if method == "exact" or (method == "auto" and MAX_LISTED_DEPTH < d <= MAX_ENUMERATED_DEPTH
                             and count >= EXACT_SAMPLE_FROM):
        bits = enumeration(n, d).sample(count, seed)  # refuses depths it cannot enumerate, and count > total
        bits.setflags(write=False)
        return Library(n, d, bits, candidates=count, edge=_check_edge(edge))
    batch = max(1, min(batch, MAX_BATCH_FACES // faces))
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
    return Library(n, d, bits, candidates=drawn, edge=_check_edge(edge))


def _check_edge(edge: float) -> float:
    """``edge`` (mm) as a float if in its range (:mod:`fabpat.validate`); PatternError otherwise."""
    return check("edge", edge, error=PatternError)


def get_pattern(
    pattern_id: str, sides: int = 6, depth: int | None = 2, edge: float = DEFAULT_EDGE
) -> Pattern:
    """The pattern of a valid ID; :class:`PatternError` naming the problem otherwise.

    ``depth=None`` takes it from the ID's length (:func:`fabpat.patterns.lattice.depth_of_id`). Depth ≤ 2 looks
    the ID up in the listed library; deeper IDs are checked by the two filters. ``edge`` (mm),
    ``sides`` and ``depth`` must be in their ranges (:mod:`fabpat.validate`): PatternError otherwise.
    """
    if not isinstance(pattern_id, str):
        raise PatternError(f"a pattern ID is a string of hex digits like '0x0488', got {pattern_id!r}")
    depth = depth_of_id(pattern_id) if depth is None else depth
    edge = _check_edge(edge)
    check_sides(sides)
    if check_depth(depth) <= MAX_LISTED_DEPTH:
        return enumerate_library(sides, depth).pattern(pattern_id, edge)
    bits = id_to_bits(pattern_id, depth)
    if not is_tileable(bits, depth)[0]:
        raise PatternError(f"pattern {pattern_id} violates the edge rule (not tileable)")
    if not is_connected(bits, sides, depth)[0]:
        raise PatternError(f"pattern {pattern_id} is disconnected in the {sides}-gon")
    return Pattern.from_id(pattern_id, sides, depth, edge)


def library(
    sides: int = 6, depth: int = 2, edge: float = DEFAULT_EDGE, *, sample: int | None = None, seed: int = 0
) -> Library:
    """The library of a regular ``sides``-gon at ``depth``, its patterns of edge ``edge`` mm.

    Depth ≤ 2 is listed in full (430 patterns at depth 2 for every n ≥ 3); deeper libraries are too
    large to list, so pass ``sample=N`` (and ``seed``) for N patterns drawn uniformly
    (:func:`sample_library`). Raises :class:`PatternError` for a bad polygon, depth, edge or sample.
    """
    if sample is not None:
        return sample_library(sides, depth, sample, seed, edge=edge)
    return enumerate_library(sides, depth, edge)


def pattern(pattern_id: str, sides: int = 6, edge: float = DEFAULT_EDGE, depth: int | None = None) -> Pattern:
    """The pattern of an ID (``fabpat.pattern("0x0488")``), its depth from the ID's length unless given.

    Raises :class:`PatternError` if the ID is malformed, not tileable or disconnected in the n-gon.
    """
    return get_pattern(pattern_id, sides, depth, edge)


make_callable(__name__, library)
