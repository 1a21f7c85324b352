"""The load-controlled strip model of ``study_graded_strip.py``: a study, not part of fabpat's API.

The paper shows by printing that a graded strip, pinned at both ends and pushed together, bends
asymmetrically with its stiff end flatter. fabpat's assembly solver does that past buckling, plates
joined by sleeves under end shortening (``fabpat.assembly.solve.strip``, ``fabpat simulate-assembly``). This
older model welds the tiles and stays below buckling under a controlled load; the study keeps it because
its amplification reading (Southwell) estimates the buckling load, which the displacement-controlled
solver does not report.

Model (the decisions, in one place):

* Every tile is its pattern's filleted outline, meshed as in the scenarios (:func:`fabpat.simulation.mesh.mesh_outline`,
  target edge ``h``), on the ideal honeycomb of edge ``e``: the sleeve's web between the plates is not
  modelled. Tiles joined by a sleeve share the nodes of their common interface segment, i.e. the
  sleeve's "full restraint" is a welded joint over the segment (:func:`strip_model` checks that the two
  tiles' segment nodes coincide).
* Pins at both ends (the kit's pins, :func:`fabpat.assembly.place.placement.end_interfaces`): the nodes of the
  first column's end interfaces hold ux, uy, uz; those of the last column hold uy, uz and carry the
  compression P, a uniform line load along −x over their segments. Rotations are free: hinges.
* A perturbation selects the upward buckle: a uniform out-of-plane force, ``imperfection`` × P in
  total, spread over the nodes by lumped area (at 0.8 P_cr the response to it is amplified about 5×).
* P is given in N, or as a fraction of :func:`critical_load`, a Rayleigh-quotient estimate of the
  strip's Euler load from the deflected shape under the perturbation alone (beam theory on the
  width-averaged deflection; an upper bound for a beam, an estimate for the lattice).

Results are the deflection profile along the strip (mean uz of the nodes in each x-bin) and two
asymmetry measures: the position of the highest point, and the ratio of the deflection areas of the
first (stiff, column 0) and second halves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.placement import end_interfaces
from fabpat.assembly.surface.tiling import Tiling
from fabpat.errors import GeometryError
from fabpat.shell import ShellProblem, ShellResult, solve_linear
from fabpat.shell.element import Material
from fabpat.shell.solve import solve_nonlinear
from fabpat.simulation.scenarios import tributary_weights

WELD_TOL = 1e-6  # mm: interface nodes of two tiles closer than this are one node
STRIP_RTOL = 1e-6  # Newton tolerance relative to the load norm (see simulate_strip)


@dataclass(frozen=True, eq=False)
class StripModel:
    """The merged mesh of a strip and its supports.

    V (n, 2) mm, F (m, 3); ``left``/``right`` node indices of the pinned end interfaces and
    ``right_weights`` the compression's shares there; ``area`` (n,) lumped nodal areas (mm²);
    ``length`` the strip's x-extent (mm); ``material`` the plates' shell material.
    """

    V: NDArray[np.float64]
    F: NDArray[np.int64]
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    right_weights: NDArray[np.float64]
    area: NDArray[np.float64]
    length: float
    material: Material

    def problem(self, compression: float, transverse: float) -> ShellProblem:
        """Supports, compression P (N, along −x at the right end) and a total out-of-plane force (N)."""
        n = len(self.V)
        fixed = np.zeros((n, 6), dtype=bool)
        fixed[self.left, :3] = True
        fixed[self.right, 1:3] = True
        loads = np.zeros((n, 6))
        np.add.at(loads[:, 0], self.right, -compression * self.right_weights)
        loads[:, 2] += transverse * self.area / self.area.sum()
        return ShellProblem(self.V, self.F, self.material, fixed, loads)


@dataclass(frozen=True, eq=False)
class StripResult:
    """Deflected strip: ``x`` (k,) bin centres from the left end and ``w`` (k,) mean uz (mm) there;
    ``peak`` the position of the highest point as a fraction of the length; ``half_ratio`` the
    deflection area of the first half over that of the second (< 1: the first half is flatter).

    ``amplification`` A: the highest deflection over that of the perturbation alone (linear), and
    ``implied_critical_load`` P / (1 − 1/A), the buckling load that amplification implies for a
    one-mode response (Southwell's reading; meaningful for P below the buckling load).
    """

    compression: float
    transverse: float
    x: NDArray[np.float64]
    w: NDArray[np.float64]
    peak: float
    half_ratio: float
    amplification: float
    implied_critical_load: float
    result: ShellResult


def _tile_mesh(pattern_id: str, edge: float, weight: float, h: float):  # noqa: ANN202 - a ShellMesh
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import mesh_outline

    outline = fillet_pattern(get_pattern(pattern_id, 6, 2, edge), weight).outline
    return mesh_outline(outline, h, 6, edge, weight=weight)


def strip_model(tiling: Tiling, face_patterns: list[str], *, edge: float = 36.0, h: float = 1.5,
                thickness: float = 2.0, weight: float = 0.2, E: float = 1000.0, nu: float = 0.35) -> StripModel:
    """Merge the tiles' meshes of a flat honeycomb strip (``tiling`` of edge ``edge``; see module doc)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if tiling.grid is None or len(face_patterns) != len(tiling.faces):
        raise ValueError("a flat strip tiling and one pattern ID per face are needed")
    meshes = {pid: _tile_mesh(pid, edge, weight, h) for pid in dict.fromkeys(face_patterns)}
    Vs, Fs, offsets = [], [], [0]
    for f, pid in enumerate(face_patterns):
        m = meshes[pid]
        # honeycomb tiles are the pattern's own polygon translated: polygon edge i is tile edge i
        Vs.append(m.V + tiling.centroids[f, :2])
        Fs.append(m.F + offsets[-1])
        offsets.append(offsets[-1] + len(m.V))
    V_all = np.vstack(Vs)
    # weld: nodes closer than WELD_TOL (transitively) become one, numbered by their first node
    pairs = cKDTree(V_all).query_pairs(WELD_TOL, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(V_all),) * 2)
    _, label = connected_components(graph, directed=False)
    keep = np.sort(np.unique(label, return_index=True)[1])  # the first node of each group
    new = np.empty(len(keep), dtype=np.int64)
    new[label[keep]] = np.arange(len(keep))
    merged = new[label]

    def nodes(f: int, i: int) -> NDArray[np.int64]:
        return merged[meshes[face_patterns[f]].interfaces[i] + offsets[f]]

    for k in tiling.interior_edges:
        (fa, ia), (fb, ib) = (tuple(int(x) for x in pair) for pair in tiling.edge_faces[k])
        a, b = nodes(fa, ia), nodes(fb, ib)
        if a.size < 2 or set(a.tolist()) != set(b.tolist()):
            raise GeometryError(f"tiles {fa} and {fb}: their interface segment nodes do not coincide")
    V = V_all[keep]
    F = merged[np.vstack(Fs)]
    ends = end_interfaces(tiling)
    last = int(tiling.grid[:, 1].max())
    left = np.unique(np.concatenate([nodes(f, i) for f, i in ends if tiling.grid[f, 1] == 0]))
    right_sets = [nodes(f, i) for f, i in ends if tiling.grid[f, 1] == last]
    # the compression is a uniform line load over every right-end segment: shares by tributary length
    right_w: dict[int, float] = {}
    for s in right_sets:
        for node, w in zip(s.tolist(), (tributary_weights(V, s) / len(right_sets)).tolist(), strict=True):
            right_w[node] = right_w.get(node, 0.0) + w
    right = np.array(sorted(right_w), dtype=np.int64)
    P = np.column_stack([V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]])
    tri = 0.5 * np.abs(P[:, 0] * P[:, 3] - P[:, 1] * P[:, 2])
    area = np.bincount(F.ravel(), np.repeat(tri / 3.0, 3), minlength=len(V))
    return StripModel(V, F, left, right, np.array([right_w[i] for i in right]), area,
                      float(np.ptp(V[:, 0])), Material(E, nu, thickness))


