"""A strip assembly pushed into its bent shape: the paper's §5 experiment in the shell solver.

Model (every decision in one place):

* Plates: each tile's filleted pattern meshed as in the scenarios (target edge ``h``), placed by the
  kit's rigid placement (:func:`fabpat.assembly.place.placement.place`, skeleton edge with the sleeves'
  setback), joined by rigid sleeves (:mod:`fabpat.assembly.solve.model`).
* Pins as in the kit (:func:`fabpat.assembly.place.placement.end_interfaces`): the nodes of column 0's end
  interfaces hold ux, uy, uz; those of the last column hold uy, uz and are moved along −x by
  ``end_shortening`` × L (L the strip's x-extent); rotations are free (hinges). The reaction is the
  x-force on the moving pins (positive in compression).
* Path: displacement control in ``steps`` equal report increments (:func:`fabpat.shell.linked.solve_path`):
  a first increment of :data:`FIRST_STEP` to the knee, then the rest of the path tried in one leap
  (:data:`LEAP_ITERATIONS`; the report points it jumps over interpolated), else increments doubling from there.
  The flat strip is a symmetric bifurcation; an upward imperfection load selects the branch: a
  uniform out-of-plane force of ``imperfection`` N in total (default ``IMPERFECTION``), spread by
  lumped area and reached in full early on the path (``IMPERFECTION_RAMP``), then held: it only selects
  the branch, so it need not grow with the shortening; the equilibrium at λ = 1 is the same as with it
  scaled by λ, and near its full size at the knee it rounds the knee off (the shipped graded strip at
  h = 6 mm takes 69 factorizations against 93 with the load scaled, its answers within 1e−9). It is 1 % of the
  buckling load of a 1 × 4 strip of the soft 0x6808 (≈ 1.05 N) and changes that strip's post-buckling
  reaction by 0.7 %; 0.001 N (scaled by λ) made the knee of the path so sharp that the same run took
  4× the Newton iterations.
* Read-outs: the width-averaged deflection profile w(x) (uz binned along x), ``peak`` its highest
  point as a fraction of L from column 0's end (parabola through the three highest bins, so it is not
  limited to the bin width), ``half_ratio`` the area under w of the half next to column 0 over the
  other half's, ``max_deflection`` the largest uz of any node.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.solve.model import (
    AssemblyModel,
    ModelSleeve,
    assembly_model,
    check_h,
    check_plausible,
    model_plates,
    plate_material,
    sleeve_moments,
)
from fabpat.errors import GeometryError
from fabpat.shell.linked import PathResult, solve_path

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.assembly.place.placement import Assembly, PlateType
    from fabpat.assembly.spec.types import AssemblySpec
    from fabpat.geometry.fillet import FilletedPattern

Arr = NDArray[np.float64]

#: default end shortening of a strip, as a fraction of its length L (``simulate-assembly``, the kit's prediction)
END_SHORTENING = 0.1
#: total upward imperfection force (N) of the end-shortening path (see module doc)
IMPERFECTION = 1e-2
#: the imperfection reaches its full size at this fraction of the path and is held after it (module doc):
#: the graded strip at h = 6 mm takes 69 factorizations (93 with the load scaled by λ over the whole
#: path, 64 with it in full from λ = 0, 72 reached at 1/32); in full from λ = 0 it cannot be halved,
#: and a strip too soft to carry it at once (E ≤ 0.1 N/mm² on the 1 × 4 test strip) never starts
IMPERFECTION_RAMP = 1.0 / 64
#: Newton tolerance relative to the reaction norm: the pin forces are a fraction of a newton while
#: the element forces that cancel to them are thousands of times larger, and their rounding would
#: otherwise sit at a 1e-8 tolerance
STRIP_RTOL = 1e-6
PROFILE_BINS = 60
#: first increment, as a fraction of the path: the shipped 2 × 15 strip buckles at about 0.01 %
#: end shortening (λ ≈ 10⁻³ of a 10 % path); a first step of one report interval leapt past it and
#: Newton settled on a wavy higher mode (reaction 4.75 N against the arch's 0.50 N)
FIRST_STEP = 1.0 / 1024
#: smallest increment: the knee of that strip's path spans about 0.01 mm of end shortening (λ ≈ 10⁻⁴)
MIN_STEP = 2.0**-20
#: largest increment (fraction of the path): past the knee the arch takes increments of a quarter of the
#: path in as many factorizations as a tenth (3–4), and the report points between are interpolated
#: (shell.linked.solve_path, ``max_step``): the shipped strip at h = 3 in 54 factorizations, not 64
MAX_STEP = 0.25
#: after the first increment (past the knee), the rest of the path is tried in one increment of at most this
#: many Newton iterations (shell.linked.solve_path, ``leap``): the shipped strip then takes 23 factorizations
#: at h = 3, not 54 (its leap: 25 iterations, 20 factorizations), 24 at h = 2 and 53 at h = 6, where its leap
#: creeps (55 iterations); the 1 × 3 test strip 30 at h = 3, not 50. A leap that stops halving its residual
#: is given up (shell.linked.LEAP_PATIENCE) and the path doubles its increments from the first as before
LEAP_ITERATIONS = 60


def kit_end_shortening(spec: object) -> float:
    """The end shortening (fraction of the length) a strip spec is used at, for its kit's prediction and
    ``simulate-assembly``'s default: the spec's own (``[load] end_shortening``, its ``end_shortening``
    field, where specs have one) when given, else :data:`END_SHORTENING`."""
    value = getattr(spec, "end_shortening", None)
    return END_SHORTENING if value is None else float(value)


@dataclass(frozen=True, eq=False)
class StripSetup:
    """An assembled strip ready for the end-shortening path: ``model``, pin nodes ``left`` (fixed) and
    ``right`` (moving), ``length`` L (mm), x of column 0's end ``x0`` (mm)."""

    model: AssemblyModel
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    length: float
    x0: float


