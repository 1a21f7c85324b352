"""Fixed times and ids in an encoded Rhino ``.3dm`` file, for byte-reproducible files (:mod:`fabpat.exchange.rhino`).

rhino3dm gives no way to choose the ids of blocks (instance definitions) and of their geometry, and its
created / last-edited times are read-only: openNURBS draws the ids at random and reads the clock. So
:func:`reproducible` changes them in the encoded file. The bytes changed keep their length, so every chunk
stays where it is; what must be redone is the CRC-32 that ends a chunk whose type code has the CRC bit
(openNURBS' ``BeginWrite3dmBigChunk``). That CRC covers the chunk's *own* bytes: its body without its
child chunks (headers, bodies and CRCs) and without the CRC itself (measured on rhino3dm 8.35's files:
every such chunk checks). The layout (openNURBS 3dm ≥ 5): a 32-byte start, then chunks of a 4-byte type
code and an 8-byte value, the length of the body for a long chunk (no :data:`TCODE_SHORT` bit).

A chunk's children are found without knowing every type code: every offset that reads as a long chunk
fitting in the file is a candidate (:class:`Chunks`), and a candidate counts as a chunk only if it checks:
its own CRC if it has the CRC bit, else its body is exactly a run of chunks. A chance reading of other
bytes checks with a probability of about 2⁻³². Before anything is changed the chunks to redo are found
and checked on the file as openNURBS wrote it; anything unexpected raises :class:`ExportError`.
"""

from __future__ import annotations

import struct
import uuid
import zlib
from datetime import datetime

from fabpat.errors import ExportError

TCODE_SHORT = 0x80000000  # a chunk whose 8-byte value is a value, not the length of a body
TCODE_CRC = 0x00008000  # a long chunk that ends in the CRC-32 of its own bytes
TCODE_PROPERTIES_TABLE = 0x10000014  # opennurbs_3dm.h
TCODE_REVISION_HISTORY = 0x20008021
START = 32  # "3D Geometry File Format" and the version, padded to 32 bytes


def _layout_error() -> ExportError:
    return ExportError("the encoded .3dm file has a chunk layout fabpat does not know: cannot make it "
                       "reproducible; write it without --timestamp")


def chunk_run(data: bytes | bytearray, start: int, end: int) -> list[tuple[int, int, int]]:
    """The chunks (offset, type code, body length; -1 for a short chunk) that fill ``data[start:end]`` one
    after the other. Raises :class:`ExportError` if they do not."""
    out = []
    at = start
    while at < end:
        if at + 12 > end:
            raise _layout_error()
        code, value = struct.unpack_from("<Iq", data, at)
        if code & TCODE_SHORT:
            out.append((at, code, -1))
            at += 12
            continue
        if value < 0 or at + 12 + value > end:
            raise _layout_error()
        out.append((at, code, value))
        at += 12 + value
    return out


