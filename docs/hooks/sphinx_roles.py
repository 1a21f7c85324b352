"""griffe extension for the API reference: the Sphinx roles of fabpat's docstrings become links.

fabpat's docstrings name other objects with Sphinx roles (``:class:`Outline```,
``:func:`~fabpat.exchange.cad.make_solid```). mkdocstrings renders Markdown, where a role would show as raw
text. This extension rewrites each role, once the package is loaded, into an autorefs link
(``[`Outline`][fabpat.geometry.outline.Outline]``) when the name resolves to a public, documented fabpat
object, and into plain code otherwise. A link that then finds no target fails the strict build.
"""

from __future__ import annotations

import re
from typing import Any

from griffe import Alias, Extension, Object

ROLE = re.compile(r":(?:class|func|meth|attr|data|mod|exc|obj):`(~?)([A-Za-z_][\w.]*)(?:\(\))?`")
UNDOCUMENTED = ("fabpat.cli",)  # not in the API reference (the CLI reference documents the commands)


def _public(path: str) -> bool:
    parts = path.split(".")
    return parts[0] == "fabpat" and not any(p.startswith("_") for p in parts[1:]) and not path.startswith(
        UNDOCUMENTED)


def _resolve(obj: Object, name: str, root: Object) -> str | None:
    """Full path of ``name`` as seen from ``obj`` (its scope, then the package), or None."""
    head, _, rest = name.partition(".")
    candidates = []
    scope: Object | None = obj
    while scope is not None:
        try:
            candidates.append(scope.resolve(head))
        except Exception:  # noqa: BLE001 - griffe raises NameResolutionError; any failure means "not here"
            pass
        scope = scope.parent
    candidates.append(head)
    for base in candidates:
        path = f"{base}.{rest}" if rest else base
        try:
            target = root.modules_collection[path]  # type: ignore[union-attr]
        except Exception:  # noqa: BLE001 - KeyError or alias resolution errors
            continue
        if isinstance(target, Alias):
            try:
                path = target.final_target.path
            except Exception:  # noqa: BLE001
                continue
        return path if _public(path) else None
    return None


class SphinxRoles(Extension):
    """Rewrite Sphinx roles in every docstring of the loaded package."""

    def on_package(self, *, pkg: Object, **kwargs: Any) -> None:
        for obj in self._walk(pkg):
            if obj.docstring is None:
                continue

            def link(m: re.Match[str], obj: Object = obj) -> str:
                short, name = m.group(1) == "~", m.group(2)
                shown = name.rsplit(".", 1)[-1] if short else name
                path = _resolve(obj, name, pkg)
                return f"[`{shown}`][{path}]" if path else f"`{shown}`"

            obj.docstring.value = ROLE.sub(link, obj.docstring.value)

    def _walk(self, obj: Object) -> list[Object]:
        out = [obj]
        for member in obj.members.values():
            if not isinstance(member, Alias):
                out += self._walk(member)
        return out
