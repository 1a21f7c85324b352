"""``fabpat design``: seeded random 1 × 9 strips (reachable by construction), the shipped 2 × 15 graded
strip against a circular arc, a parabola and a skewed arch (highest at 0.62 of the span), and the
shipped truncated-icosahedron sphere against closed targets.

Run: ``python benchmarks/bench_design.py [--count 10] [--h 3] [--max-solves 12] [--workers 2]
[--shapes circle,parabola,skewed | none] [--closed "sphere;ellipsoid:1,1,1.15" | none]
[--closed-solves 40] [--pictures DIR] [--depth 3]`` — prints one Markdown table per kind (``--depth 3``: the
shipped strip's candidates also take the built-in catalog's depth-3 hexagons, ``[patterns] depth = 3``).
A random strip's target is the
mid-line the assembly solver predicts for random per-column patterns at 10 % end shortening; each design
is re-simulated with ``simulate_assembly(design.toml)`` (its ``[load] end_shortening``) and that
re-simulation's error against the target is the table's rms.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from fabpat.design import design
from fabpat.design.api import _geometry
from fabpat.design.base import load_base
from fabpat.design.search import solve_candidate
from fabpat.design.strip import errors, midline, predicted_at
from fabpat.design.target import write_target_csv

ROOT = Path(__file__).resolve().parents[1]
GRADED = ROOT / "assemblies" / "graded-strip.toml"


def strip_spec(folder: Path, columns: int = 9) -> Path:
    """The graded strip's set-up as a 1 × ``columns`` base spec with its pattern choice left open."""
    text = GRADED.read_text(encoding="utf-8")
    text = text.replace("rows = 2", "rows = 1").replace("columns = 15", f"columns = {columns}")
    head, _, rest = text.partition("[patterns]")
    rest = rest[rest.index("[plates]"):]
    p = folder / f"strip-1x{columns}.toml"
    p.write_text(head + "[patterns]\n\n" + rest, encoding="utf-8")
    return p


def random_target(spec: Path, seed: int, h: float, out: Path) -> tuple[Path, float]:
    """A CSV of the predicted mid-line of random per-column patterns (seeded); returns it and the solve's s."""
    base = load_base(spec)
    ids = sorted(base.energies)
    length, _, face_col, _ = _geometry(base, ids[0], h)
    rng = np.random.default_rng(seed)
    cols = rng.choice(ids, max(face_col) + 1)
    t0 = time.perf_counter()
    res = solve_candidate(base.spec, tuple(cols[c] for c in face_col), h, 0.1 * length)
    x = np.linspace(0.0, 0.9 * length, 91)
    write_target_csv(out, x, predicted_at(res["x"], res["z"], x))
    return out, time.perf_counter() - t0


def shape_target(kind: str, length: float, out: Path) -> Path:
    """A circular arc, parabola or skewed arch (peak at 0.62 of the span) of arc length ``length`` mm over
    the span 0.9 × length."""
    span = 0.9 * length
    x = np.linspace(0.0, span, 181)
    if kind == "circle":  # sin(a)/a = 0.9: half-angle a of an arc of chord 0.9 × its length
        a = 1.0
        for _ in range(50):
            a -= (math.sin(a) / a - 0.9) / ((a * math.cos(a) - math.sin(a)) / a**2)
        r = span / (2 * math.sin(a))
        z = np.sqrt(r * r - (x - span / 2) ** 2) - r * math.cos(a)
    else:
        u = x / span
        shape = u * (1 - u) if kind == "parabola" else u**1.6 * (1 - u) ** 0.98  # 1.6 / (1.6 + 0.98) = 0.62
        lo, hi = 0.0, 10.0 * span
        for _ in range(80):  # the height that gives the arc length
            mid = 0.5 * (lo + hi)
            z = mid * shape / shape.max()
            lo, hi = (mid, hi) if np.hypot(np.diff(x), np.diff(z)).sum() < length else (lo, mid)
        z = lo * shape / shape.max()
    write_target_csv(out, x, z)
    return out


