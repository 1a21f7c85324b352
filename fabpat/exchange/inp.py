"""Abaqus / CalculiX input deck of a pattern scenario (same mesh, material, supports and loads).

* Elements: **S6** by default (a mid-side node is added on every triangle side; CalculiX expands S3 to
  wedges that lock badly), or ``element="S3"`` / ``"STRI3"`` (Abaqus' thin triangle; CalculiX has
  no STRI3) for Abaqus users: three-node connectivity, loads with the (1/2, 1/2) side weights.
* Numbers are written with ``%.12e`` (≤ 19 characters): CalculiX silently cuts fields longer than 20.
* Interface loads are the same uniform line loads as :mod:`fabpat.scenarios`, with the *consistent*
  weights of the element side: (1/6, 4/6, 1/6)·length for S6 (corner, mid-side, corner), (1/2, 1/2)
  for S3. Equal shares per node would add 2–18 % spurious energy.
* Supports go on every interface node (corner and mid-side). A translational support on a shell node
  is a soft hinge in CalculiX (mid-surface only), as in fabpat.
* Energy output: ``*EL PRINT, TOTALS=ONLY`` with ``ELSE`` at the default frequency 1 (a larger
  frequency makes CalculiX accumulate the NLGEOM energy wrongly).

Known CalculiX 2.20 limits for these decks (notes.md): with NLGEOM, a ``*CLOAD`` moment on a node that
also has an in-plane (DOF 1/2) support stalls Newton (Cylinder and Dome pins), and a moment about an
axis with both x and y components is applied wrongly at large rotation (Dome); compare those two
scenarios with CalculiX *linear* runs. Abaqus is not affected.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fabpat.errors import ExportError
from fabpat.mesh import ShellMesh
from fabpat.scenarios import (
    CANTILEVER_FORCE,
    CYLINDER_MOMENT,
    DOME_MOMENT,
    SCENARIOS,
    edge_tangents,
    opposite,
)

_F = "%.12e"


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


def deck_text(mesh: ShellMesh, scenario: str, *, sides: int, thickness: float = 2.0, E: float = 1000.0,
              nu: float = 0.35, nonlinear: bool = True, element: str = "S6", increment: float = 0.1) -> str:
    """The input deck as a string (see module docstring). Node/element ids are 1-based.

    increment: initial and largest NLGEOM time increment (fraction of the load)."""
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

    bc: list[tuple[int, int, int]] = []  # (node, first dof, last dof), 1-based dofs
    cl: dict[tuple[int, int], float] = {}

    def load(ids: np.ndarray, ws: np.ndarray, dof: int, total: float) -> None:
        for k, w in zip(ids, ws, strict=True):
            cl[(int(k), dof)] = cl.get((int(k), dof), 0.0) + total * w

    def moment(i: int, M: float) -> None:
        ids, ws = line_nodes(i)
        t = edge_tangents(sides)[i]
        for c in range(2):
            if t[c] != 0.0:
                load(ids, ws, 4 + c, M * t[c])

    o = opposite(0, sides)
    if scenario == "cantilever":
        bc += [(int(k), 1, 6) for k in line_nodes(0)[0]]
        load(*line_nodes(o), 3, CANTILEVER_FORCE)
    elif scenario == "cylinder":
        bc += [(int(k), 1, 3) for k in line_nodes(0)[0]]
        bc += [(int(k), 3, 3) for k in line_nodes(o)[0]]
        moment(0, CYLINDER_MOMENT)
        moment(o, CYLINDER_MOMENT)
    else:
        pinned = set(int(k) for k in line_nodes(0)[0])
        bc += [(k, 1, 3) for k in sorted(pinned)]
        for i in range(sides):
            bc += [(int(k), 3, 3) for k in line_nodes(i)[0] if int(k) not in pinned]
            moment(i, DOME_MOMENT)

    out = ["*HEADING", f"fabpat {scenario} scenario, {sides}-gon pattern, {element}, "
           f"{'NLGEOM' if nonlinear else 'linear'}; mm, N, N/mm2", "*NODE, NSET=NALL"]
    out += [f"{k + 1}, {_F % p[0]}, {_F % p[1]}, {_F % p[2]}" for k, p in enumerate(X)]
    out.append(f"*ELEMENT, TYPE={element}, ELSET=EALL")
    if element == "S6":
        conn = np.hstack([F, mids]) + 1
    else:
        conn = F + 1
    out += [f"{e + 1}, " + ", ".join(str(int(c)) for c in row) for e, row in enumerate(conn)]
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
    except OSError as exc:
        raise ExportError(f"cannot write {path}: {exc}") from exc
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
