"""The sweep machinery: resume by input hash, one transaction per pattern, SIGKILL mid-run, dask (and a
dask address that is none refused in one line).

Most tests inject a tiny fake task (module-level, so worker processes can import it); one runs the real
fillet → mesh → solver pipeline on two patterns at a coarse mesh through the CLI.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fabpat.catalog import open_catalog
from fabpat.catalog.sweep import SweepSetup, run_sweep, simulate_pattern
from fabpat.errors import FabpatError
from fabpat.simulation.convergence import converged_h
from tests.conftest import run_cli
from tests.helpers import default_sigint
from tests.helpers import invoke_result as invoke
from tests.helpers import refusal_in as one_line_error

IDS = [f"0x{k:04x}" for k in range(0x1008, 0x1008 + 16 * 12, 16)]  # 12 fake IDs (never solved)


def fake_task(pattern_id: str, sides: int, depth: int, edge: float, thickness: float, weight: float, E: float,
              nu: float, h: float, scenarios: tuple[str, ...], extrapolate: bool = False) -> list[dict[str, object]]:
    """Rows shaped like simulate_pattern's, with energy = E/1000 · (index of the scenario + 1)."""
    from fabpat.catalog import solver_version
    from fabpat.catalog.sweep import fine_mesh, pattern_hash, result_hash

    if os.environ.get("FAKE_PID_FILE"):  # the kill test checks that workers die with the parent
        with open(os.environ["FAKE_PID_FILE"], "a") as f:
            f.write(f"{os.getpid()}\n")
    time.sleep(float(os.environ.get("FAKE_SLEEP", "0")))
    if pattern_id == os.environ.get("FAKE_CRASH"):
        raise RuntimeError("boom")
    v = solver_version()
    key = {"id": pattern_id, "sides": sides, "depth": depth, "edge": edge, "thickness": thickness, "weight": weight}
    rows: list[dict[str, object]] = [{"table": "patterns", **key, "area": 1.0, "perimeter": 2.0, "polar_moment": 3.0,
                                      "input_hash": pattern_hash(pattern_id, sides, depth, edge, thickness, weight, v)}]
    for k, sc in enumerate(scenarios):
        ok = pattern_id != os.environ.get("FAKE_DIVERGE")
        h_fine = fine_mesh(h) if extrapolate else None
        rows.append({"table": "results", **key, "scenario": sc, "E": E, "nu": nu, "h": h, "h_fine": h_fine,
                     "nonlinear": 1, "energy": E / 1000 * (k + 1) if ok else None, "converged": int(ok),
                     "solver_version": v, "error": None if ok else "SolverError: fake", "computed_at": "now",
                     "input_hash": result_hash(pattern_id, sides, depth, edge, thickness, weight, E, nu, h, sc, v,
                                               h_fine)})
    return rows


def _count(db: Path) -> tuple[int, int]:
    with open_catalog(db) as cat:
        return (len(cat.query("SELECT id FROM patterns")), len(cat.query("SELECT id FROM results")))


def test_resume_skips_matching_hashes_and_recomputes_changed_inputs(tmp_path: Path) -> None:
    db = tmp_path / "c.sqlite"
    r = run_sweep(db, IDS, workers=1, task=fake_task)
    assert (r.computed, r.skipped, r.crashed) == (36, 0, []) and _count(db) == (12, 36)
    assert not Path(f"{db}-wal").exists()  # finished: one self-contained file, out of WAL mode
    r = run_sweep(db, IDS, workers=1, task=fake_task)
    assert (r.computed, r.skipped) == (0, 36)
    with sqlite3.connect(db) as c:  # lose two rows: only those are recomputed
        c.execute("DELETE FROM results WHERE id = ? AND scenario = 'dome'", (IDS[3],))
        c.execute("UPDATE results SET input_hash = 'stale' WHERE id = ? AND scenario = 'cylinder'", (IDS[5],))
    r = run_sweep(db, IDS, workers=1, task=fake_task)
    assert (r.computed, r.skipped) == (2, 34)
    r = run_sweep(db, IDS, SweepSetup(E=2000.0), workers=1, task=fake_task)  # material is in the hash
    assert r.computed == 36
    with open_catalog(db) as cat:
        assert cat.query("SELECT DISTINCT E FROM results") == [{"E": 2000.0}]
        assert {r["energy_dome"] for r in cat.pattern_rows()} == {6.0}
    assert run_sweep(db, IDS, SweepSetup(E=2000.0), workers=1, force=True, task=fake_task).computed == 36