class Chunks:
    """The long chunks of an encoded file: candidates (every offset whose 12 bytes read as a long chunk that
    fits), each checked on demand (:meth:`real`), with the children and own CRC of a real one."""

    def __init__(self, data: bytes) -> None:
        import numpy as np

        self.data = data
        n = len(data)
        if n < START + 16:
            raise _layout_error()
        word = np.zeros(n - 3, dtype=np.uint32)  # the little-endian uint32 at every offset
        for shift in range(4):
            every = word[shift::4]
            every[:] = np.frombuffer(data, dtype="<u4", count=(n - shift) // 4, offset=shift)[:len(every)]
        m = n - 12
        code, low, high = word[:m], word[4:4 + m], word[8:8 + m]
        at = np.arange(m, dtype=np.int64)
        ok = (at >= START) & ((code & TCODE_SHORT) == 0) & (high == 0) & (low >= 4) & (at + 12 + low <= n)
        self.starts = at[ok]
        self.lengths = low[ok].astype(np.int64)
        self.codes = code[ok].astype(np.int64)
        self._real: dict[int, bool] = {}

    def _body(self, k: int) -> tuple[int, int]:
        """(start, end) of candidate ``k``'s own region: its body without the CRC if it has one."""
        at, n = int(self.starts[k]), int(self.lengths[k])
        return at + 12, at + 12 + n - (4 if self.codes[k] & TCODE_CRC else 0)

    def real(self, k: int) -> bool:
        """Whether candidate ``k`` is a chunk of the file: its own CRC checks (CRC bit), or its body is
        exactly a run of chunks."""
        if k not in self._real:
            self._real[k] = False  # no chunk holds itself: a cycle reads as not real
            if self.codes[k] & TCODE_CRC:
                stored, computed = self.own_crc(k, self.data)
                self._real[k] = stored == computed
            else:
                try:
                    chunk_run(self.data, *self._body(k))
                    self._real[k] = True
                except ExportError:
                    pass
        return self._real[k]

    def children(self, k: int) -> list[int]:
        """The real candidates that are direct children of candidate ``k``, left to right."""
        import numpy as np

        start, end = self._body(k)
        out = []
        q = start
        i = int(np.searchsorted(self.starts, q))
        while i < len(self.starts) and self.starts[i] < end:
            child_end = int(self.starts[i] + 12 + self.lengths[i])
            if child_end <= end and self.real(i):
                out.append(i)
                q = child_end
                i = int(np.searchsorted(self.starts, q))
            else:
                i += 1
        return out

    def own_crc(self, k: int, data: bytes | bytearray) -> tuple[int, int]:
        """(stored, computed) CRC-32 of candidate ``k`` (with the CRC bit) in ``data`` (this file or a copy with
        the same layout): the CRC of its own bytes, children skipped whole."""
        start, end = self._body(k)
        crc, q = 0, start
        for i in self.children(k):
            crc = zlib.crc32(data[q:int(self.starts[i])], crc)
            q = int(self.starts[i] + 12 + self.lengths[i])
        crc = zlib.crc32(data[q:end], crc)
        return struct.unpack_from("<I", data, end)[0], crc

    def owner(self, offset: int) -> int | None:
        """The real chunk with the CRC bit whose own bytes hold ``offset`` (its CRC covers that byte), or None
        when the innermost real chunk holding it has no CRC."""
        import numpy as np

        holding = np.flatnonzero((self.starts + 12 <= offset) & (offset < self.starts + 12 + self.lengths))
        for k in sorted(holding.tolist(), key=lambda k: int(self.lengths[k])):  # innermost first
            if not self.real(k):
                continue
            start, end = self._body(k)
            if not start <= offset < end:
                raise _layout_error()  # a change to a CRC itself
            return k if self.codes[k] & TCODE_CRC else None
        return None


def _tm(t: datetime) -> bytes:
    """openNURBS' time (a C ``struct tm`` without ``tm_isdst``): 8 little-endian ints, sec … year − 1900,
    weekday from Sunday = 0, day of the year from 0."""
    return struct.pack("<8i", t.second, t.minute, t.hour, t.day, t.month - 1, t.year - 1900,
                       (t.weekday() + 1) % 7, t.timetuple().tm_yday - 1)


def _stamp_revision_history(data: bytearray, timestamp: str) -> list[int]:
    """Put ``timestamp`` (UTC) into the file's created and last-edited times, in place; returns the offsets
    changed (the CRC is redone by the caller). The revision history chunk: a version byte, created-by (a
    string: its count of UTF-16 units with the terminator, then the units), created (:func:`_tm`),
    last-edited-by, last edited, the revision count, its CRC-32."""
    from fabpat.exchange.stamp import utc_time

    tables = [c for c in chunk_run(data, START, len(data)) if c[1] == TCODE_PROPERTIES_TABLE]
    if len(tables) != 1:
        raise _layout_error()
    start, _, length = tables[0]
    history = [c for c in chunk_run(data, start + 12, start + 12 + length) if c[1] == TCODE_REVISION_HISTORY]
    if len(history) != 1:
        raise _layout_error()
    at = history[0][0] + 12 + 1  # after the chunk's version byte
    tm = _tm(utc_time(timestamp))
    changed = []
    for _ in range(2):  # created, then last edited
        (units,) = struct.unpack_from("<I", data, at)
        at += 4 + 2 * units
        data[at:at + len(tm)] = tm
        changed += [at, at + len(tm) - 1]
        at += len(tm)
    return changed


def reproducible(data: bytes, timestamp: str, ids: dict[uuid.UUID, uuid.UUID] | None = None) -> bytes:
    """The encoded 3dm file ``data`` with ``timestamp`` (ISO 8601) as its created and last-edited times and
    every id of ``ids`` (drawn → fixed; 16 bytes each, little-endian fields as openNURBS stores an ON_UUID)
    replaced, and the CRC-32 of every chunk holding a changed byte redone. Raises :class:`ExportError` for a
    layout this code does not know or an id found nowhere."""
    out = bytearray(data)
    changed = _stamp_revision_history(out, timestamp)
    for old, new in (ids or {}).items():
        before, after = old.bytes_le, new.bytes_le
        at = out.find(before)
        if at < 0:
            raise ExportError(f"the id {old} is not in the encoded .3dm file")
        while at >= 0:
            out[at:at + 16] = after
            changed += [at, at + 15]
            at = out.find(before, at + 16)
    chunks = Chunks(data)  # the file as openNURBS wrote it: every CRC checks
    owners = sorted({k for k in (chunks.owner(off) for off in changed) if k is not None})
    for k in owners:
        _, crc = chunks.own_crc(k, out)
        struct.pack_into("<I", out, chunks._body(k)[1], crc)
    return bytes(out)


def crc_chunks(data: bytes) -> list[int]:
    """The offsets of every chunk of ``data`` with the CRC bit whose stored CRC-32 is the CRC of its own bytes.
    A file openNURBS wrote and the same file after :func:`reproducible` have the same list (a chunk whose CRC
    was left stale would drop out of it)."""
    chunks = Chunks(data)
    return [int(chunks.starts[k]) for k in range(len(chunks.starts)) if chunks.codes[k] & TCODE_CRC and chunks.real(k)]
