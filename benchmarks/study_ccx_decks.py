"""Every exported CalculiX deck against fabpat: strain energy of both, per scenario and analysis.

Run: ``python benchmarks/study_ccx_decks.py [h] [ID:sides ...]`` (default h = 1.5, patterns
0x5a88:6 and 0x0508:5). For each pattern and analysis (linear, NLGEOM) it runs
``fabpat simulate ID --sides n --scenario all --h h [--linear] --export-inp d.inp --json`` — the deck
exactly as a user gets it — then ``ccx -i`` on each deck, and prints a Markdown table: nodes, fabpat
and CalculiX energy (N·mm), difference, whether CalculiX applied the whole load (``.sta`` total time 1)
and CalculiX's wall-clock seconds. Needs ``ccx`` (Debian package calculix-ccx). NLGEOM decks at the
default mesh take minutes each in CalculiX. Results: docs/fabrication-files.md.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fabpat.simulation.inp import read_ccx_energy


def main(argv: list[str]) -> None:
    if shutil.which("ccx") is None:
        sys.exit("ccx not found: install the Debian package calculix-ccx")
    h = argv[0] if argv and ":" not in argv[0] else "1.5"
    cases = [a.split(":") for a in argv if ":" in a] or [["0x5a88", "6"], ["0x0508", "5"]]
    print("| pattern | n | scenario | analysis | nodes | fabpat | CalculiX | difference | full load | ccx s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for pid, n in cases:
            for linear in (True, False):
                stem = f"{pid}-{n}-{'lin' if linear else 'nl'}"
                cmd = [sys.executable, "-m", "fabpat", "simulate", pid, "--sides", n, "--scenario", "all",
                       "--h", h, "--export-inp", str(out / f"{stem}.inp"), "--json"] + (["--linear"] if linear else [])
                rows = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
                for row in rows:
                    deck = f"{stem}-{row['scenario']}"
                    t = time.perf_counter()
                    subprocess.run(["ccx", "-i", deck], cwd=out, capture_output=True, text=True)
                    seconds = time.perf_counter() - t
                    sta = (out / f"{deck}.sta").read_text().strip().splitlines()
                    full = linear or abs(float(sta[-1].split()[4]) - 1.0) < 1e-9
                    energy = read_ccx_energy(out / f"{deck}.dat")
                    print(f"| {pid} | {n} | {row['scenario']} | {'linear' if linear else 'NLGEOM'} | {row['nodes']} "
                          f"| {row['energy']:.4f} | {energy:.4f} | {100 * (energy / row['energy'] - 1):+.2f} % "
                          f"| {'yes' if full else 'no'} | {seconds:.0f} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
