"""The paper's sphere closed by straight sleeves: solver cost and read-outs by mesh size, and pairs.

    python benchmarks/study_sphere.py                        # the shipped spec at h = 3, 2, 1.5
    python benchmarks/study_sphere.py --h 3                  # one mesh
    python benchmarks/study_sphere.py --pairs 0x0488/0x0508 0x0488/0x2f88 --h 3   # other pairs
    python benchmarks/study_sphere.py --pictures docs/img     # sphere-<hex>-<pent>.png per pair

Columns: h (mm), nodes (plate nodes + sleeves), dofs (unknowns of the linear systems), LU
factorizations, seconds of the closure (meshing and set-up included), radius (mm), sphericity_rms and
sphericity_max (radial deviation / radius), peak surface strain and its plate, strain energy (N·mm),
and for each pair the ratio of the two plates' Dome energies in the built-in catalog (the hexagon's
hexagon energy and the pentagon's pentagon energy).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from fabpat.assembly.solve.simulation import simulate_assembly
from fabpat.assembly.spec.load import load_spec

SPEC = "assemblies/truncated-icosahedron.toml"


def dome_energies(sides: int) -> dict[str, float]:
    """Dome energies (N·mm) of the built-in catalog's plates of ``sides`` (the rule's scenario); empty,
    with the sweep command that adds them on stderr, if the catalog has none."""
    import sys

    from fabpat.catalog import CatalogError, polygon_energies

    try:
        return polygon_energies(None, "dome", sides)
    except CatalogError as e:
        print(f"no Dome energy ratio: {e}", file=sys.stderr)
        return {}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h", type=float, nargs="+", default=[3.0, 2.0, 1.5])
    ap.add_argument("--pairs", nargs="+", default=[], metavar="HEX/PENT",
                    help="hexagon/pentagon pattern IDs (default: the spec's pair)")
    ap.add_argument("--pictures", type=Path, default=None, help="folder for one PNG per pair (finest h)")
    args = ap.parse_args()
    spec = load_spec(SPEC)
    shipped = (spec.patterns.polygon_pattern(6), spec.patterns.polygon_pattern(5))
    pairs = [tuple(p.split("/")) for p in args.pairs] or [shipped]
    hexagon, pentagon = dome_energies(6), dome_energies(5)
    print(f"{'pair':>13} {'dome ratio':>10} {'h mm':>5} {'nodes':>7} {'dofs':>7} {'fact.':>5} {'s':>6} "
          f"{'radius':>8} {'sph. rms':>9} {'sph. max':>9} {'peak strain':>11} {'plate':>5} {'energy':>8}")
    for hid, pid in pairs:
        ps = dataclasses.replace(spec.patterns, polygons=((6, hid), (5, pid)))
        sp = dataclasses.replace(spec, patterns=ps)
        e = (hexagon[hid], pentagon[pid]) if hid in hexagon and pid in pentagon else (float("nan"),) * 2
        ratio = max(e) / min(e)
        for h in args.h:
            t0 = time.perf_counter()
            sim = simulate_assembly(sp, h=h)
            s = time.perf_counter() - t0
            f = sim.fields()
            print(f"{hid + '/' + pid:>13} {ratio:10.2f} {h:5.2f} {f['nodes']:7d} {f['dofs']:7d} "
                  f"{f['factorizations']:5d} {s:6.1f} {f['radius']:8.3f} {f['sphericity_rms']:9.5f} "
                  f"{f['sphericity_max']:9.5f} {f['peak_strain']:11.5f} {f['peak_strain_plate']:>5} "
                  f"{f['energy']:8.2f}", flush=True)
        if args.pictures is not None:
            args.pictures.mkdir(parents=True, exist_ok=True)
            sim.to_png(args.pictures / f"sphere-{hid}-{pid}.png", "energy")


if __name__ == "__main__":
    main()
