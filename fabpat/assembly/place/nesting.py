"""Nesting plates on laser sheets (or print beds) without overlap.

Every plate lies inside its regular polygon (the interface segments touch the polygon edges, the rest
is inside), so the plates are nested as convex polygons: two plates whose polygons are ``spacing`` mm
apart cannot touch, whatever their pattern.

Method: bottom-left fill on a raster. Each sheet is a grid of nodes ``resolution`` mm apart; a placed
polygon *covers* every node within ``spacing/2 + resolution/√2`` of it. Two polygons whose covered
node sets are disjoint are at least ``spacing`` apart (any point of the overlap of their
``spacing/2``-neighbourhoods has a node within resolution/√2), so the raster is conservative, never
optimistic. The free positions of a new polygon (centre on a node) are the zeros of one FFT
correlation of the sheet's occupancy with the polygon's cover; the lowest (then leftmost) free
position over a few turns of the polygon wins. :func:`check_nesting` then verifies the result with
exact polygon distances.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.spec.sheet import DEFAULT_RESOLUTION
from fabpat.errors import GeometryError
from fabpat.geometry.polygons import signed_area
from fabpat.validate import check_size

#: Raster nodes of one sheet: each open sheet keeps a bool grid and the FFT correlation needs a few
#: complex64 arrays of its size (≈ 30 bytes per node), so 2e7 nodes stay below ≈ 1 GB. A 600 × 400 mm
#: laser sheet at 1 mm has 2.4e5.
MAX_RASTER_NODES = 20_000_000


@dataclass(frozen=True)
class Placement:
    """Item ``item`` on sheet ``sheet`` (0-based): turned by ``angle`` rad about its centre, moved to (x, y) mm."""

    item: int
    sheet: int
    x: float
    y: float
    angle: float

    def matrix(self) -> NDArray[np.float64]:
        """(3, 3) homogeneous 2D transform from the item's frame to the sheet."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        return np.array([[c, -s, self.x], [s, c, self.y], [0.0, 0.0, 1.0]])

    def apply(self, P: NDArray[np.float64]) -> NDArray[np.float64]:
        """(k, 2) points of the item frame → (k, 2) sheet coordinates (mm)."""
        M = self.matrix()
        return np.asarray(P) @ M[:2, :2].T + M[:2, 2]


@dataclass(frozen=True, eq=False)
class Nesting:
    """Placements of ``polygons`` (item frame, mm) on sheets of ``width`` × ``height`` mm."""

    width: float
    height: float
    margin: float
    spacing: float
    polygons: tuple[NDArray[np.float64], ...]
    placements: tuple[Placement, ...]

    @property
    def n_sheets(self) -> int:
        """Number of sheets used (0 when nothing is placed)."""
        return 1 + max((p.sheet for p in self.placements), default=-1)

    def placed(self, item: int) -> NDArray[np.float64]:
        """(k, 2) polygon of ``item`` on its sheet."""
        return self.placements[item].apply(self.polygons[item])

    def on_sheet(self, sheet: int) -> list[int]:
        """Item indices placed on sheet ``sheet`` (0-based), in placement order."""
        return [p.item for p in self.placements if p.sheet == sheet]

    def utilisation(self, sheet: int) -> float:
        """Fraction of the sheet's area covered by the polygons on it."""
        area = sum(abs(signed_area(self.polygons[i])) for i in self.on_sheet(sheet))
        return area / (self.width * self.height)


