"""Read the built-in catalog and pick patterns by stiffness.

The catalog holds every hexagon pattern's metrics and its strain energies in the three scenarios
(nonlinear, mesh-converged: each pattern solved on a 2.5 mm mesh — finer, 1.1 × min_width, for necks
under 2.27 mm — and on its nested refinement, the two energies extrapolated; docs/accuracy.md).
Under a prescribed moment a stiffer plate stores *less* energy, so the stiffest dome-former is the one
with the smallest Dome energy. Keep the printable ones (narrowest bar ≥ 2 mm) and print the stiffest and
the softest, and the five closest to a target energy.
Run: ``python examples/pick_by_stiffness.py``.
"""

import fabpat

rows = [r for r in fabpat.catalog() if r["energy_dome"] is not None and r["min_width"] >= 2.0]
rows.sort(key=lambda r: r["energy_dome"])
stiff, soft = rows[0], rows[-1]
print(f"printable={len(rows)}")
print(f"stiffest={stiff['id']} energy_dome={stiff['energy_dome']:.6f} min_width={stiff['min_width']:.4f}")
print(f"softest={soft['id']} energy_dome={soft['energy_dome']:.6f} min_width={soft['min_width']:.4f}")
target = 200.0  # N·mm
for r in sorted(rows, key=lambda r: abs(r["energy_dome"] - target))[:5]:
    print(f"near_target={r['id']} energy_dome={r['energy_dome']:.6f}")
