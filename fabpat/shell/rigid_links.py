"""Shells with rigid links: the problem (:class:`LinkedProblem`) and its master–slave elimination.

This room holds what a link is and the reduced (slave-free) system every Newton iteration of
:func:`fabpat.shell.linked.solve_path` assembles: index maps, slave placement, forces moved to the
masters and the transformed tangent; the path following itself (prescribed motion, increments)
is :mod:`fabpat.shell.linked`.

A :class:`LinkedProblem` is a triangle mesh (any number of disconnected plates, placed in 3D) plus
extra 6-dof **master** nodes. A *rigid link* ties a mesh node i (the slave) to a master s:

    x_i = x_s + R_s (Q_i(λ) (X_i − X_s) + λ t_i),    R_i = R_s Q_i(λ),    Q_i(λ) = exp(λ [φ_i]×)

(X reference positions, R total rotations, φ_i a relative rotation vector and t_i a relative offset
(mm), both in reference axes and reached at λ = 1: a rampable joint angle and a gap the joint closes;
φ = t = 0 is a rigid weld to the master). The offset changes where a slave sits, not how it moves with
its master, so the variations below hold with c_i the current lever arm. Slaves are eliminated: the
unknowns are the other mesh nodes and the masters. Their variations are δx_i = δx_s + δω_s × c_i,
δω_i = δω_s (c_i = x_i − x_s, spatial spins), i.e. a 6 × 6 block T_i = [[I, −[c_i]×], [0, I]] that
is applied to the element matrices of the elements touching a slave; the slaves' forces are sent to
their master (f_s += g_i, m_s += m_i + c_i × g_i) and the constraint's curvature adds
Σ_i [g_i]×[c_i]× to the master's spin–spin block (g_i the slave's net force), so Newton keeps its
quadratic rate. After every correction the slaves are recomputed from their master exactly, so the
constraints hold to round-off and the residual is the exact one (Felippa, *Nonlinear Finite Element
Methods*, ch. 9, master–slave elimination; Crisfield vol. 2 §17 for the rotation updates).
"""

from __future__ import annotations

import hashlib
import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from fabpat.shell.compiled import CompiledAssembler, CompiledTriangles, transform_elements
from fabpat.shell.congruent import CongruentTriangles, representatives
from fabpat.shell.element import Material
from fabpat.shell.linalg import Pardiso, SuperLUFactorizer, factorizer
from fabpat.shell.rotations import expmap, skew

