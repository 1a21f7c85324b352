"""The library enumerated with pruning: a frontier dynamic programme that counts, lists and samples the
connected, tileable patterns of a depth exactly, without drawing or filtering candidates (paper §6's
"space-pruning strategies based on topological constraints").

The quotient and why its answer is exact
----------------------------------------
A pattern is ``n`` rotated copies of the slice; copy ``f``'s side ``AC`` is glued to copy ``f + 1``'s side
``AB``: lattice point ``(0, j)`` of fan ``f`` is ``(j, 0)`` of fan ``f + 1``. So the face–vertex graph of
the solid pattern is the ``n``-fold cyclic cover of one *quotient* graph ``Q``: the slice's solid faces
and its own vertices (``i ≥ 1``), a face joined to each corner with a *voltage*, 1 for a corner on side
``AC`` (the next copy's vertex) and 0 otherwise. The centre is left out: only face 0 touches it, and the
copies of face 0 are already joined in a ring through the vertex ``(1, 0)`` they share pairwise.

A closed walk in ``Q`` has a *winding* (the sum of its voltages: how often it crosses the seam). The
cover is connected exactly when ``Q`` is connected and the windings of ``Q``'s closed walks, a subgroup
``gZ``, generate ``Z_n``: ``gcd(g, n) = 1``. The programme tracks ``g`` exactly, so its count for each
``n`` is exact whatever ``g`` turns out to be. (``Q`` is drawn without crossings on the slice with its
sides glued, a disc with the centre as a puncture; a simple cycle there winds 0 or ±1 times around the
puncture, so ``g`` is 0 or 1 and the count is the same for every ``n``: the library's exchangeability.
The computed counts agree with that and with the n-gon filters of :mod:`fabpat.patterns.library`.)

The programme
-------------
Faces are decided one at a time in ID order (face 0 first: row by row from the apex, each row from
``AB`` to ``AC``), the edge row fixed by the edge rule. After face ``k`` the *frontier* is the set of
vertices touched by a face ``≤ k`` and by a face ``> k``: between consecutive rows with the seam,
at most ``2**depth + 1`` vertices. A *state* is, for each frontier vertex, whether a solid face touches
it, the component it belongs to and its potential (the voltage of a path to the component's first
frontier vertex), and for each component its ``g`` (potentials are taken modulo ``g``). Everything
decided so far that can still matter is in the state, so equal states have equal completions: the
programme counts completions per state, exactly, with Python integers.

Pruning: a component whose last frontier vertex leaves the frontier is closed for good. If another
component is still open, or a solid face is still to come (the edge row's middle face always is), the
pattern is disconnected: the branch is cut. Otherwise the pattern is finished, and only void faces
may follow. A closed component with ``g = 0`` is ``n`` disjoint copies: cut too.

What it gives: :func:`count_library` (the exact number, also for depths far beyond listing), and
:class:`Enumeration`: ``unrank`` (the ``r``-th pattern in ID order), uniform sampling (a uniform rank,
unranked), the full listing of small depths, and ``contains`` for one slice. Depths 1–3 build in
milliseconds to seconds; the frontier of depth 4 has 17 vertices and its states do not fit: refused
(:data:`MAX_ENUMERATED_DEPTH`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import PatternError
from fabpat.patterns.lattice import check_depth, check_sides, edge_row, slice_lattice
from fabpat.validate import check

#: The deepest library the programme builds: depth 4's frontier states do not fit in time or memory.
MAX_ENUMERATED_DEPTH = 3

#: ``state[0]`` of a finished pattern (``(_DONE, g)``): its one component closed, only void faces follow.
_DONE = -2

State = tuple[int, ...]


@dataclass(frozen=True)
class _Face:
    """One face's step: where its corners sit in the working list, and which working entries stay."""

    corners: tuple[tuple[int, int], ...]  # (working index, voltage) of each corner but the centre
    take: tuple[int, ...]  # working index of each frontier entry before the face
    keep: tuple[int, ...]  # working indices that stay on the frontier after it
    drop: tuple[int, ...]  # working indices that leave it (no later face touches them)
    fresh: tuple[int, ...]  # working indices of the corners new to the frontier, ascending
    forced: int | None  # the edge rule's label, or None for a free face
    solid_ahead: bool  # a face after this one is forced solid


