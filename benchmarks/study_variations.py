"""Continuous variations: is each energy a smooth function of bridge_weight, how well does the family
interpolant predict direct solves, and how much of the energy axis does the family add? Prints Markdown.

Run (from the repository root)::

    python benchmarks/study_variations.py                         # 10 patterns × 21 members × 3 scenarios
    python benchmarks/study_variations.py --patterns 4 --workers 1 --pictures docs/img

For ``--patterns`` random hexagon patterns that have non-manifold vertices (seeded; a pattern without
one has a one-member family), every member on a grid of ``bridge_weight`` is solved as the catalog is
(``fabpat sweep --variation bridge_weight=W``: fillet, the converged two-mesh energy of each scenario)
into a study catalog (``--db``, resumable). The grid is the family's interpolation nodes
(:data:`fabpat.catalog.sweep.FAMILY_SAMPLES` and the paper's 1) and three members inside each interval, 21 in all.

Tables:

1. **Smoothness**: per scenario, the finite-difference slope d ln E / d ln w between consecutive members
   (range over the patterns) and the largest *jump*: how far a member's energy is from the cubic
   through its four nearest neighbours, relative — a jump beyond the ~1 % of the converged energies
   (docs/accuracy.md) would show a discontinuity (a remeshing artefact, a change of buckling mode).
2. **Interpolant**: the family interpolant (:mod:`fabpat.catalog.family`, PCHIP through the nodes only) against
   the direct solve of every member between the nodes: worst and median relative error.
3. **Range**: per pattern, the ratio of the largest to the smallest Dome energy over the converged members.
4. **Reachable energies**: the fraction of the log-energy axis between the library's stiffest and softest
   pattern (``--catalog``, default the built-in one) within 2 % of some pattern's energy, the discrete
   catalog alone; with the family, for the sample's patterns.
5. **The library's families** (when ``--catalog`` holds family rows, ``fabpat sweep --family``): per
   scenario the ratio of the largest to the smallest energy over each pattern's converged members
   (median, 10th and 90th percentile over the library) and the fraction of the energy axis within 2 %
   of some pattern and member (the family interpolant, :mod:`fabpat.catalog.family`).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from fabpat.catalog import open_catalog
from fabpat.catalog.sweep import FAMILY_SAMPLES, SweepSetup, run_sweep
from fabpat.geometry.fillet import vertex_stars
from fabpat.patterns.library import enumerate_library
from fabpat.simulation.scenarios import SCENARIOS


def grid() -> list[float]:
    """The nodes and three log-spaced members inside each interval between them."""
    nodes = sorted({1.0, *FAMILY_SAMPLES})
    out = [nodes[0]]
    for a, b in zip(nodes[:-1], nodes[1:], strict=True):
        out += [round(math.exp(math.log(a) + k / 4 * (math.log(b) - math.log(a))), 4) for k in (1, 2, 3)] + [b]
    return out


def pick(n: int, seed: int) -> list[str]:
    lib = enumerate_library(6, 2)
    rng = np.random.default_rng(seed)
    ids = [str(i) for i in rng.permutation(list(lib.ids))]
    return [i for i in ids if any(v.kind == "non-manifold" for v in vertex_stars(lib.pattern(i)))][:n]


def solve(db: Path, ids: list[str], weights: list[float], workers: int) -> float:
    t0 = time.perf_counter()
    for k, w in enumerate(weights):
        r = run_sweep(db, ids, SweepSetup(bridge_weight=w), workers=workers)
        print(f"  bridge_weight {w:g} ({k + 1}/{len(weights)}): {r.computed} computed, {r.skipped} stored, "
              f"{r.seconds:.0f} s", file=sys.stderr, flush=True)
    return time.perf_counter() - t0


def energies(db: Path, ids: list[str]) -> dict[tuple[str, str], dict[float, float | None]]:
    """(id, scenario) → {bridge_weight: energy or None (not converged)}."""
    out: dict[tuple[str, str], dict[float, float | None]] = {}
    with open_catalog(db) as cat:
        for r in cat.results():
            out.setdefault((str(r["id"]), str(r["scenario"])), {})[1.0] = r["energy"] if r["converged"] else None  # type: ignore[assignment]
        for r in cat.family():
            key = (str(r["id"]), str(r["scenario"]))
            out.setdefault(key, {})[float(r["bridge_weight"])] = r["energy"] if r["converged"] else None  # type: ignore[arg-type,assignment]
    return {k: v for k, v in out.items() if k[0] in ids}


def converged_run(curve: dict[float, float | None]) -> tuple[np.ndarray, np.ndarray]:
    """The contiguous converged members around w = 1, as (ln w, ln E)."""
    ws = sorted(curve)
    k = ws.index(1.0)
    lo = hi = k
    while lo > 0 and curve[ws[lo - 1]] is not None:
        lo -= 1
    while hi + 1 < len(ws) and curve[ws[hi + 1]] is not None:
        hi += 1
    run = ws[lo:hi + 1]
    return np.log(run), np.log([curve[w] for w in run])  # type: ignore[misc]


def smoothness(data: dict, scenario: str) -> tuple[float, float, float, int]:
    """(min slope, max slope, largest jump, members not converged) over the patterns of one scenario."""
    slopes, jumps, failed = [], [], 0
    for (_pid, sc), curve in data.items():
        if sc != scenario:
            continue
        failed += sum(v is None for v in curve.values())
        x, y = converged_run(curve)
        slopes += list(np.diff(y) / np.diff(x))
        for i in range(2, len(x) - 2):
            nb = [i - 2, i - 1, i + 1, i + 2]
            fit = np.polyval(np.polyfit(x[nb], y[nb], 3), x[i])
            jumps.append(abs(math.expm1(y[i] - fit)))
    return min(slopes), max(slopes), max(jumps) if jumps else math.nan, failed


def interpolation_errors(data: dict, scenario: str) -> list[float]:
    from scipy.interpolate import PchipInterpolator

    nodes = sorted({1.0, *FAMILY_SAMPLES})
    errs = []
    for (_pid, sc), curve in data.items():
        if sc != scenario:
            continue
        x, y = converged_run(curve)
        wx = np.exp(x)
        at_nodes = [i for i, w in enumerate(wx) if any(abs(w - n) < 1e-9 for n in nodes)]
        if len(at_nodes) < 2:
            continue
        f = PchipInterpolator(x[at_nodes], y[at_nodes])
        for i, _w in enumerate(wx):
            if i not in at_nodes and x[at_nodes[0]] <= x[i] <= x[at_nodes[-1]]:
                errs.append(abs(math.expm1(float(f(x[i])) - y[i])))
    return errs


def reachable(energies_list: list[float], lo: float, hi: float, tol: float = 0.02) -> float:
    """Fraction of [ln lo, ln hi] within ln(1 ± tol) of some energy."""
    grid_ = np.linspace(math.log(lo), math.log(hi), 20001)
    e = np.log(np.asarray(energies_list))
    near = np.zeros_like(grid_, dtype=bool)
    for v in e:
        near |= np.abs(grid_ - v) <= math.log1p(tol)
    return float(near.mean())


def family_intervals(data: dict, scenario: str, ids: list[str]) -> list[tuple[float, float]]:
    out = []
    for pid in ids:
        curve = data.get((pid, scenario))
        if curve:
            _, y = converged_run(curve)
            out.append((float(np.exp(y.min())), float(np.exp(y.max()))))
    return out


def reachable_with_family(points: list[float], intervals: list[tuple[float, float]], lo: float, hi: float,
                          tol: float = 0.02) -> float:
    grid_ = np.linspace(math.log(lo), math.log(hi), 20001)
    near = np.zeros_like(grid_, dtype=bool)
    for v in np.log(points):
        near |= np.abs(grid_ - v) <= math.log1p(tol)
    for a, b in intervals:
        near |= (grid_ >= math.log(a) - math.log1p(tol)) & (grid_ <= math.log(b) + math.log1p(tol))
    return float(near.mean())


def picture(pid: str, data: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fabpat.patterns.library import get_pattern

    shown = [0.25, 0.5, 1.0, 1.6, 2.5]
    fig = plt.figure(figsize=(11, 4.6))
    p = get_pattern(pid)
    for k, w in enumerate(shown):
        ax = fig.add_subplot(2, len(shown), k + 1)
        fp = p.fillet(bridge_weight=w)
        fp.plot(ax)
        ax.set_title(f"bridge_weight {w:g}\nmin width {fp.min_width():.2f} mm", fontsize=9)
        ax.set_axis_off()
    ax = fig.add_subplot(2, 1, 2)
    for sc in SCENARIOS:
        curve = data[(pid, sc)]
        ws = sorted(w for w, e in curve.items() if e is not None)
        e1 = curve[1.0]
        ax.plot(ws, [curve[w] / e1 for w in ws], "o-", ms=3, label=sc)  # type: ignore[operator]
    ax.set_xscale("log")
    ax.set_xlabel("bridge_weight (paper: 1)")
    ax.set_ylabel("energy / paper's")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.suptitle(f"{pid}: one family (hexagon, edge 36 mm, t = 2 mm)", fontsize=10)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}", file=sys.stderr)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--patterns", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--db", type=Path, default=Path("study-variations.sqlite"))
    ap.add_argument("--pictures", type=Path, default=None, help="folder for variation-<id>.png")
    ap.add_argument("--catalog", type=Path, default=None, help="catalog for tables 4–5 [default: the built-in one]")
    a = ap.parse_args()
    ids = pick(a.patterns, a.seed)
    weights = grid()
    print(f"{len(ids)} patterns ({', '.join(ids)}), {len(weights)} members: {', '.join(f'{w:g}' for w in weights)}",
          file=sys.stderr)
    seconds = solve(a.db, ids, weights, a.workers)
    data = energies(a.db, ids)
    print(f"\n{len(ids)} patterns × {len(weights)} members × 3 scenarios, {seconds:.0f} s wall with {a.workers} "
          f"workers (load average {os.getloadavg()[0]:.1f})\n")
    print("| scenario | d ln E / d ln w (min … max) | largest jump | members not converged |")
    print("|---|---|---|---|")
    for sc in SCENARIOS:
        lo, hi, jump, failed = smoothness(data, sc)
        print(f"| {sc} | {lo:.3f} … {hi:.3f} | {100 * jump:.2f} % | {failed} |")
    print("\n| scenario | interpolant vs direct solve: worst | median | members compared |")
    print("|---|---|---|---|")
    for sc in SCENARIOS:
        errs = interpolation_errors(data, sc)
        print(f"| {sc} | {100 * max(errs):.2f} % | {100 * statistics.median(errs):.2f} % | {len(errs)} |")
    print("\n| pattern | Dome energy max/min over the converged family | its members |")
    print("|---|---|---|")
    ratios = []
    for pid in ids:
        _, y = converged_run(data[(pid, "dome")])
        ratios.append(math.exp(y.max() - y.min()))
        print(f"| {pid} | {ratios[-1]:.2f} | {len(y)} |")
    print(f"\nmedian {statistics.median(ratios):.2f}, range {min(ratios):.2f} … {max(ratios):.2f}\n")
    with open_catalog(a.catalog) as cat:
        rows = cat.pattern_rows(sides=6)
    print("| scenario | library energy range (N·mm) | reachable within 2 %: catalog | sample: discrete | "
          "sample: with family |")
    print("|---|---|---|---|---|")
    for sc in SCENARIOS:
        lib = [float(r[f"energy_{sc}"]) for r in rows if r[f"energy_{sc}"]]  # type: ignore[arg-type]
        lo, hi = min(lib), max(lib)
        sample = [float(r[f"energy_{sc}"]) for r in rows if r["id"] in ids and r[f"energy_{sc}"]]  # type: ignore[arg-type]
        fam = family_intervals(data, sc, ids)
        print(f"| {sc} | {lo:.4g} … {hi:.4g} | {100 * reachable(lib, lo, hi):.1f} % | "
              f"{100 * reachable(sample, lo, hi):.1f} % | {100 * reachable_with_family(sample, fam, lo, hi):.1f} % |")
    library_families(a.catalog, rows)
    rule_mismatch(a.catalog)
    if a.pictures is not None:
        picture(ids[0], data, a.pictures / f"variation-{ids[0]}.png")


def library_families(catalog: Path | None, rows: list[dict]) -> None:
    """Table 5, from the catalog's family rows (nothing without them)."""
    from fabpat.catalog.family import family_curves

    with open_catalog(catalog) as cat:
        if not cat.family(sides=6):
            print("\n(no family rows in the catalog: `fabpat sweep --family` for table 5)")
            return
    print("\n| scenario | energy max/min over a family: median | 10–90 % | patterns with ≥ 2 members | "
          "reachable within 2 %: catalog | with the family |")
    print("|---|---|---|---|---|---|")
    for sc in SCENARIOS:
        curves = family_curves(sc, sides=6, db=catalog)
        ratios = [float(c.energies.max() / c.energies.min()) for c in curves.values() if len(c.weights) > 1]
        lib = [float(r[f"energy_{sc}"]) for r in rows if r[f"energy_{sc}"]]  # type: ignore[arg-type]
        lo, hi = min(lib), max(lib)
        spans = [(float(c.energies.min()), float(c.energies.max())) for c in curves.values()]
        p10, p90 = np.percentile(ratios, [10, 90])
        print(f"| {sc} | {statistics.median(ratios):.2f} | {p10:.2f} … {p90:.2f} | {len(ratios)} of {len(curves)} | "
              f"{100 * reachable(lib, lo, hi):.1f} % | {100 * reachable_with_family(lib, spans, lo, hi):.1f} % |")