def _rotate(P: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    return P @ np.array([[c, s], [-s, c]])


def _cover(P: NDArray[np.float64], radius: float, h: float) -> tuple[NDArray[np.bool_], int, int]:
    """Boolean stencil of the nodes within ``radius`` of convex polygon ``P`` (centre node at (cy, cx)).

    Uses the largest signed half-plane distance, a lower bound of the true distance, so the stencil
    is a superset of the exact one (conservative).
    """
    lo = np.floor((P.min(axis=0) - radius) / h).astype(int)
    hi = np.ceil((P.max(axis=0) + radius) / h).astype(int)
    a = int(max(-lo.min(), hi.max()))
    g = np.arange(-a, a + 1) * h
    X, Y = np.meshgrid(g, g)
    if signed_area(P) < 0:
        P = P[::-1]
    E = np.roll(P, -1, axis=0) - P
    N = np.stack([E[:, 1], -E[:, 0]], axis=1) / np.linalg.norm(E, axis=1)[:, None]  # outward normals
    d = (X[..., None] * N[:, 0] + Y[..., None] * N[:, 1] - np.einsum("ij,ij->i", N, P)).max(axis=-1)
    return d <= radius + 1e-9, a, a


def nest(polygons: list[NDArray[np.float64]], width: float, height: float, margin: float, spacing: float,
         resolution: float = DEFAULT_RESOLUTION, turns: int = 2) -> Nesting:
    """Place every convex polygon (item frame, centred near the origin) on as few sheets as it takes.

    ``turns`` orientations per n-gon, at angles 2πk / (n · turns): 0 and π/n for ``turns`` = 2 (a
    hexagon flat- or point-up, a pentagon point-up or point-down). Items go largest first; each takes
    the free position whose top edge is lowest (then leftmost) over the open sheets (first fit), or
    opens a new sheet. That greedy fill is run with each n-gon free to take any of its turns and with
    every combination of one turn per n-gon (point-up hexagons interlock in a honeycomb, which a free
    choice misses: it takes the flat-up hexagon's lower top), and the best layout is kept: fewest
    sheets, then the lowest top edge on the last sheet (the largest offcut left), then the lowest on
    all sheets. Raises :class:`GeometryError` if an item does not fit on an empty sheet.
    """
    h = float(resolution)
    check_size((width / h + 1) * (height / h + 1), MAX_RASTER_NODES,
               f"raster nodes of a {width:g} × {height:g} mm sheet at {h:g} mm", "a fixed limit",
               "use a smaller sheet.width × sheet.height", error=GeometryError)
    sizes = sorted({len(p) for p in polygons})
    policies: list[dict[int, tuple[int, ...]]] = [{n: tuple(range(turns)) for n in sizes}]
    if turns > 1 and len(sizes) <= 3:  # at most 2³ fixed combinations: the shipped kits have 1 or 2 polygons
        policies += [dict(zip(sizes, ((t,) for t in combo), strict=True))
                     for combo in itertools.product(range(turns), repeat=len(sizes))]
    best: tuple[tuple[int, float, float], Nesting] | None = None
    for allowed in policies:
        n = _fill(polygons, width, height, margin, spacing, h, turns, allowed)
        tops = [max(float(n.placed(i)[:, 1].max()) for i in n.on_sheet(s)) for s in range(n.n_sheets)]
        score = (n.n_sheets, tops[-1] if tops else 0.0, math.fsum(tops))
        if best is None or score < best[0]:
            best = (score, n)
    assert best is not None
    return best[1]


def _fill(polygons: list[NDArray[np.float64]], width: float, height: float, margin: float, spacing: float,
          h: float, turns: int, allowed: dict[int, tuple[int, ...]]) -> Nesting:
    """One greedy bottom-left fill of :func:`nest` on a raster of step h (mm); ``allowed[n]``: the turns
    an n-gon may take."""
    from scipy import fft as sfft  # scipy.fft: ≈ 2× numpy's FFT here; scipy.signal would cost seconds to import

    nx, ny = int(math.floor(width / h)) + 1, int(math.floor(height / h)) + 1
    radius = 0.5 * spacing + h / math.sqrt(2.0)
    sheets: list[NDArray[np.bool_]] = []
    full: set[tuple[int, int, int]] = set()  # (sheet, shape, turn) known not to fit: occupancy only grows
    shapes: dict[bytes, int] = {}
    placements: list[Placement | None] = [None] * len(polygons)
    order = sorted(range(len(polygons)), key=lambda i: (-abs(signed_area(polygons[i])), i))
    stencils: dict[tuple[int, int], tuple[NDArray[np.bool_], NDArray[np.float64], float]] = {}
    spectra: dict[tuple[int, int], NDArray[np.complex64]] = {}
    xs, ys = np.arange(nx) * h, np.arange(ny) * h
    for i in order:
        P = np.asarray(polygons[i], dtype=np.float64)
        shape = shapes.setdefault(np.round(P, 9).tobytes(), len(shapes))
        n = len(P)
        for turn in allowed[n]:
            if (shape, turn) not in stencils:
                angle = 2.0 * math.pi * turn / (n * turns)
                Q = _rotate(P, angle)
                stencils[shape, turn] = (_cover(Q, radius, h)[0], Q, angle)
        best: tuple[int, float, float, int, int, int] | None = None
        for sheet in range(len(sheets) + 1):
            if sheet == len(sheets):
                sheets.append(np.zeros((ny, nx), dtype=bool))
            occ = sheets[sheet]
            occ_hat = None
            for turn in allowed[n]:
                if (sheet, shape, turn) in full:
                    continue
                K, Q, _ = stencils[shape, turn]
                a = K.shape[0] // 2
                # linear (not circular) correlation: pad by the stencil, up to a fast FFT size
                fy, fx = sfft.next_fast_len(ny + 2 * a, True), sfft.next_fast_len(nx + 2 * a, True)
                if occ_hat is None or occ_hat.shape != (fy, fx // 2 + 1):  # stencils of other sizes pad otherwise
                    occ_hat = sfft.rfft2(occ.astype(np.float32), s=(fy, fx))
                if (shape, turn) not in spectra:
                    spectra[shape, turn] = sfft.rfft2(K[::-1, ::-1].astype(np.float32), s=(fy, fx))
                full_corr = sfft.irfft2(occ_hat * spectra[shape, turn], s=(fy, fx))
                hit = full_corr[a:a + ny, a:a + nx] > 0.5  # entry (r, c): stencil centred on node (r, c)
                # exact containment in the usable area: centre range from the polygon's extent
                okx = (xs + Q[:, 0].min() >= margin - 1e-9) & (xs + Q[:, 0].max() <= width - margin + 1e-9)
                oky = (ys + Q[:, 1].min() >= margin - 1e-9) & (ys + Q[:, 1].max() <= height - margin + 1e-9)
                free = ~hit & oky[:, None] & okx[None, :]
                rows = np.flatnonzero(free.any(axis=1))
                if len(rows) == 0:
                    full.add((sheet, shape, turn))
                    continue
                r = int(rows[0])
                c = int(np.flatnonzero(free[r])[0])
                cand = (sheet, r * h + float(Q[:, 1].max()), c * h + float(Q[:, 0].min()), r, c, turn)
                if best is None or cand[:3] < best[:3]:
                    best = cand
            if best is not None:
                break
            if not occ.any():
                break  # an empty sheet did not take it: no sheet will
        if best is None:
            raise GeometryError(f"item {i} does not fit on an empty {width:g} × {height:g} mm sheet")
        sheet, _, _, r, c, turn = best
        K, Q, angle = stencils[shape, turn]
        a = K.shape[0] // 2
        occ = sheets[sheet]
        r0, r1, c0, c1 = r - a, r + a + 1, c - a, c + a + 1
        kr0, kc0 = max(0, -r0), max(0, -c0)
        kr1, kc1 = K.shape[0] - max(0, r1 - ny), K.shape[1] - max(0, c1 - nx)
        occ[max(r0, 0):min(r1, ny), max(c0, 0):min(c1, nx)] |= K[kr0:kr1, kc0:kc1]
        placements[i] = Placement(i, sheet, c * h, r * h, angle)
    done = tuple(p for p in placements if p is not None)
    return Nesting(width, height, margin, spacing, tuple(np.asarray(p, dtype=np.float64) for p in polygons), done)


def convex_distance(P: NDArray[np.float64], Q: NDArray[np.float64]) -> float:
    """Euclidean distance (mm) between convex polygons; 0 if they touch, negative if they overlap.

    Negative values are the separating-axis overlap depth (how far apart they would have to move).
    """
    def gap(A: NDArray[np.float64], B: NDArray[np.float64]) -> float:
        E = np.roll(A, -1, axis=0) - A
        N = np.stack([E[:, 1], -E[:, 0]], axis=1)
        N /= np.linalg.norm(N, axis=1)[:, None]
        pa, pb = A @ N.T, B @ N.T
        return float(np.max(np.maximum(pb.min(axis=0) - pa.max(axis=0), pa.min(axis=0) - pb.max(axis=0))))

    sep = max(gap(P, Q), gap(Q, P))
    if sep <= 0:
        return sep

    def point_seg(X: NDArray[np.float64], A: NDArray[np.float64]) -> float:
        B = np.roll(A, -1, axis=0)
        D = B - A
        t = np.clip(((X[:, None] - A[None]) * D[None]).sum(-1) / (D * D).sum(-1)[None], 0.0, 1.0)
        return float(np.linalg.norm(X[:, None] - A[None] - t[..., None] * D[None], axis=-1).min())

    return min(point_seg(P, Q), point_seg(Q, P))


def check_nesting(nesting: Nesting, tol: float = 1e-6) -> float:
    """Verify every sheet exactly; returns the smallest gap (mm) between two items on one sheet.

    Raises :class:`GeometryError` if an item leaves the usable area (sheet minus margin) or two items
    are closer than ``spacing``.
    """
    m, W, H = nesting.margin, nesting.width, nesting.height
    smallest = math.inf
    for s in range(nesting.n_sheets):
        items = nesting.on_sheet(s)
        placed = {i: nesting.placed(i) for i in items}
        for i, P in placed.items():
            lo, hi = P.min(axis=0), P.max(axis=0)
            if lo[0] < m - tol or lo[1] < m - tol or hi[0] > W - m + tol or hi[1] > H - m + tol:
                raise GeometryError(f"sheet {s + 1}: item {i} leaves the sheet's usable area")
        for a, i in enumerate(items):
            for j in items[a + 1:]:
                d = convex_distance(placed[i], placed[j])
                smallest = min(smallest, d)
                if d < nesting.spacing - tol:
                    raise GeometryError(f"sheet {s + 1}: items {i} and {j} are {d:.3f} mm apart "
                                        f"(spacing {nesting.spacing:g} mm)")
    return smallest