def strip_setup(spec: AssemblySpec, face_patterns: list[str], *, h: float = 3.0, E: float | None = None,
                nu: float | None = None, placed: Assembly | None = None,
                filleted: dict[PlateType, FilletedPattern] | None = None) -> StripSetup:
    """Mesh, place and join the plates of a ``honeycomb-strip`` spec (an AssemblySpec). ``placed``: the
    kit's Assembly of these patterns, if already placed, and ``filleted`` its outlines per plate type
    (:func:`~fabpat.assembly.solve.model.model_plates`): nothing is placed or filleted again. ``E`` (N/mm²) and
    ``nu`` default to the spec's ``[material]`` (:func:`~fabpat.assembly.solve.model.plate_material`).

    Raises GeometryError if h exceeds ``MAX_H_PER_INTERFACE`` × the interface segment's length.
    """
    from fabpat.assembly.place.placement import place

    asm = place(spec, face_patterns) if placed is None else placed
    w = spec.plates.weight
    check_h(h, asm.plate_edge, w)
    plates = model_plates(asm, h, w, filleted)
    sleeves = [ModelSleeve(s.label, s.transform, s.plates) for s in asm.sleeves]
    model = assembly_model(plates, sleeves, plate_material(spec, E, nu))
    grid = asm.skeleton.grid
    assert grid is not None
    last = int(grid[:, 1].max())
    left = [model.nodes(f, i) for f, i in asm.pins if grid[f, 1] == 0]
    right = [model.nodes(f, i) for f, i in asm.pins if grid[f, 1] == last]
    for f, i in asm.pins:
        if model.nodes(f, i).size < 2:
            raise GeometryError(f"pinned interface {i} of plate {model.plates[f].label} has fewer than 2 mesh "
                                "nodes (mesh too coarse for the interface: lower h)")
    xs = model.X[:, 0]
    return StripSetup(model, np.unique(np.concatenate(left)), np.unique(np.concatenate(right)),
                      float(np.ptp(xs)), float(xs.min()))


