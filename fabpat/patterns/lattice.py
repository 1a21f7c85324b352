"""Slices: a triangle subdivided 1-to-4 ``depth`` times, each sub-triangle solid or void (paper §3.1).

Face ordering (fixed, used by every pattern ID)
-----------------------------------------------
The slice triangle has its apex ``A`` at the polygon centre and its base ``B → C`` on the polygon
edge (counter-clockwise). With ``N = 2**depth``, lattice points are ``(i, j)``, ``i + j ≤ N``, at
``A + i/N (B − A) + j/N (C − A)``. Faces are numbered **row by row from the apex**: row ``r``
(``r = 0 … N−1``) holds the ``2r + 1`` triangles between the lines ``i + j = r`` and ``i + j = r + 1``,
numbered from the ``AB`` side to the ``AC`` side; in a row, even positions ``k = 2j`` are "up" triangles
``(i, j), (i+1, j), (i, j+1)`` and odd positions ``k = 2j + 1`` are "down" triangles
``(i+1, j), (i+1, j+1), (i, j+1)``. The last row touches the polygon edge; its middle triangle
(a "down" triangle) touches it only at the edge midpoint. For depth 2::

    row 0:  0
    row 1:  1 2 3
    row 2:  4 5 6 7 8
    row 3:  9 10 11 12 13 14 15      (12 is the middle of the edge row)

Pattern ID
----------
The slice is the bit-string ``b_0 b_1 … b_{M−1}`` (``M = 4**depth``, ``b_k = 1`` if face ``k`` is
solid) read as a binary number with face 0 as the most significant bit, written as ``0x`` followed by
exactly ``M/4`` lowercase hex digits (depth 1: 1 digit, depth 2: 4, depth 3: 16). Parsing accepts
upper case and a missing ``0x``. The number of digits fixes the depth (``4**(depth − 1)`` digits):
:func:`depth_of_id` reads it, and where a depth is also given the length must match it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import PatternError
from fabpat.validate import check

_HEX = re.compile(r"^(0x)?([0-9a-f]+)$")


def check_depth(depth: int) -> int:
    """``depth`` as an int if in its range (:mod:`fabpat.validate`); :class:`PatternError` otherwise."""
    return int(check("depth", depth, error=PatternError))


def check_sides(sides: int) -> int:
    """``sides`` as an int if in its range (:mod:`fabpat.validate`); :class:`PatternError` otherwise."""
    return int(check("sides", sides, error=PatternError))


def n_faces(depth: int) -> int:
    """Number of sub-triangles of a slice: 4**depth."""
    return 4 ** check_depth(depth)


@cache
def slice_lattice(depth: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Lattice points and faces of a slice, in the documented face order.

    Returns ``IJ`` (p, 2) int — the ``(i, j)`` of each lattice point — and ``F`` (4**depth, 3) int
    indices into ``IJ``, counter-clockwise.
    """
    N = 2 ** check_depth(depth)
    IJ = np.array([(i, j) for r in range(N + 1) for j in range(r + 1) for i in [r - j]], dtype=np.int64)
    index = {(int(i), int(j)): k for k, (i, j) in enumerate(IJ)}
    faces = []
    for r in range(N):
        for k in range(2 * r + 1):
            j = k // 2
            if k % 2 == 0:
                i = r - j
                faces.append((index[i, j], index[i + 1, j], index[i, j + 1]))
            else:
                i = r - 1 - j
                faces.append((index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]))
    F = np.array(faces, dtype=np.int64)
    IJ.setflags(write=False)
    F.setflags(write=False)
    return IJ, F


@cache
def edge_row(depth: int) -> tuple[NDArray[np.int64], int]:
    """Faces of the last row (those touching the polygon edge) and the index of its middle face."""
    N = 2 ** check_depth(depth)
    first = (N - 1) ** 2
    row = np.arange(first, first + 2 * N - 1, dtype=np.int64)
    row.setflags(write=False)
    return row, first + N - 1


# --- pattern IDs ------------------------------------------------------------------------------------


def bits_to_id(bits: NDArray[np.bool_] | list[int]) -> str:
    """Pattern ID of a slice given as (4**depth,) bits in face order."""
    b = np.asarray(bits, dtype=bool).ravel()
    M = b.size
    if M < 4 or 4 ** round(math.log(M, 4)) != M:
        raise PatternError(f"a slice has 4**depth bits, got {M}")
    value = 0
    for bit in b:
        value = (value << 1) | int(bit)
    return f"0x{value:0{M // 4}x}"


