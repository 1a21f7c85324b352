"""`fabpat assemble` end to end: time per step for the small test spec, the paper's sphere (straight
sleeves: the kit predicts the bent shape at the default ``--predict-h``, step "prediction") and the rigid
polyhedron (sleeves at the dihedral angles).

Run: ``python benchmarks/bench_assembly.py`` — prints Markdown tables (seconds, one process, warm
imports after the first spec) and re-reads the rigid sphere's STEP assembly to confirm its 122 solids.
Output folders go to a temporary directory that is removed afterwards.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

from fabpat.assembly.build import assemble
from fabpat.assembly.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
SPECS = ("test-small.toml", "truncated-icosahedron.toml", "truncated-icosahedron-rigid.toml")


def run(spec_path: Path, out: Path) -> tuple[dict[str, float], float, dict[str, object]]:
    """Assemble one spec; returns (seconds per step, total seconds, manifest)."""
    times: dict[str, float] = {}
    state = {"step": "load", "t": time.perf_counter()}

    def tell(step: str) -> None:
        now = time.perf_counter()
        times[str(state["step"])] = times.get(str(state["step"]), 0.0) + now - float(state["t"])
        state.update(step=step, t=now)

    t0 = time.perf_counter()
    spec = load_spec(spec_path)
    assemble(spec, out, tell)
    tell("done")
    total = time.perf_counter() - t0
    return times, total, json.loads((out / "manifest.json").read_text())


def main() -> None:
    results = {}
    with tempfile.TemporaryDirectory(prefix="bench-assembly-") as tmp:
        for name in SPECS:
            results[name] = run(ROOT / "assemblies" / name, Path(tmp) / name.removesuffix(".toml"))
        from fabpat.assembly.export import read_step_solids

        t = time.perf_counter()
        solids, names = read_step_solids(Path(tmp) / "truncated-icosahedron-rigid" / "assembly.step")
        reread = time.perf_counter() - t
    steps = list(dict.fromkeys(s for times, _, _ in results.values() for s in times))
    print("| step | " + " | ".join(SPECS) + " |")
    print("|---|" + "---:|" * len(SPECS))
    for s in steps:
        print(f"| {s} | " + " | ".join(f"{results[n][0].get(s, 0.0):.2f}" for n in SPECS) + " |")
    print("| **total** | " + " | ".join(f"**{results[n][1]:.2f}**" for n in SPECS) + " |")
    print()
    print("| spec | parts | sheets | files |")
    print("|---|---|---:|---:|")
    for n in SPECS:
        m = results[n][2]
        parts = ", ".join(f"{v} × {k}" for k, v in m["counts"].items())  # type: ignore[union-attr]
        print(f"| {n} | {parts} | {m['sheets']} | {len(m['files']) + 1} |")  # type: ignore[arg-type]
    print()
    pred = results["truncated-icosahedron.toml"][2].get("prediction")
    print(f"Sphere prediction: {pred}")
    print(f"Rigid sphere STEP re-import: {solids} solids, {len(names)} named instances, {reread:.2f} s")
    if solids != 122:
        raise SystemExit(f"expected 122 solids in the sphere's STEP, got {solids}")


if __name__ == "__main__":
    main()
