"""`fabpat assemble` end to end: time per step for the small test spec, the paper's sphere (straight
sleeves: the kit predicts the bent shape at the default ``--predict-h``, step "prediction") and the rigid
polyhedron (sleeves at the dihedral angles).

Run: ``python benchmarks/bench_assembly.py`` — prints Markdown tables (seconds, one process, warm
imports after the first spec) and re-reads the rigid sphere's STEP assembly to confirm its 122 solids.
Output folders go to a temporary directory that is removed afterwards.

``python benchmarks/bench_assembly.py --solve [--h 3 2] [--save F.json] [--before F.json]`` times the
assembly solver alone (``simulate_assembly``) on the shipped graded strip (2 × 15, 10 % end shortening)
and the shipped sphere closure: nodes, dofs, Newton iterations, factorizations, seconds in the tangent
(element tangents, transformation, sparse assembly), in factorization and solves, in the residuals
(element forces), in the rest of the path (the linked solver's set-up, state updates between
iterations), in set-up and read-outs outside the path, the process's CPU seconds (every thread; less
sensitive to a shared machine's load than the wall seconds) and the answers (peak, reaction, radius,
sphericity, peak strain). The compiled kernels are loaded first (their seconds printed apart), and the
machine's calibration, the "fixed sparse LU" by which timing goals are scaled
(``bench_linalg.calibration``), is printed above the table. ``--save`` keeps the rows as JSON;
``--before`` adds the saved rows of an earlier version beside them and the relative change of every answer.
``--goldberg M N`` (with ``--solve``) adds the Goldberg sphere GP(M, N) at its best-fit placement, of the shipped
sphere's plates (0x0488 hexagons, 0x0508 pentagons, 1 mm, straight sleeves, edge 36 mm); ``--only-goldberg``
solves it alone.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from fabpat.assembly.kit.build import assemble
from fabpat.assembly.spec.load import load_spec, parse_spec

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


SOLVE_SPECS = ("graded-strip", "truncated-icosahedron")
ANSWERS = ("peak", "reaction", "radius", "sphericity_rms", "peak_strain", "energy")


def goldberg_spec(m: int, n: int) -> object:
    """GP(m, n) of the shipped sphere's plates and straight sleeves (edge 36 mm, 1 mm plates)."""
    data = {"name": f"goldberg-{m}-{n}", "tiling": {"kind": "goldberg", "m": m, "n": n, "edge": 36.0},
            "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"},
            "plates": {"thickness": 1.0}, "sleeve": {"angle": "flat"}}
    return parse_spec(data, f"goldberg-{m}-{n}.toml")


def solve_row(name: str, h: float) -> dict[str, object]:
    """One assembly solve at mesh edge h (mm): counts, seconds by phase and the answers. ``name``: a shipped
    spec's file stem, or ``goldberg-M-N``."""
    from fabpat.assembly.solve.simulation import simulate_assembly

    if name.startswith("goldberg-"):
        m, n = (int(v) for v in name.split("-")[1:])
        spec = goldberg_spec(m, n)
    else:
        spec = load_spec(ROOT / "assemblies" / f"{name}.toml")
    t, cpu = time.perf_counter(), time.process_time()
    sim = simulate_assembly(spec, h=h)
    wall, cpu = time.perf_counter() - t, time.process_time() - cpu
    f = sim.fields()
    sec = dict(sim.run.result.seconds)
    return {"spec": name, "h": h, "nodes": f["nodes"], "dofs": f["dofs"], "iterations": f["iterations"],
            "factorizations": f["factorizations"], "tangent_s": sec["tangent"], "factor_solve_s": sec["factor_solve"],
            "residual_s": sec.get("residual"),
            "rest_of_path_s": sec["total"] - sec["tangent"] - sec["factor_solve"] - sec.get("residual", 0.0),
            "outside_path_s": wall - sec["total"],
            "total_s": wall, "cpu_s": cpu, "plate_energies": f["plate_energies"], **{k: f.get(k) for k in ANSWERS}}