def _match_hex(pattern_id: str, example: str) -> re.Match[str]:
    """The ID's regex match (``0x`` optional), or :class:`PatternError`."""
    m = _HEX.match(str(pattern_id).strip().lower())
    if not m:
        raise PatternError(f"pattern ID {pattern_id!r} is not hexadecimal (expected e.g. {example})")
    return m


def _wrong_length(pattern_id: str, n: int, expected: str) -> PatternError:
    """The error for an ID with the wrong number of digits. Without ``0x``, ``0b1`` reads as the three
    hex digits 0, b, 1: such an ID is named as the binary (or octal) literal it looks like."""
    text = str(pattern_id).strip().lower()
    if text[:2] in ("0b", "0o"):
        base = "binary" if text[1] == "b" else "octal"
        return PatternError(f"pattern ID {pattern_id!r} looks {base}, not a hex ID: a pattern ID is 0x and hex "
                            f"digits, e.g. 0x0488 ({expected})")
    return PatternError(f"pattern ID {pattern_id!r} has {n} hex digits; {expected}")


def depth_of_id(pattern_id: str) -> int:
    """The subdivision depth an ID's length implies: 1 hex digit → 1, 4 → 2, 16 → 3, 4**(d − 1) → d.

    Raises :class:`PatternError` for an ID that is not hexadecimal or has another number of digits.
    """
    m = _match_hex(pattern_id, "0x0488")
    n = len(m.group(2))
    depth = 1 + round(math.log(n, 4))
    if 4 ** (depth - 1) != n:
        raise _wrong_length(pattern_id, n, "an ID has 1 (depth 1), 4 (depth 2), 16 (depth 3) or "
                            "4**(depth − 1) hex digits")
    return depth


def id_to_bits(pattern_id: str, depth: int) -> NDArray[np.bool_]:
    """(4**depth,) bool bits of a pattern ID; raises :class:`PatternError` if malformed."""
    M = n_faces(depth)
    m = _match_hex(pattern_id, f"0x{'0' * (M // 4)}")
    digits = m.group(2)
    if len(digits) != M // 4:
        raise _wrong_length(pattern_id, len(digits), f"depth {depth} needs {M // 4} hex digits")
    value = int(digits, 16)
    if value == 0:
        raise PatternError(f"pattern ID {pattern_id!r} is the empty slice (all void)")
    return np.array([(value >> (M - 1 - k)) & 1 for k in range(M)], dtype=bool)


def normalize_id(pattern_id: str, depth: int) -> str:
    """Canonical spelling (``0x`` + lowercase, fixed width) of a valid ID."""
    return bits_to_id(id_to_bits(pattern_id, depth))


# --- the slice and the polygon ----------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Slice:
    """A labelled slice: ``solid`` (4**depth,) bool in face order."""

    depth: int
    solid: NDArray[np.bool_]

    def __post_init__(self) -> None:
        s = np.asarray(self.solid, dtype=bool).copy()
        if s.shape != (n_faces(self.depth),):
            raise PatternError(f"depth {self.depth} slice needs {n_faces(self.depth)} labels, got {s.shape}")
        s.setflags(write=False)
        object.__setattr__(self, "solid", s)

    @classmethod
    def from_id(cls, pattern_id: str, depth: int = 2) -> Slice:
        """The slice of a hex ID (``"0x0688"``); raises :class:`PatternError` for a malformed ID."""
        return cls(depth, id_to_bits(pattern_id, depth))

    @property
    def id(self) -> str:
        """The slice's hex ID (face 0 the most significant bit)."""
        return bits_to_id(self.solid)

    @property
    def faces(self) -> NDArray[np.int64]:
        """Indices of the solid faces."""
        return np.flatnonzero(self.solid)


def circumradius(sides: int, edge: float) -> float:
    """Circumradius (mm) of the regular ``sides``-gon of edge ``edge`` mm: edge / (2 sin(π/n))."""
    return edge / (2.0 * math.sin(math.pi / check_sides(sides)))


def polygon_vertices(sides: int, edge: float = 36.0) -> NDArray[np.float64]:
    """(n, 2) corners of the regular n-gon, counter-clockwise; edge i runs from corner i to i + 1.

    Edge i has its midpoint at angle −π/2 + 2πi/n, so edge 0 is at the bottom, parallel to x.
    """
    n = check_sides(sides)
    R = circumradius(n, edge)
    a = -math.pi / 2 + 2 * math.pi * np.arange(n) / n - math.pi / n
    return np.stack([R * np.cos(a), R * np.sin(a)], axis=1)