Arr = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class LinkedProblem:
    """Triangle mesh + master nodes + rigid links + prescribed motion (see module doc).

    X: (n, 3) mesh node coordinates (mm). F: (m, 3) triangles. material: shell material.
    masters: (s, 3) master node positions (mm); they are nodes n … n + s − 1 of every (N, 6) array.
    link_slave: (k,) mesh node indices; link_master: (k,) master numbers 0 … s − 1; link_spin: (k, 3)
    relative rotation (rad, reference axes) of each slave about its master reached at λ = 1; link_offset:
    (k, 3) relative translation (mm, reference axes) reached at λ = 1 (default none).
    fixed: (N, 6) bool prescribed dofs (N = n + s); prescribed: (N, 6) their values at λ = 1 (mm, rad);
    loads: (N, 6) forces (N) and moments (N·mm) at λ = 1, global axes, fixed directions.
    dead_loads: (N, 6) forces and moments reached in full early on the path and held after it (default
    none): they grow linearly over λ ∈ [0, ``dead_ramp``] (0: full from the start). A load that only
    selects a branch (an imperfection) need not grow with the path, and near its full size at a
    bifurcation's knee it rounds the knee off; ramping it, rather than applying it at once, lets a
    halved increment carry less of it where the structure is too soft to take it in one step
    (docs/assembly-solver.md, Solver speed).
    thickness: (m,) mm per triangle, for plates of different thickness (default None: ``material.t``
    everywhere; :class:`fabpat.shell.compiled.CompiledTriangles`).
    congruent: (m,) a hint, for each triangle another whose reference geometry equals its own up to a rigid
    motion (same corner order, same thickness), its own number where it has none: congruent triangles then
    share their local stiffness (:mod:`fabpat.shell.congruent`; default None: each its own).
    Raises ValueError on inconsistent shapes, a slave linked twice or fixed, a partly prescribed
    nonzero rotation, or a ``congruent`` hint that is not one triangle number per triangle.
    """

    X: Arr
    F: NDArray[np.int64]
    material: Material
    masters: Arr
    link_slave: NDArray[np.int64]
    link_master: NDArray[np.int64]
    link_spin: Arr
    fixed: NDArray[np.bool_]
    prescribed: Arr
    loads: Arr
    link_offset: Arr | None = None
    dead_loads: Arr | None = None
    dead_ramp: float = 0.0
    thickness: Arr | None = None
    congruent: NDArray[np.int64] | None = None

    def load_at(self, lam: float) -> Arr:
        """(N, 6) external forces (N) and moments (N·mm) at load fraction ``lam``: λ·loads plus the
        dead loads' share, min(1, λ / dead_ramp) (1 when dead_ramp = 0)."""
        share = 1.0 if self.dead_ramp <= 0.0 else min(1.0, lam / self.dead_ramp)
        return lam * self.loads + share * self.dead_loads  # type: ignore[operator] (arrays after __post_init__)

    def __post_init__(self) -> None:
        X = np.asarray(self.X, dtype=np.float64)
        if X.shape[1] == 2:
            X = np.column_stack([X, np.zeros(len(X))])
        M = np.asarray(self.masters, dtype=np.float64).reshape(-1, 3)
        N = len(X) + len(M)
        sl = np.asarray(self.link_slave, dtype=np.int64).ravel()
        ma = np.asarray(self.link_master, dtype=np.int64).ravel()
        sp = np.asarray(self.link_spin, dtype=np.float64).reshape(-1, 3)
        fixed = np.asarray(self.fixed, dtype=bool).reshape(-1, 6)
        pres = np.asarray(self.prescribed, dtype=np.float64).reshape(-1, 6)
        loads = np.asarray(self.loads, dtype=np.float64).reshape(-1, 6)
        if not (len(sl) == len(ma) == len(sp)) or fixed.shape[0] != N or pres.shape[0] != N or loads.shape[0] != N:
            raise ValueError(f"inconsistent shapes: {len(X)} nodes + {len(M)} masters, links {len(sl)}/{len(ma)}/"
                             f"{len(sp)}, fixed {fixed.shape}, prescribed {pres.shape}, loads {loads.shape}")
        if sl.size and (sl.min() < 0 or sl.max() >= len(X) or ma.min() < 0 or ma.max() >= len(M)):
            raise ValueError("link indices out of range")
        if np.unique(sl).size != sl.size:
            raise ValueError("a node is linked to more than one master")
        if fixed[sl].any():
            raise ValueError("a linked (slave) node cannot have prescribed dofs: prescribe its master")
        partial = fixed[:, 3:].any(axis=1) & ~fixed[:, 3:].all(axis=1) & (pres[:, 3:] != 0).any(axis=1)
        if partial.any():
            raise ValueError("a nonzero prescribed rotation needs all three rotations of the node prescribed")
        off = np.zeros_like(sp) if self.link_offset is None else np.asarray(self.link_offset, np.float64).reshape(-1, 3)
        if off.shape != sp.shape:
            raise ValueError(f"link_offset has {len(off)} rows for {len(sp)} links")
        dead = (np.zeros_like(loads) if self.dead_loads is None
                else np.asarray(self.dead_loads, dtype=np.float64).reshape(-1, 6))
        if dead.shape != loads.shape:
            raise ValueError(f"dead_loads has {len(dead)} rows for {len(loads)} nodes")
        if self.thickness is not None:
            t = np.asarray(self.thickness, dtype=np.float64)
            if t.shape != (len(self.F),) or not np.all(np.isfinite(t)) or not np.all(t > 0.0):
                raise ValueError(f"thickness must be {len(self.F)} finite positive numbers (mm), one per triangle")
            object.__setattr__(self, "thickness", t)
        if self.congruent is not None:
            representatives(self.congruent, len(self.F))  # ValueError on a malformed hint
            object.__setattr__(self, "congruent", np.asarray(self.congruent, dtype=np.int64))
        if not 0.0 <= self.dead_ramp <= 1.0:
            raise ValueError(f"dead_ramp must lie in [0, 1], got {self.dead_ramp!r}")
        for name, v in (("X", X), ("masters", M), ("link_spin", sp), ("prescribed", pres), ("loads", loads),
                        ("link_offset", off), ("dead_loads", dead)):
            object.__setattr__(self, name, v)
        object.__setattr__(self, "F", np.asarray(self.F, dtype=np.int64))
        object.__setattr__(self, "link_slave", sl)
        object.__setattr__(self, "link_master", ma)
        object.__setattr__(self, "fixed", fixed)

    @property
    def n_nodes(self) -> int:
        """Mesh nodes plus master nodes."""
        return len(self.X) + len(self.masters)

    @property
    def n_dofs(self) -> int:
        """Unknowns after eliminating slaves and dofs fixed at 0 (the size of the linear systems)."""
        N = self.n_nodes
        slave = np.zeros(N, dtype=bool)
        slave[self.link_slave] = True
        return int(np.sum(~(self.fixed & (self.prescribed == 0)) & ~slave[:, None]))


