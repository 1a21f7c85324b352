"""Small structured meshes shared by the shell tests (not a test module)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def rect_mesh(L: float, b: float, nx: int, ny: int, skew: float = 0.0) -> tuple[NDArray, NDArray]:
    """(V (n, 2), F (m, 3)) of an L × b rectangle, nx × ny cells split in two triangles each;
    ``skew`` moves interior nodes by a deterministic pattern (fraction of the cell size)."""
    xs, ys = np.linspace(0, L, nx + 1), np.linspace(0, b, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    V = np.c_[X.ravel(), Y.ravel()]
    if skew:
        inner = (V[:, 0] > 0) & (V[:, 0] < L) & (V[:, 1] > 0) & (V[:, 1] < b)
        V[inner, 0] += skew * L / nx * np.sin(7.3 * V[inner, 1] + 3.1 * V[inner, 0])
        V[inner, 1] += skew * b / ny * np.cos(5.1 * V[inner, 0] - 2.3 * V[inner, 1])
    F = []
    for i in range(nx):
        for j in range(ny):
            a, c = i * (ny + 1) + j, (i + 1) * (ny + 1) + j
            if (i + j) % 2:
                F += [[a, c, c + 1], [a, c + 1, a + 1]]
            else:
                F += [[a, c, a + 1], [c, c + 1, a + 1]]
    return V, np.array(F, dtype=np.int64)


def edge_weights(V: NDArray, nodes: NDArray) -> NDArray:
    """Tributary-length shares (sum 1) of nodes along a straight edge, any order."""
    s = np.argsort(V[nodes, 0] + V[nodes, 1])
    seg = np.linalg.norm(np.diff(V[nodes[s]], axis=0), axis=1)
    w = np.zeros(nodes.size)
    w[s[:-1]] += seg / 2
    w[s[1:]] += seg / 2
    return w / w.sum()
