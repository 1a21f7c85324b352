"""VTU (ParaView) output of a shell result: reference mesh with displacement, rotation and energies.

ParaView's convention: the points are the reference (undeformed) positions and ``displacement`` a point
vector, so the filter *Warp By Vector* (vectors ``displacement``, scale factor 1) shows the deformed
shape. Storing deformed points as well would have the filter move them twice.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fabpat.errors import ExportError
from fabpat.geometry.polygons import triangle_areas
from fabpat.shell.results import ShellResult

#: fields write_vtu always writes; extra fields may not reuse these names
POINT_FIELDS = ("displacement", "rotation", "reference")
CELL_FIELDS = ("strain_energy", "membrane_energy", "bending_energy", "shear_energy", "energy_density")


def _extra(fields: dict[str, np.ndarray] | None, count: int, what: str, builtin: tuple[str, ...]) -> dict:
    """Checked copies of extra (count,) or (count, k) fields: finite numbers, names not builtin."""
    out = {}
    for name, value in (fields or {}).items():
        a = np.asarray(value)
        if name in builtin:
            raise ExportError(f"{what} field {name!r} clashes with a field the VTU always has ({', '.join(builtin)})")
        if a.ndim not in (1, 2) or a.shape[0] != count or not (np.issubdtype(a.dtype, np.number)
                                                                or a.dtype == np.bool_):
            raise ExportError(f"{what} field {name!r} must be a numeric ({count},) or ({count}, k) array, "
                              f"got {a.dtype} {a.shape}")
        if not np.all(np.isfinite(a)):  # ParaView reads NaN, but a colour map over it is meaningless
            raise ExportError(f"{what} field {name!r} has non-finite values")
        out[name] = a.astype(np.uint8) if a.dtype == np.bool_ else a
    return out


def write_vtu(path: str | Path, V: np.ndarray, F: np.ndarray, result: ShellResult,
              point_data: dict[str, np.ndarray] | None = None,
              cell_data: dict[str, np.ndarray] | None = None) -> Path:
    """Write the shell and its result to ``path`` (.vtu), for ParaView's *Warp By Vector*.

    V: (n, 2) or (n, 3) reference coordinates (mm); F: (m, 3) triangles. Points are the *reference*
    (undeformed) positions, z = 0 for a flat V; point data ``displacement`` (mm: points + displacement
    are the deformed positions, which Warp By Vector with scale 1 draws), ``rotation`` (rad, rotation
    vector), ``reference`` (the same reference coordinates, kept for older readers); cell data
    ``strain_energy``, ``membrane_energy``, ``bending_energy``, ``shear_energy`` (N·mm per element) and
    ``energy_density`` (N·mm/mm²). ``point_data`` adds further (n,) or (n, k) point fields (e.g.
    ``plate``, the plate index of each node of an assembly; ``mean_curvature``, ``gaussian_curvature``
    of :func:`fabpat.shell.curvature.curvature_fields`), ``cell_data`` (m,) or (m, k) cell fields (e.g.
    ``peak_strain`` of :func:`fabpat.shell.strain.surface_strains`). Raises ExportError if an extra
    field has the wrong length, is not numeric, has a NaN/inf or reuses a built-in name (bool fields
    are written as 0/1).
    """
    import meshio

    V = np.asarray(V, dtype=np.float64)
    X = np.column_stack([V, np.zeros(len(V))]) if V.shape[1] == 2 else V
    F = np.asarray(F, dtype=np.int64)
    extra_points = _extra(point_data, len(X), "point", POINT_FIELDS)
    extra_cells = {k: [v] for k, v in _extra(cell_data, len(F), "cell", CELL_FIELDS).items()}
    area = triangle_areas(X, F)
    ee = result.element_energy
    mesh = meshio.Mesh(
        X, [("triangle", F)],
        point_data={"displacement": result.displacement, "rotation": result.rotation, "reference": X,
                    **extra_points},
        cell_data={"strain_energy": [ee.sum(axis=1)], "membrane_energy": [ee[:, 0]],
                   "bending_energy": [ee[:, 1]], "shear_energy": [ee[:, 2]],
                   "energy_density": [ee.sum(axis=1) / area], **extra_cells},
    )
    path = Path(path)
    try:
        meshio.write(path, mesh, file_format="vtu")
    except OSError as exc:  # atomic_outputs names the target, not this temporary file, and a full disk
        from fabpat.io import writer_failed

        raise writer_failed(path, "cannot write the VTU file", exc) from exc
    return path
