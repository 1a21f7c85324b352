"""Build a laser-cut kit from Python: a strip of three hexagon plates joined by printed sleeves.

The spec is the same as a TOML file for ``fabpat assemble`` (see ``assemblies/*.toml``), given as a
dict. Writes the nested DXF sheets, the net (SVG) and the bill of materials into ``kit/``.
Run: ``python examples/build_kit.py``.
"""

import csv

from fabpat.assembly.build import assemble
from fabpat.assembly.spec import parse_spec

spec = parse_spec({
    "name": "three-plates",
    "tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
    "patterns": {"groups": ["0x0488", "0x0508", "0x0588"], "group_columns": 1},  # one column each
    "plates": {"thickness": 0.8, "process": "laser"},  # 2 mm would pass the 2 % strain limit when pushed together
    "sheet": {"width": 300.0, "height": 200.0, "kerf": 0.15},
    "output": {"formats": ["dxf", "svg", "bom"]},
}, "three-plates.toml")
kit = assemble(spec, "kit")
bom = list(csv.DictReader(open("kit/bom.csv", encoding="utf-8")))
plates = sum(int(r["count"]) for r in bom if r["kind"] == "plate")
sleeves = sum(int(r["count"]) for r in bom if r["kind"] == "sleeve")
cut = sum(int(r["count"]) * float(r["unit_cut_length_mm"]) for r in bom if r["kind"] == "plate")
print(f"plates={plates} sleeves={sleeves} sheets={kit.sheets} cut_length={cut:.3f}")
for r in bom:
    if r["kind"] == "plate":
        print(f"part={r['part'].split()[-1]} area={float(r['unit_area_mm2']):.3f} file={r['file']}")
print("wrote " + " ".join(f"kit/{f}" for f in kit.files))
