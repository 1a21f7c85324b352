"""A one-piece panel as the strip's end-shortening experiment: its fused outline (:mod:`fabpat.assembly.place.panel`)
meshed as ONE shell plate and pinned at its ends' free interfaces."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from fabpat.assembly.place.panel import build_panel
from fabpat.errors import GeometryError

if TYPE_CHECKING:
    from fabpat.assembly.solve.strip import StripSetup
    from fabpat.assembly.spec.types import AssemblySpec


def panel_setup(spec: AssemblySpec, face_patterns: Sequence[str], *, h: float = 3.0, E: float | None = None,
                nu: float | None = None) -> StripSetup:
    """The fused panel as the strip's end-shortening experiment (:class:`fabpat.assembly.solve.strip.StripSetup`):
    ONE shell plate, the fused outline meshed at target edge ``h`` (mm) by Triangle (curves flattened at
    :data:`fabpat.simulation.mesh.FLATTEN_TOL_PER_H` × h, chords moved towards their arcs,
    :func:`fabpat.simulation.mesh.flatten_outline`),
    its mid-surface on z = 0, no sleeves; pinned at the free interfaces of its first and last columns as a strip is
    (:func:`fabpat.assembly.place.placement.end_interfaces`), a mesh panel at those of its ends along the longer side
    of its bounding box (:meth:`Panel.ends`; turned by 90° onto x when that is y: the experiment pushes along x).
    ``E`` (N/mm²) and ``nu`` default to the spec's ``[material]``
    (:func:`~fabpat.assembly.solve.model.plate_material`). Raises GeometryError if h is too coarse for the interfaces
    (:func:`fabpat.assembly.solve.model.check_h`) or a pin gets fewer than 2 nodes, SpecError if a mesh panel has no
    two ends to push.
    """
    from fabpat.assembly.solve.model import ModelPlate, assembly_model, check_h, plate_material
    from fabpat.assembly.solve.strip import StripSetup
    from fabpat.assembly.surface.panel_mesh import push_axis
    from fabpat.errors import SpecError
    from fabpat.simulation.mesh import ASSEMBLY_MAX_ELEMENTS, FLATTEN_TOL_PER_H, flatten_outline, mesh_polygons

    check_h(h, spec.tiling.edge, spec.plates.weight)
    panel = build_panel(spec, face_patterns)
    try:
        pins = panel.pins()
    except SpecError as e:  # a mesh panel without two ends
        raise SpecError(f"{spec.source}: {e}") from None
    loops = flatten_outline(panel.outline, FLATTEN_TOL_PER_H * h)
    mesh = mesh_polygons(loops, h, interfaces=[(a, b) for _, _, a, b in pins], max_elements=ASSEMBLY_MAX_ELEMENTS)
    for (f, i, _, _), nodes in zip(pins, mesh.interfaces, strict=True):
        if nodes.size < 2:
            raise GeometryError(f"pinned interface {i} of tile {panel.labels[f]} has {nodes.size} mesh nodes "
                                "(need ≥ 2): lower h")
    # the experiment pushes along x (fabpat.assembly.solve.strip): a mesh panel longer in y is turned by 90° onto it
    axis = 0 if panel.tiling.grid is not None else push_axis(panel.tiling)
    turn = np.eye(4)
    if axis == 1:
        turn[:2, :2] = [[0.0, 1.0], [-1.0, 0.0]]  # y → x, and the fixed (low y) end to low x
    model = assembly_model([ModelPlate("panel", mesh, turn)], [], plate_material(spec, E, nu))
    fixed = len(panel.ends()[0])
    left, right = mesh.interfaces[:fixed], mesh.interfaces[fixed:]
    xs = model.X[:, 0]
    return StripSetup(model, np.unique(np.concatenate(left)), np.unique(np.concatenate(right)), float(np.ptp(xs)),
                      float(xs.min()))
