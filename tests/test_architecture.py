"""The package map in docs/design-notes.md is true: every module is in it once, in its stage, and the
imports (every import statement: top-level, function-local and TYPE_CHECKING ones) run only from a stage
to the stages its row names, except the arrows the page lists as running back, each with its reason."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "fabpat"
NOTES = ROOT / "docs" / "design-notes.md"


def modules() -> dict[str, Path]:
    """Every module of fabpat by its dotted name without the ``fabpat.`` prefix (a package by its own name,
    ``fabpat/__init__.py`` as ``__init__``)."""
    out = {}
    for f in sorted(PACKAGE.rglob("*.py")):
        parts = list(f.relative_to(PACKAGE).with_suffix("").parts)
        if parts[-1] == "__init__" and len(parts) > 1:
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def imports(path: Path, known: dict[str, Path]) -> set[str]:
    """The fabpat modules ``path`` imports (``from fabpat.shell import solve`` is ``shell.solve``; the
    package ``fabpat`` itself, e.g. for ``__version__``, is ``__init__``)."""

    def resolve(name: str) -> str:
        rest = name.removeprefix("fabpat").removeprefix(".")
        while rest and rest not in known:
            rest = rest.rpartition(".")[0]
        return rest or "__init__"

    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "fabpat":
            out |= {resolve(f"{node.module}.{a.name}") for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {resolve(a.name) for a in node.names if a.name.split(".")[0] == "fabpat"}
    return out


def section(title: str) -> list[list[str]]:
    """The rows of the first table under the heading ``title`` in docs/design-notes.md, as cells."""
    text = NOTES.read_text(encoding="utf-8")
    start = re.search(rf"^#+ {re.escape(title)}\s*$", text, re.M)
    assert start, f"docs/design-notes.md has no section {title!r}"
    rows = []
    for line in text[start.end():].splitlines():
        if line.startswith("#"):
            break
        if line.startswith("|") and not set(line) <= set("|-: "):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows[1:]  # without the header


def names(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


def stage_map() -> tuple[list[str], dict[str, str], dict[str, set[str]]]:
    """Stage order, module → stage, stage → the stages it may import (itself included)."""
    order: list[str] = []
    where: dict[str, str] = {}
    allowed: dict[str, set[str]] = {}
    for stage, uses, mods, *_ in section("Module map"):
        if stage not in order:
            order.append(stage)
        ups = set(order) if uses == "every stage above" else {u.strip() for u in uses.split(",") if u.strip() != "–"}
        allowed.setdefault(stage, {stage}).update(ups)
        for m in names(mods):
            assert m not in where, f"{m} is listed twice in the module map"
            where[m] = stage
    return order, where, allowed


def back_arrows() -> set[tuple[str, str]]:
    return {(names(a)[0], names(b)[0]) for a, b, *_ in section("Arrows that run back")}


def test_every_module_is_in_the_map_once() -> None:
    _, where, _ = stage_map()
    have = set(modules())
    assert sorted(have - set(where)) == [], "modules missing from docs/design-notes.md's module map"
    assert sorted(set(where) - have) == [], "the module map names modules that do not exist"


def test_stages_name_only_stages_above_them() -> None:
    order, _, allowed = stage_map()
    for stage, ups in allowed.items():
        assert all(order.index(u) <= order.index(stage) for u in ups), (stage, ups)


def test_no_import_from_a_later_stage_except_the_listed_arrows() -> None:
    _, where, allowed = stage_map()
    known = modules()
    listed = back_arrows()
    seen = set()
    wrong = []
    for m, path in known.items():
        for t in imports(path, known) - {m}:
            if where[t] in allowed[where[m]]:
                continue
            if (m, t) in listed:
                seen.add((m, t))
            else:
                wrong.append(f"{m} ({where[m]}) imports {t} ({where[t]})")
    assert wrong == []
    assert sorted(listed - seen) == [], "arrows listed as running back that no longer exist"


def test_the_shell_engine_knows_nothing_outside_itself() -> None:
    known = modules()
    for m, path in known.items():
        if m == "shell" or m.startswith("shell."):
            outside = {t for t in imports(path, known) if t != "errors" and not t.startswith("shell")}
            assert outside == set(), f"{m} imports {outside}"


def test_no_import_circle_but_through_the_listed_arrows() -> None:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    known = modules()
    index = {m: i for i, m in enumerate(known)}
    listed = back_arrows()
    edges = [(index[m], index[t]) for m, p in known.items() for t in imports(p, known) - {m} if (m, t) not in listed]
    a, b = zip(*edges, strict=True)
    graph = coo_matrix(([1] * len(a), (a, b)), shape=(len(known),) * 2)
    n, label = connected_components(graph, directed=True, connection="strong")
    circles = [sorted(m for m, i in index.items() if label[i] == k) for k in range(n)]
    assert [c for c in circles if len(c) > 1] == []


@pytest.mark.parametrize("title", ["Module map", "Arrows that run back"])
def test_the_tables_exist(title: str) -> None:
    assert section(title), f"the {title!r} table of docs/design-notes.md is empty"


#: escapes from the type checker: `type: ignore` comments and `: Any` annotations in fabpat/ may only shrink
#: (the static check itself is .ci/typecheck.py against .ci/mypy-baseline.txt); lower these as they go
TYPE_IGNORES, ANY_ANNOTATIONS = 20, 29


def test_escapes_from_the_type_checker_do_not_grow() -> None:
    text = [p.read_text(encoding="utf-8") for p in (ROOT / "fabpat").rglob("*.py")]
    ignores = sum(t.count("type: ignore") for t in text)
    anys = sum(t.count(": Any") for t in text)
    assert ignores <= TYPE_IGNORES, f"{ignores} `type: ignore` in fabpat/, at most {TYPE_IGNORES}"
    assert anys <= ANY_ANNOTATIONS, f"{anys} `: Any` in fabpat/, at most {ANY_ANNOTATIONS}"
    assert ignores > 10 and anys > 10  # the walk finds the package (a wrong path would pass vacuously)


def test_the_assembly_is_rooms_behind_a_face() -> None:
    """``fabpat/assembly`` holds its face and at most 8 entries, each a sub-package of at most 12 modules, in
    the module map in import order (so no room imports a later one: the test above) and no two rooms importing
    each other; its face is the five names."""
    root = PACKAGE / "assembly"
    entries = sorted(p.name for p in root.iterdir() if p.name != "__pycache__" and p.name != "__init__.py")
    assert len(entries) + 1 <= 8, entries
    assert all((root / e).is_dir() for e in entries), "every job of the assembly is a sub-package"
    for e in entries:
        count = len(list((root / e).glob("*.py")))
        assert 2 <= count <= 12, f"assembly/{e} has {count} modules"
    known = modules()
    room = {m: m.split(".")[1] for m in known if m.startswith("assembly.")}
    arrows = {(room[m], room[i]) for m in room for i in imports(known[m], known) if i in room and room[i] != room[m]}
    both = sorted((a, b) for a, b in arrows if (b, a) in arrows and a < b)
    assert both == [], f"rooms importing each other: {both}"
    import fabpat.assembly as face

    assert sorted(face.__all__) == ["AssemblySimulation", "AssemblySpec", "assemble", "load_spec",
                                    "simulate_assembly"]
