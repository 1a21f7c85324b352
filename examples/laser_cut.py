"""Choose a pattern and export it for a laser cutter.

Among the 430 hexagon patterns, take the one whose solid covers closest to half the hexagon, check
that its narrowest bar survives the kerf, and write a DXF (kerf-compensated CUT layer, ID on the
ENGRAVE layer) and an SVG preview. Run: ``python examples/laser_cut.py`` (writes into the current folder).
"""

import math

import fabpat

KERF = 0.15  # mm: a typical CO2-laser kerf in 2 mm acrylic or plywood

lib = fabpat.library(sides=6, depth=2, edge=36.0)
hexagon = 3 * math.sqrt(3) / 2 * 36.0**2  # mm²
p = min(lib, key=lambda q: abs(q.metrics.area - hexagon / 2))
fp = p.fillet(weight=0.2)
width = fp.min_width(tol=0.01)
if width < 2 * KERF:
    raise SystemExit(f"{p.id}: narrowest bar {width:.2f} mm is too thin for a {KERF} mm kerf")
fp.export(f"{p.id}.dxf", kerf=KERF, curves="lines", curve_tolerance=0.01)
fp.export(f"{p.id}.svg")
print(f"id={p.id} lattice_area={p.metrics.area:.4f} filleted_area={fp.metrics.area:.4f} "
      f"perimeter={fp.metrics.perimeter:.4f} min_width={width:.3f} kerf={KERF}")
print(f"wrote {p.id}.dxf {p.id}.svg")