@cache
def _faces(depth: int) -> tuple[_Face, ...]:
    """The programme's steps for a depth: each face's corners (the quotient's vertices, with voltages)
    placed in the working list of frontier vertices."""
    IJ, F = slice_lattice(depth)
    index = {(int(i), int(j)): k for k, (i, j) in enumerate(IJ)}
    M = len(F)
    corners: list[list[tuple[int, int]]] = []
    for face in F:
        cs = []
        for p in face:
            i, j = (int(x) for x in IJ[p])
            if i == 0 and j == 0:
                continue  # the centre: see the module docstring
            cs.append((index[j, 0], 1) if i == 0 else (index[i, j], 0))
        corners.append(cs)
    last = {v: k for k, cs in enumerate(corners) for v, _ in cs}
    row, middle = edge_row(depth)
    forced = {int(f): int(f == middle) for f in row}
    solid_after = [False] * M
    for k in range(M - 2, -1, -1):
        solid_after[k] = solid_after[k + 1] or forced.get(k + 1) == 1
    steps = []
    frontier: list[int] = []
    for k, cs in enumerate(corners):
        work = sorted(set(frontier) | {v for v, _ in cs})
        pos = {v: w for w, v in enumerate(work)}
        keep = [v for v in work if last[v] > k]
        steps.append(_Face(tuple((pos[v], t) for v, t in cs), tuple(pos[v] for v in frontier),
                           tuple(pos[v] for v in keep), tuple(pos[v] for v in work if last[v] == k),
                           tuple(pos[v] for v in work if v not in frontier), forced.get(k), solid_after[k]))
        frontier = keep
    return tuple(steps)


def _step(state: State, solid: bool, face: _Face) -> State | None:
    """The state after deciding ``face`` (``solid`` or void), or None if no completion can be valid.

    A state lists, for the m frontier vertices, m component labels (−1: no solid face touches it yet)
    and m potentials, then one ``g`` per component; labels in order of first appearance, each
    component's first potential 0, potentials modulo ``g`` where ``g > 0``.
    """
    if state and state[0] == _DONE:
        return None if solid else state
    m = len(face.take)
    # The working list is the frontier with the face's new corners inserted (positions ascending).
    labs = list(state[:m])
    pots = list(state[m:2 * m])
    for w in face.fresh:
        labs.insert(w, -1)
        pots.insert(w, 0)
    gs: list[int] = list(state[2 * m:])
    if not solid and not face.drop:  # nothing joins or leaves: the state, with the new corners untouched
        return (*labs, *pots, *gs)
    if solid:
        new = len(gs)
        gs.append(0)
        for w, volt in face.corners:
            c = labs[w]
            if c == -1:
                labs[w], pots[w] = new, volt
            elif c == new:  # a cycle through this face: its winding joins the component's g
                gs[new] = math.gcd(gs[new], volt - pots[w])
            else:  # another component joins: shift its potentials so that this corner has ``volt``
                shift = volt - pots[w]
                for x, cx in enumerate(labs):
                    if cx == c:
                        labs[x] = new
                        pots[x] += shift
                gs[new] = math.gcd(gs[new], gs[c])
    relabel: dict[int, int] = {}  # old label → new, in order of first appearance on the new frontier
    first: list[int] = []
    out_labs, out_pots = [], []
    for w in face.keep:
        c = labs[w]
        if c < 0:
            out_labs.append(-1)
            out_pots.append(0)
            continue
        r = relabel.get(c)
        if r is None:
            r = relabel[c] = len(first)
            first.append(pots[w])
        g = gs[c]
        p = pots[w] - first[r]
        out_labs.append(r)
        out_pots.append(p % g if g else p)
    # A component closes when its last vertices leave the frontier: they are among the dropped ones.
    closed = {labs[w] for w in face.drop if labs[w] >= 0 and labs[w] not in relabel}
    if closed:
        (c, *others) = closed
        if others or relabel or face.solid_ahead or gs[c] == 0:
            return None  # two pieces, or one that winds 0 times (n disjoint copies)
        return (_DONE, gs[c])
    return (*out_labs, *out_pots, *(gs[c] for c in relabel))


@dataclass(frozen=True)
class _Table:
    """Every reachable state after each face, as successor indices: ``succ[k][s]`` the (void, solid)
    successors of state ``s`` before face ``k``, −1 where the choice is impossible (plain tuples: the
    walks index them one pair at a time); ``final_g`` the ``g`` of each finished state after the last face."""

    succ: tuple[tuple[tuple[int, int], ...], ...]
    final_g: tuple[int, ...]

    @property
    def n_states(self) -> int:
        """States over all layers (the programme's size)."""
        return sum(len(s) for s in self.succ) + len(self.final_g)