def rule_mismatch(catalog: Path | None) -> None:
    """Table 6: how far the rules' patterns are from their targets, discrete and with members."""
    from fabpat.assembly.choose import rules
    from fabpat.catalog import polygon_energies
    from fabpat.catalog.family import family_curves

    with open_catalog(catalog) as cat:
        if not cat.family(sides=6):
            return
    hexagon = polygon_energies(catalog, "cylinder", 6)
    curves = family_curves("cylinder", sides=6, db=catalog)
    targets = rules.graded_targets(hexagon, 5)
    before = rules.graded(hexagon, 5)
    after = rules.graded_members(hexagon, curves, 5)
    print("\n| graded rule (Cylinder, 5 patterns) | target N·mm | pattern | energy | mismatch | with members | "
          "energy | mismatch |")
    print("|---|---|---|---|---|---|---|---|")
    for k, (t, b, (pid, w)) in enumerate(zip(targets, before, after, strict=True)):
        e_after = curves[pid].energy(w)
        print(f"| {k + 1} | {t:.4g} | {b} | {hexagon[b]:.4g} | {100 * (hexagon[b] / t - 1):+.2f} % | "
              f"{pid} at {w:.3g} | {e_after:.4g} | {100 * (e_after / t - 1):+.2f} % |")
    hd, pd = polygon_energies(catalog, "dome", 6), polygon_energies(catalog, "dome", 5)
    hid, pid = rules.similar_pair(hd, pd)
    pent = family_curves("dome", sides=5, db=catalog).get(pid)
    if pent is not None and len(pent.weights) > 1:
        w = rules.nearest_member(pent, hd[hid])
        ratio_after, who = hd[hid] / pent.energy(w), f"pentagon {pid} at {w:.3g}"
    else:
        hc = family_curves("dome", sides=6, db=catalog)[hid]
        w = rules.nearest_member(hc, pd[pid])
        ratio_after, who = hc.energy(w) / pd[pid], f"hexagon {hid} at {w:.3g}"
    print(f"\nsimilar-energy rule (Dome): {hid} / {pid}, energy ratio {hd[hid] / pd[pid]:.4f}; with members "
          f"({who}) {ratio_after:.4f}")


if __name__ == "__main__":
    main()
