"""What a stored result depends on: the solver version (the package version and a digest of the
code of every module the pipeline runs) and the input hash of a catalog row (:mod:`fabpat.catalog`).
It imports no other catalog module; the pipeline's modules are found from the package folder
(``importlib.resources.files("fabpat")``), not from this file's place.

A sweep skips a row whose stored hash equals the one it would compute now, so changing any input or
the solver code recomputes exactly the affected rows. The digest reads the code without its comments
and docstrings (:func:`code_text`): rewording an explanation does not make 16 000 stored solves stale,
while any change to a statement, a constant or a default does. It reads the pipeline as one program,
not as files (:func:`code_statements`): its top-level statements and third-party imports, whatever
module holds them, with imports of fabpat's own names reduced to the names. So moving a function to
another module, splitting a module or putting modules in a package stales nothing, while the code that
runs is what is hashed. A name defined in two pipeline modules (:func:`ambiguous_names`) keeps its
module in every import of it, so switching between two definitions of one name is a change too.
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
_PIPELINE_ROOTS = ("fabpat.patterns.library", "fabpat.geometry.fillet", "fabpat.simulation.mesh",
                   "fabpat.simulation.scenarios", "fabpat.simulation.convergence")
# Writers and pictures that pipeline objects reach for on request (``FilletedPattern.export``,
# ``ScenarioResult.to_vtu``, notebook pictures) never change a stored number: not part of the digest.
# The old-name finder (fabpat._moved) only maps import paths.
_OUTPUT_ONLY = ("fabpat.exchange", "fabpat.views", "fabpat.simulation.vtu", "fabpat.simulation.png_result",
                "fabpat.simulation.inp", "fabpat.io", "fabpat._moved")



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
        todo.extend(".".join(parts[:k]) for k in range(1, len(parts)))  # importing a.b.c runs a's and a.b's __init__
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


def _defined_names(tree: ast.Module) -> list[str]:
    """Names a module's top-level statements define (functions, classes, assigned names)."""
    out: list[str] = []
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            out.append(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            out += [t.id for t in targets if isinstance(t, ast.Name)]
    return out


def ambiguous_names(sources: Sequence[str]) -> frozenset[str]:
    """Top-level names defined in more than one of the modules ``sources`` (Python code), ``__all__``
    aside: an import of one of them keeps its module in the digest (module doc)."""
    seen: dict[str, int] = {}
    for src in sources:
        for name in set(_defined_names(ast.parse(src))):
            seen[name] = seen.get(name, 0) + 1
    return frozenset(n for n, k in seen.items() if k > 1 and n != "__all__")


def _own_import(node: ast.AST, ambiguous: frozenset[str]) -> str | None:
    """``from fabpat import a, b as c`` for an import of fabpat's own unambiguous names from any of its
    modules (where a name lives does not change what it computes), else None."""
    if (isinstance(node, ast.ImportFrom) and node.level == 0 and node.module
            and node.module.split(".")[0] == "fabpat" and not {a.name for a in node.names} & ambiguous):
        return "from fabpat import " + ", ".join(a.name if a.asname is None else f"{a.name} as {a.asname}"
                                                  for a in node.names)
    return None


def _segment(lines: list[str], node: ast.stmt) -> str:
    """A top-level statement's source, decorators included, from its first column to its last."""
    first = min([node, *getattr(node, "decorator_list", [])], key=lambda n: (n.lineno, n.col_offset))
    end_line, end_col = node.end_lineno or node.lineno, node.end_col_offset or 0
    part = lines[first.lineno - 1:end_line]
    if len(part) == 1:
        return _cut(part[0], first.col_offset, end_col)
    return "\n".join([_cut(part[0], first.col_offset, None), *part[1:-1], _cut(part[-1], 0, end_col)])


def _cut(line: str, start: int, end: int | None) -> str:
    """``line`` between two UTF-8 byte offsets (as :mod:`ast` counts columns)."""
    b = line.encode()
    return b[start:end].decode()


def code_statements(source: str, ambiguous: frozenset[str] = frozenset()) -> tuple[list[str], list[str]]:
    """(third-party imports, other statements) of a module's top level: the names each import binds
    (:func:`_bindings`) and each other statement read by :func:`code_text`; what the digest of
    :func:`solver_version` reads of one module (module doc).

    Every import of fabpat's own unambiguous names, wherever it is (a function-local one too), is first
    written ``from fabpat import …`` (:func:`_own_import`); at the top level it is then left out, as are
    ``from __future__`` imports and ``__all__``: they bind names, and which code a name runs is hashed
    where that code is defined. Raises :class:`SyntaxError` for code that does not parse.
    """
    lines = source.splitlines()
    edits = []
    for node in ast.walk(ast.parse(source)):
        if (own := _own_import(node, ambiguous)) is not None:
            assert isinstance(node, ast.stmt)
            edits.append((node.lineno, node.col_offset, node.end_lineno or node.lineno, node.end_col_offset or 0, own))
    for l0, c0, l1, c1, text in sorted(edits, reverse=True):  # from the end: earlier positions stay valid
        lines[l0 - 1:l1] = [_cut(lines[l0 - 1], 0, c0) + text + _cut(lines[l1 - 1], c1, None)]
    source = "\n".join(lines) + "\n"
    lines = source.splitlines()
    imports: list[str] = []
    statements: list[str] = []
    for node in ast.parse(source).body:
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module in ("fabpat", "__future__"):
            continue
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            continue
        if isinstance(node, ast.Import | ast.ImportFrom):
            imports += _bindings(node)
        elif text := code_text(_segment(lines, node)):
            statements.append(text)
    return imports, statements


def _bindings(node: ast.Import | ast.ImportFrom) -> list[str]:
    """One line per name a top-level import binds (``numpy as np``, ``functools: lru_cache``): a module
    that imports two names and one that imports either of them bind the same ones."""
    if isinstance(node, ast.Import):
        return [a.name if a.asname is None else f"{a.name} as {a.asname}" for a in node.names]
    base = "." * node.level + (node.module or "")
    return [f"{base}: {a.name}" if a.asname is None else f"{base}: {a.name} as {a.asname}" for a in node.names]


def program_digest(sources: Sequence[str]) -> bytes:
    """SHA-256 digest of modules (Python code) read as one program (module doc): the set of names their
    third-party imports bind, then their other top-level statements sorted (:func:`code_statements`)."""
    ambiguous = ambiguous_names(sources)
    imports: set[str] = set()
    statements: list[str] = []
    for src in sources:
        i, st = code_statements(src, ambiguous)
        imports.update(i)
        statements += st
    h = hashlib.sha256()
    for text in [*sorted(imports), "", *sorted(statements)]:
        h.update(text.encode() + b"\0")
    return h.digest()


@cache
def solver_version() -> str:
    """``fabpat <version>+<digest>``: the package version and a digest of the pipeline's code
    (:func:`pipeline_modules`, read by :func:`code_statements`: comments, docstrings and the modules
    that hold each statement left out; the names the third-party imports bind as a set, the statements
    sorted) and of the mesher's version (another Delaunay mesh, another energy)."""
    from fabpat import __version__

    h = hashlib.sha256(program_digest([f.read_text(encoding="utf-8") for f in pipeline_modules()]))
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
