"""Congruent triangles share their reference data: the compiled corotational triangles of a mesh in which
many triangles are copies of a few, up to a rigid motion (:mod:`fabpat.shell.compiled`).

An assembly of 92 plates of two types has 92 copies of two plate meshes, placed by rigid motions. A
triangle's reference data in the corotational formulation (Felippa & Haugen, CMAME 194 (2005) 2285;
:mod:`fabpat.shell.corotational`) live in its own initial frame: the corner coordinates in that frame,
the shape-function gradients, the local stiffness K (the membrane and bending-shear blocks of
:func:`fabpat.shell.element.local_stiffness`) and its root Q (K = QᵀQ) depend on the triangle's shape,
corner order, material and thickness only, not on where it sits. Only the initial frame E0 (3 × 3) is
the triangle's own. So the mesh passes a hint, ``congruent`` (m,): for each triangle another whose
reference geometry equals its own up to a rigid motion, with the same corner order and thickness (its own
number where it has none). The reference data are then computed and stored once per distinct number and
every triangle reads its row (:func:`fabpat.shell.kernels.shared_element_kernels`). The shell engine
knows triangles, not plates: the assembly model gives the hint (:class:`fabpat.assembly.solve.model.AssemblyModel`).

The hint is checked, not trusted: every triangle's corners in its own initial frame must match its
representative's to :data:`CONGRUENT_TOLERANCE` of the mesh's size (mm), else GeometryError. Shared rows
change nothing but round-off: a copy's data computed from its placed coordinates differ from its
representative's by ~1e-16 relative (bitwise equal for copies turned by quarter turns about the axes,
tested), and the forces and tangents of the shared rows are those of the representative's numbers,
bitwise. On GP(3, 0) at h = 3 (92 plates of two types: 44 688 triangles, 936 rows) the linked solver's
set-up takes 0.67 CPU seconds rather than 2.45 and its reference data 6 MB rather than 284 MB.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.shell.compiled import CompiledTriangles, kernel_lock
from fabpat.shell.element import BENDING_DOFS, MEMBRANE_DOFS, Material, element_frames
from fabpat.shell.kernels import shared_element_kernels
from fabpat.shell.strain import strain_from_dofs

Arr = NDArray[np.float64]

#: largest difference between a triangle's corners and its representative's, each in its own initial
#: frame, as a fraction of the mesh's largest coordinate (mm): placements are rigid to ~1e-15, so a
#: larger difference is a wrong hint (another shape, a mirror image, another corner order)
CONGRUENT_TOLERANCE = 1e-9
#: triangles per batch of :meth:`CongruentTriangles.energy_split` (bounds the gathered 9 × 9 blocks)
_CHUNK = 8192


def representatives(congruent: NDArray[np.int64], m: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(distinct triangle numbers (k,), each triangle's row among them (m,)) of a hint ``congruent`` (m,)
    (module doc). Raises GeometryError unless it holds m triangle numbers 0 … m − 1."""
    c = np.asarray(congruent)
    if c.shape != (m,) or not np.issubdtype(c.dtype, np.integer) or (m and (c.min() < 0 or c.max() >= m)):
        raise GeometryError(f"congruent must hold one triangle number 0 … {m - 1} per triangle ({m})")
    reps, rows = np.unique(c.astype(np.int64), return_inverse=True)
    return reps, rows.astype(np.int64).reshape(m)


