"""Continuous variations: every library pattern as a family whose look and stiffness vary smoothly.

The journal version of the method (Scandurra, Laccone, Malomo, Callieri, Cignoni, Giorgi, *Procedural
generation of geometric patterns for thin shell fabrication*, Computers & Graphics, 2024) varies each
pattern's geometry continuously. fabpat's family parameter is the middle weight of the fillet arcs at
non-manifold vertices, which the paper fixes at 1 (§3.3: "we assign the same weight to all the control
points, thus producing a quadratic Bézier curve"):

* ``bridge_weight`` — the arcs at **non-manifold** vertices bridge the void runs between ligaments.
  The arc (M₁, V, M₂; 1, w, 1) passes at B(½) = V + (M − V)/(1 + w), with M the chord midpoint, so
  the bridge's material at the vertex scales with 1/(1 + w): a small weight gives wide, stiff necks,
  a large one narrow, compliant hinges. A symmetric neck's width is 2/(1 + w) times the paper's
  (every neck of the hexagon lattice is symmetric).

Why this one (measured, docs/variations.md): it keeps everything the method guarantees —

* **tileable**: the interface segments and their bow-tie arcs do not depend on them, so two patterns
  at any two variations meet at identical interface geometry;
* **exchangeable** and **symmetric**: they act on every vertex of a class alike, so the n-fold
  rotational symmetry stays;
* **connected**: an arc stays inside its control triangle for every positive weight, so a bridge
  never opens;
* **exact**: every arc stays a quadratic rational Bézier curve, in the model, STEP and .3dm alike.

The other candidates were measured and left out: the weight of the arcs at sharp vertices moves the
three energies of 0x0488 and 0x2d88 by at most 0.6 % over [0.2, 5] (no stiffness range, only another
catalog dimension to sweep); a ligament offset would break exactness (the offset of a conic is not a
conic) and a warp of the lattice's interior vertices moves the interface geometry.

The valid ranges are in :data:`fabpat.validate.RANGES` (the one table of every number's range), with
the measurement that bounds them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields

from fabpat.errors import GeometryError
from fabpat.validate import RANGES, check


@dataclass(frozen=True)
class Variation:
    """One member of a pattern's family.

    ``bridge_weight`` (dimensionless; the paper's 1): middle weight of the arcs at non-manifold vertices.
    Every value is checked against its range on construction (:class:`GeometryError`);
    :meth:`from_values` also checks the names.
    """

    bridge_weight: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, check(f.name, getattr(self, f.name), error=GeometryError))

    @classmethod
    def from_values(cls, values: Mapping[str, object] | None = None, **more: object) -> Variation:
        """The variation with ``values`` (name → number) on top of the paper's defaults.

        Raises :class:`GeometryError` naming the valid parameters for an unknown name, and the range
        for a value outside it (:func:`fabpat.validate.check`).
        """
        if values is not None and not isinstance(values, Mapping):
            raise GeometryError(f"variation values must be a mapping name → number such as {{'bridge_weight': 0.5}}, "
                                f"got {type(values).__name__} {values!r:.40}"
                                + (" (that is the command line's spelling)" if isinstance(values, str) else ""))
        given = {**(values or {}), **more}
        names = [f.name for f in fields(cls)]
        for key in given:
            if key not in names:
                raise GeometryError(f"unknown variation {key!r}; valid: {', '.join(names)}")
        return cls(**given)  # type: ignore[arg-type]  # the values are checked by __post_init__

    @property
    def is_paper(self) -> bool:
        """True for the paper's fillets (every parameter at its default)."""
        return self == PAPER_VARIATION

    def items(self) -> dict[str, float]:
        """The parameters as an ordered name → value dict."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}

    def changed(self) -> dict[str, float]:
        """Only the parameters that differ from the paper's."""
        paper = PAPER_VARIATION.items()
        return {k: v for k, v in self.items().items() if v != paper[k]}

    def label(self) -> str:
        """``"bridge_weight=0.5"`` (only what differs from the paper), or ``""``."""
        return " ".join(f"{k}={_shortest(v)}" for k, v in self.changed().items())

    def tag(self) -> str:
        """The short name of the member that parts, plates and candidates carry after the pattern ID:
        ``"b0.5"`` (``bridge_weight`` 0.5), or ``""`` for the paper's."""
        return " ".join(f"{_TAGS[k]}{_shortest(v)}" for k, v in self.changed().items())


def _shortest(v: float) -> str:
    """``f"{v:g}"`` unless that names another number (1.0000001 → "1"): then ``repr``, which round-trips,
    so two different members never share a label."""
    short = f"{v:g}"
    return short if float(short) == v else repr(float(v))


#: The one-letter prefix of each parameter in :meth:`Variation.tag`.
_TAGS: dict[str, str] = {"bridge_weight": "b"}


PAPER_VARIATION = Variation()

#: What each parameter means, in the words of ``fabpat variations``.
MEANINGS: dict[str, str] = {
    "bridge_weight": "middle weight of the fillet arcs at non-manifold vertices: neck width scales with "
                     "2/(1 + w), small = wide stiff necks, large = narrow compliant hinges",
}


def variations() -> list[dict[str, object]]:
    """The family parameters as ``fabpat variations --json`` lists them: one dict per parameter with
    ``name``, ``min``, ``max``, ``default`` (the paper's value), ``unit`` (``""``: dimensionless) and
    ``meaning``."""
    out: list[dict[str, object]] = []
    for f in fields(Variation):
        r = RANGES[f.name]
        out.append({"name": f.name, "min": r.low, "max": r.high, "default": float(getattr(PAPER_VARIATION, f.name)),
                    "unit": r.unit, "meaning": MEANINGS[f.name]})
    return out
