"""Inverse design: a target shape in, one pattern per tile and a verified spec out (``fabpat design``).

This version designs honeycomb strips: :func:`design` (:mod:`fabpat.design.api`) reads a target
mid-line (:mod:`fabpat.design.target`) and a base spec (:mod:`fabpat.design.base`), chooses a
first guess with the reduced elastica model (:mod:`fabpat.design.strip`), refines it with full
assembly solves (:mod:`fabpat.design.search`) and writes design.toml, design.json and design.png
(:mod:`fabpat.design.outputs`). See docs/design.md.
"""

from fabpat.design.api import DesignResult, design
from fabpat.design.target import ClosedTarget, StripTarget, TargetError, read_target

__all__ = ["ClosedTarget", "DesignResult", "StripTarget", "TargetError", "design", "read_target"]
