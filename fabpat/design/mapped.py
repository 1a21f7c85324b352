"""A closed design's tiling mapped onto its target: the base tiling's faces carried onto the target surface,
relaxed into flat, nearly regular faces (:mod:`fabpat.design.remesh`), and plates shaped to them.

Why (docs/design.md, "Reachability"): equal regular plates carry a sphere's metric, and a closed convex surface
is fixed by its metric, so patterns and sleeve angles alone close them into a sphere's shape whatever the target.
Plates cut to the target's own faces carry the target's metric; the patterns and the sleeves then decide how
smoothly the flat plates bend into it.

The design's spec is the base's with its ``[tiling]`` replaced by a mesh tiling of the relaxed faces::

    [tiling]
    kind = "mesh"
    file = "mapped.obj"     # written beside design.toml
    edge = 36.0             # the base's plate edge (mm): the mesh is scaled to it
    plates = "shaped"       # every plate its own face's polygon (fabpat.geometry.shaped)

Variables of ``--vary`` (:data:`VARY`): ``shapes`` (the mapped faces, fixed before the solves: they follow from the
target), ``patterns`` (a pattern per face or per face group, ``--per``, found by the closed search of
:mod:`fabpat.design.closed`), ``angles`` and ``thickness`` (a printed angle per sleeve, a thickness per plate:
``[sleeve] angles`` and ``[plates] thicknesses`` of the spec).
"""

from __future__ import annotations

import copy
import math
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SpecError

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.design.base import DesignBase
    from fabpat.design.target import ClosedTarget

#: the design variables ``--vary`` may list
VARY = ("shapes", "patterns", "angles", "thickness")
#: ``--vary`` by default: a closed target's metric needs its shapes; an open tiling's (a cap, a tube) stiffness and
#: joints; a strip's patterns (its search keeps the sleeves' angle: asking for angles only adds a note saying so)
DEFAULT_VARY_CLOSED = ("shapes", "patterns")
DEFAULT_VARY_OPEN = ("patterns", "angles")
DEFAULT_VARY_STRIP = ("patterns",)
#: ``--per``: a pattern per face (the default; refined from the best group design) or per face group (polygon and
#: latitude band)
PER = ("face", "group")
#: the mapped mesh's file name, beside design.toml
MESH_NAME = "mapped.obj"


def read_vary(vary: object, closed: bool) -> tuple[str, ...]:
    """The ``--vary`` words (a comma-separated string or a sequence of words; None: the default for a closed or an
    open target) in :data:`VARY` order. Raises SpecError naming an unknown word and the valid ones."""
    if vary is None:
        return DEFAULT_VARY_CLOSED if closed else DEFAULT_VARY_OPEN
    if isinstance(vary, str):
        words: list[object] = [w.strip() for w in vary.split(",")]
    elif isinstance(vary, list | tuple):
        words = list(vary)
    else:
        raise SpecError(f"vary must be a comma-separated string or a list of words ({', '.join(VARY)}), "
                        f"got {type(vary).__name__}")
    for w in words:
        if not isinstance(w, str) or w not in VARY:
            raise SpecError(f"--vary: unknown word {w!r}: give a comma-separated list of {', '.join(VARY)}")
    if not words:
        raise SpecError(f"--vary is empty: give a comma-separated list of {', '.join(VARY)}")
    return tuple(v for v in VARY if v in words)


def read_per(per: object) -> str:
    """``--per``: "face" or "group"; SpecError otherwise."""
    if per not in PER:
        raise SpecError(f"--per must be one of {', '.join(PER)}, got {per!r}")
    return str(per)


