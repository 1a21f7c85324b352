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

The cantilever and cylinder break the rotational symmetry only at two interfaces, so the polygon is solved
mode by mode: the stiffness commutes with the rotation by one fan, so in the discrete Fourier basis of the fans
(a vertex of fan f moves as ω^{kf} times its fan-0 representative, ω = e^{2πi/n}; mode k and n − k are
conjugate, modes 0 and n/2 real) it falls into n blocks of one fan's vertices, each assembled from one pair
of each orbit. Each block is condensed onto the interface's three vertices (a partial Cholesky factorisation,
the interface last); the condensed blocks, transformed back, give the stiffness on the 3n interface vertices,
where the supports and loads are: each scenario is then a solve of 3n unknowns. The dome is the symmetric
mode alone, and its deflection away from the interface comes from the same factorisation. Equal, but for
round-off, to solving each scenario on every vertex (tests/test_response_plate.py; the penalties bring that
round-off to ~1e-7 in the logarithms), at a third of the cost.

All four are returned as logarithms. Compiled (numba): skyline (envelope) Cholesky factorisations in reverse
Cuthill–McKee order, spread over the cores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import reverse_cuthill_mckee

import fabpat.shell.kernel_cache  # noqa: F401 - sets numba.config.CACHE_DIR (the user's cache), read by the decorators below
from fabpat.catalog.response_kernels import add_pair, condense, dense_solve, skyline_solve, unit_unused
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
#: patterns are solved in this many chunks at most, spread over the cores (each holds two one-fan blocks)
CHUNKS = 8


@dataclass(frozen=True, eq=False)
class PlateTopology:
    """The lattice of a (sides, depth) polygon as the compiled solves read it (vertices renumbered row by row).

    ``face`` (nf, 3) vertices, ``slice_face`` (nf,), ``grad`` (nf, 2, 3) slope of w per vertex value (1/mm),
    ``area`` (nf,) mm²; ``hinge_*`` and ``neck_*``: the face pairs, their 6 vertices, their slope-jump rows
    and stiffnesses; ``iface`` (n, 4) face, outer vertex, inner vertices; ``moment`` (n, 3) the unit moment's
    load on the interface's outer and inner vertices; ``rep`` (nv,) the fan-0 vertex each vertex is a rotation
    of, ``angle`` (nv,) that rotation (rad), ``fan`` (nv,) its fan; ``pos`` (n_rep,) each fan-0 vertex's
    unknown in a mode's block (the interface's three last), ``first`` (n_rep,) the blocks' skyline; ``phase``
    (n//2 + 1, nv) ω^{k·fan} per mode k (ω = e^{2πi/n}), ``turn`` (n//2 + 1, n) ω^{k·d}."""

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
    fan: NDArray[np.int64]
    pos: NDArray[np.int64]
    phase: NDArray[np.complex128]
    turn: NDArray[np.complex128]


def face_pairs(F: NDArray[np.int64]) -> tuple[list[tuple[int, int, int, int]], list[tuple[int, int]]]:
    """Faces of the triangles ``F`` (m, 3) sharing an edge (f1 < f2, a, b: the edge's vertices, in edge order)
    and sharing only a vertex (f1 < f2, sorted); the learned response's cell adjacency reads the same pairs."""
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


