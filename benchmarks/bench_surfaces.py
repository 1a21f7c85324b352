"""Designing any surface: each target designed, its design.toml re-simulated by ``simulate-assembly``, and the
re-simulated plates measured against the target by a fit of this script's own (not the design's).

Run: ``python benchmarks/bench_surfaces.py [--h H] [--max-solves N] [--cases NAME,…] [--out DIR]``.

Cases (name: target, base spec, ``--vary``, ``--per``):

* ``ellipsoid``: ``ellipsoid:1,1,1.15`` on ``assemblies/truncated-icosahedron.toml``, shapes,patterns,angles, face;
* ``ellipsoid-flat``: the same target with ``--vary patterns --per group`` (the design before shapes);
* ``sphere``: ``sphere`` on the same base, patterns,angles, group;
* ``dome``: ``cap:0.75`` on ``assemblies/hex-cap-dome.toml``, patterns,angles, group;
* ``barrel``: ``revolution:0.45,0.5,0.45`` on ``assemblies/hex-tube-revolution.toml``, patterns,angles, group;
* ``tube``: ``revolution:0.45,0.475,0.5,0.5,0.5,0.475,0.45`` (a cylinder with tipped ends) on the same base.

An open target (``cap:H``, ``revolution:…``) is fitted here by its own definition (docs/design.md, "Open
surfaces"), coded apart from :mod:`fabpat.design.revolution`: the target as large as the nodes (the RMS distance
from the centroid, the target's by quadrature of its area), the distance in closed form for the cap (from the
sphere inside the cap's cone, else from the rim circle) and from the nearest of 20 001 points of the meridian for
a revolution (within 2.5e-5 of its length), the origin and axis by least squares started along each principal
axis of the nodes, the best kept; rms over the nodes' RMS distance from their centroid, as the design's.
``--reuse`` measures designs already in ``--out``.

Each row: the design's own ``relative_rms``, the re-simulated one (the deformed plate nodes of the VTU, fitted
here: centre, rotation and scale of the target by nonlinear least squares on the first-order distance
g/|∇g|, g(q) = |q / (s·semi-axes)| − 1, started with the target's distinct axis along each principal axis of the
nodes, the best kept; rms over the fitted scale s, the semi-axis of ratio 1), the peak strain, the solves and
the seconds. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]
TI = str(ROOT / "assemblies" / "truncated-icosahedron.toml")
CAP = str(ROOT / "assemblies" / "hex-cap-dome.toml")
TUBE = str(ROOT / "assemblies" / "hex-tube-revolution.toml")
CASES = {
    "ellipsoid": ("ellipsoid:1,1,1.15", TI, "shapes,patterns,angles", "face"),
    "ellipsoid-flat": ("ellipsoid:1,1,1.15", TI, "patterns", "group"),
    "sphere": ("sphere", TI, "patterns,angles", "group"),
    "dome": ("cap:0.75", CAP, "patterns,angles", "group"),
    "barrel": ("revolution:0.45,0.5,0.45", TUBE, "patterns,angles", "group"),
    "tube": ("revolution:0.45,0.475,0.5,0.5,0.5,0.475,0.45", TUBE, "patterns,angles", "group"),
}


def semi_axes(target: str) -> np.ndarray:
    """The target's semi-axis ratios: (1, 1, 1) for a sphere, (A, B, C) for ``ellipsoid:A,B,C``."""
    if target == "sphere":
        return np.ones(3)
    return np.array([float(v) for v in target.split(":", 1)[1].split(",")])


def fit_error(P: np.ndarray, semi: np.ndarray) -> tuple[float, float]:
    """(rms distance / s, max distance / s) of the points P (n, 3) mm from the best similarity image of the
    ellipsoid of semi-axes s·``semi`` (module doc)."""
    c0 = P.mean(axis=0)
    _, vec = np.linalg.eigh(np.cov((P - c0).T))
    s0 = float(np.sqrt((np.linalg.norm(P - c0, axis=1) ** 2).mean() / (semi**2).mean()))

    def residual(p: np.ndarray) -> np.ndarray:
        q = (P - p[:3]) @ Rotation.from_rotvec(p[3:6]).as_matrix() / (p[6] * semi)
        r = np.linalg.norm(q, axis=1)
        grad = q / (p[6] * semi) / r[:, None]
        return (r - 1.0) / np.linalg.norm(grad, axis=1)

    best = None
    for k in range(3):
        R0 = np.roll(vec, 2 - k, axis=1)
        if np.linalg.det(R0) < 0:
            R0[:, 0] *= -1
        fit = least_squares(residual, np.r_[c0, Rotation.from_matrix(R0).as_rotvec(), s0])
        rms = float(np.sqrt((fit.fun**2).mean()))
        if best is None or rms < best[0]:
            best = (rms, float(np.abs(fit.fun).max()), float(fit.x[6]))
    assert best is not None
    return best[0] / best[2], best[1] / best[2]


