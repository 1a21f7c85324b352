"""``simulate_assembly``: an assembly spec as one shell model, whichever its kind (the Python front door
of ``fabpat simulate-assembly``).

* ``honeycomb-strip``: the end pins are pushed together (:mod:`fabpat.assembly.simulate`).
* ``panel``: the same experiment on the fused panel, one shell with no sleeves
  (:func:`fabpat.assembly.panel.panel_setup`).
* ``truncated-icosahedron``: the sleeves turn from the polyhedron's dihedral angles to the spec's
  sleeve angle and bend the plates into a sphere (:mod:`fabpat.assembly.closure`).

Both report the fields of :meth:`AssemblySimulation.fields`; the read-outs a kind does not have are
``None`` (``peak``, ``half_ratio`` of a closed assembly; ``radius``, ``sphericity_*`` of a strip, and of
a closed or bent shape no sphere describes: a flat field, a cube, a tube, :func:`fabpat.assembly.closure.shape_sphere`).
Surface strain and mid-surface curvature are computed for both.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.model import AssemblyModel
from fabpat.errors import SpecError
from fabpat.mesh import ASSEMBLY_MAX_ELEMENTS

Arr = NDArray[np.float64]

#: default report steps per kind (the closure is smooth and nearly linear; the strip buckles)
DEFAULT_STEPS = {"honeycomb-strip": 10, "truncated-icosahedron": 4, "mesh": 4, "goldberg": 4, "hex-tube": 4,
                 "hex-cap": 4, "panel": 10}
#: colour fields of :meth:`AssemblySimulation.to_png` on a closed assembly
PNG_FIELDS = ("energy", "mean_curvature", "gaussian_curvature", "strain")


@dataclass(frozen=True, eq=False)
class AssemblySimulation:
    """The solved assembly: ``kind``, the ``model``, the solver's run (a StripRun or ClosureRun),
    ``curvature`` the point fields of :func:`fabpat.shell.curvature.curvature_fields` of the deformed
    mid-surface (``mean_curvature`` 1/mm, ``gaussian_curvature`` 1/mm², ``curvature_fitted``; signed
    positive where a plate bends away from the closed assembly's centre, i.e. convex outwards) and
    per-element ``element_strain`` (peak surface strain, :func:`fabpat.shell.strain.surface_strains`)."""

    kind: str
    name: str
    model: AssemblyModel
    run: Any
    seconds: float
    element_strain: Arr
    curvature: dict[str, Arr]
    strain_limit: float
    h: float

    @property
    def closed(self) -> bool:
        """True for an assembly closed by its sleeves (the sphere), False for a strip or a panel."""
        from fabpat.assembly.spec import STRIP_KINDS

        return self.kind not in STRIP_KINDS

    def plate_peak_strain(self) -> dict[str, float]:
        """{plate label: largest principal surface strain of its elements}."""
        m = self.model
        e = self.element_strain
        return {p.label: float(e[m.element_offsets[i]:m.element_offsets[i + 1]].max()) for i, p in enumerate(m.plates)}

    def over_limit(self) -> list[str]:
        """Plates whose peak strain exceeds ``strain_limit``."""
        return [k for k, v in self.plate_peak_strain().items() if v > self.strain_limit]

    def fields(self) -> dict[str, Any]:
        """The ``simulate-assembly`` output (lengths mm, energies and moments N·mm, forces N)."""
        r, m = self.run, self.model
        res = r.result
        peak = self.plate_peak_strain()
        worst = max(peak, key=lambda k: peak[k])
        # a closed assembly has no deflection profile; a strip that never left its plane has a flat one
        flat = self.closed or not abs(r.max_deflection) > 1e-9 * r.setup.length
        row: dict[str, Any] = {
            "converged": True, "plates": len(m.plates), "sleeves": len(m.sleeves), "nodes": m.n_nodes,
            "dofs": res.dofs, "iterations": res.iterations, "seconds": self.seconds, "energy": r.energy,
            "plate_energies": r.plate_energies, "sleeve_moments": r.sleeve_moments, "reaction": r.reaction,
            "max_deflection": r.max_deflection, "peak": None if flat else r.peak,
            "half_ratio": None if flat else r.half_ratio, "path": r.path,
            "radius": r.radius if self.closed else None,
            "sphericity_rms": r.sphericity_rms if self.closed else None,
            "sphericity_max": r.sphericity_max if self.closed else None,
            "mesh_deviation_rms": r.mesh_deviation_rms if self.closed else None,
            "mesh_deviation_max": r.mesh_deviation_max if self.closed else None,
            **self._cylinder(),
            "peak_strain": peak[worst], "peak_strain_plate": worst, "strain_limit": self.strain_limit,
            "over_limit": self.over_limit(), "factorizations": res.factorizations, "h": self.h,
            "warm_start": res.warm,
        }
        return row

    def _cylinder(self) -> dict[str, float | None]:
        """A tube's least-squares cylinder (:func:`fabpat.assembly.closure.fit_cylinder`, started on the
        tube's axis x): ``cylinder_radius`` (mm) and ``cylindricity_rms`` (RMS radial deviation over the
        radius); None for other kinds."""
        if self.kind != "hex-tube":
            return {"cylinder_radius": None, "cylindricity_rms": None}
        from fabpat.assembly.closure import fit_cylinder

        P = self.deformed()
        c, d, radius = fit_cylinder(P, np.array([1.0, 0.0, 0.0]))
        w = P - c
        dev = (np.linalg.norm(w - np.outer(w @ d, d), axis=1) - radius) / radius
        return {"cylinder_radius": radius, "cylindricity_rms": float(np.sqrt(np.mean(dev * dev)))}

    def __repr__(self) -> str:
        """One line: kind, name, size, energy, peak strain and the shape's read-out (radius and
        sphericity of a closed assembly, the arch's peak and height of a strip); no arrays."""
        f = self.fields()
        shape = ((f"radius={f['radius']:.2f} mm, sphericity_rms={100 * f['sphericity_rms']:.3f} %"
                  if f["radius"] is not None else f"radius=None ({self.run.sphere_note})") if self.closed else
                 f"peak={'None' if f['peak'] is None else format(f['peak'], '.3f')}, "
                 f"max_deflection={f['max_deflection']:.2f} mm")
        return (f"AssemblySimulation(kind={self.kind!r}, name={self.name!r}, plates={f['plates']}, "
                f"sleeves={f['sleeves']}, nodes={f['nodes']}, h={self.h:g} mm, energy={f['energy']:.4g} N·mm, "
                f"peak_strain={f['peak_strain']:.4g} on {f['peak_strain_plate']}, {shape})")

    def _repr_html_(self) -> str:
        """A notebook's table of the scalar :meth:`fields` (lists and per-plate dicts left out)."""
        from html import escape

        rows = "".join(f"<tr><th style='text-align:left'>{escape(k)}</th><td>{escape(_cell(v))}</td></tr>"
                       for k, v in self.fields().items() if not isinstance(v, dict | list))
        return (f"<table><caption>{escape(self.kind)} {escape(self.name)}: simulate-assembly</caption>"
                f"{rows}</table>")

    def _repr_png_(self) -> bytes:
        """A notebook's picture: :meth:`to_png` (a closed assembly's bent shape, a strip's profile)."""
        import tempfile
        from pathlib import Path

        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "simulation.png"
            self.to_png(path)
            return path.read_bytes()

    def deformed(self) -> Arr:
        """(n, 3) deformed positions of the plate nodes (mm)."""
        n = len(self.model.X)
        return self.model.X + self.run.result.final.displacement[:n]

    def to_vtu(self, path: str | os.PathLike[str]) -> None:
        """Every plate, deformed, for ParaView: the shell fields of :func:`fabpat.exchange.vtu.write_vtu`
        plus point fields ``plate``, ``mean_curvature``, ``gaussian_curvature`` and the cell field
        ``surface_strain``."""
        from fabpat.exchange.vtu import write_vtu

        _check_path(path)
        m = self.model
        write_vtu(path, m.X, m.F, self.shell_result(),
                  point_data={"plate": m.plate_of_node[: len(m.X)].astype(np.int64), **self.curvature},
                  cell_data={"surface_strain": self.element_strain})

    def to_png(self, path: str | os.PathLike[str], field: str = "energy") -> None:
        """A strip: its deflection profile and reaction curve; a closed assembly: the bent shape
        coloured by ``field`` (one of :data:`PNG_FIELDS`). Raises SpecError for another field, ExportError
        for a path that is not one."""
        _check_path(path)
        if not self.closed:
            from fabpat.assembly.simulate import write_profiles_png

            write_profiles_png(path, [(self.name, self.run)])
            return
        if field not in PNG_FIELDS:
            raise SpecError(f"png field must be one of {', '.join(PNG_FIELDS)}, got {field!r}")
        from fabpat.assembly.preview import render_prediction_png

        render_prediction_png(self, path, field)

    def shell_result(self) -> Any:
        """The final state of the plates as a :class:`fabpat.shell.ShellResult`."""
        from fabpat.shell.results import ShellResult

        n = len(self.model.X)
        r = self.run.result
        fin = r.final
        return ShellResult(fin.displacement[:n], fin.rotation[:n], self.run.energy, r.element_energy,
                           fin.reactions[:n], float("nan"), r.iterations, r.increments, r.cuts, True, True,
                           dict(r.seconds))


