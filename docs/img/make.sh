#!/usr/bin/env bash
# Regenerates the pictures of the README and the docs with fabpat itself (run from the repository root).
# The two PNGs are shrunk so the repository stays small (Pillow comes with matplotlib).
set -euo pipefail
cd "$(dirname "$0")/../.."
img=docs/img
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

fabpat show 0xa --depth 1 --svg "$img/pattern-0xa-depth1.svg"
fabpat show 0x0688 --svg "$img/pattern-0x0688.svg"
fabpat show 0x0688 --sides 3 --svg "$img/pattern-0x0688-triangle.svg"
fabpat show 0x0688 --filleted --svg "$img/filleted-0x0688.svg"
fabpat show 0x0688 --sides 5 --filleted --svg "$img/filleted-0x0688-pentagon.svg"
fabpat sheet --sides 6 --out "$tmp/library.png"
fabpat assemble assemblies/truncated-icosahedron.toml --out "$tmp/sphere-kit" --no-progress >/dev/null
# the paper's claim as pictures: the shipped pair (Dome energies 1.45× apart) and one 3.4× apart
fabpat simulate-assembly assemblies/truncated-icosahedron.toml --png "$tmp/sphere-similar.png" >/dev/null
sed 's/pentagon = "0x0508"/pentagon = "0x2f88"/' assemblies/truncated-icosahedron.toml > "$tmp/differing.toml"
fabpat simulate-assembly "$tmp/differing.toml" --png "$tmp/sphere-differing.png" >/dev/null

python - "$tmp" "$img" <<'PY'
import sys
from PIL import Image

tmp, img = sys.argv[1:]
sheet = Image.open(f"{tmp}/library.png").convert("L")
sheet = sheet.resize((800, round(sheet.height * 800 / sheet.width)), Image.LANCZOS).quantize(colors=4)
sheet.save(f"{img}/library-sheet.png", optimize=True, bits=4)
sphere = Image.open(f"{tmp}/sphere-kit/assembly.png").convert("RGB")
sphere = sphere.resize((640, round(sphere.height * 640 / sphere.width)), Image.LANCZOS)
sphere.quantize(colors=64, method=Image.Quantize.MEDIANCUT).save(f"{img}/sphere-assembly.png", optimize=True)
for name in ("similar", "differing"):
    pic = Image.open(f"{tmp}/sphere-{name}.png").convert("RGB")
    pic = pic.resize((480, round(pic.height * 480 / pic.width)), Image.LANCZOS)
    pic.quantize(colors=64, method=Image.Quantize.MEDIANCUT).save(f"{img}/sphere-{name}.png", optimize=True)
PY
