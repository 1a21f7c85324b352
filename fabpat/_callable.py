"""Modules that can be called, so that ``fabpat.library(...)``, ``fabpat.pattern(...)`` and
``fabpat.catalog()`` are the top-level API while ``fabpat.library`` etc. stay importable modules.

A package attribute named like a submodule is replaced by the module as soon as that submodule is
imported (the import system sets it), so a plain function ``fabpat.library`` could not survive the
package's own imports. Instead the module itself becomes callable, by the mechanism the Python
reference documents for customising module attribute access (assigning ``module.__class__``).
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable
from typing import Any


class CallableModule(types.ModuleType):
    """A module whose call runs its ``__call_target__`` (a function, or ``"module:function"``)."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return _target(self)(*args, **kwargs)


def _target(module: types.ModuleType) -> Callable[..., Any]:
    target = module.__dict__["__call_target__"]
    if isinstance(target, str):  # resolved on first call: the function may live in a later module
        name, _, attr = target.partition(":")
        target = getattr(importlib.import_module(name), attr)
    return target  # type: ignore[no-any-return]


def make_callable(module_name: str, target: Callable[..., Any] | str) -> None:
    """Make ``sys.modules[module_name]`` callable: calling it calls ``target``."""
    module = sys.modules[module_name]
    module.__call_target__ = target  # type: ignore[attr-defined]
    module.__class__ = CallableModule
