"""VTU (ParaView) output of a shell result: deformed mesh with displacement, rotation and energies."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fabpat.shell.results import ShellResult


def write_vtu(path: str | Path, V: np.ndarray, F: np.ndarray, result: ShellResult,
              point_data: dict[str, np.ndarray] | None = None) -> Path:
    """Write the deformed shell to ``path`` (.vtu).

    V: (n, 2) or (n, 3) reference coordinates (mm); F: (m, 3) triangles. Points are the *deformed*
    positions; point data ``displacement`` (mm), ``rotation`` (rad, rotation vector), ``reference``
    (initial coordinates); cell data ``strain_energy``, ``membrane_energy``, ``bending_energy``,
    ``shear_energy`` (N·mm per element) and ``energy_density`` (N·mm/mm²). ``point_data`` adds
    further (n,) or (n, k) point fields (e.g. ``plate``, the plate index of each node of an assembly).
    """
    import meshio

    V = np.asarray(V, dtype=np.float64)
    X = np.column_stack([V, np.zeros(len(V))]) if V.shape[1] == 2 else V
    F = np.asarray(F, dtype=np.int64)
    P = X[F]
    area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    ee = result.element_energy
    mesh = meshio.Mesh(
        X + result.displacement, [("triangle", F)],
        point_data={"displacement": result.displacement, "rotation": result.rotation, "reference": X,
                    **(point_data or {})},
        cell_data={"strain_energy": [ee.sum(axis=1)], "membrane_energy": [ee[:, 0]],
                   "bending_energy": [ee[:, 1]], "shear_energy": [ee[:, 2]],
                   "energy_density": [ee.sum(axis=1) / area]},
    )
    path = Path(path)
    try:
        meshio.write(path, mesh, file_format="vtu")
    except OSError as exc:  # atomic_outputs names the target, not this temporary file, and a full disk
        from fabpat.io import writer_failed

        raise writer_failed(path, "cannot write the VTU file", exc) from exc
    return path
