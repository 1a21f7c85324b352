"""The valid ranges of the design loop's own parameters, added to :data:`fabpat.validate.RANGES` so that
``fabpat design``'s options and :func:`fabpat.design.design` check them with the one range check
(:func:`fabpat.validate.check`) and state them in ``--help`` alike.

* ``max_solves``: the search's budget of full assembly solves, 1 … 1000 (one solve of a 2 × 15 strip
  takes about a minute on 2 cores: 1000 is a long night, beyond that the budget is a typo).
* ``design_tolerance``: reachable when the rms error is at most this fraction of the span, in (0, 0.5]
  (above half the span any arch would count as reached).
* ``axis_ratio``: each of an ``ellipsoid:A,B,C`` target's axis ratios, 0.1 … 10 (a hundredfold spread between two
  axes at most: no tiling of plates of one size closes into a needle or a disc, and a ratio like 1e300 or
  1e-320 overflowed the fit after the solves instead of being refused before them).
* ``cap_height``: a ``cap:H`` target's height over its rim radius, (0, 1] (1: a hemisphere; a deeper cap would
  close over its rim).
* ``profile_radius``: each radius of a ``revolution:…`` target over its length, [0.02, 10] (a tube fifty times
  longer than wide, or a hundred times wider than long, is no tube of plates).
* ``max_minutes``: the design run's time budget in minutes, (0, 10080] (a week; the best design so far is
  written when it runs out).
"""

from __future__ import annotations

from fabpat.validate import RANGES, Range

DESIGN_RANGES = (
    Range("max_solves", 1, 1000, integer=True, why="budget of full assembly solves of the design search: one 2 × 15 "
          "strip solve is about a minute on 2 cores"),
    Range("design_tolerance", 0.0, 0.5, low_open=True, why="rms error over the span that counts as reached: above "
          "half the span any arch would"),
    Range("axis_ratio", 0.1, 10.0, why="an ellipsoid target's axis ratio, as in ellipsoid:1,1,1.15: a closed tiling "
          "of plates of one size cannot close into a needle or a disc"),
    Range("cap_height", 0.0, 1.0, low_open=True, why="a cap:H target's height over its rim radius: 1 is a "
          "hemisphere"),
    Range("profile_radius", 0.02, 10.0, why="a revolution target's radius over its length, as in "
          "revolution:0.45,0.5,0.45"),
    Range("max_minutes", 0.0, 10080.0, low_open=True, why="time budget of a design run, minutes: a week at most"),
)
for _r in DESIGN_RANGES:
    RANGES.setdefault(_r.name, _r)
