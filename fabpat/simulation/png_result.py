"""PNG of a deformed pattern coloured by element strain energy (the paper's Fig. 12 look)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fabpat.errors import ExportError
from fabpat.shell.results import ShellResult

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure


def draw(V: np.ndarray, F: np.ndarray, result: ShellResult, *, caption: str = "", elev: float = 28.0,
         azim: float = -60.0) -> Figure:
    """A matplotlib figure of the deformed mesh in a 3D view, faces coloured by strain-energy density
    (N·mm/mm², log scale so that the narrow, highly loaded necks and the quiet parts are both visible).

    V: (n, 2) or (n, 3) reference coordinates (mm); F: (m, 3) triangles; ``caption`` is the figure's
    title, as given (the caller states the energy it reports:
    :meth:`fabpat.simulation.scenarios.ScenarioResult.caption`).
    The caller closes the figure (``matplotlib.pyplot.close``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    V = np.asarray(V, dtype=np.float64)
    X = np.column_stack([V, np.zeros(len(V))]) if V.shape[1] == 2 else V
    x = X + result.displacement
    P = x[F]
    P0 = X[F]
    area = 0.5 * np.linalg.norm(np.cross(P0[:, 1] - P0[:, 0], P0[:, 2] - P0[:, 0]), axis=1)
    dens = result.element_energy.sum(axis=1) / area
    pos = dens[dens > 0]
    lo = float(np.percentile(pos, 2)) if pos.size else 1e-12
    norm = LogNorm(vmin=max(lo, 1e-12), vmax=max(float(dens.max()), lo * 10))
    cmap = plt.get_cmap("turbo")
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(P, facecolors=cmap(norm(np.clip(dens, norm.vmin, None))), linewidths=0))
    lo3, hi3 = x.min(axis=0), x.max(axis=0)
    c, r = 0.5 * (lo3 + hi3), 0.5 * float(np.max(hi3 - lo3))
    ax.set(xlim=(c[0] - r, c[0] + r), ylim=(c[1] - r, c[1] + r), zlim=(c[2] - r, c[2] + r),
           xlabel="x (mm)", ylabel="y (mm)", zlabel="z (mm)")
    ax.view_init(elev=elev, azim=azim)
    # mplot3d draws the z label outside the axes box, where a tight bounding box does not look: a
    # slightly zoomed-out box keeps every label on the canvas
    ax.set_box_aspect(None, zoom=0.85)
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=ax, shrink=0.6, pad=0.1, label="strain energy density (N·mm/mm²)")
    ax.set_title(caption)
    return fig


def _save(fig: Figure, target: str | Path | io.BytesIO, dpi: int) -> None:
    import matplotlib.pyplot as plt

    try:
        fig.savefig(target, dpi=dpi, bbox_inches="tight", format="png")
    except OSError as exc:  # atomic_outputs names the target, not this temporary file, and a full disk
        from fabpat.io import writer_failed

        raise writer_failed(Path(str(target)), "cannot write the picture", exc) from exc
    except (ValueError, RuntimeError) as exc:  # matplotlib's refusals become one line at this boundary
        raise ExportError(f"cannot write the picture: {exc}") from exc
    finally:
        plt.close(fig)


def write_png(path: str | Path, V: np.ndarray, F: np.ndarray, result: ShellResult, *, title: str = "",
              dpi: int = 150, elev: float = 28.0, azim: float = -60.0) -> Path:
    """Render :func:`draw`'s figure (captioned ``title``) to ``path``.

    Always PNG, whatever the suffix (the CLI checks it is .png); ExportError if matplotlib cannot write."""
    path = Path(path)
    _save(draw(V, F, result, caption=title, elev=elev, azim=azim), path, dpi)
    return path


def png_bytes(V: np.ndarray, F: np.ndarray, result: ShellResult, *, caption: str = "", dpi: int = 100) -> bytes:
    """:func:`draw`'s figure as PNG bytes (a notebook's ``_repr_png_``)."""
    buf = io.BytesIO()
    _save(draw(V, F, result, caption=caption), buf, dpi)
    return buf.getvalue()