@cache
def _table(depth: int) -> _Table:
    """The layered state graph of a depth, built forward from the empty frontier."""
    d = check_depth(depth)
    if d > MAX_ENUMERATED_DEPTH:
        raise PatternError(f"depth {d} is too deep to enumerate (its frontier has up to {2**d + 1} vertices); "
                           f"depths 1–{MAX_ENUMERATED_DEPTH} are counted exactly, deeper ones can be sampled "
                           "(--sample N)")
    layer: dict[State, int] = {(): 0}
    succ = []
    for face in _faces(d):
        nxt: dict[State, int] = {}
        out = []
        for state in layer:  # dicts keep insertion order: state i is the i-th key
            pair = [-1, -1]
            for bit in (0, 1) if face.forced is None else (face.forced,):
                s = _step(state, bool(bit), face)
                if s is not None:
                    pair[bit] = nxt.setdefault(s, len(nxt))
            out.append((pair[0], pair[1]))
        succ.append(tuple(out))
        layer = nxt
    # After the last face the frontier is empty, so every state left is a finished pattern (_DONE, g);
    # only the all-void slice would leave (), and the edge rule's middle face excludes it (g = 0: invalid).
    final_g = tuple(s[1] if s and s[0] == _DONE else 0 for s in layer)
    return _Table(tuple(succ), final_g)


@dataclass(frozen=True, eq=False)
class Enumeration:
    """The connected, tileable patterns of one polygon and depth, counted per state of the programme.

    ``completions[k][s]`` is the number of valid ways to decide faces ``k …`` from state ``s`` (Python
    ints, exact); ``total`` = ``completions[0][0]``, the library's size. Patterns are ranked in ID
    order (the order of :func:`fabpat.patterns.library.enumerate_library`).
    """

    sides: int
    depth: int
    table: _Table
    completions: tuple[tuple[int, ...], ...]

    @property
    def total(self) -> int:
        """The exact number of connected, tileable patterns (an int of any size)."""
        return self.completions[0][0]

    def unrank(self, rank: int) -> NDArray[np.bool_]:
        """(4**depth,) bool: the slice of the pattern at position ``rank`` (0-based) in ID order.

        Raises :class:`PatternError` for a rank outside ``[0, total)``.
        """
        if not isinstance(rank, int | np.integer) or isinstance(rank, bool) or not 0 <= rank < self.total:
            raise PatternError(f"rank must be an integer in [0, {self.total}), got {rank!r}")
        r = int(rank)
        bits = np.zeros(len(self.table.succ), dtype=bool)
        s = 0
        for k, succ in enumerate(self.table.succ):
            void, solid = succ[s]
            below = self.completions[k + 1][void] if void >= 0 else 0
            if r < below:
                s = void
            else:
                r -= below
                bits[k] = True
                s = solid
        return bits

    def count_prefix(self, prefix: NDArray[np.bool_] | list[bool]) -> int:
        """How many patterns have their first ``len(prefix)`` faces labelled as ``prefix`` (bool, in
        face order): 0 if none (a forced face contradicted, or no valid completion)."""
        b = np.asarray(prefix, dtype=bool).ravel()
        if b.size > len(self.table.succ):
            raise PatternError(f"a depth-{self.depth} slice has {len(self.table.succ)} labels, got {b.size}")
        s = 0
        for k, bit in enumerate(b):
            s = self.table.succ[k][s][int(bit)]
            if s < 0:
                return 0
        return self.completions[b.size][s]

    def rank(self, bits: NDArray[np.bool_] | list[bool]) -> int:
        """The position (0-based, ID order) of a pattern's (4**depth,) slice: the inverse of
        :meth:`unrank`. Raises :class:`PatternError` if the slice is not in the library."""
        b = np.asarray(bits, dtype=bool).ravel()
        if b.size != len(self.table.succ) or not self.count_prefix(b):
            raise PatternError(f"the slice is not a connected, tileable depth-{self.depth} pattern")
        r, s = 0, 0
        for k, bit in enumerate(b):
            void, solid = self.table.succ[k][s]
            if bit:
                r += self.completions[k + 1][void] if void >= 0 else 0
                s = solid
            else:
                s = void
        return r

    def all_bits(self) -> NDArray[np.bool_]:
        """(total, 4**depth) bool: every pattern's slice, in ID order, read off the programme (no
        candidate is examined and rejected). Raises :class:`PatternError` above a million patterns."""
        if self.total > 1_000_000:
            raise PatternError(f"depth {self.depth} has {self.total} patterns: too many to list; sample them")
        rows = list(self._walk(0, 0, []))
        out = np.array(rows, dtype=bool).reshape(len(rows), len(self.table.succ))
        return out

    def _walk(self, k: int, s: int, prefix: list[bool]) -> Iterator[list[bool]]:
        if k == len(self.table.succ):
            yield list(prefix)
            return
        for bit in (0, 1):
            t = self.table.succ[k][s][bit]
            if t >= 0 and self.completions[k + 1][t]:
                prefix.append(bool(bit))
                yield from self._walk(k + 1, t, prefix)
                prefix.pop()

    def contains(self, bits: NDArray[np.bool_]) -> bool:
        """Is this (4**depth,) slice a connected, tileable pattern of the polygon? (Walks the programme's
        steps; an independent check of the n-gon filters.) Raises :class:`PatternError` for a wrong size."""
        b = np.asarray(bits, dtype=bool).ravel()
        faces = _faces(self.depth)
        if b.size != len(faces):
            raise PatternError(f"a depth-{self.depth} slice has {len(faces)} labels, got {b.size}")
        state: State | None = ()
        for face, bit in zip(faces, b, strict=True):
            if face.forced is not None and face.forced != bit:
                return False
            state = _step(state, bool(bit), face)
            if state is None:
                return False
        return bool(state) and state[0] == _DONE and math.gcd(state[1], self.sides) == 1

    def ranks(self, count: int, seed: int = 0, distinct: bool = True) -> list[int]:
        """``count`` uniform random ranks in ``[0, total)`` from numpy's generator seeded with ``seed``:
        distinct ones (a uniform random subset, in draw order) unless ``distinct=False``.
        Raises :class:`PatternError` for a bad count or seed, or ``count`` distinct ranks asked of fewer
        patterns."""
        count = int(check("sample", count, "sample size", error=PatternError))
        seed = int(check("seed", seed, error=PatternError))
        if distinct and count > self.total:
            raise PatternError(f"depth {self.depth} has only {self.total} patterns, cannot sample {count}")
        rng = np.random.default_rng(seed)
        out: list[int] = []
        seen: set[int] = set()
        while len(out) < count:
            want = count - len(out)
            if self.total < 2**63:  # numpy draws them at once, unbiased
                batch = [int(r) for r in rng.integers(0, self.total, size=want, dtype=np.int64)]
            else:
                batch = [_below(rng, self.total) for _ in range(want)]
            for r in batch:
                if distinct:
                    if r in seen:
                        continue
                    seen.add(r)
                out.append(r)
        return out

    def sample(self, count: int, seed: int = 0) -> NDArray[np.bool_]:
        """(count, 4**depth) bool: ``count`` distinct patterns drawn uniformly (exactly: uniform ranks,
        unranked), reproducible for a ``seed``. Raises :class:`PatternError` if there are fewer."""
        rows = [self.unrank(r) for r in self.ranks(count, seed)]
        return np.array(rows, dtype=bool).reshape(count, len(self.table.succ))


