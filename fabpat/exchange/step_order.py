"""A fixed order for the colour blocks OCCT appends to a STEP assembly, so two runs give one file.

OCCT's XDE writer (``STEPCAFControl_Writer``) ends the data section of an assembly with one block per
coloured component: a ``MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION`` and the styled item,
style and colour entities it refers to. It takes them from a map keyed by shape, whose order follows
memory addresses, so the blocks came out permuted from run to run (the same entities, numbered
alike, holding other colours). :func:`sort_trailing_styles` puts them in one order: sorted by their
text, their own entity numbers reduced to offsets within the block. Each block is then renumbered
into the same range of numbers, so nothing else in the file changes.

It only acts when the tail of the data section is exactly such blocks, all of one length, that
refer only inside themselves or to earlier entities, and that no earlier entity refers to; any
other file is left as OCCT wrote it.

OCCT also numbers the ``NEXT_ASSEMBLY_USAGE_OCCURRENCE`` ids (their first attribute, '1', '2', …) with a
counter that lives as long as the process, so a second assembly written by one process got '11', '12', …
where a fresh process writes '1', '2', …: :func:`renumber_occurrences` shifts them to start at 1 (what a
fresh process writes), so the file does not depend on what the process wrote before.
"""

from __future__ import annotations

import os
import re

_ENTITY = re.compile(rb"^#(\d+) = ", re.MULTILINE)
_REF = re.compile(rb"#(\d+)")
_HEAD = b"MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION("
_OCCURRENCE = re.compile(rb"(NEXT_ASSEMBLY_USAGE_OCCURRENCE\(')(\d+)(')")


def _entities(data: bytes) -> tuple[bytes, list[tuple[int, bytes]], bytes] | None:
    """(text before the first entity, [(number, text after "#n = ")], the closing text) of the DATA section."""
    start = data.find(b"\nDATA;\n")
    end = data.rfind(b"\nENDSEC;")
    if start < 0 or end < start:
        return None
    body = data[start + len(b"\nDATA;\n"):end + 1]
    marks = list(_ENTITY.finditer(body))
    if not marks or marks[0].start() != 0:
        return None
    ents = [(int(m[1]), body[m.end():(marks[i + 1].start() if i + 1 < len(marks) else len(body))])
            for i, m in enumerate(marks)]
    return data[:start + len(b"\nDATA;\n")], ents, data[end + 1:]


def _blocks(ents: list[tuple[int, bytes]]) -> tuple[int, int] | None:
    """(index of the first block's entity, block length) if the tail is equal-length colour blocks."""
    heads = [i for i, (_, text) in enumerate(ents) if text.startswith(_HEAD)]
    if len(heads) < 2:
        return None
    first, size = heads[0], heads[1] - heads[0]
    if heads != list(range(first, len(ents), size)) or (len(ents) - first) % size:
        return None
    numbers = [n for n, _ in ents[first:]]
    if numbers != list(range(numbers[0], numbers[0] + len(numbers))):
        return None
    return first, size


def _relative(text: bytes, lo: int, hi: int, low_bound: int) -> bytes | None:
    """``text`` with references into [lo, hi) as ``#@offset``; None if it refers to another block."""
    def sub(m: re.Match[bytes]) -> bytes:
        n = int(m[1])
        if lo <= n < hi:
            return b"#@%d" % (n - lo)
        if n >= low_bound:
            raise ValueError
        return m[0]

    try:
        return _REF.sub(sub, text)
    except ValueError:
        return None


def sort_trailing_styles(path: str | os.PathLike[str]) -> bool:
    """Rewrite the STEP file ``path`` with its trailing colour blocks in a fixed order (see the module
    docstring). Returns whether the file was rewritten; a file of another shape is left as it is."""
    with open(path, "rb") as f:
        data = f.read()
    parsed = _entities(data)
    if parsed is None:
        return False
    head, ents, tail = parsed
    found = _blocks(ents)
    if found is None:
        return False
    first, size = found
    base = ents[first][0]
    if any(base <= int(m[1]) for _, text in ents[:first] for m in _REF.finditer(text)):
        return False  # something earlier refers into the blocks: their numbers are not free to move
    blocks = []
    for b in range(first, len(ents), size):
        lo = ents[b][0]
        rel = [_relative(text, lo, lo + size, base) for _, text in ents[b:b + size]]
        if any(r is None for r in rel):
            return False
        blocks.append(rel)
    blocks.sort()
    out = [head, *(b"#%d = " % n + text for n, text in ents[:first])]
    for k, rel in enumerate(blocks):
        lo = base + k * size
        for j, text in enumerate(rel):
            body = re.sub(rb"#@(\d+)", lambda m, lo=lo: b"#%d" % (lo + int(m[1])), text)  # type: ignore[misc]
            out.append(b"#%d = " % (lo + j) + body)
    out.append(tail)
    new = b"".join(out)
    if new == data:
        return False
    with open(path, "wb") as f:
        f.write(new)
    return True


def renumber_occurrences(path: str | os.PathLike[str]) -> bool:
    """Rewrite the STEP file ``path`` with its ``NEXT_ASSEMBLY_USAGE_OCCURRENCE`` ids shifted to start at 1
    (see the module docstring). Returns whether the file was rewritten (not when they start at 1, or there
    are none)."""
    with open(path, "rb") as f:
        data = f.read()
    ids = [int(m[2]) for m in _OCCURRENCE.finditer(data)]
    if not ids or min(ids) == 1:
        return False
    shift = min(ids) - 1
    new = _OCCURRENCE.sub(lambda m: m[1] + b"%d" % (int(m[2]) - shift) + m[3], data)
    with open(path, "wb") as f:
        f.write(new)
    return True
