"""Assembly picture (PNG): the placed parts drawn with a painter's algorithm in matplotlib.

mplot3d sorts polygons per collection and is slow past ~10 k polygons; projecting the triangles
ourselves (orthographic camera, back faces culled, far-to-near order, Lambert shading) draws a sphere's
~60 k visible triangles as one 2D ``PolyCollection`` in a couple of seconds, with correct occlusion
for these convex-ish assemblies. Plate labels are written on the plates that face the camera; the
pinned interfaces of a strip are marked with red triangles.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.parts import PICTURE_TOLERANCE, PartLibrary, apply
from fabpat.assembly.show.export import colours

if TYPE_CHECKING:
    from matplotlib.axes import Axes

LIGHT = np.array([0.4, -0.5, 0.77])  # towards the light, camera-ish side (unit-normalised below)


def _camera(view: NDArray[np.float64]) -> NDArray[np.float64]:
    """(3, 3) rows: right, up, towards the viewer (``view`` points from the object to the camera)."""
    w = view / np.linalg.norm(view)
    up = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.95 else np.array([0.0, 1.0, 0.0])
    r = np.cross(up, w)
    r /= np.linalg.norm(r)
    return np.stack([r, np.cross(w, r), w])


def plain_text(text: str) -> str:
    """``text`` as matplotlib draws it literally: every ``$`` escaped, so a user's name such as
    ``$\\frac{ $`` is not parsed as mathtext (an unbalanced formula would stop the picture)."""
    return text.replace("$", r"\$")


def _hex(c: str) -> NDArray[np.float64]:
    return np.array([int(c[i:i + 2], 16) / 255 for i in (1, 3, 5)])


Item = tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], bool]


def project(items: list[Item], C: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Painter's projection of triangle meshes: ``items`` are (V (n, 3) world mm, F (m, 3), face colours
    (m, 3) RGB in [0, 1], cull) — ``cull`` drops the faces turned away from the camera (closed, outward
    solids); without it both sides show (a mid-surface). Returns the 2D triangles (k, 3, 2) and their
    Lambert-shaded colours (k, 3), far first."""
    light = LIGHT / np.linalg.norm(LIGHT)
    tris, shades, depths = [], [], []
    for V, F, base, cull in items:
        W = V @ C.T  # camera coordinates: x right, y up, z towards the viewer
        A, B, D = W[F[:, 0]], W[F[:, 1]], W[F[:, 2]]
        N = np.cross(B - A, D - A)
        norm = np.linalg.norm(N, axis=1)
        keep = (N[:, 2] > 1e-12 * norm) & (norm > 0) if cull else norm > 0
        N = N[keep] / norm[keep, None]
        lam = np.abs(N @ (C @ light))
        shades.append(np.clip(base[keep] * (0.35 + 0.65 * lam[:, None]), 0, 1))
        P = np.stack([A[keep], B[keep], D[keep]], axis=1)
        tris.append(P[:, :, :2])
        depths.append(P[:, :, 2].mean(axis=1))
    order = np.argsort(np.concatenate(depths), kind="stable")  # far first
    return np.concatenate(tris)[order], np.concatenate(shades)[order]


def draw(ax: Axes, P2: NDArray[np.float64], S: NDArray[np.float64]) -> None:
    """Put projected triangles (:func:`project`) on ``ax`` with equal axes and a small margin."""
    from matplotlib.collections import PolyCollection

    lo, hi = P2.reshape(-1, 2).min(axis=0), P2.reshape(-1, 2).max(axis=0)
    ax.add_collection(PolyCollection(P2, facecolors=S, edgecolors=S, linewidths=0.15))
    pad = 0.04 * float((hi - lo).max())
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.axis("off")


def render_png(lib: PartLibrary, path: str | os.PathLike[str], title: str, dpi: int = 110) -> None:
    """Draw the assembled object to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    asm = lib.assembly
    flat = np.ptp(asm.skeleton.V[:, 2]) < 1e-6
    view = np.array([0.25, -1.0, 1.3]) if flat else np.array([1.0, -1.4, 0.9])
    C = _camera(view)
    cols = colours(lib)
    items = []
    for _, key, T in lib.placed():
        V, F = lib.mesh(key, PICTURE_TOLERANCE)
        items.append((apply(T, V), F, np.tile(_hex(cols[key]), (len(F), 1)), True))
    P2, S = project(items, C)
    lo, hi = P2.reshape(-1, 2).min(axis=0), P2.reshape(-1, 2).max(axis=0)
    aspect = float((hi[1] - lo[1]) / (hi[0] - lo[0]))
    fig, ax = plt.subplots(figsize=(9, min(9.0, max(3.5, 9 * aspect + 1.0))))  # fit long strips, no blank bands
    draw(ax, P2, S)
    for p in asm.plates:
        n_world = p.transform[:3, 2]
        if (C @ n_world)[2] > 0.3 and len(asm.plates) <= 60:
            c = apply(p.transform, np.array([[0.0, 0.0, p.thickness]]))[0] @ C.T
            ax.text(c[0], c[1], p.label, ha="center", va="center", fontsize=7, color="black", zorder=5)
    for f, i in asm.pins:
        plate = asm.plates[f]
        seg = lib.filleted[plate.type].interface_segments[i]
        m = apply(plate.transform, np.array([[*seg.mean(axis=0), 0.5 * plate.thickness]]))[0] @ C.T
        ax.plot(m[0], m[1], marker="^", color="#d00000", markersize=8, zorder=6)
    counts = ", ".join(f"{v} × {k}" for k, v in asm.counts().items())
    ax.set_title(f"{plain_text(title)}\n{counts}" + ("\n▲ pinned interfaces" if asm.pins else ""), fontsize=9)
    fig.tight_layout()
    fig.savefig(os.fspath(path), dpi=dpi, format="png")
    plt.close(fig)


def picture_size(path: str | os.PathLike[str]) -> tuple[int, int]:
    """(width, height) in pixels of a PNG, read back with matplotlib."""
    import matplotlib.image as mpimg

    img = mpimg.imread(os.fspath(path))
    return int(img.shape[1]), int(img.shape[0])
