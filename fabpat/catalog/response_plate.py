"""Physics features of the learned response: a linear plate model of a pattern's lattice, solved in microseconds.

:func:`plate_features` gives, per pattern, four numbers that the boosted trees of
:mod:`fabpat.catalog.response` read beside the cells: the compliances (½ fᵀu) of the three scenarios in a linear
Kirchhoff plate model of the *unfilleted* lattice, and the membrane energy that the linear dome deflection
forces into the network (the first nonlinear term: how much the dome stiffens as it deflects).

The plate model (no mesh, no fillet; one unknown per lattice vertex, the deflection w):

* each solid lattice triangle is flat (w linear on it: its slope is ``G_f · w``);
* two solid triangles that share an edge form a hinge of stiffness 3·L²/(A₁ + A₂) on the jump of the slope
  across the edge — the discrete-shell bending energy (Grinspun et al., *Discrete shells*, SCA 2003;
  Bridson et al., SCA 2003), which for a plate of bending stiffness D is D times this, so D is left out;
* two solid triangles that share only a vertex (the joints the fillet bridges with a neck) are tied by
  ``NECK`` · 3·L²/(A₁ + A₂) on the whole slope jump |g₁ − g₂|² (the neck carries bending and twist alike);
  ``NECK`` = 0.3 was chosen by rank correlation with the catalog's depth-2 and depth-3 energies
  (docs/learned-response.md: 0.1 and 1.0 did worse at both depths);
* the scenarios as in :mod:`fabpat.simulation.scenarios`, on each interface's lattice triangle (the middle one
  of the edge row, whose outer vertex is the interface): cantilever — that triangle of interface 0 clamped, a
  force of 1.5 on the opposite interface's vertex; cylinder — w = 0 along interfaces 0 and opposite (the outer
  vertex fixed, the two inner ones level), a moment of 50 on each; dome — the same on every interface, 100
  each. Supports are penalties (10⁶ against entries of order 1).

The membrane term: the linear dome deflection w strains the mid-plane by ε₀ = ½ ∇w ∇wᵀ (von Kármán); the
network relaxes it in-plane (constant-strain triangles, ν = 0.35; vertex joints carry an in-plane rotation
spring), and what stays is the energy that makes the real (nonlinear) dome stiffer than the linear one. The
dome is symmetric under the polygon's rotations, so its deflection and its relaxation are solved on one fan
(the symmetric Fourier mode: a vertex of fan f is the fan-0 vertex rotated by 2πf/n).

All four are returned as logarithms. Solves: a skyline (envelope) Cholesky on the vertices ordered row by row
across the polygon, and dense Cholesky on the one-fan systems; compiled (numba) and spread over the cores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from fabpat.patterns.lattice import edge_row
from fabpat.patterns.pattern import DEFAULT_EDGE, pattern_topology

#: the neck's stiffness against a hinge's of the same lattice (module doc)
NECK = 0.3
#: the support penalty, against stiffness entries of order one
PENALTY = 1.0e6
#: Poisson's ratio of the membrane (the catalog's material)
NU = 0.35
#: the scenarios' loads (:mod:`fabpat.simulation.scenarios`): force (N), cylinder and dome moments (N·mm)
FORCE, CYLINDER, DOME = 1.5, 50.0, 100.0
#: how many physics features :func:`plate_features` returns per pattern
N_PHYSICS = 4
#: patterns are solved in this many chunks at most, spread over the cores (each holds two (nv, nv) arrays)
CHUNKS = 8


@dataclass(frozen=True, eq=False)
class PlateTopology:
    """The lattice of a (sides, depth) polygon as the compiled solves read it (vertices renumbered row by row).

    ``face`` (nf, 3) vertices, ``slice_face`` (nf,), ``grad`` (nf, 2, 3) slope of w per vertex value (1/mm),
    ``area`` (nf,) mm²; ``hinge_*`` and ``neck_*``: the face pairs, their 6 vertices, their slope-jump rows
    and stiffnesses; ``iface`` (n, 4) face, outer vertex, inner vertices; ``moment`` (n, 3) the unit moment's
    load on the interface face's vertices; ``first`` (nv,) the skyline of the w system; ``rep`` (nv,) the fan-0
    vertex each vertex is a rotation of, ``angle`` (nv,) that rotation (rad)."""

    face: NDArray[np.int64]
    slice_face: NDArray[np.int64]
    grad: NDArray[np.float64]
    area: NDArray[np.float64]
    hinge_faces: NDArray[np.int64]
    hinge_vertices: NDArray[np.int64]
    hinge_row: NDArray[np.float64]
    hinge_k: NDArray[np.float64]
    neck_faces: NDArray[np.int64]
    neck_vertices: NDArray[np.int64]
    neck_rows: NDArray[np.float64]
    neck_k: NDArray[np.float64]
    iface: NDArray[np.int64]
    moment: NDArray[np.float64]
    first: NDArray[np.int64]
    rep: NDArray[np.int64]
    angle: NDArray[np.float64]
    n_rep: int
    edge2: float
    mem_rows: NDArray[np.float64]
    mem_turn: NDArray[np.float64]
    fan0_faces: NDArray[np.int64]
    hinge_orbit: NDArray[np.int64]
    hinge_weight: NDArray[np.float64]
    neck_orbit: NDArray[np.int64]
    neck_weight: NDArray[np.float64]
    mem_first: NDArray[np.int64]


def _pairs(F: NDArray[np.int64]) -> tuple[list[tuple[int, int, int, int]], list[tuple[int, int]]]:
    """Faces sharing an edge (f1, f2, a, b: the edge's vertices) and sharing only a vertex (f1, f2)."""
    edges: dict[tuple[int, int], list[int]] = {}
    verts: dict[int, list[int]] = {}
    for f, tri in enumerate(F.tolist()):
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            edges.setdefault((min(a, b), max(a, b)), []).append(f)
        for a in tri:
            verts.setdefault(a, []).append(f)
    hinges = [(v[0], v[1], a, b) for (a, b), v in sorted(edges.items()) if len(v) == 2]
    shared = {(h[0], h[1]) for h in hinges}
    necks = sorted({(a, b) for fs in verts.values() for a in fs for b in fs if a < b} - shared)
    return hinges, necks


def _orbits(pairs: NDArray[np.int64], sides: int, depth: int) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """One face pair of each orbit under the polygon's rotations (fan f's face s is f·4**depth + s) and the
    orbit's size: a sum over the orbits, each weighted by its size, is the sum over every pair."""
    m = 4**depth
    orbit: dict[tuple[int, int], list[int]] = {}
    for k, (a, b) in enumerate(pairs.tolist()):
        key = min(tuple(sorted(((a // m + r) % sides * m + a % m, (b // m + r) % sides * m + b % m)))
                  for r in range(sides))
        orbit.setdefault(key, []).append(k)
    reps = sorted(ks[0] for ks in orbit.values())
    size = {ks[0]: len(ks) for ks in orbit.values()}
    return np.array(reps, dtype=np.int64), np.array([float(size[k]) for k in reps])


def _membrane_rows(grad: NDArray[np.float64], F: NDArray[np.int64], angle: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each face's strain rows (nf, 3, 6) [εxx, εyy, γxy] and in-plane rotation row (nf, 6) on the fan-0
    unknowns (u, v of each vertex's fan-0 representative: a vertex moves as its representative rotated by
    its angle: u = c·ur − s·vr, v = s·ur + c·vr)."""
    c, s = np.cos(angle[F]), np.sin(angle[F])  # (nf, 3)
    gx, gy = grad[:, 0, :], grad[:, 1, :]
    B = np.zeros((len(F), 3, 6))
    turn = np.zeros((len(F), 6))
    B[:, 0, 0::2], B[:, 0, 1::2] = gx * c, -gx * s
    B[:, 1, 0::2], B[:, 1, 1::2] = gy * s, gy * c
    B[:, 2, 0::2], B[:, 2, 1::2] = gy * c + gx * s, -gy * s + gx * c
    turn[:, 0::2], turn[:, 1::2] = 0.5 * (gx * s - gy * c), 0.5 * (gx * c + gy * s)
    return B, turn


@cache
def plate_topology(sides: int, depth: int) -> PlateTopology:
    """The :class:`PlateTopology` of the ``sides``-gon at ``depth`` (cached; the polygon of the default edge)."""
    topo = pattern_topology(sides, depth)
    V0 = topo.vertices(DEFAULT_EDGE)
    order = np.lexsort((np.round(V0[:, 0], 6), np.round(V0[:, 1], 6)))  # row by row across the polygon
    new = np.empty_like(order)
    new[order] = np.arange(order.size)
    V, F = V0[order], new[np.asarray(topo.F)]
    P = V[F]
    M = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2)  # (nf, 2, 2): columns the two edge vectors
    area = 0.5 * np.abs(np.linalg.det(M))
    grad = np.linalg.inv(np.transpose(M, (0, 2, 1))) @ np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])
    hinges, necks = _pairs(F)
    L2 = float(np.sum((V[F[0, 0]] - V[F[0, 1]]) ** 2))  # every lattice edge has this length
    h = np.array(hinges, dtype=np.int64)
    e = V[h[:, 3]] - V[h[:, 2]]
    normal = np.stack([-e[:, 1], e[:, 0]], axis=1) / np.linalg.norm(e, axis=1)[:, None]
    hinge_row = np.einsum("hi,hij->hj", normal, np.concatenate([grad[h[:, 0]], -grad[h[:, 1]]], axis=2))
    nk = np.array(necks, dtype=np.int64)
    neck_rows = np.concatenate([grad[nk[:, 0]], -grad[nk[:, 1]]], axis=2)
    iface, moment = [], []
    mid = int(edge_row(depth)[1])
    for i in range(sides):
        f = i * 4**depth + mid
        tri = F[f]
        outer = int(tri[np.argmax(np.linalg.norm(V[tri], axis=1))])
        inner = [int(t) for t in tri if t != outer]
        iface.append([f, outer, *inner])
        c = V[tri].mean(axis=0)
        moment.append((c / np.linalg.norm(c)) @ grad[f])
    first = np.arange(len(V))
    for tri in np.concatenate([F[h[:, :2]].reshape(-1, 6), F[nk].reshape(-1, 6)]):
        first[tri] = np.minimum(first[tri], tri.min())
    n = sides
    owned = (len(V0) - 1) // n
    rep = np.where(order == 0, 0, 1 + (order - 1) % owned)
    angle = 2.0 * math.pi * np.where(order == 0, 0, (order - 1) // owned) / n
    rows, turn = _membrane_rows(grad, F, angle)
    hinge_orbit, hinge_weight = _orbits(h[:, :2], sides, depth)
    neck_orbit, neck_weight = _orbits(nk, sides, depth)
    mem_first = np.arange(2 * (owned + 1))  # the skyline of the one-fan membrane system (u, v per vertex)
    for verts in [*F[: 4**depth], *F[nk[neck_orbit]].reshape(-1, 6)]:
        dofs = np.concatenate([2 * rep[verts], 2 * rep[verts] + 1])
        mem_first[dofs] = np.minimum(mem_first[dofs], dofs.min())
    out = PlateTopology(F, np.asarray(topo.slice_face), grad, area, h[:, :2].copy(), F[h[:, :2]].reshape(-1, 6),
                        hinge_row, 3.0 * L2 / (area[h[:, 0]] + area[h[:, 1]]), nk, F[nk].reshape(-1, 6), neck_rows,
                        NECK * 3.0 * L2 / (area[nk[:, 0]] + area[nk[:, 1]]), np.array(iface, dtype=np.int64),
                        np.array(moment), first, rep, angle, owned + 1, L2, rows, turn,
                        np.arange(4**depth, dtype=np.int64), hinge_orbit, hinge_weight, neck_orbit, neck_weight,
                        mem_first)
    for a in vars(out).values():  # noqa: B007 - frozen arrays
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    return out


def plate_features(cells: NDArray[np.bool_], sides: int, depth: int) -> NDArray[np.float64]:
    """(k, 4) log cantilever, cylinder and dome compliances and log dome membrane energy (module doc) of
    (k, 4**depth) slices (bool, the slice's faces in lattice order), on the ``sides``-gon of the default edge.
    Units are the model's (plate stiffness D = 1), the same for every pattern: features, not energies."""
    t = plate_topology(sides, depth)
    solid = np.ascontiguousarray(np.asarray(cells, dtype=np.bool_)[:, t.slice_face])
    ints = (t.face, t.hinge_faces, t.hinge_vertices, t.neck_faces, t.neck_vertices, t.iface, t.first, t.rep,
            t.fan0_faces, t.hinge_orbit, t.neck_orbit, np.arange(t.hinge_k.size), np.arange(t.neck_k.size),
            t.mem_first)
    reals = (t.grad, t.area, t.hinge_row, t.hinge_k, t.neck_rows, t.neck_k, t.moment, t.mem_rows, t.mem_turn,
             t.hinge_weight, t.neck_weight, np.ones(t.hinge_k.size), np.ones(t.neck_k.size))
    return _features(solid, ints, reals, t.n_rep, t.edge2)


@njit(cache=True, fastmath=True)  # fastmath: the inner products vectorise (4× on the factorisation)
def _skyline_solve(A: NDArray[np.float64], first: NDArray[np.int64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Solve A x = b for SPD A (its lower triangle within the skyline ``first``), factorising A in place."""
    n = A.shape[0]
    for i in range(n):
        for j in range(first[i], i + 1):
            s = A[i, j]
            for k in range(max(first[i], first[j]), j):
                s -= A[i, k] * A[j, k]
            if j < i:
                A[i, j] = s / A[j, j]
            else:
                A[i, i] = math.sqrt(max(s, 1e-300))
    x = b.copy()
    for i in range(n):
        s = x[i]
        for k in range(first[i], i):
            s -= A[i, k] * x[k]
        x[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):
        x[i] /= A[i, i]
        for k in range(first[i], i):
            x[k] -= A[i, k] * x[i]
    return x


@njit(cache=True)
def _dense_solve(A: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    first = np.zeros(A.shape[0], dtype=np.int64)
    return _skyline_solve(A, first, b)


@njit(cache=True)
def _add_pair(K: NDArray[np.float64], idx: NDArray[np.int64], row: NDArray[np.float64], k: float) -> None:
    """K[idx, idx] += k · row rowᵀ, lower triangle (idx may repeat)."""
    for a in range(idx.size):
        for b in range(idx.size):
            if idx[b] <= idx[a]:
                K[idx[a], idx[b]] += k * row[a] * row[b]


@njit(cache=True)
def _pin(K: NDArray[np.float64], iface: NDArray[np.int64], clamp: bool) -> None:
    """w = 0 along an interface (outer vertex fixed, inner ones level); ``clamp``: its whole triangle fixed."""
    o, a, b = iface[1], iface[2], iface[3]
    K[o, o] += PENALTY
    if clamp:
        K[a, a] += PENALTY
        K[b, b] += PENALTY
    else:
        K[a, a] += PENALTY
        K[b, b] += PENALTY
        K[max(a, b), min(a, b)] -= PENALTY


@njit(cache=True)
def _bending(solid: NDArray[np.bool_], hinge_faces: NDArray[np.int64], hinge_vertices: NDArray[np.int64],
             hinge_row: NDArray[np.float64], hinge_k: NDArray[np.float64], neck_faces: NDArray[np.int64],
             neck_vertices: NDArray[np.int64], neck_rows: NDArray[np.float64], neck_k: NDArray[np.float64],
             rep: NDArray[np.int64], hinges: NDArray[np.int64], hinge_weight: NDArray[np.float64],
             necks: NDArray[np.int64], neck_weight: NDArray[np.float64], K: NDArray[np.float64]) -> None:
    """Add the plate's hinges and necks (those listed, each times its weight) to K (lower triangle), vertex v
    as unknown ``rep[v]``."""
    idx = np.empty(6, dtype=np.int64)
    for m in range(hinges.size):
        h = hinges[m]
        if solid[hinge_faces[h, 0]] and solid[hinge_faces[h, 1]]:
            for c in range(6):
                idx[c] = rep[hinge_vertices[h, c]]
            _add_pair(K, idx, hinge_row[h], hinge_weight[m] * hinge_k[h])
    for m in range(necks.size):
        h = necks[m]
        if solid[neck_faces[h, 0]] and solid[neck_faces[h, 1]]:
            k = neck_weight[m] * neck_k[h]
            for c in range(6):
                idx[c] = rep[neck_vertices[h, c]]
            for a in range(6):
                for b in range(6):
                    if idx[b] <= idx[a]:
                        K[idx[a], idx[b]] += k * (neck_rows[h, 0, a] * neck_rows[h, 0, b]
                                                  + neck_rows[h, 1, a] * neck_rows[h, 1, b])


@njit(cache=True)
def _unit_unused(solid: NDArray[np.bool_], face: NDArray[np.int64], rep: NDArray[np.int64], K: NDArray[np.float64],
                 dofs: int) -> None:
    """A unit diagonal for each unknown (``dofs`` per vertex) that no solid face moves."""
    used = np.zeros(K.shape[0], dtype=np.bool_)
    for f in range(face.shape[0]):
        if solid[f]:
            for c in range(3):
                for d in range(dofs):
                    used[dofs * rep[face[f, c]] + d] = True
    for v in range(K.shape[0]):
        if not used[v]:
            K[v, v] += 1.0


@njit(cache=True)
def _membrane_energy(solid: NDArray[np.bool_], face: NDArray[np.int64], grad: NDArray[np.float64],
                     area: NDArray[np.float64], rows: NDArray[np.float64], turn: NDArray[np.float64],
                     fan0_faces: NDArray[np.int64], neck_faces: NDArray[np.int64], neck_orbit: NDArray[np.int64],
                     neck_weight: NDArray[np.float64], rep: NDArray[np.int64], n_rep: int, edge2: float,
                     w: NDArray[np.float64], outer0: int, n_fans: int, mem_first: NDArray[np.int64]) -> float:
    """The in-plane energy left after the network relaxes the strain ½∇w∇wᵀ of a symmetric deflection w (per
    fan-0 vertex), solved on one fan (module doc): every face of an orbit adds the same, so fan 0's faces
    count n times, and each neck orbit by its size."""
    n = 2 * n_rep
    K = np.zeros((n, n))
    f0 = np.zeros(n)
    Cm = np.array([[1.0, NU, 0.0], [NU, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - NU)]]) / (1.0 - NU * NU)
    eps0 = np.zeros(3)
    CB = np.zeros((3, 6))
    idx = np.empty(12, dtype=np.int64)
    row = np.empty(12)
    for f in fan0_faces:
        if not solid[f]:
            continue
        gx = gy = 0.0
        for j in range(3):
            gx += grad[f, 0, j] * w[rep[face[f, j]]]
            gy += grad[f, 1, j] * w[rep[face[f, j]]]
        eps0[0], eps0[1], eps0[2] = 0.5 * gx * gx, 0.5 * gy * gy, gx * gy
        for r in range(3):
            for a in range(6):
                CB[r, a] = Cm[r, 0] * rows[f, 0, a] + Cm[r, 1] * rows[f, 1, a] + Cm[r, 2] * rows[f, 2, a]
        for j in range(3):
            idx[2 * j], idx[2 * j + 1] = 2 * rep[face[f, j]], 2 * rep[face[f, j]] + 1
        wa = n_fans * area[f]
        for a in range(6):
            f0[idx[a]] += wa * (CB[0, a] * eps0[0] + CB[1, a] * eps0[1] + CB[2, a] * eps0[2])
            for b in range(6):
                if idx[b] <= idx[a]:
                    K[idx[a], idx[b]] += wa * (rows[f, 0, a] * CB[0, b] + rows[f, 1, a] * CB[1, b]
                                               + rows[f, 2, a] * CB[2, b])
    for m in range(neck_orbit.size):
        h = neck_orbit[m]
        f1, f2 = neck_faces[h, 0], neck_faces[h, 1]
        if solid[f1] and solid[f2]:
            for j in range(3):
                idx[2 * j], idx[2 * j + 1] = 2 * rep[face[f1, j]], 2 * rep[face[f1, j]] + 1
                idx[6 + 2 * j], idx[7 + 2 * j] = 2 * rep[face[f2, j]], 2 * rep[face[f2, j]] + 1
            for a in range(6):
                row[a], row[6 + a] = turn[f1, a], -turn[f2, a]
            _add_pair(K, idx, row, neck_weight[m] * NECK * edge2)
    _unit_unused(solid, face, rep, K, 2)
    K[0, 0] += PENALTY  # the centre stays put in a symmetric field
    K[1, 1] += PENALTY
    K[2 * rep[outer0], 2 * rep[outer0]] += PENALTY  # no rigid turn: interface 0 does not slide along its edge
    u = _skyline_solve(K, mem_first, f0)
    energy = 0.0
    for f in fan0_faces:
        if not solid[f]:
            continue
        gx = gy = 0.0
        for j in range(3):
            gx += grad[f, 0, j] * w[rep[face[f, j]]]
            gy += grad[f, 1, j] * w[rep[face[f, j]]]
        eps0[0], eps0[1], eps0[2] = -0.5 * gx * gx, -0.5 * gy * gy, -gx * gy
        for j in range(3):
            for c in range(2):
                x = u[2 * rep[face[f, j]] + c]
                for r in range(3):
                    eps0[r] += rows[f, r, 2 * j + c] * x
        e0, e1, e2 = eps0[0], eps0[1], eps0[2]
        energy += 0.5 * n_fans * area[f] * (e0 * (Cm[0, 0] * e0 + Cm[0, 1] * e1) + e1 * (Cm[1, 0] * e0 + Cm[1, 1] * e1)
                                            + e2 * Cm[2, 2] * e2)
    return energy


@njit(cache=True)
def _compact(solid: NDArray[np.bool_], face: NDArray[np.int64], hinge_faces: NDArray[np.int64],
             hinge_vertices: NDArray[np.int64], neck_faces: NDArray[np.int64], neck_vertices: NDArray[np.int64],
             index: NDArray[np.int64], first: NDArray[np.int64]) -> int:
    """Number the vertices of solid faces 0, 1, … in row order (``index``, −1 for the others) and fill
    ``first``, the skyline of their system; returns their count."""
    nv = index.size
    for v in range(nv):
        index[v] = -1
    for f in range(face.shape[0]):
        if solid[f]:
            for c in range(3):
                index[face[f, c]] = 0
    n = 0
    for v in range(nv):
        if index[v] == 0:
            index[v] = n
            first[n] = n
            n += 1
    for pairs, verts in ((hinge_faces, hinge_vertices), (neck_faces, neck_vertices)):
        for h in range(pairs.shape[0]):
            if solid[pairs[h, 0]] and solid[pairs[h, 1]]:
                low = nv
                for c in range(6):
                    low = min(low, index[verts[h, c]])
                for c in range(6):
                    first[index[verts[h, c]]] = min(first[index[verts[h, c]]], low)
    return n


@njit(cache=True)
def _one(solid: NDArray[np.bool_], ints: tuple[NDArray[np.int64], ...], reals: tuple[NDArray[np.float64], ...],
         n_rep: int, edge2: float, K: NDArray[np.float64], Kw: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """The four features of one pattern (``solid`` per face) into ``out``; K, Kw: (nv, nv) work arrays."""
    (face, hinge_faces, hinge_vertices, neck_faces, neck_vertices, iface, _, rep, fan0_faces, hinge_orbit,
     neck_orbit, all_hinges, all_necks, mem_first) = ints
    (grad, area, hinge_row, hinge_k, neck_rows, neck_k, moment, rows, turn, hinge_weight, neck_weight,
     ones_h, ones_n) = reals
    nv = K.shape[0]
    n = iface.shape[0]
    index = np.empty(nv, dtype=np.int64)
    first = np.empty(nv, dtype=np.int64)
    m = _compact(solid, face, hinge_faces, hinge_vertices, neck_faces, neck_vertices, index, first)
    for i in range(m):
        for j in range(first[i], i + 1):
            K[i, j] = 0.0
    _bending(solid, hinge_faces, hinge_vertices, hinge_row, hinge_k, neck_faces, neck_vertices, neck_rows, neck_k,
             index, all_hinges, ones_h, all_necks, ones_n, K)
    pinned = np.empty(4, dtype=np.int64)
    for scenario in range(2):
        for i in range(m):
            for j in range(first[i], i + 1):
                Kw[i, j] = K[i, j]
        f = np.zeros(m)
        if scenario == 0:  # cantilever: interface 0 clamped, the force on the opposite interface
            for c in range(1, 4):
                pinned[c] = index[iface[0, c]]
            _pin(Kw, pinned, True)
            f[index[iface[n // 2, 1]]] = FORCE
        else:  # cylinder: w = 0 along both, a moment on each
            for i in (0, n // 2):
                for c in range(1, 4):
                    pinned[c] = index[iface[i, c]]
                _pin(Kw, pinned, False)
                for c in range(3):
                    f[index[face[iface[i, 0], c]]] += CYLINDER * moment[i, c]
        u = _skyline_solve(Kw[:m, :m], first[:m], f)
        out[scenario] = math.log(0.5 * (f @ u))
    # dome: symmetric under the polygon's rotations, solved on one fan's vertices (one pair of each orbit)
    Kd = np.zeros((n_rep, n_rep))
    _bending(solid, hinge_faces, hinge_vertices, hinge_row, hinge_k, neck_faces, neck_vertices, neck_rows, neck_k,
             rep, hinge_orbit, hinge_weight, neck_orbit, neck_weight, Kd)
    _unit_unused(solid, face, rep, Kd, 1)
    f = np.zeros(n_rep)
    for i in range(n):
        for c in range(1, 4):
            pinned[c] = rep[iface[i, c]]
        _pin(Kd, pinned, False)
        for c in range(3):
            f[rep[face[iface[i, 0], c]]] += DOME * moment[i, c]
    w = _dense_solve(Kd, f)
    out[2] = math.log(0.5 * (f @ w))
    out[3] = math.log(1.0 + _membrane_energy(solid, face, grad, area, rows, turn, fan0_faces, neck_faces,
                                             neck_orbit, neck_weight, rep, n_rep, edge2, w, iface[0, 1], n,
                                             mem_first))


@njit(cache=True, parallel=True)
def _features(solid: NDArray[np.bool_], ints: tuple[NDArray[np.int64], ...], reals: tuple[NDArray[np.float64], ...],
              n_rep: int,
              edge2: float) -> NDArray[np.float64]:
    """(k, 4) features of k patterns (``solid`` (k, nf)), in chunks spread over the cores."""
    k = solid.shape[0]
    nv = ints[6].size
    out = np.zeros((k, N_PHYSICS))
    chunks = min(k, CHUNKS)
    # work arrays per chunk allocated here: numba hoists an allocation inside a prange body out of the loop,
    # which would share it between threads
    work = np.zeros((chunks, 2, nv, nv))
    for c in prange(chunks):
        for p in range(c * k // chunks, (c + 1) * k // chunks):
            _one(solid[p], ints, reals, n_rep, edge2, work[c, 0], work[c, 1], out[p])
    return out
