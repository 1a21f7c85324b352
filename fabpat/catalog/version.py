"""What a stored result depends on: the solver version (the package version and a digest of the
code of every module the pipeline runs) and the input hash of a catalog row (:mod:`fabpat.catalog`).
It imports no other catalog module; the pipeline's modules are found from the package folder
(``importlib.resources.files("fabpat")``), not from this file's place.

A sweep skips a row whose stored hash equals the one it would compute now, so changing any input or
the solver code recomputes exactly the affected rows. The digest reads the code without its comments
and docstrings (:func:`code_text`): rewording an explanation does not make 11 000 stored solves stale,
while any change to a statement, a constant or a default does.
"""

from __future__ import annotations

import ast
import hashlib
import io
import json
import tokenize
from collections.abc import Mapping, Sequence
from functools import cache
from importlib import resources
from pathlib import Path

# The results depend on the code of these modules and of every fabpat module they import (found by
# reading their import statements): that code's digest is part of the solver version, so a code change
# invalidates stored results instead of silently mixing them, and an unrelated module does not.
_PIPELINE_ROOTS = ("fabpat.library", "fabpat.fillet", "fabpat.mesh", "fabpat.scenarios", "fabpat.convergence")
# Writers and pictures that pipeline objects reach for on request (``FilletedPattern.export``,
# ``ScenarioResult.to_vtu``, notebook pictures) never change a stored number: not part of the digest.
_OUTPUT_ONLY = ("fabpat.exchange", "fabpat.cad", "fabpat.contours", "fabpat.pictures", "fabpat.plots", "fabpat.io")



def pipeline_modules(roots: Sequence[str] = _PIPELINE_ROOTS) -> list[Path]:
    """Source files of ``roots`` and of every fabpat module they import, directly or not (sorted).

    Imports are read from the source (``ast``), including the lazy ones inside functions; the
    output-only modules (:data:`_OUTPUT_ONLY`: file writers, pictures) are left out.
    """
    import ast

    base = Path(str(resources.files("fabpat")))

    def path_of(module: str) -> Path | None:
        parts = module.split(".")[1:]
        if not parts:
            return base / "__init__.py"
        for cand in (base.joinpath(*parts[:-1], parts[-1] + ".py"), base.joinpath(*parts, "__init__.py")):
            if cand.is_file():
                return cand
        return None

    seen: dict[str, Path] = {}
    todo = list(roots)
    while todo:
        mod = todo.pop()
        if any(mod == o or mod.startswith(o + ".") for o in _OUTPUT_ONLY):
            continue
        path = path_of(mod)
        if mod in seen or path is None:
            continue
        seen[mod] = path
        parts = mod.split(".")
        todo.extend(".".join(parts[:k]) for k in range(2, len(parts)))  # importing a.b.c runs a.b's __init__
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("fabpat"):
                todo.append(node.module)
                todo.extend(f"{node.module}.{a.name}" for a in node.names)  # `from fabpat.shell import solve`
            elif isinstance(node, ast.Import):
                todo.extend(a.name for a in node.names if a.name.startswith("fabpat"))
    return sorted(set(seen.values()))


def code_text(source: str) -> str:
    """``source`` (Python code) without its comments, docstrings and blank lines, each line's trailing
    space stripped: what the digest of :func:`solver_version` reads.

    Comments are found by :mod:`tokenize` and docstrings (every string statement: a module's, class's or
    function's docstring and an attribute's, none of which runs) by :mod:`ast`; both report the same
    positions on every Python version, so the text does not depend on the interpreter. Raises
    :class:`SyntaxError` for code that does not parse.
    """
    lines = source.splitlines()

    def column(line: int, utf8_offset: int) -> int:  # ast counts columns in UTF-8 bytes, tokenize in characters
        return len(lines[line - 1].encode()[:utf8_offset].decode())

    cut: list[tuple[int, int, int, int]] = []  # (first line, column, last line, end column); lines from 1
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            cut.append((*tok.start, *tok.end))
    for doc in ast.walk(ast.parse(source)):
        # a string statement does nothing when run: a docstring, or the documentation of an attribute
        if isinstance(doc, ast.Expr) and isinstance(doc.value, ast.Constant) and isinstance(doc.value.value, str):
            end_line, end_col = doc.end_lineno or doc.lineno, doc.end_col_offset or 0
            cut.append((doc.lineno, column(doc.lineno, doc.col_offset), end_line, column(end_line, end_col)))
    for l0, c0, l1, c1 in sorted(cut, reverse=True):  # from the end: earlier positions stay valid
        lines[l0 - 1:l1] = [lines[l0 - 1][:c0] + lines[l1 - 1][c1:]]
    return "\n".join(line.rstrip() for line in lines if line.strip())


@cache
def solver_version() -> str:
    """``fabpat <version>+<digest>``: the package version and a digest of the pipeline's code
    (:func:`pipeline_modules`, read by :func:`code_text`: comments and docstrings left out) and of the
    mesher's version (another Delaunay mesh, another energy)."""
    from fabpat import __version__

    base = Path(str(resources.files("fabpat")))
    h = hashlib.sha256()
    for f in pipeline_modules():
        h.update(f.relative_to(base).as_posix().encode())
        h.update(code_text(f.read_text(encoding="utf-8")).encode())
    try:
        from importlib.metadata import version

        h.update(version("triangle").encode())
    except Exception:  # noqa: BLE001 - metadata missing in odd installs: the digest still covers the code
        pass
    return f"fabpat {__version__}+{h.hexdigest()[:12]}"


def input_hash(inputs: Mapping[str, object]) -> str:
    """A 16-hex-digit SHA-256 of a flat mapping of inputs (keys sorted; floats by ``repr``)."""
    text = json.dumps({k: inputs[k] for k in sorted(inputs)}, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
