"""The depth-2 and depth-3 clouds in one picture: Cylinder energy against filleted area and min width.

Run: ``python benchmarks/plot_depths.py [OUT.png]`` (default ``docs/img/depth-clouds.png``): the built-in
catalog's 430 depth-2 patterns and its shipped depth-3 patterns, hexagons (top) and pentagons (bottom); prints,
per polygon, the Cylinder-energy range (max over min) of each depth and of both together, over every pattern and
over those printable at the print limit (min width ≥ 0.8 mm).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fabpat  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PRINTABLE = 0.8  # mm: fabpat.exchange.registry.PRINT_MIN_WIDTH, two perimeters of a 0.4 mm nozzle


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img" / "depth-clouds.png"
    fig, axes = plt.subplots(2, 2, figsize=(10, 8), constrained_layout=True)
    print("| polygon | depth | patterns | Cylinder min N·mm | max | max / min | printable max / min | min width mm |")
    print("|---|---|---:|---:|---:|---:|---:|---|")
    for row, (sides, name) in enumerate(((6, "hexagons"), (5, "pentagons"))):
        d2 = [r for r in fabpat.catalog(sides=sides) if r["energy_cylinder"]]
        d3 = [r for r in fabpat.catalog(sides=sides, depth=3) if r["energy_cylinder"]]
        for ax, x, label in ((axes[row, 0], "filleted_area", "filleted area (mm²)"),
                             (axes[row, 1], "min_width", "min width (mm)")):
            for rows, what, colour in ((d2, f"depth 2 ({len(d2)})", "#1f77b4"), (d3, f"depth 3 ({len(d3)})",
                                                                                  "#d62728")):
                ax.scatter([r[x] for r in rows], [r["energy_cylinder"] for r in rows], s=9, alpha=0.6, c=colour,
                           label=what)
            ax.set_xlabel(label)
            ax.set_ylabel(f"Cylinder energy (N·mm), {name}")
            ax.set_yscale("log")
            ax.legend()
        for depth, rows in (("2", d2), ("3", d3), ("both", d2 + d3)):
            e = [float(r["energy_cylinder"]) for r in rows]
            p = [float(r["energy_cylinder"]) for r in rows if float(r["min_width"]) >= PRINTABLE]
            w = [float(r["min_width"]) for r in rows]
            print(f"| {name} | {depth} | {len(rows)} | {min(e):.2f} | {max(e):.2f} | {max(e) / min(e):.2f} | "
                  f"{max(p) / min(p):.2f} | {min(w):.2f} – {max(w):.2f} |")
    fig.suptitle("Plates of 36 mm edge, 2 mm PLA: the paper's depth-2 library and the shipped depth-3 patterns")
    fig.savefig(out, dpi=100)
    print(out)


if __name__ == "__main__":
    main()