def _meridian_distance(P: np.ndarray, p: np.ndarray, scale: float, curve: np.ndarray, cap: float | None) -> np.ndarray:
    """Distances (n,) mm of P from the open target at origin p[:3], axis turned by rotvec p[3:6] from z, ``scale``
    mm per unit: the cap of height ``cap`` in closed form, else the meridian ``curve`` (m, 2) points (ρ, a)."""
    q = (P - p[:3]) @ Rotation.from_rotvec(p[3:6]).as_matrix() / scale
    rho, a = np.hypot(q[:, 0], q[:, 1]), q[:, 2]
    if cap is not None:
        R = (1.0 + cap * cap) / (2.0 * cap)
        lo = cap - R  # the sphere's centre on the axis
        inside = (a - lo) * R >= -lo * np.hypot(rho, a - lo)  # within the cone from the centre through the rim
        return scale * np.where(inside, np.abs(np.hypot(rho, a - lo) - R), np.hypot(rho - 1.0, a))
    from scipy.spatial import cKDTree

    return scale * cKDTree(curve).query(np.column_stack([rho, a]))[0]


def open_fit_error(P: np.ndarray, target: str) -> tuple[float, float]:
    """(rms, max) distance of P (n, 3) mm from the open ``target`` over the nodes' RMS radius (module doc)."""
    from scipy.interpolate import make_interp_spline

    kind, values = target.split(":", 1)
    nums = [float(v) for v in values.split(",")]
    cap = nums[0] if kind == "cap" else None
    if cap is not None:  # the cap's area is uniform in height (Archimedes): ρ² + (a − H/2)² averaged over a
        R = (1.0 + cap * cap) / (2.0 * cap)
        a = np.linspace(0.0, cap, 20001)
        size = float(np.sqrt(np.mean(R * R - (a - cap + R) ** 2 + (a - 0.5 * cap) ** 2)))
        curve = np.zeros((0, 2))
    else:
        a = np.linspace(0.0, 1.0, 20001)
        sp = make_interp_spline(np.linspace(0.0, 1.0, len(nums)), nums, k=min(3, len(nums) - 1))
        r, dr = sp(a), sp.derivative()(a)
        w = r * np.sqrt(1.0 + dr * dr)
        ac = float((w * a).sum() / w.sum())
        size = float(np.sqrt((w * (r * r + (a - ac) ** 2)).sum() / w.sum()))
        curve = np.column_stack([r, a])
    c0 = P.mean(axis=0)
    radius = float(np.sqrt((np.linalg.norm(P - c0, axis=1) ** 2).mean()))
    scale = radius / size
    _, vec = np.linalg.eigh(np.cov((P - c0).T))
    best = None
    for k in range(3):
        for sign in (1.0, -1.0):
            z = sign * vec[:, k]
            along = (P - c0) @ z
            start = c0 + (float(along.max()) - scale * cap if cap is not None else float(along.min())) * z
            w0 = Rotation.align_vectors([z], [[0.0, 0.0, 1.0]])[0].as_rotvec()
            fit = least_squares(lambda p: _meridian_distance(P, p, scale, curve, cap), np.r_[start, w0])
            rms = float(np.sqrt((fit.fun**2).mean()))
            if best is None or rms < best[0]:
                best = (rms, float(np.abs(fit.fun).max()))
    assert best is not None
    return best[0] / radius, best[1] / radius


def run(name: str, h: float, max_solves: int, out: Path, reuse: bool = False) -> dict[str, object]:
    target, spec, vary, per = CASES[name]
    folder = out / name
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "fabpat", "design", target, "--spec", spec, "--vary", vary, "--per", per,
           "--out", str(folder), "--h", str(h), "--max-solves", str(max_solves), "--no-progress"]
    if not (reuse and (folder / "design.json").exists()):
        subprocess.run(cmd, check=True, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    rec = json.loads((folder / "design.json").read_text(encoding="utf-8"))
    seconds = rec["seconds"] if reuse else seconds
    vtu = folder / "resim.vtu"
    subprocess.run([sys.executable, "-m", "fabpat", "simulate-assembly", str(folder / "design.toml"), "--h", str(h),
                    "--vtu", str(vtu), "--no-progress"], check=True, capture_output=True, text=True)
    import meshio

    m = meshio.read(vtu)
    P = np.asarray(m.points) + np.asarray(m.point_data["displacement"])
    rms, mx = fit_error(P, semi_axes(target)) if target.startswith(("sphere", "ellipsoid")) else \
        open_fit_error(P, target)
    return {"case": name, "design": rec["relative_rms"], "resimulated": rms, "max": mx,
            "peak_strain": rec["peak_strain"], "solves": rec["solves"], "seconds": seconds,
            "single": rec["baselines"].get("single", {}).get("relative_rms")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--h", type=float, default=6.0)
    ap.add_argument("--max-solves", type=int, default=12)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--out", default="bench-surfaces")
    ap.add_argument("--reuse", action="store_true", help="measure the designs already in --out")
    a = ap.parse_args()
    rows = [run(name, a.h, a.max_solves, Path(a.out), a.reuse) for name in a.cases.split(",")]
    print("| case | design | re-simulated (rms / max) | single pattern | peak strain | solves | seconds |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        single = "–" if r["single"] is None else f"{100 * float(r['single']):.3f} %"
        print(f"| {r['case']} | {100 * float(r['design']):.3f} % | {100 * float(r['resimulated']):.3f} % / "
              f"{100 * float(r['max']):.3f} % | {single} | {100 * float(r['peak_strain']):.2f} % | {r['solves']} | "
              f"{float(r['seconds']):.0f} |")


if __name__ == "__main__":
    main()