#: peak memory of an assembly solve per plate element (bytes) and its fixed part: measured with
#: ``/usr/bin/time -v`` on 1 × 3 and 1 × 12 strips of 0x0488 (0.8 mm plates) through simulate_assembly at
#: h = 3 mm: 1 476 and 5 904 elements, 198 MB and 466 MB maximum resident set, i.e. 60.5 kB per element
#: over 109 MB (the graded 2 × 15 strip, ≈ 19 000 elements, peaked near 1.2 GB, on the same line);
#: rounded up. A scenario solve needs about 40 kB per element (fabpat.mesh.DEFAULT_MAX_ELEMENTS).
ASSEMBLY_BYTES_PER_ELEMENT = 62_000
ASSEMBLY_BASE_BYTES = 120_000_000


def available_memory() -> int | None:
    """Bytes of memory this process may still use: the kernel's MemAvailable (``/proc/meminfo``), or the
    room left under a cgroup v2 memory limit if smaller (a container's); None where neither is known."""
    from pathlib import Path

    found: list[int] = []
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit != "max":
            found.append(int(limit) - int(Path("/sys/fs/cgroup/memory.current").read_text().strip()))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def check_assembly_memory(elements: float, what: str) -> float:
    """Refuse (GeometryError, one line naming the estimate and the memory available) a solve of ``elements``
    plate elements whose estimated peak memory, :data:`ASSEMBLY_BASE_BYTES` + :data:`ASSEMBLY_BYTES_PER_ELEMENT`
    × elements, exceeds :func:`available_memory`; returns the estimate (bytes). ``what`` starts the message."""
    from fabpat.errors import GeometryError

    need = ASSEMBLY_BASE_BYTES + ASSEMBLY_BYTES_PER_ELEMENT * float(elements)
    room = available_memory()
    if room is not None and need > room:
        raise GeometryError(f"{what}: the solve would need about {need / 1e9:.1f} GB of memory ({elements:.0f} "
                            f"elements × {ASSEMBLY_BYTES_PER_ELEMENT / 1e3:g} kB), more than the {room / 1e9:.1f} GB "
                            "this machine has available: use a coarser h or a smaller assembly")
    return need