class SolverSetup:
    """What the solves of one mesh share: the reduced system's assembler (sparse pattern and scatter, the
    largest set-up outside the Newton iterations) and the factoriser holding PARDISO's symbolic analysis of
    that pattern. A caller that solves one tiling again and again (a design's angle search: the same
    meshes and supports, other sleeve angles) holds one and passes it to each solve
    (:func:`fabpat.shell.linked.solve_path`'s ``setup``); the second solve then builds no pattern and
    analyses nothing, only refactors. The assembler is keyed by a digest of its inputs (element dofs,
    free mask, threads), which fix the pattern; another mesh replaces it (one is kept: a design's meshes
    do not alternate). The factoriser re-analyses by itself when the pattern changes
    (:class:`fabpat.shell.linalg.Pardiso`). ``assemblers`` counts the assemblers built. A copy sent to
    another process (pickle) arrives empty: a compiled assembler and a PARDISO handle stay in their
    process."""

    def __init__(self) -> None:
        self._key = b""
        self._asm: CompiledAssembler | None = None
        self._fz: Pardiso | SuperLUFactorizer | None = None
        self._fzT: Pardiso | SuperLUFactorizer | None = None
        self.assemblers = 0
        #: whose matrix the transposed factoriser holds (a PARDISO factoriser solves with its latest one)
        self.transposed_of: weakref.ref[object] | None = None

    def _empty(self) -> None:
        self._key, self._asm, self._fz, self._fzT, self.assemblers = b"", None, None, None, 0
        self.transposed_of = None

    def assembler(self, edofs: NDArray[np.int64], free: NDArray[np.bool_], threads: int | None) -> CompiledAssembler:
        """The compiled assembler of element dofs ``edofs`` (m, 18) and free mask ``free`` (N,), the kept one
        if its inputs were these."""
        h = hashlib.blake2b(digest_size=16)
        for a in (np.ascontiguousarray(edofs, dtype=np.int64), np.ascontiguousarray(free, dtype=bool)):
            h.update(str(a.shape).encode())
            h.update(a.tobytes())
        h.update(str(threads).encode())
        key = h.digest()
        if self._asm is None or key != self._key:
            self._asm, self._key = CompiledAssembler(edofs, free, threads), key
            self.assemblers += 1
        return self._asm

    def factorizer(self, transposed: bool = False) -> Pardiso | SuperLUFactorizer:
        """The shared factoriser (:func:`fabpat.shell.linalg.factorizer`, made on first use); ``transposed``:
        the one kept for the transposed tangents of adjoint solves, whose pattern (Kᵀ's) is another
        but as fixed by the mesh. Raises SolverError as that function."""
        if transposed:
            if self._fzT is None:
                self._fzT = factorizer()
            return self._fzT
        if self._fz is None:
            self._fz = factorizer()
        return self._fz

    def __getstate__(self) -> dict[str, object]:
        return {}

    def __setstate__(self, state: dict[str, object]) -> None:
        self._empty()