@dataclass(frozen=True, eq=False)
class StripRun:
    """The bent strip. ``path``: one dict {end_shortening, reaction, max_deflection} per report step;
    ``x``, ``w`` the final width-averaged profile (mm from column 0's end, mm); ``element_strain`` (m,)
    each element's peak surface strain, ``plate_peak_strain`` {plate label: its peak}, ``over_limit``
    the labels above ``strain_limit``; the rest as the ``simulate-assembly`` output fields (see
    :func:`run_strip`)."""

    setup: StripSetup
    end_shortening: float
    imperfection: float
    energy: float
    plate_energies: dict[str, float]
    sleeve_moments: dict[str, float]
    reaction: float
    max_deflection: float
    peak: float
    half_ratio: float
    path: list[dict[str, float]]
    x: Arr
    w: Arr
    result: PathResult
    element_strain: Arr
    plate_peak_strain: dict[str, float]
    peak_strain: float
    peak_strain_plate: str
    strain_limit: float
    over_limit: list[str]


def profile(setup: StripSetup, uz: Arr, bins: int = PROFILE_BINS) -> tuple[Arr, Arr]:
    """Bin centres (mm from column 0's end) and the area-weighted mean uz of the plate nodes per bin."""
    m = setup.model
    x = m.X[:, 0] - setup.x0
    a = m.lumped_area()
    k = np.minimum((x / setup.length * bins).astype(np.int64), bins - 1)
    aa = np.bincount(k, a, minlength=bins)
    w = np.bincount(k, a * uz[: len(x)], minlength=bins) / np.maximum(aa, 1e-300)
    ok = aa > 0
    return ((np.arange(bins) + 0.5) * setup.length / bins)[ok], w[ok]


def peak_position(x: Arr, w: Arr, length: float) -> float:
    """Where w is highest, as a fraction of ``length``: vertex of the parabola through the top bin and
    its neighbours (the top bin's centre at either end)."""
    k = int(np.argmax(w))
    if 0 < k < len(w) - 1:
        (x0, x1, x2), (y0, y1, y2) = x[k - 1:k + 2], w[k - 1:k + 2]
        den = (x0 - x1) * (x0 - x2) * (x1 - x2)
        A = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
        B = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / den
        if A < 0:
            return float(np.clip(-B / (2 * A), x0, x2) / length)
    return float(x[k] / length)


