"""Abaqus / CalculiX input deck of a pattern scenario (same mesh, material, supports and loads).

* Elements: **S6** by default (a mid-side node is added on every triangle side; CalculiX expands S3 to
  wedges that lock badly), or ``element="S3"`` / ``"STRI3"`` (Abaqus' thin triangle; CalculiX has
  no STRI3) for Abaqus users: three-node connectivity, loads with the (1/2, 1/2) side weights.
* Numbers are written with ``%.12e`` (≤ 19 characters): CalculiX silently cuts fields longer than 20.
* Interface loads are the same uniform line loads as :mod:`fabpat.simulation.scenarios`, with the *consistent*
  weights of the element side: (1/6, 4/6, 1/6)·length for S6 (corner, mid-side, corner), (1/2, 1/2)
  for S3. Equal shares per node would add 2–18 % spurious energy.
* Supports as in :mod:`fabpat.simulation.scenarios`, on every interface node (corner and mid-side), except the
  in-plane part of the moment scenarios' pins: with NLGEOM, CalculiX 2.20 stalls on a node that carries
  a ``*CLOAD`` moment and an in-plane (DOF 1/2) support (the Cylinder deck stopped at 5 % of the load,
  notes.md pitfall 3). Cylinder and Dome decks hold uz on the interface nodes and put a statically
  determinate in-plane support (ux, uy at one node, one more component at a second) on corner nodes
  that carry no moment; the moments put no in-plane load on the plate, so these supports carry none.
  Linear CalculiX runs give the same energy with either support (0x5a88 Cylinder, h = 3: 12.33757
  both); fabpat's pins also hold the interface in plane, which only large rotations can feel.
  A translational support on a shell node is a soft hinge in CalculiX (mid-surface only), as in fabpat.
* CalculiX 2.20 NLGEOM applies a moment with both x and y components wrongly at large rotation (a Dome
  deck of 0x5a88 came out 17 % too soft at h = 3, a Cylinder deck of the pentagon 0x0508 20 %). In
  NLGEOM decks the nodes of an interface that is not along x or y get a ``*TRANSFORM`` whose x axis is
  the interface tangent, and the moment is DOF 4 of that frame: CalculiX then agrees with fabpat as on
  the axis-aligned interfaces. The frame alone makes CalculiX about 0.5 % softer per framed interface
  (measured with an identity frame), so linear decks, which need none, keep global components.
* Energy output: ``*EL PRINT, TOTALS=ONLY`` with ``ELSE`` at the default frequency 1 (a larger
  frequency makes CalculiX accumulate the NLGEOM energy wrongly).

Abaqus reads the same keywords (``*TRANSFORM`` applies to rotations there too).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fabpat.errors import ExportError
from fabpat.simulation.mesh import ShellMesh
from fabpat.simulation.scenarios import (
    CANTILEVER_FORCE,
    CYLINDER_MOMENT,
    DOME_MOMENT,
    SCENARIOS,
    edge_tangents,
    opposite,
)

_F = "%.12e"
AXIS_TOL = 1e-12  # a tangent component below this is zero: the interface lies along a global axis


def _midside_nodes(F: np.ndarray, n: int) -> tuple[np.ndarray, dict[tuple[int, int], int]]:
    """(m, 3) mid-side node ids (0-based, numbered from n) of sides (0-1, 1-2, 2-0), and the map."""
    mid: dict[tuple[int, int], int] = {}
    out = np.empty((F.shape[0], 3), dtype=np.int64)
    for e, tri in enumerate(F):
        for k in range(3):
            a, b = int(tri[k]), int(tri[(k + 1) % 3])
            key = (min(a, b), max(a, b))
            if key not in mid:
                mid[key] = n + len(mid)
            out[e, k] = mid[key]
    return out, mid


def _in_plane_supports(V: np.ndarray, busy: set[int], a: np.ndarray, b: np.ndarray) -> list[tuple[int, int, int]]:
    """A statically determinate in-plane support on corner nodes that carry no moment (0-based ids).

    ux, uy at the free node nearest ``a`` and one more component at the free node nearest ``b``: the
    one across the line between the two, so that the in-plane rotation is held as well. The moment
    scenarios put no in-plane load on the plate, so these supports carry nothing."""
    free = np.array([k for k in range(V.shape[0]) if k not in busy], dtype=np.int64)
    if free.size < 2:
        raise ExportError("the mesh has fewer than two nodes off the loaded interfaces to hold it in plane")
    pa = int(free[np.argmin(np.linalg.norm(V[free] - a, axis=1))])
    pb = int(free[np.argmin(np.linalg.norm(V[free] - b, axis=1))])
    if pa == pb:
        raise ExportError("the mesh has no two distinct nodes off the loaded interfaces to hold it in plane")
    d = V[pb] - V[pa]
    dof = 1 if abs(d[1]) >= abs(d[0]) else 2
    return [(pa, 1, 2), (pb, dof, dof)]


def deck_text(mesh: ShellMesh, scenario: str, *, sides: int, thickness: float = 2.0, E: float = 1000.0,
              nu: float = 0.35, nonlinear: bool = True, element: str = "S6", increment: float = 0.1,
              pattern: str = "") -> str:
    """The input deck as a string (see module docstring). Node/element ids are 1-based.

    pattern: what the heading names the plate by (``"0x0488 b0.5"``, :attr:`FilletedPattern.label
    <fabpat.geometry.fillet.FilletedPattern.label>`); "" names only its polygon.

    increment: initial and largest NLGEOM time increment (fraction of the load). Raises ValueError
    for an unknown scenario or element, :class:`ExportError` if an interface is not meshed along
    element sides or the mesh has no two nodes off the loaded interfaces.

    Long because it writes the deck's keyword blocks in the order CalculiX reads them (nodes, elements, sets,
    material, shell section, boundary, step, loads, output), each a few lines.
    """
    if scenario not in SCENARIOS:
        raise ValueError(f"unknown scenario {scenario!r}")
    element = element.upper()
    if element not in ("S6", "S3", "STRI3"):
        raise ValueError(f"element must be S6, S3 or STRI3, got {element!r}")
    V = mesh.V
    n = mesh.n_nodes
    X = np.column_stack([V, np.zeros(n)])
    F = mesh.F
    mids, midmap = _midside_nodes(F, n) if element == "S6" else (None, {})
    if midmap:
        pairs = np.array(sorted(midmap, key=midmap.__getitem__))
        X = np.vstack([X, 0.5 * (X[pairs[:, 0]] + X[pairs[:, 1]])])
    ifs = mesh.interfaces

    def line_nodes(i: int) -> tuple[np.ndarray, np.ndarray]:
        """All nodes of interface i (corner + mid-side) and their consistent shares (sum 1)."""
        nodes = ifs[i]
        seg = np.linalg.norm(np.diff(V[nodes], axis=0), axis=1)
        w: dict[int, float] = {}
        for (a, b), L in zip(zip(nodes[:-1], nodes[1:], strict=True), seg, strict=True):
            a, b = int(a), int(b)
            if element == "S6":
                m = midmap.get((min(a, b), max(a, b)))
                if m is None:
                    raise ExportError(f"interface {i}: nodes {a}, {b} are not joined by an element side")
                w[a] = w.get(a, 0.0) + L / 6
                w[b] = w.get(b, 0.0) + L / 6
                w[m] = w.get(m, 0.0) + 4 * L / 6
            else:
                w[a] = w.get(a, 0.0) + L / 2
                w[b] = w.get(b, 0.0) + L / 2
        ids = np.array(list(w), dtype=np.int64)
        ws = np.array([w[k] for k in ids])
        return ids, ws / ws.sum()

    bc: list[tuple[int, int, int]] = []  # (node, first dof, last dof), 1-based dofs, 0-based nodes
    cl: dict[tuple[int, int], float] = {}  # (node, dof): value; moments about the interface's tangent
    frames: list[tuple[int, np.ndarray]] = []  # (interface, node ids) that get a *TRANSFORM

    def load(ids: np.ndarray, ws: np.ndarray, dof: int, total: float) -> None:
        for k, w in zip(ids, ws, strict=True):
            cl[(int(k), dof)] = cl.get((int(k), dof), 0.0) + total * w

    tangents = edge_tangents(sides)
    o = opposite(0, sides)
    if scenario == "cantilever":
        bc += [(int(k), 1, 6) for k in line_nodes(0)[0]]
        load(*line_nodes(o), 3, CANTILEVER_FORCE)
    else:
        loaded = (0, o) if scenario == "cylinder" else tuple(range(sides))
        M = CYLINDER_MOMENT if scenario == "cylinder" else DOME_MOMENT
        busy: set[int] = set()
        for i in loaded:
            ids, ws = line_nodes(i)
            t = tangents[i]
            bc += [(int(k), 3, 3) for k in ids]  # a local frame below keeps z: DOF 3 stays the global uz
            if nonlinear and min(abs(t[0]), abs(t[1])) > AXIS_TOL:
                load(ids, ws, 4, M)  # DOF 4: the rotation about the local x axis, the interface tangent
                frames.append((i, ids))
            else:
                for c in range(2):
                    if abs(t[c]) > AXIS_TOL:
                        load(ids, ws, 4 + c, M * t[c])
            busy |= {int(k) for k in ids}
        mid = [V[ifs[i]].mean(axis=0) for i in (0, o)]
        bc += _in_plane_supports(V, busy, mid[0], mid[1])

    mode = "NLGEOM" if nonlinear else "linear"
    what = f"pattern {pattern} ({sides}-gon)" if pattern else f"{sides}-gon pattern"
    out = ["*HEADING", f"fabpat {scenario} scenario, {what}, {element}, {mode}; mm, N, N/mm2"]
    if scenario != "cantilever":
        out += ["** In-plane supports sit on nodes that carry no moment (CalculiX NLGEOM stalls on nodes with",
                "** both): ux, uy at one node and one more component at a second hold the plate in plane and",
                "** carry nothing, as the moments put no in-plane load on it; the interfaces carry uz only."]
    if frames:
        out += ["** CalculiX 2.20 NLGEOM applies a moment with both x and y components wrongly at large",
                "** rotation. The nodes of an interface that is not along x or y get a *TRANSFORM whose x axis",
                "** is the interface tangent, and their moment is DOF 4 of that frame: then CalculiX agrees",
                "** with fabpat (the frame alone makes CalculiX about 0.5 % softer per framed interface)."]
    out.append("*NODE, NSET=NALL")
    out += [f"{k + 1}, {_F % p[0]}, {_F % p[1]}, {_F % p[2]}" for k, p in enumerate(X)]
    out.append(f"*ELEMENT, TYPE={element}, ELSET=EALL")
    if element == "S6":
        conn = np.hstack([F, mids]) + 1
    else:
        conn = F + 1
    out += [f"{e + 1}, " + ", ".join(str(int(c)) for c in row) for e, row in enumerate(conn)]
    for i, ids in frames:
        t = tangents[i]
        out.append(f"*NSET, NSET=IF{i}")
        out += [", ".join(str(int(k) + 1) for k in ids[j:j + 8]) for j in range(0, len(ids), 8)]
        out += [f"*TRANSFORM, NSET=IF{i}, TYPE=R", f"{_F % t[0]}, {_F % t[1]}, 0, {_F % -t[1]}, {_F % t[0]}, 0"]
    out += ["*MATERIAL, NAME=PLA", "*ELASTIC", f"{_F % E}, {_F % nu}",
            "*SHELL SECTION, ELSET=EALL, MATERIAL=PLA", _F % thickness, "*BOUNDARY"]
    out += [f"{k + 1}, {a}, {b}" for k, a, b in bc]
    out += ["*STEP, NLGEOM, INC=1000" if nonlinear else "*STEP", "*STATIC"]
    if nonlinear:
        out.append(f"{min(0.05, increment):g}, 1.0, 1e-6, {increment:g}")
    out.append("*CLOAD")
    out += [f"{k + 1}, {d}, {_F % v}" for (k, d), v in sorted(cl.items()) if v != 0.0]
    out += ["*NODE PRINT, NSET=NALL", "U", "*EL PRINT, ELSET=EALL, TOTALS=ONLY", "ELSE", "*END STEP", ""]
    return "\n".join(out)


def write_inp(path: str | Path, mesh: ShellMesh, scenario: str, **kwargs: object) -> Path:
    """Write :func:`deck_text` to ``path``; keyword arguments as :func:`deck_text`."""
    path = Path(path)
    try:
        path.write_text(deck_text(mesh, scenario, **kwargs))  # type: ignore[arg-type]
    except OSError as exc:  # atomic_outputs names the target, not this temporary file, and a full disk
        from fabpat.io import writer_failed

        raise writer_failed(path, "cannot write the CalculiX deck", exc) from exc
    return path


def read_ccx_energy(dat_path: str | Path) -> float:
    """Last total internal energy printed by CalculiX (``*EL PRINT … TOTALS=ONLY``, ``ELSE``) in a .dat."""
    lines = Path(dat_path).read_text().splitlines()
    val = None
    for i, line in enumerate(lines):
        if "total internal energy" in line.lower():
            for nxt in lines[i + 1:]:
                if nxt.strip():
                    val = float(nxt.split()[-1])
                    break
    if val is None:
        raise ExportError(f"no internal energy found in {dat_path}")
    return val