#: what ``spec`` may be: an AssemblySpec or the path of its TOML file
_SPEC_TYPES = (str, os.PathLike)


def _cell(value: object) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _check_path(path: object) -> None:
    """ExportError unless ``path`` names a file that can be written: a non-empty path that is not a
    folder, nor an existing file that is not regular (a device or FIFO)."""
    import stat
    from pathlib import Path

    from fabpat.errors import ExportError

    if isinstance(path, bytes) or not isinstance(path, _SPEC_TYPES) or not str(path):
        raise ExportError(f"an output path must be a non-empty file name, got {path!r}")
    p = Path(path)
    if p.is_dir():
        raise ExportError(f"cannot write {p}: it is a folder; give a file name")
    try:
        mode = p.stat().st_mode
    except OSError:
        return  # not there yet (or unreadable: the writer names the cause)
    if not stat.S_ISREG(mode):
        raise ExportError(f"cannot write {p}: it exists and is not a regular file (a device or FIFO)")


def check_assembly_size(spec: Any, patterns: list[str], h: float, max_elements: int,
                        option: str = "raise it with --max-elements", h_name: str = "h") -> float:
    """Refuse (GeometryError, naming --max-elements and an h that passes) an assembly whose plate meshes
    at edge h (mm) would hold more than ``max_elements`` triangles in total, or whose solve would need
    more memory than the machine has (:func:`check_assembly_memory`), before any meshing; the estimate is
    :func:`fabpat.mesh.estimate_elements` of each distinct filleted outline × its count.
    ``option`` (how to raise the limit) and ``h_name`` (how the caller spells h) word the message."""
    import math

    from fabpat.assembly.placement import build_tiling
    from fabpat.errors import GeometryError
    from fabpat.fillet import fillet_pattern
    from fabpat.library import get_pattern
    from fabpat.mesh import estimate_elements
    from fabpat.validate import check, check_size, round_up

    max_elements = int(check("max_elements", max_elements, "max_elements", error=GeometryError))
    from fabpat.variation import Variation

    count: dict[tuple[str, int, float], int] = {}
    for f, (pid, face) in enumerate(zip(patterns, build_tiling(spec).faces, strict=True)):
        key = (pid, len(face), spec.patterns.bridge_weight_of(f) if spec.patterns else 1.0)
        count[key] = count.get(key, 0) + 1
    area = perimeter = 0.0
    for (pid, sides, w), k in count.items():
        o = fillet_pattern(get_pattern(pid, sides, None, spec.tiling.edge), spec.plates.weight, Variation(w)).outline
        area += k * o.area
        perimeter += k * o.perimeter
    n = estimate_elements(area, perimeter, h)
    c = math.sqrt(3.0) / 4.0
    suggest = (perimeter + math.sqrt(perimeter**2 + 4.0 * max_elements * area / c)) / (2.0 * max_elements)
    check_size(n, max_elements, f"{spec.source}: mesh elements of the whole assembly at {h_name} = {h:g} mm", option,
               f"use {h_name} ≥ {round_up(suggest):g} mm", error=GeometryError)
    check_assembly_memory(n, f"{spec.source}: the whole assembly at {h_name} = {h:g} mm")
    return n