def run_strip(setup: StripSetup, end_shortening: float = END_SHORTENING, *, steps: int = 10,
              imperfection: float = IMPERFECTION, progress: Callable[[float], None] | None = None,
              strain_limit: float = 0.02, start: tuple[Arr, Arr] | None = None) -> StripRun:
    """Push the pins together by ``end_shortening`` × L in ``steps`` report increments; ``progress(λ)``
    (optional) is told the fraction of the end shortening reached after every report step. Plates
    whose peak surface strain (:func:`fabpat.shell.strain.surface_strains`) exceeds ``strain_limit``
    are listed in ``over_limit``. ``start``: a warm start (:func:`fabpat.assembly.solve.model.warm_guess`),
    tried at the full end shortening first (:func:`fabpat.shell.linked.solve_path`).

    Raises ValueError if end_shortening is not in (0, 0.5) or imperfection < 0, SolverError if the
    path is lost (naming the load fraction reached).
    """
    from fabpat.shell.rotations import expmap
    from fabpat.shell.strain import surface_strains

    if not 0.0 < end_shortening < 0.5:
        raise ValueError(f"end shortening must be in (0, 0.5), got {end_shortening:g}")
    if not imperfection >= 0.0:
        raise ValueError(f"imperfection must be ≥ 0, got {imperfection:g}")
    m = setup.model
    N = m.n_nodes
    n = len(m.X)
    fixed = np.zeros((N, 6), dtype=bool)
    fixed[setup.left, :3] = True
    fixed[setup.right, :3] = True
    pres = np.zeros((N, 6))
    pres[setup.right, 0] = -end_shortening * setup.length
    loads = np.zeros((N, 6))
    area = m.lumped_area()
    loads[:n, 2] = imperfection * area / area.sum()
    problem = m.problem(fixed, pres, np.zeros_like(loads), dead_loads=loads, dead_ramp=IMPERFECTION_RAMP)
    r = solve_path(problem, steps=steps, rtol=STRIP_RTOL, first_step=FIRST_STEP, max_step=MAX_STEP,
                   min_step=MIN_STEP, direction=loads if imperfection > 0 else None, progress=progress,
                   start=start, leap=LEAP_ITERATIONS)
    path = []
    for pt in r.points:
        path.append({"end_shortening": pt.lam * end_shortening, "reaction": float(-pt.reactions[setup.right, 0].sum()),
                     "max_deflection": float(pt.displacement[:n, 2].max()), "exact": pt.exact})
    fin = r.final
    x, w = profile(setup, fin.displacement[:, 2])
    half = setup.length / 2
    first = float(np.trapezoid(np.where(x <= half, w, 0.0), x))
    second = float(np.trapezoid(np.where(x > half, w, 0.0), x))
    ee = r.element_energy.sum(axis=1)
    pe = m.per_plate(ee)
    X = np.vstack([m.X, m.problem(fixed, pres, loads).masters])
    moments = np.max([sleeve_moments(m, X + pt.displacement, pt.link_forces) for pt in r.points], axis=0) \
        if m.sleeves else np.zeros(0)
    eps = surface_strains(m.X, m.F, m.material, m.X + fin.displacement[:n], expmap(fin.rotation[:n]),
                          m.element_thickness)
    peak = m.per_plate(eps, np.max)
    worst = max(peak, key=lambda k: peak[k])
    check_plausible(m, float(ee.sum()), fin.displacement, peak[worst],
                    f"strip pushed together by {end_shortening:g} × its length")
    return StripRun(setup, end_shortening, imperfection, float(ee.sum()), pe,
                    {s.label: float(v) for s, v in zip(m.sleeves, moments, strict=True)},
                    path[-1]["reaction"], path[-1]["max_deflection"], peak_position(x, w, setup.length),
                    first / second if second != 0 else math.inf, path, x, w, r, eps, peak, peak[worst], worst,
                    float(strain_limit), [k for k, v in peak.items() if v > strain_limit])


def write_profiles_png(path: str | Path, runs: list[tuple[str, StripRun]], dpi: int = 150) -> Path:
    """Side view of one or more bent strips (mean uz along x) and their reaction–end-shortening curves."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fabpat.assembly.show.render import plain_text

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 3.4), dpi=dpi, gridspec_kw={"width_ratios": [2.2, 1]})
    for k, (name, r) in enumerate(runs):
        L = r.setup.length
        ax.plot(r.x / L, r.w, color=f"C{k}", lw=2, label=f"{plain_text(name)}: peak {r.peak:.3f}")
        ax.plot([r.peak], [np.interp(r.peak * L, r.x, r.w)], "o", color=f"C{k}")
        bx.plot([0.0] + [p["end_shortening"] for p in r.path], [0.0] + [p["reaction"] for p in r.path], ".-",
                color=f"C{k}", label=plain_text(name))
    ax.axvline(0.5, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("x / L from column 0's end")
    ax.set_ylabel("mean deflection uz, mm")
    ax.set_xlim(0, 1)
    ax.legend(fontsize=8)
    bx.set_xlabel("end shortening / L")
    bx.set_ylabel("reaction, N")
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, format="png")
    plt.close(fig)
    return Path(path)
