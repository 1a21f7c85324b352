"""A flat net of a tiling: every face unfolded into the plane without overlaps, every edge labelled.

The net is the assembly map. Faces are the skeleton polygons (edge ``E`` mm) laid out along a spanning
tree of the face adjacency graph: a child face is hinged onto its parent across their shared edge
(dashed "fold" in the drawing). Edges not in the tree are "cuts": the two faces carrying the same
joint label are far apart in the net and meet in the assembly. Each face shows its plate label, and
each of its edges the label of the sleeve on that edge (``E07``), so plate labels, sleeve labels and
the labels engraved on the plates all say what joins what.

Spanning trees are tried breadth-first from every face (and with reversed neighbour order) until one
unfolds without overlaps; overlap is decided with exact convex-polygon distances.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from xml.sax.saxutils import escape

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.nesting import convex_distance
from fabpat.assembly.surface.tiling import Tiling
from fabpat.errors import GeometryError
from fabpat.patterns.lattice import polygon_vertices
from fabpat.validate import SAME_POINT


@dataclass(frozen=True, eq=False)
class Net:
    """``polygons[f]`` (n_f, 2) mm: face f's corners in the plane (corner i = skeleton vertex ``faces[f][i]``).

    ``parent[f]``: the face f is hinged to (−1 for the root); ``folds``: edges of the spanning tree.
    """

    tiling: Tiling
    polygons: tuple[NDArray[np.float64], ...]
    parent: tuple[int, ...]
    folds: frozenset[int]

    def min_gap(self) -> float:
        """Smallest distance (mm) between two faces that do not share a vertex in the net."""
        best = math.inf
        for a in range(len(self.polygons)):
            for b in range(a + 1, len(self.polygons)):
                if self._share_vertex(a, b):
                    continue
                best = min(best, convex_distance(self.polygons[a], self.polygons[b]))
        return best

    def _share_vertex(self, a: int, b: int) -> bool:
        P, Q = self.polygons[a], self.polygons[b]
        return bool((np.linalg.norm(P[:, None] - Q[None], axis=2) < 1e-6).any())

    def overlaps(self) -> list[tuple[int, int]]:
        """Pairs of faces whose interiors overlap (empty for a valid net)."""
        out = []
        for a in range(len(self.polygons)):
            for b in range(a + 1, len(self.polygons)):
                if convex_distance(self.polygons[a], self.polygons[b]) < -SAME_POINT:
                    out.append((a, b))
        return out


def _hinge(child: NDArray[np.float64], i: int, p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``child`` (k, 2) moved rigidly so that its corner i lands on p and corner i + 1 on q."""
    a, b = child[i], child[(i + 1) % len(child)]
    u, v = b - a, q - p
    ang = math.atan2(v[1], v[0]) - math.atan2(u[1], u[0])
    c, s = math.cos(ang), math.sin(ang)
    R = np.array([[c, -s], [s, c]])
    return (child - a) @ R.T + p


def _face_shapes(tiling: Tiling) -> list[NDArray[np.float64]]:
    """Each face's polygon (n_f, 2) mm: the regular n-gon of the tiling's edge, or on a tiling of shaped plates
    (:class:`~fabpat.assembly.surface.shaped.ShapedTiling`) the face's own."""
    from fabpat.assembly.surface.shaped import ShapedTiling

    if isinstance(tiling, ShapedTiling):
        return tiling.face_polygons()
    E = tiling.edge_length()
    shapes = {n: polygon_vertices(n, E) for n in set(tiling.sides.tolist())}
    return [shapes[len(loop)] for loop in tiling.faces]


def _unfold(tiling: Tiling, root: int, reverse: bool, shapes: list[NDArray[np.float64]]) -> Net:
    polys: dict[int, NDArray[np.float64]] = {root: shapes[root].copy()}
    parent = {root: -1}
    folds = set()
    queue = deque([root])
    while queue:
        f = queue.popleft()
        edges = list(enumerate(tiling.face_edges[f]))
        for i, k in reversed(edges) if reverse else edges:
            if k < 0:
                continue
            (fa, ia), (fb, ib) = tiling.edge_faces[k]
            g, j = (int(fb), int(ib)) if fa == f else (int(fa), int(ia))
            if g < 0 or g in polys:
                continue
            P = polys[f]
            n = len(P)
            # The shared edge runs v_i → v_{i+1} in f and v_{i+1} → v_i in g (both loops CCW from outside).
            polys[g] = _hinge(shapes[g], j, P[(i + 1) % n], P[i])
            parent[g] = f
            folds.add(int(k))
            queue.append(g)
    if len(polys) != len(tiling.faces):
        raise GeometryError("the tiling's faces are not connected: no net")
    return Net(tiling, tuple(polys[f] for f in range(len(tiling.faces))),
               tuple(parent[f] for f in range(len(tiling.faces))), frozenset(folds))