def solve_table(hs: list[float], save: Path | None, before: Path | None, rows_file: Path | None = None,
                names: tuple[str, ...] = SOLVE_SPECS) -> None:
    """Solve ``names`` (or read ``rows_file``, rows of an earlier ``--save``) and print the tables."""
    if rows_file is None:
        from bench_linalg import calibration

        from fabpat.shell.compiled import load_kernels

        print(f"compiled kernels loaded in {load_kernels():.1f} s (not in the rows below)")
        print(f"calibration (SuperLU factorisation of 0x2d08's Dome tangent at h = 0.7 mm, least of 5): "
              f"{calibration():.3f} s\n")
    rows = json.loads(rows_file.read_text()) if rows_file else [solve_row(name, h) for h in hs for name in names]
    if save is not None:
        save.write_text(json.dumps(rows, indent=1))
    old = {(r["spec"], r["h"]): r for r in json.loads(before.read_text())} if before else {}
    cols = ("nodes", "dofs", "iterations", "factorizations", "tangent_s", "factor_solve_s", "residual_s",
            "rest_of_path_s", "outside_path_s", "total_s", "cpu_s")
    print("| assembly | h mm | " + " | ".join(cols) + " |")
    print("|---|---:|" + "---:|" * len(cols))
    for r in rows:
        for label, src in (("before", old.get((r["spec"], r["h"]))), ("now", r)):
            if src is None:
                continue
            # rows saved before the residuals were timed apart count them in rest_of_path_s
            cells = [("–" if src.get(c) is None else f"{src[c]:.1f}") if c.endswith("_s") else str(src[c])
                     for c in cols]
            print(f"| {r['spec']} ({label}) | {r['h']:g} | " + " | ".join(cells) + " |")
    if old:
        print()
        print("| assembly | h mm | answer | before | now | relative change |")
        print("|---|---:|---|---:|---:|---:|")
        for r in rows:
            o = old.get((r["spec"], r["h"]))
            if o is None:
                continue
            for k in ANSWERS:
                if r.get(k) is None or o.get(k) is None or k == "reaction" and r["spec"] != "graded-strip":
                    continue
                a, b = float(o[k]), float(r[k])  # type: ignore[arg-type]
                print(f"| {r['spec']} | {r['h']:g} | {k} | {a:.6g} | {b:.6g} | {(b - a) / a:.1e} |")
            pe_o, pe_n = o["plate_energies"], r["plate_energies"]
            worst = max(abs(pe_n[p] / pe_o[p] - 1.0) for p in pe_o)  # type: ignore[index]
            print(f"| {r['spec']} | {r['h']:g} | plate energies, worst | | | {worst:.1e} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--solve", action="store_true", help="time the assembly solver alone (see the module doc)")
    ap.add_argument("--h", type=float, nargs="+", default=[3.0], help="mesh edges, mm (with --solve)")
    ap.add_argument("--save", type=Path, help="write the --solve rows to this JSON file")
    ap.add_argument("--before", type=Path, help="JSON rows of an earlier --save to compare with")
    ap.add_argument("--rows", type=Path, help="print the tables of saved --solve rows instead of solving")
    ap.add_argument("--goldberg", type=int, nargs=2, metavar=("M", "N"), help="also solve GP(M, N) (with --solve)")
    ap.add_argument("--only-goldberg", action="store_true", help="solve GP(M, N) alone (with --goldberg)")
    args = ap.parse_args()
    if args.solve or args.rows:
        gp = (f"goldberg-{args.goldberg[0]}-{args.goldberg[1]}",) if args.goldberg else ()
        solve_table(args.h, args.save, args.before, args.rows, gp if args.only_goldberg else SOLVE_SPECS + gp)
        return
    results = {}
    with tempfile.TemporaryDirectory(prefix="bench-assembly-") as tmp:
        for name in SPECS:
            results[name] = run(ROOT / "assemblies" / name, Path(tmp) / name.removesuffix(".toml"))
        from fabpat.assembly.show.export import read_step_solids

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
