"""``simulate_assembly``: an assembly spec as one shell model, whichever its kind (the Python front door
of ``fabpat simulate-assembly``).

* ``honeycomb-strip``: the end pins are pushed together (:mod:`fabpat.assembly.solve.strip`).
* ``panel``: the same experiment on the fused panel, one shell with no sleeves
  (:func:`fabpat.assembly.solve.panel.panel_setup`).
* ``truncated-icosahedron``: the sleeves turn from the polyhedron's dihedral angles to the spec's
  sleeve angle and bend the plates into a sphere (:mod:`fabpat.assembly.solve.closure`).

Both report the fields of :meth:`AssemblySimulation.fields`; the read-outs a kind does not have are
``None`` (``peak``, ``half_ratio`` of a closed assembly; ``radius``, ``sphericity_*`` of a strip, and of
a closed or bent shape no sphere describes: a flat field, a cube, a tube,
:func:`fabpat.assembly.solve.closure.shape_sphere`).
Surface strain and mid-surface curvature are computed for both.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.solve.model import AssemblyModel
from fabpat.assembly.solve.result import PNG_FIELDS, AssemblySimulation, read_outs
from fabpat.assembly.solve.sizing import check_assembly_size
from fabpat.errors import SpecError
from fabpat.simulation.mesh import ASSEMBLY_MAX_ELEMENTS

if TYPE_CHECKING:
    from fabpat.assembly.solve.closure import ClosureRun
    from fabpat.assembly.solve.strip import StripRun
    from fabpat.assembly.spec.types import AssemblySpec

Arr = NDArray[np.float64]
#: the front door's return type and its picture fields, importable from here as from their room
__all__ = ["DEFAULT_STEPS", "PNG_FIELDS", "AssemblySimulation", "simulate_assembly"]

#: default report steps per kind (the closure is smooth and nearly linear; the strip buckles)
DEFAULT_STEPS = {"honeycomb-strip": 10, "truncated-icosahedron": 4, "mesh": 4, "goldberg": 4, "hex-tube": 4,
                 "hex-cap": 4, "panel": 10}
#: what ``spec`` may be: an AssemblySpec or the path of its TOML file
_SPEC_TYPES = (str, os.PathLike)


def simulate_assembly(spec: AssemblySpec | str | os.PathLike[str], *, h: float = 3.0, steps: int | None = None,
                      end_shortening: float | None = None,
                      imperfection: float | None = None, youngs_modulus: float | None = None,
                      poisson: float | None = None, progress: Callable[[float], None] | None = None,
                      max_elements: int = ASSEMBLY_MAX_ELEMENTS,
                      start: AssemblySimulation | None = None) -> AssemblySimulation:
    """Solve the assembly of ``spec`` (an AssemblySpec or a path to its TOML file).

    ``h`` target mesh edge (mm); ``steps`` report steps (default :data:`DEFAULT_STEPS` of the kind);
    ``end_shortening`` (default the spec's ``[load] end_shortening``, else 0.1) and ``imperfection`` (N, default
    :data:`fabpat.assembly.solve.strip.IMPERFECTION`) apply to strips only and are refused on a closed
    assembly; ``youngs_modulus`` (N/mm²) and ``poisson`` override the spec's ``[material]``;
    ``max_elements`` bounds the whole assembly's mesh (:func:`fabpat.assembly.solve.sizing.check_assembly_size`).
    A sphere with ``rule = "roundest"`` is closed with each candidate pair and the roundest is reported, as ``fabpat
    assemble`` builds it (:func:`fabpat.assembly.solve.predict.choose_roundest`; the roundest of all if none
    is under the limit). ``start``: a converged simulation of the same tiling (e.g. with one pattern
    changed) to warm-start from (:func:`fabpat.assembly.solve.model.warm_guess`; the solver tries the final
    state from there first and follows the path from the start if that fails: ``warm_start`` in
    :meth:`AssemblySimulation.fields`). ``progress(f)`` is told the fraction f done after every report step
    of the path (of the end shortening, of the sleeves' turn, or over all the candidate pairs of "roundest"). Raises
    SpecError (bad spec, argument or option for this kind), GeometryError (h too coarse for the
    interfaces, or a mesh too large), SolverError (path lost, naming the load or angle fraction reached).

    Long because it dispatches every kind of assembly (strip, panel, closed tilings) to its model and load
    with one shared set of checks; each branch calls the module named for that kind.
    """
    from fabpat.assembly.choose.choice import face_patterns
    from fabpat.assembly.place.placement import build_tiling
    from fabpat.assembly.spec.load import AssemblySpec, load_spec
    from fabpat.validate import check

    if not isinstance(spec, AssemblySpec):
        if not isinstance(spec, _SPEC_TYPES) or isinstance(spec, bytes):
            raise SpecError(f"spec must be an AssemblySpec or the path of a TOML spec file, got {type(spec).__name__}")
        spec = load_spec(spec)
    check("h", h, "h", error=SpecError)
    if progress is not None and not callable(progress):
        raise SpecError(f"progress must be a callable or None, got {type(progress).__name__}")
    kind = spec.tiling.kind
    closed = not spec.tiling.pushed  # a strip or a panel is pushed together; the rest is closed by its sleeves
    n_steps = DEFAULT_STEPS[kind] if steps is None else int(check("steps", steps, "steps", error=SpecError))
    for name, value in (("end_shortening", end_shortening), ("imperfection", imperfection)):
        if value is not None and closed:
            raise SpecError(f"{spec.source}: {name} applies to strips (end shortening and the buckle it "
                            f"selects); a closed assembly is bent by its sleeves: leave {name} out")
    if not closed and spec.tiling.strip and spec.tiling.columns < 2:  # the pinned first and last column are one
        raise SpecError(f"{spec.source}: simulate-assembly pushes a {kind}'s first and last columns together: "
                        f"tiling.columns = {spec.tiling.columns} has only one (give at least 2)")
    if not closed:
        from fabpat.assembly.solve.strip import kit_end_shortening

        shortening = kit_end_shortening(spec) if end_shortening is None else check("end_shortening", end_shortening,
                                                                                 "end_shortening", error=SpecError)
        if imperfection is not None:
            imperfection = check("imperfection_force", imperfection, "imperfection", error=SpecError)
    mat = spec.material
    E = mat.youngs_modulus if youngs_modulus is None else check("youngs_modulus", youngs_modulus, "youngs_modulus",
                                                                 error=SpecError)
    nu = mat.poisson if poisson is None else check("poisson", poisson, "poisson", error=SpecError)
    if (E, nu) != (mat.youngs_modulus, mat.poisson):
        spec = dataclasses.replace(spec, material=dataclasses.replace(mat, youngs_modulus=E, poisson=nu))
    t0 = time.perf_counter()
    plates = len(build_tiling(spec).faces)
    if start is not None and (not isinstance(start, AssemblySimulation) or start.kind != kind
                              or len(start.model.plates) != plates):
        got = (f"a {start.kind} of {len(start.model.plates)} plates" if isinstance(start, AssemblySimulation)
               else type(start).__name__)
        raise SpecError(f"{spec.source}: start must be an AssemblySimulation of the same tiling ({kind}, "
                        f"{plates} plates), got {got}")

    def guess(model: AssemblyModel) -> tuple[Arr, Arr] | None:
        if start is None:
            return None
        from fabpat.assembly.solve.model import warm_guess

        fin, old = start.run.result.final, start.model
        return warm_guess(old.X, old.offsets, fin.displacement, fin.rotation, model.X, model.offsets)

    if closed and spec.patterns.rule == "roundest":
        # the pair the kit would build: each candidate closed, the roundest kept (under the strain limit if any is)
        from fabpat.assembly.choose.choice import candidate_pairs
        from fabpat.assembly.choose.members import with_candidates
        from fabpat.assembly.place.placement import build_tiling
        from fabpat.assembly.solve.predict import choose_roundest

        pairs = candidate_pairs(spec)  # with bridge_weight = "rule" also the family members (names "ID bW")
        faces = [len(f) for f in build_tiling(spec).faces]
        check_assembly_size(*with_candidates(spec, [pairs[0][0] if n == 6 else pairs[0][1] for n in faces]), h,
                            max_elements)
        _, best, _, _ = choose_roundest(spec, pairs, faces, h, True, lambda _spec, _ids: None, progress)
        return read_outs(kind, spec.name, best.setup.model, best, time.perf_counter() - t0, mat.strain_limit, h)
    from fabpat.assembly.choose.choice import with_members

    spec = with_members(spec)  # bridge_weight = "rule": the members the kit would get
    patterns = face_patterns(spec)
    check_assembly_size(spec, patterns, h, max_elements)
    if not closed:
        from fabpat.assembly.solve.strip import IMPERFECTION, run_strip, strip_setup

        if spec.tiling.panel:  # the plates fused into one shell, no sleeves (fabpat.assembly.place.panel)
            from fabpat.assembly.solve.panel import panel_setup

            setup = panel_setup(spec, patterns, h=h, E=E, nu=nu)
        else:
            setup = strip_setup(spec, patterns, h=h, E=E, nu=nu)
        run: StripRun | ClosureRun = run_strip(setup, shortening, steps=n_steps,
                        imperfection=IMPERFECTION if imperfection is None else imperfection, progress=progress,
                        strain_limit=mat.strain_limit, start=guess(setup.model))
        model = setup.model
    else:
        from fabpat.assembly.solve.closure import closure_setup, run_closure

        csetup = closure_setup(spec, patterns, h=h, E=E, nu=nu)
        run = run_closure(csetup, steps=n_steps, strain_limit=mat.strain_limit, progress=progress,
                          start=guess(csetup.model))
        model = csetup.model
    return read_outs(kind, spec.name, model, run, time.perf_counter() - t0, mat.strain_limit, h)
