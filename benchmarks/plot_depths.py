"""The depth-2 and depth-3 hexagon clouds in one picture: Cylinder energy against filleted area and min width.

Run: ``python benchmarks/plot_depths.py [OUT.png]`` (default ``docs/img/depth-clouds.png``): the built-in
catalog's 430 depth-2 hexagons and the depth-3 rows of ``benchmarks/data/depth3-hexagons.sqlite``; prints the
Cylinder-energy range (max over min) of each depth and of both together.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import fabpat  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEPTH3 = ROOT / "benchmarks" / "data" / "depth3-hexagons.sqlite"


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img" / "depth-clouds.png"
    d2 = [r for r in fabpat.catalog(sides=6) if r["energy_cylinder"]]
    d3 = [r for r in fabpat.catalog(DEPTH3, sides=6) if r["depth"] == 3 and r["energy_cylinder"]]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, x, label in ((axes[0], "filleted_area", "filleted area (mm²)"), (axes[1], "min_width", "min width (mm)")):
        for rows, name, colour in ((d2, f"depth 2 ({len(d2)})", "#1f77b4"), (d3, f"depth 3 ({len(d3)})", "#d62728")):
            ax.scatter([r[x] for r in rows], [r["energy_cylinder"] for r in rows], s=9, alpha=0.6, c=colour,
                       label=name)
        ax.set_xlabel(label)
        ax.set_ylabel("Cylinder energy (N·mm)")
        ax.set_yscale("log")
        ax.legend()
    fig.suptitle("Hexagons of 36 mm, 2 mm PLA: the paper's depth-2 library and a uniform depth-3 sample")
    fig.savefig(out, dpi=110)
    for name, rows in (("depth 2", d2), ("depth 3", d3), ("both", d2 + d3)):
        e = [float(r["energy_cylinder"]) for r in rows]
        w = [float(r["min_width"]) for r in rows]
        print(f"| {name} | {len(rows)} | {min(e):.2f} | {max(e):.2f} | {max(e) / min(e):.2f} | "
              f"{min(w):.2f} – {max(w):.2f} |")
    print(out)


if __name__ == "__main__":
    main()