def _block_order(elements: NDArray[np.int64], last: NDArray[np.int64], m: int
                 ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Each fan-0 vertex's unknown in a mode's block (``pos`` (m,)) and the block's skyline (``first`` (m,)):
    the vertices ``last`` (the interface's) at the end in their order, the others in reverse Cuthill–McKee
    order of the coupling by ``elements`` (e, 6) (fan-0 vertices of the hinges and necks), which keeps the
    profile small."""
    rest = np.setdiff1d(np.arange(m), last)
    a = np.repeat(elements, 6, axis=1).ravel()
    b = np.tile(elements, (1, 6)).ravel()
    G = coo_matrix((np.ones(a.size), (a, b)), shape=(m, m)).tocsr()[rest][:, rest]
    pos = np.empty(m, dtype=np.int64)
    pos[rest[reverse_cuthill_mckee(G, symmetric_mode=True)]] = np.arange(rest.size)
    pos[last] = rest.size + np.arange(last.size)
    first = np.arange(m)
    for e in pos[elements]:
        first[e] = np.minimum(first[e], e.min())
    return pos, first


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
    hinges, necks = face_pairs(F)
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
        load = dict(zip(tri.tolist(), ((c / np.linalg.norm(c)) @ grad[f]).tolist(), strict=True))
        moment.append([load[v] for v in iface[-1][1:]])
    n = sides
    owned = (len(V0) - 1) // n
    rep = np.where(order == 0, 0, 1 + (order - 1) % owned)
    fan = np.where(order == 0, 0, (order - 1) // owned)
    angle = 2.0 * math.pi * fan / n
    rows, turn = _membrane_rows(grad, F, angle)
    hinge_orbit, hinge_weight = _orbits(h[:, :2], sides, depth)
    neck_orbit, neck_weight = _orbits(nk, sides, depth)
    mem_first = np.arange(2 * (owned + 1))  # the skyline of the one-fan membrane system (u, v per vertex)
    for verts in [*F[: 4**depth], *F[nk[neck_orbit]].reshape(-1, 6)]:
        dofs = np.concatenate([2 * rep[verts], 2 * rep[verts] + 1])
        mem_first[dofs] = np.minimum(mem_first[dofs], dofs.min())
    iface_ = np.array(iface, dtype=np.int64)
    pos, first = _block_order(rep[np.concatenate([F[h[:, :2]].reshape(-1, 6), F[nk].reshape(-1, 6)])],
                              rep[iface_[0, 1:]], owned + 1)
    k = np.arange(n // 2 + 1)[:, None]
    out = PlateTopology(F, np.asarray(topo.slice_face), grad, area, h[:, :2].copy(), F[h[:, :2]].reshape(-1, 6),
                        hinge_row, 3.0 * L2 / (area[h[:, 0]] + area[h[:, 1]]), nk, F[nk].reshape(-1, 6), neck_rows,
                        NECK * 3.0 * L2 / (area[nk[:, 0]] + area[nk[:, 1]]), iface_, np.array(moment), first, rep,
                        angle, owned + 1, L2, rows, turn, np.arange(4**depth, dtype=np.int64), hinge_orbit,
                        hinge_weight, neck_orbit, neck_weight, mem_first, fan, pos,
                        np.exp(2j * math.pi * k * fan[None, :] / n), np.exp(2j * math.pi * k * np.arange(n) / n))
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
    pairs = (t.hinge_faces, t.hinge_vertices, t.hinge_orbit, t.neck_faces, t.neck_vertices, t.neck_orbit)
    rows = (t.hinge_row, t.hinge_k, t.hinge_weight, t.neck_rows, t.neck_k, t.neck_weight)
    mem = (t.pos, t.rep, t.first, t.iface, t.fan0_faces, t.mem_first)
    reals = (t.grad, t.area, t.mem_rows, t.mem_turn, t.moment, np.ascontiguousarray(t.phase.real))
    return _features(solid, t.face, pairs, rows, mem, reals, (t.phase, t.turn), t.n_rep, t.edge2)


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
            add_pair(K, idx, row, neck_weight[m] * NECK * edge2)
    unit_unused(solid, face, rep, K, 2)
    K[0, 0] += PENALTY  # the centre stays put in a symmetric field
    K[1, 1] += PENALTY
    K[2 * rep[outer0], 2 * rep[outer0]] += PENALTY  # no rigid turn: interface 0 does not slide along its edge
    u = skyline_solve(K, mem_first, f0)
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
def _mode_block(solid: NDArray[np.bool_], face: NDArray[np.int64], pairs: tuple[NDArray[np.int64], ...],
                rows: tuple[NDArray[np.float64], ...], pos: NDArray[np.int64], rep: NDArray[np.int64],
                phase: NDArray, turning: bool, K: NDArray) -> None:
    """K (m, m), lower triangle, := the plate's block of one Fourier mode of the polygon's rotations (module
    doc): Σ over the listed hinge and neck orbits of weight · k · conj(p_a) · (row_a · row_b) · p_b, vertex v as
    unknown ``pos[rep[v]]`` with phase p = ``phase[v]``; ``turning`` (a mode other than the symmetric one): the
    centre does not move. An unknown that no solid face moves gets a unit diagonal."""
    hinge_faces, hinge_vertices, hinges, neck_faces, neck_vertices, necks = pairs
    hinge_row, hinge_k, hinge_weight, neck_rows, neck_k, neck_weight = rows
    m = K.shape[0]
    for i in range(m):
        for j in range(i + 1):
            K[i, j] = 0.0
    idx = np.empty(6, dtype=np.int64)
    ph = np.empty(6, dtype=phase.dtype)
    for kind in range(2):
        orbits = hinges if kind == 0 else necks
        faces = hinge_faces if kind == 0 else neck_faces
        verts = hinge_vertices if kind == 0 else neck_vertices
        for o in range(orbits.size):
            h = orbits[o]
            if not (solid[faces[h, 0]] and solid[faces[h, 1]]):
                continue
            for c in range(6):
                v = verts[h, c]
                idx[c] = -1 if turning and rep[v] == 0 else pos[rep[v]]
                ph[c] = phase[v]
            k = (hinge_weight[o] * hinge_k[h]) if kind == 0 else (neck_weight[o] * neck_k[h])
            for a in range(6):
                if idx[a] < 0:
                    continue
                for b in range(6):
                    if 0 <= idx[b] <= idx[a]:
                        if kind == 0:
                            r = hinge_row[h, a] * hinge_row[h, b]
                        else:
                            r = neck_rows[h, 0, a] * neck_rows[h, 0, b] + neck_rows[h, 1, a] * neck_rows[h, 1, b]
                        K[idx[a], idx[b]] += k * r * np.conj(ph[a]) * ph[b]
    used = np.zeros(m, dtype=np.bool_)
    for f in range(face.shape[0]):
        if solid[f]:
            for c in range(3):
                if not (turning and rep[face[f, c]] == 0):
                    used[pos[rep[face[f, c]]]] = True
    for i in range(m):
        if not used[i]:
            K[i, i] += 1.0


@njit(cache=True)
def _add_mode(S: NDArray[np.float64], K: NDArray, m: int, turn: NDArray[np.complex128], weight: float) -> None:
    """S (3n, 3n) += weight · Re(ω^{k(f−g)} Ŝ_k[i, j]) at interface dof (f, i), (g, j): one mode's share of the
    stiffness condensed onto the interfaces, Ŝ_k the Schur complement in K's last 3 rows (``turn[d]`` = ω^{kd})."""
    n = turn.size
    for i in range(3):
        for j in range(3):
            s = K[m + i, m + j] if j <= i else np.conj(K[m + j, m + i])
            for f in range(n):
                for g in range(n):
                    S[3 * f + i, 3 * g + j] += weight * (turn[(f - g) % n] * s).real


@njit(cache=True)
def _compliance(S: NDArray[np.float64], pins: NDArray[np.int64], clamp: bool, f: NDArray[np.float64],
                scale: float) -> float:
    """½ fᵀu for (S + the pins) u = f, S (3m, 3m) the stiffness on m interfaces' dofs (outer vertex, inner
    ones): each listed interface w = 0 along it (outer fixed, inner ones level) or, ``clamp``, fixed
    altogether, by penalties ``scale`` · :data:`PENALTY`."""
    A = S.copy()
    for i in pins:
        p = scale * PENALTY
        A[3 * i, 3 * i] += p
        A[3 * i + 1, 3 * i + 1] += p
        A[3 * i + 2, 3 * i + 2] += p
        if not clamp:
            A[3 * i + 2, 3 * i + 1] -= p
    return float(0.5 * (f @ dense_solve(A, f)))


@njit(cache=True)
def _one(solid: NDArray[np.bool_], face: NDArray[np.int64], pairs: tuple[NDArray[np.int64], ...],
         rows: tuple[NDArray[np.float64], ...], mem: tuple[NDArray[np.int64], ...],
         reals: tuple[NDArray[np.float64], ...], waves: tuple[NDArray[np.complex128], ...], n_rep: int,
         edge2: float, Kr: NDArray[np.float64], Kc: NDArray[np.complex128], out: NDArray[np.float64]) -> None:
    """The four features of one pattern (``solid`` per face) into ``out``; Kr, Kc: (n_rep, n_rep) work arrays."""
    pos, rep, first, iface, fan0_faces, mem_first = mem
    grad, area, mem_rows, mem_turn, moment, phase_re = reals
    phase, turn = waves
    n = iface.shape[0]
    m = n_rep - 3  # the unknowns condensed out; the last three are the interface's
    S = np.zeros((3 * n, 3 * n))
    w = np.zeros(n_rep)
    for k in range(n // 2 + 1):
        if k == 0 or 2 * k == n:  # the symmetric and the alternating modes are real
            _mode_block(solid, face, pairs, rows, pos, rep, phase_re[k], k > 0, Kr)
            condense(Kr, first, m)
            _add_mode(S, Kr, m, turn[k], 1.0 / (n * n))
        else:  # modes k and n − k are conjugate: one complex block counts twice
            _mode_block(solid, face, pairs, rows, pos, rep, phase[k], True, Kc)
            condense(Kc, first, m)
            _add_mode(S, Kc, m, turn[k], 2.0 / (n * n))
        if k == 0:  # the dome: every interface pinned and loaded alike, the symmetric mode alone
            fb = n * DOME * moment[0]
            Sb = np.zeros((3, 3))
            for i in range(3):
                for j in range(i + 1):
                    Sb[i, j] = Kr[m + i, m + j]
            wb = dense_solve(_pinned(Sb, n), fb)
            out[2] = math.log(0.5 * (fb @ wb))
            w[m:] = wb
            for j in range(m):  # the rest: −L_aa⁻ᴴ L_baᴴ w_b
                for i in range(3):
                    w[j] -= Kr[m + i, j] * wb[i]
            for i in range(m - 1, -1, -1):
                w[i] /= Kr[i, i]
                for j in range(first[i], i):
                    w[j] -= Kr[i, j] * w[i]
    fc = np.zeros(3 * n)
    fc[3 * (n // 2)] = FORCE
    out[0] = math.log(_compliance(S, np.array([0]), True, fc, 1.0))
    fy = np.zeros(3 * n)
    for i in (0, n // 2):
        fy[3 * i: 3 * i + 3] += CYLINDER * moment[i]
    out[1] = math.log(_compliance(S, np.array([0, n // 2]), False, fy, 1.0))
    w_rep = np.empty(n_rep)
    for r in range(n_rep):
        w_rep[r] = w[pos[r]]
    hinge_faces, hinge_vertices, hinges, neck_faces, neck_vertices, necks = pairs
    out[3] = math.log(1.0 + _membrane_energy(solid, face, grad, area, mem_rows, mem_turn, fan0_faces, neck_faces,
                                             necks, rows[5], rep, n_rep, edge2, w_rep, iface[0, 1], n, mem_first))


@njit(cache=True)
def _pinned(Sb: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """One interface's 3×3 lower stiffness with w = 0 along it, penalties n · :data:`PENALTY` (n interfaces
    folded onto one)."""
    A = Sb.copy()
    A[0, 0] += n * PENALTY
    A[1, 1] += n * PENALTY
    A[2, 2] += n * PENALTY
    A[2, 1] -= n * PENALTY
    return A


@njit(cache=True, parallel=True)
def _features(solid: NDArray[np.bool_], face: NDArray[np.int64], pairs: tuple[NDArray[np.int64], ...],
              rows: tuple[NDArray[np.float64], ...], mem: tuple[NDArray[np.int64], ...],
              reals: tuple[NDArray[np.float64], ...], waves: tuple[NDArray[np.complex128], ...], n_rep: int,
              edge2: float) -> NDArray[np.float64]:
    """(k, 4) features of k patterns (``solid`` (k, nf)), in chunks spread over the cores."""
    k = solid.shape[0]
    out = np.zeros((k, N_PHYSICS))
    chunks = min(k, CHUNKS)
    # work arrays per chunk allocated here: numba hoists an allocation inside a prange body out of the loop,
    # which would share it between threads
    work_r = np.zeros((chunks, n_rep, n_rep))
    work_c = np.zeros((chunks, n_rep, n_rep), dtype=np.complex128)
    for c in prange(chunks):
        for p in range(c * k // chunks, (c + 1) * k // chunks):
            _one(solid[p], face, pairs, rows, mem, reals, waves, n_rep, edge2, work_r[c], work_c[c], out[p])
    return out