def test_failures_are_stored_crashes_are_not(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    db = tmp_path / "c.sqlite"
    monkeypatch.setenv("FAKE_CRASH", IDS[0])
    monkeypatch.setenv("FAKE_DIVERGE", IDS[1])
    r = run_sweep(db, IDS[:4], workers=2, task=fake_task)
    assert len(r.crashed) == 1 and r.crashed[0].startswith(f"{IDS[0]}: RuntimeError: boom")
    assert (r.computed, r.failed_rows) == (9, 3)
    with open_catalog(db) as cat:
        rows = {q["id"]: q for q in cat.pattern_rows()}
        assert IDS[0] not in rows and rows[IDS[1]]["energy_cantilever"] is None
        assert rows[IDS[1]]["converged_cantilever"] is False and rows[IDS[2]]["converged_cantilever"] is True
    monkeypatch.delenv("FAKE_CRASH")
    r = run_sweep(db, IDS[:4], workers=1, task=fake_task)  # the crashed one is retried, the failure is not
    assert (r.computed, r.skipped) == (3, 9)


def test_write_rows_is_all_or_nothing(tmp_path: Path) -> None:
    rows = fake_task(IDS[0], 6, 2, 36.0, 2.0, 0.2, 1000.0, 0.35, 1.5, ("cantilever", "dome"))
    with open_catalog(tmp_path / "c.sqlite", write=True) as cat:
        with pytest.raises(ValueError, match="unknown table"):
            cat.write_rows([*rows, {"table": "nope"}])
        assert cat.query("SELECT COUNT(*) AS n FROM results") == [{"n": 0}]
        assert cat.write_rows(rows) == 3


_KILL_SCRIPT = """
import sys
from fabpat.catalog.sweep import run_sweep
from tests.test_sweep import IDS, fake_task
run_sweep(sys.argv[1], IDS, workers=2, task=fake_task)
"""


def test_sigkill_mid_run_loses_nothing_finished_and_resumes(tmp_path: Path) -> None:
    db, pids = tmp_path / "c.sqlite", tmp_path / "pids.txt"
    env = dict(os.environ, FAKE_SLEEP="0.5", FAKE_PID_FILE=str(pids), PYTHONPATH=str(Path(__file__).parents[1]))
    proc = subprocess.Popen([sys.executable, "-c", _KILL_SCRIPT, str(db)], env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # wait until a few patterns are committed, then kill
            if db.exists():
                try:
                    if _count(db)[0] >= 4:
                        break
                except Exception:  # noqa: BLE001 - the schema may not exist yet
                    pass
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)  # the parent only: its workers must die with it (PDEATHSIG)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    with sqlite3.connect(db) as c:
        assert c.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    n_patterns, n_results = _count(db)
    assert 4 <= n_patterns < len(IDS)  # killed mid-run, finished patterns kept
    assert n_results == 3 * n_patterns  # no pattern half-written
    worker_pids = {int(p) for p in pids.read_text().split()} - {proc.pid}
    time.sleep(0.5)
    alive = [p for p in worker_pids if Path(f"/proc/{p}").exists() and "Z" not in _state(p)]
    assert not alive, f"worker processes survived the killed sweep: {alive}"
    r = run_sweep(db, IDS, workers=1, task=fake_task)
    assert (r.skipped, r.computed) == (3 * n_patterns, 3 * (len(IDS) - n_patterns))
    assert _count(db) == (len(IDS), 3 * len(IDS))


def test_ctrl_c_stops_workers_promptly(tmp_path: Path) -> None:
    db, pids = tmp_path / "c.sqlite", tmp_path / "pids.txt"
    env = dict(os.environ, FAKE_SLEEP="10", FAKE_PID_FILE=str(pids), PYTHONPATH=str(Path(__file__).parents[1]))
    proc = subprocess.Popen([sys.executable, "-c", _KILL_SCRIPT, str(db)], env=env, stderr=subprocess.PIPE,
                            preexec_fn=default_sigint)  # SIGINT is ignored in a background job's children
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (pids.exists() and len(pids.read_text().split()) >= 2):
        time.sleep(0.05)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert time.monotonic() - t0 < 5  # the 10-s tasks in progress are abandoned, not awaited
    assert b"KeyboardInterrupt" in err
    time.sleep(0.3)
    assert not [p for p in map(int, pids.read_text().split()) if "Z" not in _state(p)]


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return "Z"


def test_dask_local_cluster(tmp_path: Path) -> None:
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as lc:
        db = tmp_path / "c.sqlite"
        r = run_sweep(db, IDS[:5], dask=lc.scheduler_address, task=fake_task)
        assert (r.computed, r.crashed) == (15, [])
        assert run_sweep(db, IDS[:5], dask=lc.scheduler_address, task=fake_task).skipped == 15
        r = run_sweep(db, IDS[:5], dask=lc.scheduler_address, task=fake_task, force=True)  # pure=False: reruns
        assert r.computed == 15
    assert _count(db) == (5, 15)
    with pytest.raises(FabpatError, match="cannot connect to the dask scheduler"):
        run_sweep(db, IDS[:1], dask="tcp://127.0.0.1:1", dask_timeout=0.5, task=fake_task)
    # an unreachable scheduler leaves no new (empty) catalog behind
    new = tmp_path / "new.sqlite"
    with pytest.raises(FabpatError, match="cannot connect to the dask scheduler"):
        run_sweep(new, IDS[:1], dask="tcp://127.0.0.1:1", dask_timeout=0.5, task=fake_task)
    assert not new.exists()


@pytest.mark.slow
def test_real_pipeline_two_patterns_coarse(tmp_path: Path) -> None:
    """The real simulate_pattern through the CLI (process pool), at a coarse 3 mm mesh."""
    db = tmp_path / "c.sqlite"
    res = run_cli("sweep", "--sample", "2", "--seed", "5", "--h", "3", "--workers", "2", "--db", str(db))
    assert res.returncode == 0, res.stderr
    assert "6 pattern-scenarios computed (0 did not converge)" in res.stdout
    with open_catalog(db) as cat:
        rows = cat.pattern_rows(pictures=True)
        res_rows = cat.results()
    assert len(rows) == 2 and all(r["svg_path"].startswith("M ") for r in rows)
    for r in rows:
        assert 0 < r["min_width"] < r["filleted_area"] and r["area"] > 0
        # soft lacy patterns: cantilever energy above the solid hexagon's 2.6 N·mm (notes), dome the largest
        assert 2.6 < r["energy_cantilever"] < 200 and r["energy_dome"] > r["energy_cylinder"]
    # --h 3 is the coarse mesh's upper bound: a pattern whose necks it would not resolve gets 1.1 × min_width
    widths = {r["id"]: r["min_width"] for r in rows}
    assert all(q["h"] == converged_h(widths[q["id"]], 3.0) and q["h_fine"] == q["h"] / 2 for q in res_rows)
    assert all(q["nodes"] > 100 and q["iterations"] > 1 for q in res_rows)
    assert len({q["solver_version"] for q in res_rows}) == 1
    res = run_cli("sweep", "--sample", "2", "--seed", "5", "--h", "3", "--db", str(db))
    assert "0 pattern-scenarios computed" in res.stdout and "6 already up to date" in res.stdout


def test_simulate_pattern_records_geometry_error() -> None:
    rows = simulate_pattern("0x0000", 6, 2, 36.0, 2.0, 0.2, 1000.0, 0.35, 1.5, ("cantilever",))
    assert rows[0]["table"] == "patterns" and "PatternError" in rows[0]["error"]
    assert rows[1]["converged"] == 0 and rows[1].get("energy") is None and "PatternError" in rows[1]["error"]


def test_cli_errors_are_one_line(tmp_path: Path) -> None:
    res = invoke("sweep", "--db", str(tmp_path / "no" / "c.sqlite"), "--sample", "1")
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and "does not exist" in res.stderr
    res = invoke("sweep", "--depth", "3", "--db", str(tmp_path / "c.sqlite"))
    assert res.exit_code == 2 and "--sample" in res.stderr


@pytest.mark.slow
def test_extrapolated_sweep_stores_richardson_energy_and_switching_recomputes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--extrapolate`` (the default): the stored energy is E₁ + (E₁ − E₂)/(2^1.2 − 1) of the runs on a
    2 mm mesh and its nested refinement (Richardson with order 1.2), the other fields are the fine mesh's,
    ``h_fine`` says so; ``--no-extrapolate`` recomputes the row as one 1.5 mm mesh (the hash covers it),
    and the default again recomputes it extrapolated."""
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.convergence import nested_meshes
    from fabpat.simulation.mesh import mesh_outline
    from fabpat.simulation.scenarios import run_scenario

    # in this process (the real CLI group, --workers 1 runs inline): the test is about the stored rows,
    # not the process; the library cache stays off as in run_cli
    monkeypatch.setenv("FABPAT_CACHE", "off")
    db = tmp_path / "c.sqlite"
    other = {"table": "results", "id": "0xffff", "sides": 6, "depth": 2, "edge": 36.0, "thickness": 2.0,
             "weight": 0.2, "scenario": "dome", "E": 1000.0, "nu": 0.35, "h": 1.5, "nonlinear": 1, "energy": 1.0,
             "converged": 1, "solver_version": "v", "input_hash": "x", "computed_at": "now"}
    with open_catalog(db, write=True) as cat:  # a one-mesh row of another pattern: the sweep makes a mix
        cat.write_rows([other])
    res = invoke("sweep", "--sample", "1", "--seed", "0", "--db", str(db), "--workers", "1", "--extrapolate")
    assert res.exit_code == 0, res.stderr
    assert "3 extrapolated and 1 one-mesh energies" in res.stderr and res.stderr.count("warning") == 1
    with open_catalog(db, write=True) as cat:
        cat.conn.execute("DELETE FROM results WHERE id = '0xffff'")
        cat.conn.commit()
    with open_catalog(db) as cat:
        ids = {r["id"] for r in cat.results()}
    assert len(ids) == 1
    pid = ids.pop()
    fp = fillet_pattern(get_pattern(pid, 6, 2, 36.0), 0.2)
    (_, coarse), (_, fine) = nested_meshes(fp.outline, 2.5, 6, 36.0)
    run1 = run_scenario(fine, "cylinder", sides=6)
    e2, e1 = run_scenario(coarse, "cylinder", sides=6).energy, run1.energy
    e15 = run_scenario(mesh_outline(fp.outline, 1.5, 6, 36.0), "cylinder", sides=6).energy
    converged = e1 + (e1 - e2) / (2.0**1.2 - 1.0)
    with open_catalog(db) as cat:
        row = next(r for r in cat.results(scenario="cylinder"))
    assert row["h"] == 2.5 and row["h_fine"] == 1.25 and row["converged"] == 1
    assert row["energy"] == pytest.approx(converged, rel=1e-7)
    assert row["energy"] > e1 > e2  # the energy rises towards the converged value (docs/accuracy.md)
    assert row["nodes"] == run1.nodes and row["iterations"] == run1.iterations
    res = invoke("sweep", "--sample", "1", "--seed", "0", "--db", str(db), "--workers", "1", "--no-extrapolate")
    assert "3 pattern-scenarios computed" in res.stdout and "warning" not in res.stderr, res.stdout
    with open_catalog(db) as cat:
        row = next(r for r in cat.results(scenario="cylinder"))
    assert row["h"] == 1.5 and row["h_fine"] is None and row["energy"] == pytest.approx(e15, rel=1e-7)
    res = invoke("sweep", "--sample", "1", "--seed", "0", "--db", str(db), "--workers", "1")
    assert "3 pattern-scenarios computed" in res.stdout, res.stdout
    with open_catalog(db) as cat:
        row = next(r for r in cat.results(scenario="cylinder"))
    assert row["h_fine"] == 1.25 and row["energy"] == pytest.approx(converged, rel=1e-7)


def test_catalog_without_h_fine_reads_as_single_mesh_and_gains_the_column_when_written(tmp_path: Path) -> None:
    """A catalog made before ``h_fine`` existed (schema 1 as first released) is sound: read, its rows say
    None; opened read-only it is not modified; opened for writing it gains the column."""
    import hashlib

    db = tmp_path / "old.sqlite"
    conn = sqlite3.connect(db)
    from fabpat.catalog import PATTERN_COLUMNS, RESULT_COLUMNS, SCHEMA_VERSION

    conn.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
    conn.execute("INSERT INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,))
    conn.execute(f"CREATE TABLE patterns ({', '.join(f'{c} {t}' for c, t in PATTERN_COLUMNS.items())}, "
                 "PRIMARY KEY (id, sides, depth, edge, thickness, weight))")
    old = {c: t for c, t in RESULT_COLUMNS.items() if c != "h_fine"}
    conn.execute(f"CREATE TABLE results ({', '.join(f'{c} {t}' for c, t in old.items())}, "
                 "PRIMARY KEY (id, sides, depth, edge, thickness, weight, scenario))")
    conn.execute("INSERT INTO results (id, sides, depth, edge, thickness, weight, scenario, E, nu, h, nonlinear, "
                 "energy, converged, solver_version, input_hash, computed_at) VALUES "
                 "('0x2d08', 6, 2, 36, 2, 0.2, 'dome', 1000, 0.35, 1.5, 1, 180.0, 1, 'v', 'x', 'now')")
    conn.commit()
    conn.close()
    before = hashlib.sha256(db.read_bytes()).hexdigest()
    with open_catalog(db) as cat:
        rows = cat.results()
    assert rows[0]["h_fine"] is None and rows[0]["energy"] == 180.0
    assert hashlib.sha256(db.read_bytes()).hexdigest() == before  # readers never modify
    with open_catalog(db, write=True):
        pass
    cols = {r[1] for r in sqlite3.connect(db).execute("PRAGMA table_info(results)")}
    assert "h_fine" in cols


def test_extrapolated_sweep_too_fine_names_the_finer_mesh_and_a_valid_h(tmp_path: Path) -> None:
    """The size check covers the finer mesh (the refinement to h/2) and suggests an --h that passes (one
    line, exit 2, no file)."""
    from fabpat.simulation.mesh import check_polygon_elements

    db = tmp_path / "c.sqlite"
    res = invoke("sweep", "--sample", "1", "--extrapolate", "--h", "0.5", "--db", str(db))
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and not db.exists()
    assert "finer mesh of h = 0.5 mm" in res.stderr and "h ≥ 0.8 mm" in res.stderr, res.stderr
    check_polygon_elements(6, 36.0, 0.8, fine_ratio=0.5)  # the suggestion passes
    with pytest.raises(FabpatError):
        check_polygon_elements(6, 36.0, 0.79, fine_ratio=0.5)


@pytest.mark.parametrize("bad", [{"h": 0.0}, {"h": -1.0}, {"E": -1.0}, {"nu": 0.5}, {"sides": 2},
                                 {"extrapolate": "yes"}, {"h": float("nan")}])
def test_sweep_setup_refuses_bad_values_before_any_row(bad: dict[str, object]) -> None:
    """From Python as from the CLI: a value outside the valid ranges is one RangeError, not failed rows."""
    from fabpat.errors import RangeError

    with pytest.raises(RangeError, match="SweepSetup"):
        SweepSetup(**bad)  # type: ignore[arg-type]


@pytest.mark.slow
def test_extrapolated_sweep_meshes_a_narrow_pattern_finer_and_says_so(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Triangle patterns are narrower than 1 mm: the default 2.5 mm coarse mesh would not resolve them, so
    each is meshed at the coarsest h that does (1.1 × min_width, rounded down) and the rows say which."""
    monkeypatch.setenv("FABPAT_CACHE", "off")  # in this process (--workers 1 runs inline), as run_cli would
    db = tmp_path / "t.sqlite"
    res = invoke("sweep", "--sides", "3", "--sample", "1", "--seed", "0", "--db", str(db), "--workers", "1")
    assert res.exit_code == 0 and "(0 did not converge)" in res.stdout, res.stdout + res.stderr
    with open_catalog(db) as cat:
        rows, pats = cat.results(), {p["id"]: p for p in cat.pattern_rows()}
    assert len(rows) == 3 and all(r["converged"] for r in rows)
    for r in rows:
        w = pats[r["id"]]["min_width"]
        assert r["h"] < 2.0 and r["h"] <= 1.1 * w < r["h"] + 0.01 and r["h_fine"] == pytest.approx(r["h"] / 2)


@pytest.mark.parametrize("sig, code, word", [(signal.SIGTERM, 143, "terminated"), (signal.SIGINT, 130, "interrupted")])
def test_a_signal_to_the_sweep_command_exits_128_plus_it(tmp_path: Path, sig: int, code: int, word: str) -> None:
    """`fabpat sweep` (the real CLI and pipeline) signalled once a pattern is stored: SIGTERM exits 143
    "terminated", Ctrl-C 130 "interrupted" (the shell's 128 + signal), one line, the stored rows kept."""
    db = tmp_path / "c.sqlite"
    env = dict(os.environ, FABPAT_CACHE="off")
    proc = subprocess.Popen([sys.executable, "-m", "fabpat", "sweep", "--sample", "6", "--h", "8", "--workers", "1",
                             "--db", str(db)], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_sigint)  # SIGINT is ignored in a background job's children
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:  # a pattern committed: the sweep is under way
            if db.exists():
                with contextlib.suppress(sqlite3.Error), contextlib.closing(
                        sqlite3.connect(f"{db.as_uri()}?mode=ro", uri=True)) as c:
                    if c.execute("SELECT COUNT(*) FROM patterns").fetchone()[0] >= 1:
                        break
            time.sleep(0.05)
        assert proc.poll() is None, "the sweep ended before it could be signalled"
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code, (proc.returncode, err)
    lines = [line for line in err.splitlines() if not line.startswith("simulated ")]  # a slow run's progress
    assert len(lines) == 1 and lines[0].startswith(f"fabpat: {word};") and "Traceback" not in err, err
    assert "run the same command again to resume" in err and out == ""
    n_patterns, n_results = _count(db)
    assert 1 <= n_patterns < 6 and n_results == 3 * n_patterns


def test_dask_garbage_address(tmp_path: Path) -> None:
    pytest.importorskip("distributed", reason="dask.distributed is not installed")
    line = one_line_error(tmp_path, "sweep", "--dask", "garbage://x", "--db", "c.sqlite")
    assert "garbage://x" in line and "unknown address scheme" in line
