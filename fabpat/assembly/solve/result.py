"""The solved assembly and its read-outs: :class:`AssemblySimulation` (what
:func:`fabpat.assembly.solve.simulation.simulate_assembly` returns) and :func:`record`, the one list of fields
that ``fabpat simulate-assembly --json``, the notebook table and a kit's ``prediction.json`` print.

Units: mm, N, N·mm; strains dimensionless. Sources: the read-outs of docs/assembly-solver.md.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.solve.closure import ClosureRun, shape_cylinder
from fabpat.assembly.solve.model import AssemblyModel
from fabpat.assembly.spec.types import STRIP_KINDS
from fabpat.errors import SpecError

if TYPE_CHECKING:
    from fabpat.assembly.solve.strip import StripRun
    from fabpat.shell.results import ShellResult

Arr = NDArray[np.float64]
#: what an output path may be
_PATH_TYPES = (str, os.PathLike)

#: colour fields of :meth:`AssemblySimulation.to_png` on a closed assembly
PNG_FIELDS = ("energy", "mean_curvature", "gaussian_curvature", "strain")


class LazyFields(Mapping[str, "Arr"]):
    """Point fields computed on first use by ``make`` (a read-only mapping of name → (n,) array): the curvature
    fit is wanted by a VTU or a picture, not by the numbers of a solve (0.09 s of the shipped sphere's 1.8,
    0.26 s of GP(3, 0)'s)."""

    def __init__(self, make: Callable[[], dict[str, Arr]]) -> None:
        self._make: Callable[[], dict[str, Arr]] | None = make
        self._fields: dict[str, Arr] = {}

    def _all(self) -> dict[str, Arr]:
        if self._make is not None:
            self._fields, self._make = self._make(), None
        return self._fields

    def __getitem__(self, key: str) -> Arr:
        return self._all()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._all())

    def __len__(self) -> int:
        return len(self._all())

    def __reduce__(self) -> tuple[type[dict[str, Arr]], tuple[dict[str, Arr]]]:
        return (dict, (self._all(),))  # sent to another process as the plain fields