def unfold(tiling: Tiling) -> Net:
    """A non-overlapping net of ``tiling`` (the first breadth-first tree that works; see module doc).

    Raises :class:`GeometryError` if none of the trees tried unfolds without overlaps.
    """
    roots = sorted(range(len(tiling.faces)), key=lambda f: (-len(tiling.faces[f]), f))
    shapes = _face_shapes(tiling)
    for root in roots:
        for reverse in (False, True):
            net = _unfold(tiling, root, reverse, shapes)
            if not net.overlaps():
                return net
    raise GeometryError(f"no overlap-free net found for the {tiling.name}")


def net_svg(net: Net, plate_labels: list[str], edge_labels: list[tuple[str, ...]], title: str,
            colours: list[str] | None = None) -> str:
    """The net as a standalone SVG (mm): faces, fold (dashed) and cut (solid) edges, all labels.

    ``edge_labels[f][i]``: the text written inside face f along its polygon edge i ("PIN" is drawn
    in red, "" is skipped); ``colours[f]``: fill of face f.
    """
    pts = np.vstack(net.polygons)
    lo, hi = pts.min(axis=0) - 10.0, pts.max(axis=0) + 10.0
    size = hi - lo
    E = net.tiling.edge_length()
    fs_face, fs_edge = 0.22 * E, 0.11 * E
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{size[0]:.2f}mm" height="{size[1] + 12:.2f}mm" '
        f'viewBox="{lo[0]:.3f} {-hi[1] - 12:.3f} {size[0]:.3f} {size[1] + 12:.3f}">',
        f"<title>{escape(title)}</title>",
        f'<text x="{lo[0] + 2:.2f}" y="{-hi[1] - 4:.2f}" font-family="sans-serif" font-size="{0.16 * E:.2f}">'
        f"{escape(title)} — fold edges dashed, cut edges solid; equal edge labels join (one sleeve each)</text>",
    ]
    for f, P in enumerate(net.polygons):
        fill = colours[f] if colours else "#eeeeee"
        d = " ".join(f"{x:.3f},{-y:.3f}" for x, y in P)
        out.append(f'<polygon class="face" id="face-{escape(plate_labels[f])}" points="{d}" fill="{fill}" '
                   'stroke="none"/>')
    drawn: set[int] = set()
    for f, P in enumerate(net.polygons):
        n = len(P)
        c = P.mean(axis=0)
        for i in range(n):
            a, b = P[i], P[(i + 1) % n]
            k = net.tiling.face_edges[f][i]
            if k not in drawn or k < 0:
                dash = ' stroke-dasharray="2,1.5"' if k in net.folds else ""
                out.append(f'<line class="edge" x1="{a[0]:.3f}" y1="{-a[1]:.3f}" x2="{b[0]:.3f}" y2="{-b[1]:.3f}" '
                           f'stroke="black" stroke-width="0.4"{dash}/>')
                drawn.add(k)
            text = edge_labels[f][i]
            if not text:
                continue
            m = 0.5 * (a + b)
            pos = m + 0.16 * (c - m)  # inside the face, near the edge: the label belongs to this plate's side
            ang = round(-math.degrees(math.atan2(b[1] - a[1], b[0] - a[0])), 2)
            # in (−180°, 180°], no −0: a horizontal edge's round-off sign (atan2 of ±1e-15) would make the
            # same net read −180.00 on one machine and 180.00 on another
            ang = (ang + 360.0 if ang <= -180.0 else ang) + 0.0
            colour = "#d00000" if text == "PIN" else "#000080"
            out.append(f'<text class="edge-label" x="{pos[0]:.3f}" y="{-pos[1]:.3f}" font-family="sans-serif" '
                       f'font-size="{fs_edge:.2f}" fill="{colour}" text-anchor="middle" dominant-baseline="central" '
                       f'transform="rotate({ang:.2f} {pos[0]:.3f} {-pos[1]:.3f})">{escape(text)}</text>')
        out.append(f'<text class="plate-label" x="{c[0]:.3f}" y="{-c[1]:.3f}" font-family="sans-serif" '
                   f'font-size="{fs_face:.2f}" font-weight="bold" text-anchor="middle" dominant-baseline="central">'
                   f"{escape(plate_labels[f])}</text>")
    out.append("</svg>\n")
    return "\n".join(out)
