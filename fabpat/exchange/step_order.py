"""A fixed order for the colour blocks OCCT appends to a STEP assembly, so two runs give one file.

OCCT's XDE writer (``STEPCAFControl_Writer``) ends the data section of an assembly with one block per
coloured component: a ``MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION`` and the styled item,
style and colour entities it refers to. It takes them from a map keyed by shape, whose order follows
memory addresses, so the blocks came out permuted from run to run (the same entities, numbered
alike, holding other colours). :func:`sort_trailing_styles` puts them in one order: sorted by their
text, their own entity numbers reduced to offsets within the block. Each block is then renumbered
into the same range of numbers, so nothing else in the file changes. OCCT writes a colour used by
several blocks once, in the first of them, and the others refer to it (the rigid sphere's two sleeve
kinds share one grey): such a shared entity is compared as if every block held it, and written again
in the first block, in the new order, that uses it.

It only acts when the tail of the data section is exactly such blocks, numbered on, that refer only
inside themselves, to earlier entities or to another block's shared entity without references, and
that no earlier entity refers to; any other file is left as OCCT wrote it.

OCCT also numbers the ``NEXT_ASSEMBLY_USAGE_OCCURRENCE`` ids (their first attribute, '1', '2', …) with a
counter that lives as long as the process, so a second assembly written by one process got '11', '12', …
where a fresh process writes '1', '2', …: :func:`renumber_occurrences` shifts them to start at 1 (what a
fresh process writes), so the file does not depend on what the process wrote before.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Sequence

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


def _blocks(ents: list[tuple[int, bytes]]) -> list[tuple[int, int]] | None:
    """The (start, end) indices of the colour blocks if the tail of ``ents`` is such blocks, numbered on."""
    heads = [i for i, (_, text) in enumerate(ents) if text.startswith(_HEAD)]
    if len(heads) < 2:
        return None
    first = heads[0]
    if any(not ents[i][1].startswith(_HEAD) for i in heads) or first == len(ents):
        return None
    numbers = [n for n, _ in ents[first:]]
    if numbers != list(range(numbers[0], numbers[0] + len(numbers))):
        return None
    return list(zip(heads, [*heads[1:], len(ents)], strict=True))


def _canonical(block: list[tuple[int, bytes]], text_of: dict[int, bytes], shared: set[bytes],
               base: int) -> list[bytes] | None:
    """The block as texts with its own references as ``#@k`` (k: the position in this list) and every shared
    leaf entity (``shared``: a text another block refers to) put right after the first entity that refers
    to it, whether the block defines it or refers to another block's. None for a block this cannot order."""
    lo, hi = block[0][0], block[-1][0] + 1
    own = [(n, text) for n, text in block if text not in shared]  # shared leaves are re-placed below
    pos: dict[int, int] = {}
    placed: dict[bytes, int] = {}
    k = 0
    for n, text in own:
        pos[n] = k
        k += 1
        for m in _REF.finditer(text):
            ref = int(m[1])
            if ref < base:
                continue
            target = text_of.get(ref)
            if target in shared and target not in placed:
                placed[target] = k
                k += 1
    if len(own) + len(placed) != k or any(text in shared and text not in placed for _, text in block):
        return None  # a shared entity nothing in the block refers to

    def sub(m: re.Match[bytes]) -> bytes:
        ref = int(m[1])
        if ref < base:
            return m[0]
        target = text_of[ref]
        if target in shared:
            return b"#@%d" % placed[target]
        if not lo <= ref < hi:
            raise ValueError  # a reference into another block that is not to a shared leaf
        return b"#@%d" % pos[ref]

    out: list[bytes] = [b""] * k
    try:
        for n, text in own:
            out[pos[n]] = _REF.sub(sub, text)
    except ValueError:
        return None
    for text, at in placed.items():
        out[at] = text
    return out


def _placeholder_numbers(numbers: Sequence[int]) -> Callable[[re.Match[bytes]], bytes]:
    """The replacement of a block's placeholder ``#@k``: the number ``#n`` its entity k gets."""
    return lambda m: b"#%d" % numbers[int(m[1])]


def sort_trailing_styles(path: str | os.PathLike[str]) -> bool:
    """Rewrite the STEP file ``path`` with its trailing colour blocks in a fixed order (see the module
    docstring). Returns whether the file was rewritten; a file of another shape is left as it is.

    Blocks may differ in length: OCCT writes a colour (a ``COLOUR_RGB`` with no references) once, in the first
    block that uses it, and later blocks refer to that entity. Such shared entities are placed the same way
    in every block to compare them, and after sorting each is written again in the first block that uses it."""
    with open(path, "rb") as f:
        data = f.read()
    parsed = _entities(data)
    if parsed is None:
        return False
    head, ents, tail = parsed
    found = _blocks(ents)
    if found is None:
        return False
    first = found[0][0]
    base = ents[first][0]
    if any(base <= int(m[1]) for _, text in ents[:first] for m in _REF.finditer(text)):
        return False  # something earlier refers into the blocks: their numbers are not free to move
    text_of = dict(ents[first:])
    block_of = {n: b for b, (i, j) in enumerate(found) for n, _ in ents[i:j]}
    shared = set()
    for b, (i, j) in enumerate(found):
        for _, text in ents[i:j]:
            for m in _REF.finditer(text):
                ref = int(m[1])
                if ref >= base and block_of.get(ref, b) != b:
                    if ref not in text_of or _REF.search(text_of[ref]):
                        return False  # a reference out of the tail, or to another block's non-leaf
                    shared.add(text_of[ref])
    blocks = []
    for i, j in found:
        canon = _canonical(ents[i:j], text_of, shared, base)
        if canon is None:
            return False
        blocks.append(canon)
    blocks.sort()
    out = [head, *(b"#%d = " % n + text for n, text in ents[:first])]
    number = base
    defined: dict[bytes, int] = {}
    for canon in blocks:
        numbers, fresh = [], []  # each entity's number, and whether this block writes it
        for text in canon:
            if text in shared and text in defined:
                numbers.append(defined[text])  # written by an earlier block: refer to it
                fresh.append(False)
                continue
            numbers.append(number)
            fresh.append(True)
            if text in shared:
                defined[text] = number
            number += 1
        for text, n, new in zip(canon, numbers, fresh, strict=True):
            if new:
                body = re.sub(rb"#@(\d+)", _placeholder_numbers(numbers), text)
                out.append(b"#%d = " % n + body)
    if number != base + len(ents) - first:
        return False  # the blocks would not fill the same numbers
    out.append(tail)
    rewritten = b"".join(out)
    if rewritten == data:
        return False
    with open(path, "wb") as f:
        f.write(rewritten)
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
