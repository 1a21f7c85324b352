"""Inverse design: a target shape in, one pattern per tile and a verified spec out (``fabpat design``).

:func:`design` (:mod:`fabpat.design.api`) reads a target (:mod:`fabpat.design.target`) and a base spec
(:mod:`fabpat.design.base`), every refusal before the first solve. A honeycomb strip's target is a mid-line:
a first guess from the reduced elastica model (:mod:`fabpat.design.strip`) is refined with full assembly
solves (:mod:`fabpat.design.search`). A closed tiling's target is a surface (``sphere``,
``ellipsoid:A,B,C`` or a mesh file), reached by a Bayesian search over face groups
(:mod:`fabpat.design.closed`); the closed kinds designed are :data:`fabpat.design.base.CLOSED_KINDS`. An
open tiling (:data:`fabpat.design.base.OPEN_KINDS`) takes a surface of revolution (``cap:H``, ``revolution:…``;
:mod:`fabpat.design.revolution`), designed the same way.
The outputs are design.toml, design.json and design.png (:mod:`fabpat.design.outputs`). See docs/design.md.

The module is callable: ``fabpat.design(target, spec, ...)`` calls :func:`design`, whichever of
``import fabpat`` and ``from fabpat.design import design`` comes first (:mod:`fabpat._callable`).
"""

from fabpat._callable import make_callable
from fabpat.design.api import DesignResult, design
from fabpat.design.target import ClosedTarget, StripTarget, TargetError, read_target

__all__ = ["ClosedTarget", "DesignResult", "StripTarget", "TargetError", "design", "read_target"]

make_callable(__name__, design)