def _below(rng: np.random.Generator, total: int) -> int:
    """A uniform integer in ``[0, total)`` of any size: random bits, rejected when too large (< 2 tries
    on average), so no modulo bias."""
    bits = max(1, (total - 1).bit_length())
    nbytes = (bits + 7) // 8
    while True:
        r = int.from_bytes(rng.bytes(nbytes), "little") >> (8 * nbytes - bits)
        if r < total:
            return r


@cache
def enumeration(sides: int, depth: int) -> Enumeration:
    """The programme of a polygon and depth (≤ :data:`MAX_ENUMERATED_DEPTH`), completions counted.

    The state graph is the same for every ``sides`` (built once per depth); which finished states are
    valid depends on ``sides`` (``gcd(g, sides) = 1``), so the counts are computed per polygon.
    Raises :class:`PatternError` for a bad polygon or depth, or a depth too deep to enumerate.
    """
    n, d = check_sides(sides), check_depth(depth)
    table = _table(d)
    counts: list[tuple[int, ...]] = [tuple(int(math.gcd(g, n) == 1) for g in table.final_g)]
    for succ in reversed(table.succ):
        below = counts[-1]
        counts.append(tuple((below[a] if a >= 0 else 0) + (below[b] if b >= 0 else 0) for a, b in succ))
    return Enumeration(n, d, table, tuple(reversed(counts)))


def count_library(sides: int = 6, depth: int = 3) -> int:
    """The exact number of connected, tileable patterns of the regular ``sides``-gon at ``depth``
    (2 at depth 1, 430 at depth 2, for every n), by the pruned enumeration (module docstring).

    Raises :class:`PatternError` for a bad polygon or depth, or a depth above :data:`MAX_ENUMERATED_DEPTH`.
    """
    return enumeration(sides, depth).total


def free_faces(depth: int) -> int:
    """Faces the edge rule leaves free: (2**depth − 1)**2 (9 at depth 2, 49 at depth 3)."""
    return (2 ** check_depth(depth) - 1) ** 2