class _Reduced:
    """Index maps and operators of the reduced (slave-free) system of a LinkedProblem; the element
    kernels and the matrix sums run compiled on ``threads`` threads (:mod:`fabpat.shell.compiled`);
    the assembler comes from ``setup`` when given (:class:`SolverSetup`)."""

    def __init__(self, p: LinkedProblem, threads: int | None = None, setup: SolverSetup | None = None) -> None:
        n, N = len(p.X), p.n_nodes
        self.n, self.N = n, N
        self.model: CompiledTriangles | CongruentTriangles = (
            CompiledTriangles(p.X, p.F, p.material, threads=threads, thickness=p.thickness) if p.congruent is None
            else CongruentTriangles(p.X, p.F, p.material, p.congruent, threads=threads, thickness=p.thickness))
        rep = np.arange(N)
        rep[p.link_slave] = n + p.link_master
        self.slave_mask = np.zeros(N, dtype=bool)
        self.slave_mask[p.link_slave] = True
        s = len(p.masters)
        Fr = np.vstack([rep[p.F], np.repeat(n + np.arange(s), 3).reshape(s, 3)])  # + one pseudo-element per master
        edofs = (6 * Fr[:, :, None] + np.arange(6)).reshape(-1, 18)
        zero_fixed = p.fixed & (p.prescribed == 0)
        free = ~zero_fixed & ~self.slave_mask[:, None]
        self.asm = (CompiledAssembler(edofs, free.ravel(), threads) if setup is None
                    else setup.assembler(edofs, free.ravel(), threads))
        # prescribed (nonzero) dofs: identity rows in the matrix, excluded from the residual test
        self.moving = (p.fixed & ~zero_fixed).ravel()
        pos = np.full(6 * N, -1)
        pos[self.asm.free] = np.arange(self.asm.free.size)
        self.rows_p = pos[np.flatnonzero(self.moving)]
        self.test = self.asm.free[~self.moving[self.asm.free]]  # dofs whose residual must vanish
        # elements touching a slave: their corner blocks get the transformation T
        corner = self.slave_mask[p.F]  # (m, 3)
        self.aff = np.flatnonzero(corner.any(axis=1))
        self.aff_corner = corner[self.aff]
        self.master_of = np.full(N, -1)
        self.master_of[p.link_slave] = n + p.link_master
        self.m, self.s = len(p.F), s
        self._rows: NDArray[np.int64] | None = None
        self._diag: NDArray[np.int64] | None = None

    def place_slaves(self, p: LinkedProblem, x: Arr, R: Arr, lam: float) -> None:
        """Slave positions and rotations from their masters (in place), at joint angles λ φ."""
        if p.link_slave.size == 0:
            return
        ms = self.n + p.link_master
        Q = expmap(lam * p.link_spin)
        Rm = R[ms]
        RQ = Rm @ Q
        r0 = p.X[p.link_slave] - p.masters[p.link_master]
        x[p.link_slave] = x[ms] + np.einsum("kij,kj->ki", RQ, r0) + lam * np.einsum("kij,kj->ki", Rm, p.link_offset)
        R[p.link_slave] = RQ

    def forces(self, p: LinkedProblem, x: Arr, R: Arr, lam: float) -> tuple[Arr, Arr, Arr, Arr]:
        """Full-space net internal force g = f_int − λ f_ext − f_dead (N, 6), element forces, energies, local dofs."""
        n = self.n
        fe, U, d = self.model.forces_at(x, R)  # the mesh's nodes come first: masters are not read
        g = np.zeros(6 * self.N)
        g[: 6 * n] = np.bincount(self.model.edofs.ravel(), weights=fe.ravel(), minlength=6 * n)
        g = g.reshape(-1, 6) - p.load_at(lam)
        return g, fe, U, d

    def reduce(self, p: LinkedProblem, g: Arr, x: Arr) -> Arr:
        """Reduced net force (N, 6) of the full one: slaves' forces moved to their masters."""
        gr = g.copy()
        if p.link_slave.size:
            sl, ms = p.link_slave, self.n + p.link_master
            c = x[sl] - x[ms]
            np.add.at(gr, ms, np.concatenate([g[sl, :3], g[sl, 3:] + np.cross(c, g[sl, :3])], axis=1))
            gr[sl] = 0.0
        return gr

    def matrix(self, p: LinkedProblem, x: Arr, R: Arr, d: Arr, g: Arr, scale: float) -> sp.csc_matrix:
        """Reduced tangent (CSC) with identity rows (× scale) at the prescribed dofs."""
        n = self.n
        Ke = self.model.tangents_at(x, R)
        if self.aff.size:
            F = p.F[self.aff]
            c = x[F] - x[np.where(self.master_of[F] >= 0, self.master_of[F], F)]  # (a, 3, 3); 0 off slaves
            transform_elements(Ke, self.aff, c, self.model.threads)
        Km = np.zeros((self.s, 18, 18))
        if p.link_slave.size:
            sl, mm = p.link_slave, p.link_master
            c = x[sl] - x[n + mm]
            blk = skew(g[sl, :3]) @ skew(c)
            np.add.at(Km[:, 3:6, 3:6], mm, blk)
        K = self.asm.matrix(Ke, Km)
        if self.rows_p.size:
            if self._rows is None:  # the sparsity pattern is fixed: find the entries once
                col = np.repeat(np.arange(K.shape[1]), np.diff(K.indptr))
                self._rows = np.flatnonzero(np.isin(K.indices, self.rows_p))
                self._diag = np.flatnonzero(np.isin(K.indices, self.rows_p) & (K.indices == col))
            K.data[self._rows] = 0.0
            K.data[self._diag] = scale
        return K