@dataclass(frozen=True, eq=False)
class AssemblySimulation:
    """The solved assembly: ``kind``, the ``model``, the solver's run (a StripRun or ClosureRun),
    ``curvature`` the point fields of :func:`fabpat.shell.curvature.curvature_fields` of the deformed
    mid-surface (``mean_curvature`` 1/mm, ``gaussian_curvature`` 1/mm², ``curvature_fitted``; signed
    positive where a plate bends away from the closed assembly's centre, i.e. convex outwards; a mapping
    computed on first use, :class:`LazyFields`) and
    per-element ``element_strain`` (peak surface strain, :func:`fabpat.shell.strain.surface_strains`)."""

    kind: str
    name: str
    model: AssemblyModel
    run: StripRun | ClosureRun
    seconds: float
    element_strain: Arr
    curvature: Mapping[str, Arr]
    strain_limit: float
    h: float

    @property
    def closed(self) -> bool:
        """True for an assembly closed by its sleeves (the sphere), False for a strip or a panel."""
        return self.kind not in STRIP_KINDS

    def plate_peak_strain(self) -> dict[str, float]:
        """{plate label: largest principal surface strain of its elements}."""
        return plate_peak_strain(self.model, self.element_strain)

    def over_limit(self) -> list[str]:
        """Plates whose peak strain exceeds ``strain_limit``."""
        return [k for k, v in self.plate_peak_strain().items() if v > self.strain_limit]

    def fields(self) -> dict[str, Any]:
        """The ``simulate-assembly`` output (lengths mm, energies and moments N·mm, forces N): :func:`record`."""
        return record(self.kind, self.model, self.run, self.seconds, self.element_strain, self.strain_limit, self.h)

    def __repr__(self) -> str:
        """One line: kind, name, size, energy, peak strain and the shape's read-out (radius and
        sphericity of a closed assembly, a tube's cylinder, the arch's peak and height of a strip); no arrays."""
        f = self.fields()
        if f.get("cylinder_radius") is not None:  # a tube: its cylinder, no sphere
            round_ = (f"cylinder_radius={f['cylinder_radius']:.2f} mm, "
                      f"cylindricity_rms={100 * f['cylindricity_rms']:.3f} %")
        else:
            round_ = (f"radius={f['radius']:.2f} mm, sphericity_rms={100 * f['sphericity_rms']:.3f} %"
                      if f["radius"] is not None else f"radius=None ({getattr(self.run, 'sphere_note', '')})")
        shape = (round_ if self.closed else
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
        """Every plate, deformed, for ParaView: the shell fields of :func:`fabpat.simulation.vtu.write_vtu`
        plus point fields ``plate``, ``mean_curvature``, ``gaussian_curvature`` and the cell field
        ``surface_strain``."""
        from fabpat.simulation.vtu import write_vtu

        _check_path(path)
        m = self.model
        write_vtu(path, m.X, m.F, self.shell_result(),
                  point_data={"plate": m.plate_of_node[: len(m.X)].astype(np.int64), **self.curvature},
                  cell_data={"surface_strain": self.element_strain})

    def to_png(self, path: str | os.PathLike[str], field: str | None = None) -> None:
        """A strip: its deflection profile and reaction curve; a closed assembly: the bent shape
        coloured by ``field`` (one of :data:`PNG_FIELDS`, default ``"energy"``). Raises SpecError for
        another field, or any field for a strip (whose picture is its profile: a field there was quietly
        ignored, ``"bogus"`` too), ExportError for a path that is not one or does not end in ``.png`` (PNG bytes
        under a ``.jpg`` name open as a broken image, as the CLI's ``--png`` refuses)."""
        _check_path(path)
        from fabpat.io import check_suffix

        check_suffix(path, [".png"], "a PNG picture's file name")
        if field is not None and (not isinstance(field, str) or field not in PNG_FIELDS):
            raise SpecError(f"png field must be one of {', '.join(PNG_FIELDS)}, got {field!r}")
        if not self.closed:
            if field is not None:
                raise SpecError(f"png field {field!r} colours a closed assembly's bent shape; a strip's PNG is its "
                                "deflection profile: leave the field out")
            from fabpat.assembly.solve.strip import StripRun, write_profiles_png

            assert isinstance(self.run, StripRun)  # a pushed kind is solved by run_strip
            write_profiles_png(path, [(self.name, self.run)])
            return
        from fabpat.assembly.solve.preview import render_prediction_png

        render_prediction_png(self, path, field or "energy")

    def shell_result(self) -> ShellResult:
        """The final state of the plates as a :class:`fabpat.shell.ShellResult`."""
        from fabpat.shell.results import ShellResult

        n = len(self.model.X)
        r = self.run.result
        fin = r.final
        return ShellResult(fin.displacement[:n], fin.rotation[:n], self.run.energy, r.element_energy,
                           fin.reactions[:n], float("nan"), r.iterations, r.increments, r.cuts, True, True,
                           dict(r.seconds))


def plate_peak_strain(model: AssemblyModel, element_strain: Arr) -> dict[str, float]:
    """{plate label: largest principal surface strain of its elements} (``element_strain`` (m,))."""
    m, e = model, element_strain
    return m.per_plate(e, np.max)


def record(kind: str, model: AssemblyModel, run: StripRun | ClosureRun, seconds: float, element_strain: Arr,
           strain_limit: float, h: float) -> dict[str, Any]:
    """The ``simulate-assembly`` fields (``--json``, :meth:`AssemblySimulation.fields`, a kit's
    ``prediction.json``) of a solver ``run`` (StripRun or ClosureRun) of ``model`` of tiling ``kind``, solved
    in ``seconds`` at mesh edge ``h`` (mm) with per-element peak surface strain ``element_strain`` (m,):
    counts, solver effort, energies N·mm, sleeve moments N·mm, reaction N, lengths mm, strains against
    ``strain_limit``; a read-out the kind does not have is None (``peak`` and ``half_ratio`` of a closed
    assembly, the sphere's of a strip)."""
    closed = kind not in STRIP_KINDS
    r, m = run, model
    cylinder = _cylinder(kind, model, run)
    sphere = closed and cylinder["cylinder_radius"] is None  # a tube's read-out is its cylinder, never a sphere
    res = r.result
    peak = plate_peak_strain(model, element_strain)
    worst = max(peak, key=lambda k: peak[k])
    row: dict[str, object] = {
        "converged": True, "plates": len(m.plates), "sleeves": len(m.sleeves), "nodes": m.n_nodes,
        "dofs": res.dofs, "iterations": res.iterations, "seconds": seconds, "energy": r.energy,
        "plate_energies": r.plate_energies, "sleeve_moments": r.sleeve_moments, "reaction": r.reaction,
        "max_deflection": r.max_deflection, **_arch(r, closed), "path": r.path, **_closure(r, closed, sphere),
        **cylinder,
        "peak_strain": peak[worst], "peak_strain_plate": worst, "strain_limit": strain_limit,
        "over_limit": [k for k, v in peak.items() if v > strain_limit], "factorizations": res.factorizations,
        "h": h, "warm_start": res.warm,
    }
    return row


def _arch(run: StripRun | ClosureRun, closed: bool) -> dict[str, float | None]:
    """A strip's arch: ``peak`` and ``half_ratio`` of its deflection profile; None for a closed assembly, which has
    no profile, and for a strip that never left its plane (a flat profile)."""
    if isinstance(run, ClosureRun) or closed:
        return {"peak": None, "half_ratio": None}
    flat = not abs(run.max_deflection) > 1e-9 * run.setup.length
    return {"peak": None if flat else run.peak, "half_ratio": None if flat else run.half_ratio}


def _closure(run: StripRun | ClosureRun, closed: bool, sphere: bool) -> dict[str, float | None]:
    """A closure's sphere (``radius`` mm, ``sphericity_rms``, ``sphericity_max``: None unless ``sphere``) and how far
    its plates end from the mesh (``mesh_deviation_rms``/``_max`` mm); None for a strip."""
    if not isinstance(run, ClosureRun) or not closed:
        return {"radius": None, "sphericity_rms": None, "sphericity_max": None, "mesh_deviation_rms": None,
                "mesh_deviation_max": None}
    return {"radius": run.radius if sphere else None,
            "sphericity_rms": run.sphericity_rms if sphere else None,
            "sphericity_max": run.sphericity_max if sphere else None,
            "mesh_deviation_rms": run.mesh_deviation_rms, "mesh_deviation_max": run.mesh_deviation_max}


def _cylinder(kind: str, model: AssemblyModel, run: StripRun | ClosureRun) -> dict[str, float | None]:
    """A tube's least-squares cylinder: ``cylinder_radius`` (mm) and ``cylindricity_rms`` (RMS radial
    deviation over the radius), the run's own (:func:`fabpat.assembly.solve.closure.shape_cylinder`) or, for a run
    of a tube made without its ``ClosureSetup.tube``, fitted here; None for other kinds."""
    if kind != "hex-tube":
        return {"cylinder_radius": None, "cylindricity_rms": None}
    if isinstance(run, ClosureRun) and run.cylinder_radius is not None:
        return {"cylinder_radius": run.cylinder_radius, "cylindricity_rms": run.cylindricity_rms}
    radius, rms = shape_cylinder(model.X + run.result.final.displacement[: len(model.X)])
    return {"cylinder_radius": radius, "cylindricity_rms": rms}


def _cell(value: object) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _check_path(path: object) -> None:
    """ExportError unless ``path`` names a file that can be written: a non-empty path that is not a
    folder, nor an existing file that is not regular (a device or FIFO)."""
    import stat
    from pathlib import Path

    from fabpat.errors import ExportError

    if isinstance(path, bytes) or not isinstance(path, _PATH_TYPES) or not str(path):
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


def read_outs(kind: str, name: str, model: AssemblyModel, run: StripRun | ClosureRun, seconds: float,
              strain_limit: float, h: float) -> AssemblySimulation:
    """The :class:`AssemblySimulation` of a solver ``run`` of ``model``: per-element peak surface strain (the
    run's, else :meth:`~fabpat.assembly.solve.model.AssemblyModel.surface_strains`) and the deformed
    mid-surface's curvature fields (fitted when first read)."""
    from fabpat.shell.curvature import curvature_fields
    from fabpat.shell.rotations import expmap

    n = len(model.X)
    fin = run.result.final
    x = model.X + fin.displacement[:n]
    eps = getattr(run, "element_strain", None)
    if eps is None:
        eps = model.surface_strains(x, expmap(fin.rotation[:n]))
    centre = getattr(run, "centre", None)
    if centre is None:  # a strip: its plates bend away from a point far below (the arch is convex upwards)
        centre = model.X.mean(axis=0) - np.array([0.0, 0.0, 1e6])
    curv = LazyFields(lambda: curvature_fields(x, model.F, model.plate_of_node[:n], center=centre))
    return AssemblySimulation(kind, name, model, run, seconds, np.asarray(eps), curv, strain_limit, h)


def prediction_record(run: StripRun | ClosureRun, seconds: float, h: float, kind: str) -> dict[str, Any]:
    """A kit's ``prediction.json`` fields: :func:`record` of a ClosureRun or StripRun solved in ``seconds``
    at mesh edge ``h`` (mm), with the run's own element strains and strain limit — exactly the fields of
    ``fabpat simulate-assembly --json`` on the same spec."""
    return record(kind, run.setup.model, run, round(seconds, 3), run.element_strain, run.strain_limit, h)