class CongruentTriangles:
    """The compiled corotational triangles of a mesh whose congruent triangles share their reference data
    (module doc): the interface the linked solver uses of :class:`~fabpat.shell.compiled.CompiledTriangles`
    (``F``, ``edofs``, ``threads``, :meth:`forces_at`, :meth:`tangents_at`, :meth:`linear_diagonal`,
    :meth:`energy_split`), same shapes and units, and for the same numbers the same results bitwise; and
    the surface strains of a state (:meth:`surface_strains`).

    X: (n, 3) node coordinates (mm); F: (m, 3) triangles; mat: material and thickness; congruent: (m,)
    the hint; ``thickness`` (m,) mm per triangle (None: ``mat.t``). ``reference`` is the compiled triangles of
    the representatives alone. Raises GeometryError on a hint that names a non-congruent triangle or one of
    another thickness, GeometryError on a ``thickness`` of the wrong shape or not positive.
    """

    def __init__(self, X: Arr, F: NDArray[np.int64], mat: Material, congruent: NDArray[np.int64], *,
                 threads: int | None = None, thickness: Arr | None = None) -> None:
        self.X = np.asarray(X, dtype=np.float64)
        self.F = np.array(F, dtype=np.int64, order="C")  # writable: one compiled signature (CompiledTriangles)
        self.mat = mat
        m = len(self.F)
        reps, self.rows = representatives(congruent, m)
        if thickness is not None:
            t = np.asarray(thickness, dtype=np.float64)
            if t.shape == (m,) and not np.array_equal(t, t[reps][self.rows]):
                raise GeometryError("congruent triangles must have the same thickness")
        own_t = None if thickness is None else np.asarray(thickness, dtype=np.float64)[reps]
        self.reference = CompiledTriangles(self.X, self.F[reps], mat, threads=threads, thickness=own_t)
        self.E0, x, y = element_frames(self.X, self.F)
        self.thickness = None if thickness is None else np.asarray(thickness, dtype=np.float64)
        #: (m, 3, 2) each triangle's corners in its initial frame (mm): its representative's
        self.xl0 = ref = self.reference.xl0[self.rows]
        scale = max(float(np.abs(self.X).max(initial=0.0)), 1.0)
        worst = max(float(np.abs(x - ref[..., 0]).max(initial=0.0)), float(np.abs(y - ref[..., 1]).max(initial=0.0)))
        if not worst <= CONGRUENT_TOLERANCE * scale:
            raise GeometryError(f"the triangles named congruent are not: corners {worst:.3g} mm apart in their own "
                             "frames (another shape, a mirror image or another corner order)")
        self.threads = self.reference.threads
        self.edofs = (6 * self.F[:, :, None] + np.arange(6)).reshape(-1, 18)
        r = self.reference
        gN, xl0, _, K, Q = r._consts  # the representatives' own, as the kernels' warm-up passes them
        self._consts = (gN, xl0, np.ascontiguousarray(self.E0), K, Q, np.ascontiguousarray(self.rows, dtype=np.int64))
        self._fe, self._U, self._d = np.empty((m, 18)), np.empty(m), np.empty((m, 18))
        self._Kt: Arr | None = None

    def _run(self, x: Arr, R: Arr, Kt: Arr | None) -> None:
        x = np.ascontiguousarray(x, dtype=np.float64)
        R = np.ascontiguousarray(R, dtype=np.float64)
        gN, xl0, E0, K, Q, rows = self._consts
        with kernel_lock():
            numba.set_num_threads(self.threads)
            shared_element_kernels(x, R, self.F, gN, xl0, E0, K, Q, rows, self._fe, self._U, self._d,
                            Kt if Kt is not None else np.empty((0, 18, 18)), Kt is not None)

    def forces_at(self, x: Arr, R: Arr) -> tuple[Arr, Arr, Arr]:
        """Element internal forces (m, 18) N and N·mm, strain energies (m,) N·mm and local dofs (m, 18) at
        node positions x (n, 3) mm and rotations R (n, 3, 3)."""
        self._run(x, R, None)
        return self._fe.copy(), self._U.copy(), self._d.copy()

    def tangents_at(self, x: Arr, R: Arr) -> Arr:
        """(m, 18, 18) consistent tangents at node positions x (n, 3) mm and rotations R (n, 3, 3); the array
        is overwritten by the next call."""
        if self._Kt is None:
            self._Kt = np.empty((len(self.F), 18, 18))
        self._run(x, R, self._Kt)
        return self._Kt

    def linear_diagonal(self) -> Arr:
        """(m, 18) diagonals of the global-frame element stiffness at the initial geometry
        (:meth:`fabpat.shell.compiled.CompiledTriangles.linear_diagonal`), each triangle's own frame E0 on its
        representative's K."""
        K = self.reference.local.K.reshape(-1, 6, 3, 6, 3)
        blocks = K[:, np.arange(6), :, np.arange(6), :][:, self.rows]  # (6, m, 3, 3) node-dof diagonal blocks
        return np.einsum("mij,bmjk,mik->mbi", self.E0, blocks, self.E0).reshape(len(self.F), 18)

    def surface_strains(self, x: Arr, R: Arr) -> Arr:
        """(m,) per triangle the largest principal strain magnitude on either surface (dimensionless,
        :func:`fabpat.shell.strain.surface_strains`) at node positions x (n, 3) mm and rotations R (n, 3, 3),
        of the local dofs the compiled kernels give (no local stiffness per triangle). Raises GeometryError
        on a degenerate (zero-area) deformed triangle."""
        with np.errstate(divide="ignore", invalid="ignore"):
            out = strain_from_dofs(self, self.forces_at(x, R)[2], self.thickness).peak
        if not np.all(np.isfinite(out)):
            raise GeometryError("degenerate (zero-area) triangle in the deformed mesh")
        return out

    def energy_split(self, d: Arr) -> Arr:
        """(m, 3) element energies (membrane, bending, transverse shear) N·mm of local dofs d (m, 18)
        (:meth:`fabpat.shell.corotational.CorotationalTriangles.energy_split`), in batches of
        :data:`_CHUNK` triangles."""
        L, out = self.reference.local, np.empty((len(self.F), 3))
        for a in range(0, len(self.F), _CHUNK):
            rw = self.rows[a:a + _CHUNK]
            dm, db = d[a:a + _CHUNK][:, MEMBRANE_DOFS], d[a:a + _CHUNK][:, BENDING_DOFS]
            out[a:a + _CHUNK] = 0.5 * np.stack([np.einsum("mi,mij,mj->m", dm, L.Km[rw], dm),
                                                np.einsum("mi,mij,mj->m", db, L.Kb[rw], db),
                                                np.einsum("mi,mij,mj->m", db, L.Ks[rw], db)], axis=1)
        return out
