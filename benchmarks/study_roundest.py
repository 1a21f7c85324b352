"""``rule = "roundest"`` on the shipped sphere, from the catalog's patterns alone and with its family members.

    python benchmarks/study_roundest.py                       # both, 8 candidates, h = 3
    python benchmarks/study_roundest.py --candidates 4 --h 4 --only members

For each way (``patterns``: the spec's rule alone; ``members``: with ``bridge_weight = "rule"``, the
catalog's swept family members join the candidates, :mod:`fabpat.assembly.choose.members`) it prints the candidate
pairs in the rule's order with the closed sphere's radius (mm), sphericity_rms and sphericity_max
(radial deviation over the radius, %), peak surface strain (%) and seconds, the kept pair marked, and
any note on a polygon without family rows. The number the rule minimises is sphericity_rms (under the
strain limit). Results in docs/sphere.md and docs/variations.md.
"""

from __future__ import annotations

import argparse
import time
import tomllib
from pathlib import Path

from fabpat.assembly.choose.choice import candidate_pairs
from fabpat.assembly.place.placement import build_tiling
from fabpat.assembly.solve.predict import choose_roundest
from fabpat.assembly.spec.load import parse_spec

SPEC = Path(__file__).resolve().parents[1] / "assemblies" / "truncated-icosahedron.toml"


def run(members: bool, candidates: int, h: float) -> None:
    """Close every candidate pair of one way and print its Markdown rows."""
    data = tomllib.loads(SPEC.read_text(encoding="utf-8"))
    data["patterns"] = {"rule": "roundest", "scenario": "dome", "candidates": candidates,
                        **({"bridge_weight": "rule"} if members else {})}
    spec = parse_spec(data, str(SPEC))
    notes: list[str] = []
    pairs = candidate_pairs(spec, notes=notes)
    faces = [len(f) for f in build_tiling(spec).faces]
    t0 = time.perf_counter()
    _, _, _, tried = choose_roundest(spec, pairs, faces, h, True, lambda _spec, _ids: None)
    way = "members" if members else "patterns"
    for r in tried:
        if "error" in r:
            print(f"| {way} | {r['hexagon']} | {r['pentagon']} | failed: {r['error']} | | | | | |")
            continue
        print(f"| {way} | {r['hexagon']} | {r['pentagon']} | {r['radius']:.2f} | {100 * r['sphericity_rms']:.3f} | "
              f"{100 * r['sphericity_max']:.3f} | {100 * r['peak_strain']:.2f} | {r['seconds']:.0f} | "
              f"{'kept' if r['chosen'] else ''} |")
    for n in notes:
        print(f"\nnote ({way}): {n}")
    print(f"\n{way}: {len(tried)} closures in {time.perf_counter() - t0:.0f} s\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--candidates", type=int, default=8)
    ap.add_argument("--h", type=float, default=3.0)
    ap.add_argument("--only", choices=("patterns", "members"), default=None)
    a = ap.parse_args()
    print("| way | hexagon | pentagon | radius mm | sphericity_rms % | sphericity_max % | peak strain % | s | |")
    print("|---|---|---|---|---|---|---|---|---|")
    for members in (False, True):
        if a.only is None or a.only == ("members" if members else "patterns"):
            run(members, a.candidates, a.h)


if __name__ == "__main__":
    main()