@dataclass(frozen=True, eq=False)
class MappedTiling:
    """The base tiling mapped onto the target: ``V`` (n, 3) mm, ``faces``, the OBJ bytes written beside design.toml,
    ``face_irregularity`` (largest relative edge deviation and largest angle deviation from the regular polygon
    of the face's mean edge, degrees, over the faces), ``planarity`` (largest distance of a corner from its face's
    best-fit plane, as a fraction of the tiling's size), ``distance_rms`` (the corners' rms distance from the target,
    a fraction of the size) and the relaxation's ``seconds``."""

    V: NDArray[np.float64]
    faces: tuple[tuple[int, ...], ...]
    obj: bytes
    face_irregularity: dict[str, float]
    planarity: float
    distance_rms: float
    seconds: float
    #: the temporary folder the design's spec reads the mesh from while it runs ("" before); removed after it
    folder: str = ""


def map_base(tgt: ClosedTarget, base: DesignBase) -> MappedTiling:
    """The base spec's skeleton tiling mapped onto ``tgt`` and relaxed (:func:`fabpat.design.remesh.relax`).
    Raises SolverError (the relaxation did not converge: what it reached) or SpecError (a face of the relaxed
    tiling too far from regular for a shaped plate: the face and its deviation)."""
    from fabpat.assembly.place.placement import build_tiling
    from fabpat.design.remesh import map_tiling, relax, write_obj
    from fabpat.design.remesh_target import place_target
    from fabpat.geometry.shaped import MAX_IRREGULARITY

    skel = build_tiling(base.spec)
    V0 = np.asarray(skel.V, dtype=np.float64) * float(base.spec.tiling.edge)
    faces = tuple(tuple(int(i) for i in loop) for loop in skel.faces)
    surface, _ = place_target(V0, faces, tgt)
    r = relax(map_tiling(V0, faces, tgt), faces, surface)
    m = r.measures
    edge, angle = float(np.max(m.edge_deviation)), float(np.max(m.angle_deviation))
    worst = int(np.argmax(np.maximum(m.edge_deviation / MAX_IRREGULARITY[0],
                                     m.angle_deviation / MAX_IRREGULARITY[1])))
    if edge > MAX_IRREGULARITY[0] or angle > MAX_IRREGULARITY[1]:
        label = skel.labels[worst]
        e_w, a_w = 100 * float(m.edge_deviation[worst]), math.degrees(float(m.angle_deviation[worst]))
        raise SpecError(f"{tgt.source}: the base tiling mapped onto the target has face {label} "
                        f"{e_w:.1f} % / {a_w:.1f}° from regular, over the shaped plates' limit of "
                        f"{100 * MAX_IRREGULARITY[0]:g} % / {math.degrees(MAX_IRREGULARITY[1]):g}°: flat faces of "
                        "this base cannot follow the target's curvature there (docs/design.md, Reachability)")
    return MappedTiling(r.V, faces, write_obj(r.V, faces),
                        {"edge": edge, "angle_deg": math.degrees(angle)},
                        float(np.max(m.planarity)) / m.size, float(m.distance_rms), float(r.seconds))


def mapped_base(tgt: ClosedTarget, base: DesignBase) -> tuple[DesignBase, MappedTiling]:
    """The design base whose tiling is ``base``'s mapped onto ``tgt`` with shaped plates (module doc): its spec reads
    the mapped mesh from a temporary folder kept for the design's life; ``data`` names it :data:`MESH_NAME`, the
    file written beside design.toml."""
    from fabpat.assembly.spec.load import parse_spec

    mapped = map_base(tgt, base)
    folder = Path(tempfile.mkdtemp(prefix="fabpat-mapped-"))
    (folder / MESH_NAME).write_bytes(mapped.obj)
    tiling = {"kind": "mesh", "file": MESH_NAME, "edge": float(base.spec.tiling.edge), "plates": "shaped"}
    data = copy.deepcopy(base.data)
    data["tiling"] = tiling
    # the base's own way of choosing (its "spec" baseline: one key per polygon reads the same on a mesh), else a
    # placeholder, as load_base puts: the design names every plate's pattern
    pats = data.get("patterns") if base.way is not None else None
    spec = parse_spec(dict(data, patterns=pats or {"pattern": "0x0488"}), str(folder / "design.toml"))
    return replace(base, spec=spec, data=data), replace(mapped, folder=str(folder))