def deflection_profile(model: StripModel, uz: NDArray[np.float64], bins: int = 60) -> tuple[
        NDArray[np.float64], NDArray[np.float64]]:
    """Bin centres (mm from the left end) and the area-weighted mean uz of the nodes in each bin."""
    x = model.V[:, 0] - model.V[:, 0].min()
    k = np.minimum((x / model.length * bins).astype(np.int64), bins - 1)
    a = np.bincount(k, model.area, minlength=bins)
    w = np.bincount(k, model.area * uz, minlength=bins) / np.maximum(a, 1e-300)
    ok = a > 0
    return ((np.arange(bins) + 0.5) * model.length / bins)[ok], w[ok]


def critical_load(model: StripModel, bins: int = 60) -> float:
    """Rayleigh estimate of the strip's buckling load (N) from its shape under a uniform lateral load.

    P ≈ ∫ EI w''² dx / ∫ w'² dx = 2U / ∫ w'² dx, with U the strain energy of the linear solution
    under a unit out-of-plane force and w the width-averaged deflection profile.
    """
    r = solve_linear(model.problem(0.0, 1.0))
    x, w = deflection_profile(model, r.displacement[:, 2], bins)
    slope = np.gradient(w, x)
    return float(2.0 * r.energy / np.trapezoid(slope**2, x))


def simulate_strip(model: StripModel, compression: float, imperfection: float = 0.01,
                   bins: int = 60) -> StripResult:
    """Geometrically nonlinear solve under compression P (N) plus the perturbation; the profile."""
    if not compression > 0 or not imperfection > 0:
        raise ValueError("compression and imperfection must be > 0")
    transverse = imperfection * compression
    # Residual ≤ 1e-6 of the loads, not the scenarios' 1e-8: the loads here are a fraction of a newton
    # while the element forces that cancel to them are thousands of times larger, and their rounding
    # (≈ 1e-9 N) would otherwise sit at the tolerance.
    r = solve_nonlinear(model.problem(compression, transverse), rtol=STRIP_RTOL)
    x, w = deflection_profile(model, r.displacement[:, 2], bins)
    half = model.length / 2
    first = np.trapezoid(np.where(x <= half, w, 0.0), x)
    second = np.trapezoid(np.where(x > half, w, 0.0), x)
    _, w0 = deflection_profile(model, solve_linear(model.problem(0.0, transverse)).displacement[:, 2], bins)
    A = float(w.max() / w0.max())
    return StripResult(compression, transverse, x, w, float(x[np.argmax(w)] / model.length),
                       float(first / second) if second != 0 else math.inf, A,
                       compression / (1.0 - 1.0 / A) if A > 1 else math.inf, r)
