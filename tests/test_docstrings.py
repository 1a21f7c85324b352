"""Every public name has a docstring: the API reference (docs/api.md, mkdocstrings) is built from them.

Public = a module under ``fabpat`` whose dotted path has no part starting with ``_``; in it, every
function and class defined there (not imported) whose name does not start with ``_``; in such a
class, every method, property, cached property, class- and static method it defines whose name does
not start with ``_``. Also every name in ``fabpat.__all__`` (the top-level API).
"""

from __future__ import annotations

import functools
import importlib
import inspect
import pkgutil
from types import ModuleType

import fabpat


def _public_modules() -> list[ModuleType]:
    names = ["fabpat"] + [m.name for m in pkgutil.walk_packages(fabpat.__path__, "fabpat.")]
    return [importlib.import_module(n) for n in names if not any(p.startswith("_") for p in n.split(".")[1:])]


def _doc(obj: object) -> str:
    return (getattr(obj, "__doc__", None) or "").strip()


def _member_function(value: object) -> object | None:
    if isinstance(value, property):
        return value.fget
    if isinstance(value, functools.cached_property):
        return value.func
    if isinstance(value, classmethod | staticmethod):
        return value.__func__
    return value if inspect.isfunction(value) else None


def _undocumented() -> list[str]:
    missing = []
    for mod in _public_modules():
        if not _doc(mod):
            missing.append(mod.__name__)
        for name, obj in vars(mod).items():
            if name.startswith("_") or not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            if getattr(obj, "__module__", None) != mod.__name__:
                continue
            doc = _doc(obj)
            # a dataclass without a docstring gets its signature as __doc__: that is not documentation
            if not doc or (inspect.isclass(obj) and doc.startswith(f"{name}(")):
                missing.append(f"{mod.__name__}.{name}")
            if inspect.isclass(obj):
                for member, value in vars(obj).items():
                    func = _member_function(value)
                    if not member.startswith("_") and func is not None and not _doc(func):
                        missing.append(f"{mod.__name__}.{name}.{member}")
    for name in getattr(fabpat, "__all__", ()):
        if not _doc(getattr(fabpat, name)):
            missing.append(f"fabpat.{name}")
    return missing


def test_every_public_name_has_a_docstring() -> None:
    assert _undocumented() == []


def test_the_check_sees_public_names() -> None:
    # guard against a walk that finds nothing (and so passes vacuously)
    names = {m.__name__ for m in _public_modules()}
    assert {"fabpat.geometry.outline", "fabpat.exchange.rhino", "fabpat.shell", "fabpat.assembly.kit.build"} <= names
    assert _member_function(vars(fabpat.geometry.outline.RationalQuad)["control_points"]) is not None


def test_the_api_reference_covers_every_public_module() -> None:
    # docs/api/*.md render modules with mkdocstrings (``::: fabpat.x``); the CLI has its own page
    from pathlib import Path

    pages = Path(__file__).resolve().parents[1] / "docs" / "api"
    rendered = {line.split()[1] for page in pages.glob("*.md") for line in page.read_text().splitlines()
                if line.startswith("::: ")}
    public = {m.__name__ for m in _public_modules()}
    missing = sorted(n for n in public if not n.startswith("fabpat.cli") and n not in rendered)
    assert missing == []