def resimulate(folder: Path, target: Path, h: float) -> float:
    """rms error (mm) of ``simulate_assembly(design.toml)`` (its [load] end_shortening) against the target."""
    from fabpat.assembly.solve.simulation import simulate_assembly

    sim = simulate_assembly(folder / "design.toml", h=h)
    x, z = midline(sim.run.setup, sim.run.result.final.displacement)
    t = np.loadtxt(target, delimiter=",", skiprows=1)
    return errors(x, z, t[:, 0], t[:, 1])[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("--h", type=float, default=3.0)
    ap.add_argument("--max-solves", type=int, default=12)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--shapes", default="circle,parabola,skewed")
    ap.add_argument("--closed", default="sphere;ellipsoid:1,1,1.15")
    ap.add_argument("--closed-solves", type=int, default=40)
    ap.add_argument("--pictures", default=None, help="copy each closed and shipped-strip design.png here")
    ap.add_argument("--depth", type=int, choices=(2, 3), default=2, help="the shipped strip's [patterns] depth")
    a = ap.parse_args()
    strips(a)
    if a.closed != "none":
        closed(a)


def closed(a: argparse.Namespace) -> None:
    """The shipped sphere spec against each closed target: the design and its baselines (relative rms over
    the radius), re-simulated with ``simulate_assembly(design.toml)``."""
    from fabpat.assembly.solve.simulation import simulate_assembly

    spec = ROOT / "assemblies" / "truncated-icosahedron.toml"
    print(f"\nh = {a.h:g} mm, --max-solves {a.closed_solves}, --workers {a.workers}\n")
    print("| target | relative_rms | rms mm | scale | re-simulated sphericity_rms | peak strain | spec (hand-picked) "
          "| single pattern | distinct patterns | solves | seconds |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for n, target in enumerate(a.closed.split(";")):
            out = Path(tmp) / f"closed-{n}"
            r = design(target, spec, out=out, h=a.h, max_solves=a.closed_solves, workers=a.workers).record
            sim = simulate_assembly(out / "design.toml", h=a.h)
            if a.pictures:
                import shutil

                name = target.split(":")[0] if ":" in target else Path(target).stem
                shutil.copy(out / "design.png", Path(a.pictures) / f"design-{name}.png")
            b = r["baselines"]
            print(f"| {target} | {r['relative_rms']:.3%} | {r['rms_error']:.3f} | {r['scale']:.2f} | "
                  f"{sim.run.sphericity_rms:.3%} | {r['peak_strain']:.2%} | {b['spec']['relative_rms']:.3%} | "
                  f"{b['single']['relative_rms']:.3%} | {len(set(r['patterns'].values()))} | {r['solves']} | "
                  f"{r['seconds']:.0f} |", flush=True)


def strips(a: argparse.Namespace) -> None:
    """The strip table (module doc)."""
    if a.count == 0 and a.shapes == "none":
        return
    print(f"h = {a.h:g} mm, --max-solves {a.max_solves}, --workers {a.workers}\n")
    print("| strip | target | rms mm | relative_rms | re-simulated rms mm | single pattern | rule | solves | seconds |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        runs: list[tuple[str, str, Path, Path]] = []
        spec9 = strip_spec(folder)
        for seed in range(a.count):
            t, _ = random_target(spec9, seed, a.h, folder / f"random-{seed}.csv")
            runs.append(("1 × 9", f"random seed {seed}", spec9, t))
        shapes = [] if a.shapes == "none" else a.shapes.split(",")
        if shapes:
            graded = GRADED
            if a.depth == 3:  # the shipped spec with the depth-3 candidates added
                graded = folder / "graded-strip-depth3.toml"
                graded.write_text(GRADED.read_text(encoding="utf-8").replace(
                    'rule = "graded"\n', 'rule = "graded"\ndepth = 3\n', 1), encoding="utf-8")
            base = load_base(graded)
            length = _geometry(base, sorted(base.energies)[0], a.h)[0]
            for kind in shapes:
                runs.append((f"2 × 15 graded{', depth 3' if a.depth == 3 else ''}", kind, graded,
                             shape_target(kind, length, folder / f"{kind}.csv")))
        for n, (strip, what, spec, target) in enumerate(runs):
            out = folder / f"out-{n}"
            r = design(target, spec, out=out, h=a.h, max_solves=a.max_solves, workers=a.workers).record
            again = resimulate(out, target, a.h)
            if a.pictures and strip.startswith("2 × 15"):
                import shutil

                shutil.copy(out / "design.png", Path(a.pictures) / f"design-strip-{what}.png")
            b = r["baselines"]
            single = f"{b['single']['relative_rms']:.2%}" if "single" in b else "–"
            rule = f"{b['rule']['relative_rms']:.2%}" if "rule" in b else "–"
            print(f"| {strip} | {what} | {r['rms_error']:.2f} | {r['relative_rms']:.2%} | {again:.2f} | {single} | "
                  f"{rule} | {r['solves']} | {r['seconds']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