def simulate_assembly(spec: Any, *, h: float = 3.0, steps: int | None = None, end_shortening: float | None = None,
                      imperfection: float | None = None, youngs_modulus: float | None = None,
                      poisson: float | None = None, progress: Callable[[float], None] | None = None,
                      max_elements: int = ASSEMBLY_MAX_ELEMENTS,
                      start: AssemblySimulation | None = None) -> AssemblySimulation:
    """Solve the assembly of ``spec`` (an AssemblySpec or a path to its TOML file).

    ``h`` target mesh edge (mm); ``steps`` report steps (default :data:`DEFAULT_STEPS` of the kind);
    ``end_shortening`` (default the spec's ``[load] end_shortening``, else 0.1) and ``imperfection`` (N, default
    :data:`fabpat.assembly.simulate.IMPERFECTION`) apply to strips only and are refused on a closed
    assembly; ``youngs_modulus`` (N/mm²) and ``poisson`` override the spec's ``[material]``;
    ``max_elements`` bounds the whole assembly's mesh (:func:`check_assembly_size`). A sphere with
    ``rule = "roundest"`` is closed with each candidate pair and the roundest is reported, as ``fabpat
    assemble`` builds it (:func:`fabpat.assembly.predict.choose_roundest`; the roundest of all if none
    is under the limit). ``start``: a converged simulation of the same tiling (e.g. with one pattern
    changed) to warm-start from (:func:`fabpat.assembly.model.warm_guess`; the solver tries the final
    state from there first and follows the path from the start if that fails: ``warm_start`` in
    :meth:`AssemblySimulation.fields`). ``progress(f)`` is told the fraction f done after every report step
    of the path (of the end shortening, of the sleeves' turn, or over all the candidate pairs of "roundest"). Raises
    SpecError (bad spec, argument or option for this kind), GeometryError (h too coarse for the
    interfaces, or a mesh too large), SolverError (path lost, naming the load or angle fraction reached).
    """
    from fabpat.assembly.choice import face_patterns
    from fabpat.assembly.placement import build_tiling
    from fabpat.assembly.spec import AssemblySpec, load_spec
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
    steps = DEFAULT_STEPS[kind] if steps is None else check("steps", steps, "steps", error=SpecError)
    for name, value in (("end_shortening", end_shortening), ("imperfection", imperfection)):
        if value is not None and closed:
            raise SpecError(f"{spec.source}: {name} applies to strips (end shortening and the buckle it "
                            f"selects); a closed assembly is bent by its sleeves: leave {name} out")
    if not closed and spec.tiling.strip and spec.tiling.columns < 2:  # the pinned first and last column are one
        raise SpecError(f"{spec.source}: simulate-assembly pushes a {kind}'s first and last columns together: "
                        f"tiling.columns = {spec.tiling.columns} has only one (give at least 2)")
    if not closed:
        from fabpat.assembly.simulate import kit_end_shortening

        end_shortening = kit_end_shortening(spec) if end_shortening is None else check("end_shortening", end_shortening,
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
        from fabpat.assembly.model import warm_guess

        fin, old = start.run.result.final, start.model
        return warm_guess(old.X, old.offsets, fin.displacement, fin.rotation, model.X, model.offsets)

    if closed and spec.patterns.rule == "roundest":
        # the pair the kit would build: each candidate closed, the roundest kept (under the strain limit if any is)
        from fabpat.assembly.choice import candidate_pairs
        from fabpat.assembly.placement import build_tiling
        from fabpat.assembly.predict import choose_roundest
        from fabpat.members import with_candidates

        pairs = candidate_pairs(spec)  # with bridge_weight = "rule" also the family members (names "ID bW")
        faces = [len(f) for f in build_tiling(spec).faces]
        check_assembly_size(*with_candidates(spec, [pairs[0][0] if n == 6 else pairs[0][1] for n in faces]), h,
                            max_elements)
        _, run, _, _ = choose_roundest(spec, pairs, faces, h, True, lambda _spec, _ids: None, progress)
        return _read_outs(kind, spec.name, run.setup.model, run, time.perf_counter() - t0, mat.strain_limit, h)
    from fabpat.assembly.choice import with_members

    spec = with_members(spec)  # bridge_weight = "rule": the members the kit would get
    patterns = face_patterns(spec)
    check_assembly_size(spec, patterns, h, max_elements)
    if not closed:
        from fabpat.assembly.simulate import IMPERFECTION, run_strip, strip_setup

        if spec.tiling.panel:  # the plates fused into one shell, no sleeves (fabpat.assembly.panel)
            from fabpat.assembly.panel import panel_setup

            setup = panel_setup(spec, patterns, h=h, E=E, nu=nu)
        else:
            setup = strip_setup(spec, patterns, h=h, E=E, nu=nu)
        run = run_strip(setup, float(end_shortening), steps=steps,  # type: ignore[arg-type]
                        imperfection=IMPERFECTION if imperfection is None else imperfection, progress=progress,
                        strain_limit=mat.strain_limit, start=guess(setup.model))
        model = setup.model
    else:
        from fabpat.assembly.closure import closure_setup, run_closure

        csetup = closure_setup(spec, patterns, h=h, E=E, nu=nu)
        run = run_closure(csetup, steps=steps, strain_limit=mat.strain_limit, progress=progress,
                          start=guess(csetup.model))
        model = csetup.model
    return _read_outs(kind, spec.name, model, run, time.perf_counter() - t0, mat.strain_limit, h)


def _read_outs(kind: str, name: str, model: AssemblyModel, run: Any, seconds: float, strain_limit: float,
               h: float) -> AssemblySimulation:
    from fabpat.shell.curvature import curvature_fields
    from fabpat.shell.rotations import expmap
    from fabpat.shell.strain import surface_strains

    n = len(model.X)
    fin = run.result.final
    x = model.X + fin.displacement[:n]
    eps = getattr(run, "element_strain", None)
    if eps is None:
        eps = surface_strains(model.X, model.F, model.material, x, expmap(fin.rotation[:n]))
    centre = getattr(run, "centre", None)
    if centre is None:  # a strip: its plates bend away from a point far below (the arch is convex upwards)
        centre = model.X.mean(axis=0) - np.array([0.0, 0.0, 1e6])
    curv = curvature_fields(x, model.F, model.plate_of_node[:n], center=centre)
    return AssemblySimulation(kind, name, model, run, seconds, np.asarray(eps), curv, strain_limit, h)
