"""Modules that can be called, so that ``fabpat.library(...)``, ``fabpat.pattern(...)`` and
``fabpat.catalog()`` are the top-level API while ``fabpat.library`` etc. stay importable modules.

A package attribute named like a submodule is replaced by the module as soon as that submodule is
imported (the import system sets it), so a plain function ``fabpat.library`` could not survive the
package's own imports. Instead the module itself becomes callable, by the mechanism the Python
reference documents for customising module attribute access (assigning ``module.__class__``).

So that ``help(fabpat.library)``, ``inspect.signature(fabpat.library)`` and Jupyter's ``fabpat.library?``
describe the call, such a module reports the function's signature as ``__signature__`` (which
:func:`inspect.signature` reads before anything else) and a ``__doc__`` that is the function's
docstring followed by the module's. Both are properties of the class: a data descriptor on the type
wins over the module's own ``__doc__`` entry in its ``__dict__``.
"""

from __future__ import annotations

import importlib
import inspect
import sys
import types
from collections.abc import Callable
from typing import Any


class CallableModule(types.ModuleType):
    """A module whose call runs its ``__call_target__`` (a function, or ``"module:function"``)."""

    def __call__(self, *args: object, **kwargs: object) -> Any:
        return _target(self)(*args, **kwargs)

    @property
    def __signature__(self) -> inspect.Signature:
        return inspect.signature(_target(self))

    @property
    def __doc__(self) -> str | None:  # noqa: D105
        own = self.__dict__.get("__doc__")
        call = inspect.getdoc(_target(self)) or ""
        name = self.__name__
        head = f"{name}{inspect.signature(_target(self))}\n\n{call}" if call else ""
        if not own:
            return head or None
        return f"{head}\n\nThe module {name} (calling it calls the function above):\n\n{inspect.cleandoc(own)}"


def _target(module: types.ModuleType) -> Callable[..., Any]:
    target = module.__dict__["__call_target__"]
    if isinstance(target, str):  # resolved on first call: the function may live in a later module
        name, _, attr = target.partition(":")
        target = getattr(importlib.import_module(name), attr)
    function: Callable[..., Any] = target  # make_callable's target
    return function


def make_callable(module_name: str, target: Callable[..., Any] | str) -> None:
    """Make ``sys.modules[module_name]`` callable: calling it calls ``target``."""
    module = sys.modules[module_name]
    module.__dict__["__call_target__"] = target  # what _target reads
    module.__class__ = CallableModule
