"""The sleeve's dimensions on a tiling's joint (paper §5): how far each plate's edge sits from the skeleton
edge so that a web separates the sleeve's two slots, the skeleton edge that leaves room for them, and the
directions of the two plates in a joint's cross-section. The sleeve's solid is
:class:`fabpat.assembly.place.sleeve.Sleeve`; its frame and angles are described there.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.geometry.fillet import interface_half_length

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.assembly.surface.tiling import Tiling

def required_setback(dihedral: float, thickness: float, clearance: float, wall: float) -> float:
    """Smallest plate setback (mm) for which a web of ``wall`` mm separates the two slots.

    The slot's inner bottom corner (s = g − c/2, r = −(t + c)/2 along plate A) must lie ``wall/2``
    from the bisector plane: (g − c/2) sin(φ/2) − ((t + c)/2) cos(φ/2) = wall/2.
    """
    h = 0.5 * dihedral
    return 0.5 * clearance + (0.5 * wall + 0.5 * (thickness + clearance) * math.cos(h)) / math.sin(h)


def setback(sides: int, skeleton: float, plate: float) -> float:
    """Distance (mm) between a plate's polygon edge and the skeleton edge: the apothem difference."""
    return (skeleton - plate) / (2.0 * math.tan(math.pi / sides))


def min_plate_edge(margin: float, wall: float, weight: float) -> float:
    """Smallest plate edge (mm) a sleeve fits on: its slot (the interface segment, 2e/16/(1 + w) of the
    edge e for interface weight w, plus ``margin``) and two walls of ``wall`` within the edge."""
    return (margin + 2.0 * wall) / (1.0 - 2.0 * interface_half_length(1.0, weight=weight))


def skeleton_edge(tiling: Tiling, plate_edge: float, thickness: float, clearance: float, wall: float,
                  printed: Callable[[float], float] | Mapping[int, float] | None = None) -> float:
    """Smallest skeleton edge (mm) for which every joint's slots are separated by ``wall`` mm: the plate
    edge plus a sleeve allowance that depends on the joints' angles, the thickness, the clearance and the
    wall only (so a plate edge for a wanted skeleton size is a subtraction).

    ``printed`` gives the angle (rad) each joint's sleeve is printed at: a map of a joint's dihedral
    angle (rad) to it, or {interior edge k: angle} (a joint it lacks: its dihedral); default the
    dihedral. The web must hold at both angles, the printed part's and the start state's. With plates
    of several thicknesses, ``thickness`` is the thickest (mm): every slot is then at least as far out
    as its own plate needs.
    """
    need = 0.0
    for k in tiling.interior_edges:
        phi = float(tiling.dihedral[k])
        if printed is None:
            angle = phi
        elif isinstance(printed, Mapping):
            angle = float(printed.get(int(k), phi))
        else:
            angle = printed(phi)
        g = max(required_setback(a, thickness, clearance, wall) for a in (phi, angle))
        for f, _ in tiling.edge_faces[k]:
            need = max(need, 2.0 * g * math.tan(math.pi / len(tiling.faces[f])))
    return plate_edge + need


def joint_labels(tiling: Tiling) -> dict[int, str]:
    """Interior edge k → its joint's label, "E01" … in the order of ``tiling.interior_edges``, zero-padded
    to the digits of their count ("E1" … "E7" for 7 joints): the labels the kit prints on plates and
    sleeves and ``[sleeve] angles`` names."""
    width = len(str(len(tiling.interior_edges)))
    return {int(k): f"E{n + 1:0{width}d}" for n, k in enumerate(tiling.interior_edges)}


def joint_direction(dihedral: float, side: int) -> NDArray[np.float64]:
    """(2,) unit vector (Y, Z) from the edge into plate A (side 0) or B (side 1) of a joint at ``dihedral`` rad.

    ``(±sin φ/2, −cos φ/2)`` (module docstring): the slot directions of a sleeve printed at φ, and the
    plates' directions in a sleeve frame placed on a skeleton joint of dihedral φ.
    """
    h = 0.5 * dihedral
    return np.array([math.sin(h) if side == 0 else -math.sin(h), -math.cos(h)])


def joint_normal(dihedral: float, side: int) -> NDArray[np.float64]:
    """(2,) unit normal of plate A / B of a joint at ``dihedral`` rad, pointing to the convex (+Z) side."""
    d = joint_direction(dihedral, side)
    n = np.array([-d[1], d[0]])
    return n if n[1] >= 0 else -n
