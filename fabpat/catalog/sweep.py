"""The library sweep: fillet → mesh → every scenario (nonlinear) for each pattern, into a catalog.

One task per pattern (:func:`simulate_pattern`) runs in a worker process (``--workers``) or on a
dask.distributed cluster (``--dask``); it returns plain row dicts, and only the parent process writes
the catalog — one transaction per finished pattern, committed as soon as it arrives. So a sweep killed
at any point (even SIGKILL) keeps every finished pattern and leaves no half-written one, and the next
run resumes: a row is skipped when its stored ``input_hash`` equals the one it would get now.

A pattern's scenarios share its mesh (or, with ``extrapolate``, its two meshes), which is why the task
is a pattern, not a pattern-scenario (meshing is ~3 % of a solve, but would be repeated three times).
"""

from __future__ import annotations

import contextlib
import os
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from fabpat.catalog import Catalog, input_hash, open_catalog, solver_version
from fabpat.errors import FabpatError

#: the paper's PLA: E = 1 GPa (§4.1); ν is not given, 0.35 is usual for PLA (notes)
PLA_E = 1000.0  # N/mm²
PLA_NU = 0.35
DEFAULT_H = 1.5  # mm: mesh size of a one-mesh sweep (--no-extrapolate; fabpat.simulation.mesh.mesh_outline's default)
#: the family members ``fabpat sweep --family`` computes (bridge_weight, fabpat.patterns.variation), besides the
#: paper's 1 whose results are the catalog's own: log-spaced over the range (ratio ≈ 1.6), the nodes of
#: the interpolant in :mod:`fabpat.catalog.family` (its measured error is in docs/variations.md)
FAMILY_SAMPLES = (0.25, 0.4, 0.63, 1.6, 2.5)
#: adaptive refinement of the family (:func:`refinements`): an interval between two converged members
#: gets its geometric midpoint when the log–log slope changes across either end by more than
#: :data:`REFINE_BEND` / its width in ln w (the curve bends by more than ~0.1 in ln E over it: the
#: interpolant's error there can pass 1 %), or when the next member did not converge (a limit point
#: near: the energy rises steeply), at most :data:`REFINE_LEVELS` times. Measured (docs/variations.md):
#: the Dome energy of 0x1908 rises from 365 to 647 N·mm over w = 1 … 1.6 and buckles at 1.79; the
#: interpolant through the standard members alone is 7.6 % off there, with the midpoints 1.26 and 1.42
#: 0.43 %.
REFINE_BEND = 0.1
REFINE_LEVELS = 2


@dataclass(frozen=True)
class SweepSetup:
    """Every input of a sweep that affects the numbers (lengths mm, E N/mm²)."""

    sides: int = 6
    depth: int = 2
    edge: float = 36.0
    thickness: float = 2.0
    weight: float = 0.2
    E: float = PLA_E
    nu: float = PLA_NU
    #: mesh size (mm); None: the coarse mesh of a converged run (2.5, refined once to 1.25) when
    #: extrapolating, else DEFAULT_H
    h: float | None = None
    scenarios: tuple[str, ...] = ("cantilever", "cylinder", "dome")
    #: also refine the mesh once (nested, h/2) and store the Richardson-extrapolated energy (the
    #: mesh-converged value, as the built-in catalog; False: one mesh of h, ≈ 3× faster and 3–5 % low in
    #: the median; docs/accuracy.md)
    extrapolate: bool = True
    #: the family member (:mod:`fabpat.patterns.variation`): 1 = the paper's fillets, stored in ``results``; any
    #: other value is stored in the catalog's ``family`` table
    bridge_weight: float = 1.0

    def __post_init__(self) -> None:
        """Raises :class:`~fabpat.errors.RangeError` (one line) for a value outside
        :data:`fabpat.validate.RANGES`, as the CLI options do, before any row is computed."""
        from fabpat.validate import check

        if self.h is None:
            from fabpat.simulation.convergence import CONVERGED_MESHES

            object.__setattr__(self, "h", CONVERGED_MESHES[0] if self.extrapolate is True else DEFAULT_H)
        for name, value in (("sides", self.sides), ("depth", self.depth), ("edge", self.edge),
                            ("thickness", self.thickness), ("weight", self.weight), ("youngs_modulus", self.E),
                            ("poisson", self.nu), ("h", self.h), ("bridge_weight", self.bridge_weight)):
            check(name, value, f"SweepSetup {name}")
        if not isinstance(self.extrapolate, bool):
            from fabpat.errors import RangeError

            raise RangeError(f"SweepSetup extrapolate must be True or False, got {self.extrapolate!r}")

    @property
    def h_fine(self) -> float | None:
        """Mesh size (mm) of the second mesh of an extrapolating sweep, else None."""
        return fine_mesh(self.h) if self.extrapolate else None

    def key(self, pattern_id: str) -> dict[str, object]:
        """The catalog row key of one pattern under this setup."""
        return {"id": pattern_id, "sides": self.sides, "depth": self.depth, "edge": float(self.edge),
                "thickness": float(self.thickness), "weight": float(self.weight)}


def fine_mesh(h: float) -> float:
    """The second mesh (mm) of an extrapolated energy: h/2, the nested refinement of the mesh of h
    (:data:`fabpat.simulation.convergence.CONVERGED_MESHES`, as ``fabpat simulate --extrapolate``)."""
    from fabpat.simulation.convergence import CONVERGED_MESHES

    return float(h) * (CONVERGED_MESHES[1] / CONVERGED_MESHES[0])  # 0.5 exactly: 1.76 → 0.88, not 0.8800000000000001


def pattern_hash(pattern_id: str, sides: int, depth: int, edge: float, thickness: float, weight: float,
                 version: str) -> str:
    """Input hash of a ``patterns`` row (geometry only: thickness is part of the key, not the shape)."""
    return input_hash({"id": pattern_id, "sides": sides, "depth": depth, "edge": float(edge),
                       "thickness": float(thickness), "weight": float(weight), "solver": version})


def result_hash(pattern_id: str, sides: int, depth: int, edge: float, thickness: float, weight: float,
                E: float, nu: float, h: float, scenario: str, version: str, h_fine: float | None = None,
                bridge_weight: float = 1.0) -> str:
    """Input hash of a ``results`` row: the key, material, mesh size(s), nonlinear flag, solver version.
    ``h_fine``: the second mesh of an extrapolated energy (None: one mesh; the hash is then the same as
    before extrapolation existed); ``bridge_weight``: the family member (1, the paper's: the hash is the
    same as before families existed)."""
    inputs: dict[str, object] = {"id": pattern_id, "sides": sides, "depth": depth, "edge": float(edge),
                                 "thickness": float(thickness), "weight": float(weight), "E": float(E),
                                 "nu": float(nu), "h": float(h), "nonlinear": True, "scenario": scenario,
                                 "solver": version}
    if h_fine is not None:
        inputs["h_fine"] = float(h_fine)
    if bridge_weight != 1.0:
        inputs["bridge_weight"] = float(bridge_weight)
    return input_hash(inputs)


def simulate_pattern(pattern_id: str, sides: int, depth: int, edge: float, thickness: float, weight: float,
                     E: float, nu: float, h: float, scenarios: Sequence[str],
                     extrapolate: bool = False, bridge_weight: float = 1.0) -> list[dict[str, object]]:
    """Fillet, mesh and run ``scenarios`` (nonlinear) on one pattern; the catalog rows to store.

    Returns one ``patterns`` row (``"table": "patterns"``) and one ``results`` row per scenario; for a
    family member (``bridge_weight`` ≠ 1, :mod:`fabpat.patterns.variation`) one ``family`` row per scenario,
    carrying the member's ``bridge_weight``, ``min_width`` and ``filleted_area``, and no patterns row.
    ``extrapolate``: also refine the mesh once (:func:`fabpat.simulation.convergence.nested_meshes`, h/2) and
    store the Richardson-extrapolated energy (:func:`fabpat.simulation.convergence.run_converged`, as ``fabpat
    simulate --extrapolate``) with ``h_fine``;
    the row's other fields are then the fine mesh's, and ``seconds`` the sum over both (as the JSON of
    ``fabpat simulate --extrapolate``).
    Deterministic failures (:class:`~fabpat.errors.FabpatError`: an outline that cannot be filleted
    or meshed, a solve that does not converge) become rows with ``converged = 0`` and ``error``, so a
    resumed sweep does not retry them; anything else propagates (a bug: nothing is stored).
    Hashes use the solver version of the process that computes (a dask worker with other code gets
    a different hash, and a later sweep recomputes its rows).

    The work is :func:`fabpat.simulation.energies.scenario_energies` (as ``fabpat simulate``); this turns
    it into rows.
    """
    from fabpat.patterns.library import get_pattern
    from fabpat.patterns.variation import Variation
    from fabpat.simulation.energies import ScenarioEnergies, scenario_energies

    version = solver_version()
    member = bridge_weight != 1.0
    h_fine = fine_mesh(h) if extrapolate else None
    key = {"id": pattern_id, "sides": sides, "depth": depth, "edge": float(edge), "thickness": float(thickness),
           "weight": float(weight)}
    prow: dict[str, object] = {"table": "patterns", **key,
                               "input_hash": pattern_hash(pattern_id, sides, depth, edge, thickness, weight,
                                                          version)}
    got: ScenarioEnergies | None = None
    try:
        pattern = get_pattern(pattern_id, sides, depth, edge)
        m = pattern.metrics
        prow.update(area=m.area, perimeter=m.perimeter, ratio=m.ratio, polar_moment=m.polar_moment)
    except FabpatError as e:
        prow["error"] = f"{type(e).__name__}: {e}"
    else:
        # h is an upper bound when extrapolating: converged_h lowers it where a neck would be unresolved
        # (the row's h says so); a sweep has no --max-elements (checked up front for the whole polygon)
        got = scenario_energies(pattern, scenarios, weight=weight, variation=Variation(bridge_weight), h=h,
                                extrapolate=extrapolate, h_is_bound=True, thickness=thickness, E=E, nu=nu,
                                option="fixed for sweeps", keep_errors=True)
        prow.update(got.columns)  # as `fabpat library`
        if got.columns and got.filleted is not None:
            prow["svg_path"] = got.filleted.outline.to_svg_path()
        if got.error is not None:
            prow["error"] = got.error
    rows: list[dict[str, object]] = [prow]
    for k, scenario in enumerate(scenarios):
        row: dict[str, object] = {"table": "family" if member else "results", **key, "scenario": scenario,
                                  "E": float(E), "nu": float(nu), "h": float(h), "h_fine": h_fine, "nonlinear": 1,
                                  "converged": 0, "solver_version": version,
                                  "input_hash": result_hash(pattern_id, sides, depth, edge, thickness, weight, E,
                                                            nu, h, scenario, version, h_fine, bridge_weight),
                                  "error": prow.get("error")}
        if member:
            row.update(bridge_weight=float(bridge_weight), min_width=prow.get("min_width"),
                       filleted_area=prow.get("filleted_area"))
        if got is not None and got.mesh is not None:
            run = got.runs[k]
            # the meshes used (a narrow pattern's coarse h may be below the set-up's; the hash keeps the set-up)
            row.update(nodes=got.mesh.n_nodes, elements=got.mesh.n_elements, h=float(got.meshes[0][0]),
                       h_fine=float(got.meshes[-1][0]) if len(got.meshes) > 1 else None, seconds=run.seconds)
            if run.result is not None:
                row.update(energy=run.energy, max_displacement=float(run.result.fine.max_displacement),
                           converged=int(run.converged), iterations=int(run.result.fine.iterations))
            else:
                row["error"] = run.error
        row["computed_at"] = datetime.now(UTC).isoformat(timespec="seconds")
        rows.append(row)
    return rows[1:] if member else rows


Task = Callable[..., list[dict[str, object]]]


@dataclass
class SweepReport:
    """What a sweep did: counts are pattern-scenario rows unless named otherwise."""

    patterns: int  # patterns in the library (or sample)
    rows: int  # pattern-scenario rows wanted
    skipped: int  # already in the catalog with a matching hash
    computed: int  # newly stored
    failed_rows: int  # stored with converged = 0 (deterministic failures)
    crashed: list[str] = field(default_factory=list)  # "ID: error" of tasks that raised (nothing stored)
    seconds: float = 0.0


def plan(cat: Catalog, ids: Sequence[str], setup: SweepSetup, force: bool) -> list[tuple[str, tuple[str, ...]]]:
    """(pattern ID, scenarios to compute) for every pattern that needs work."""
    version = solver_version()
    s = setup
    member = s.bridge_weight != 1.0
    pats, res = cat.stored_hashes(s.sides, s.depth, float(s.edge), float(s.thickness), float(s.weight),
                                  float(s.bridge_weight))
    jobs = []
    for pid in ids:
        todo = tuple(sc for sc in s.scenarios if force or res.get((pid, sc)) != result_hash(
            pid, s.sides, s.depth, s.edge, s.thickness, s.weight, s.E, s.nu, s.h, sc, version, s.h_fine,
            s.bridge_weight))
        # a family member's geometry is in its own rows
        pattern_stale = not member and pats.get(pid) != pattern_hash(pid, s.sides, s.depth, s.edge, s.thickness,
                                                                    s.weight, version)
        if todo or pattern_stale:
            jobs.append((pid, todo))
    return jobs


def _worker_init() -> None:
    """Worker processes: one BLAS thread each (the pool already uses every core), and die with the
    parent — a SIGKILLed sweep must not leave orphans computing results nobody will store."""
    import contextlib
    import signal

    with contextlib.suppress(Exception):
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG (Linux)
    with contextlib.suppress(ImportError):
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle (it stops the workers)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the parent's SIGTERM handler (cli) is not for workers


def _run_local(task: Task, jobs: list[tuple[tuple, str]], workers: int) -> Iterator[tuple[str, object]]:
    """Yield (pattern ID, rows or exception) as tasks finish, in worker processes (or inline if 1)."""
    if workers <= 1:
        for args, pid in jobs:
            try:
                yield pid, task(*args)
            except Exception as e:  # noqa: BLE001 - reported per pattern; the sweep goes on
                yield pid, e
        return
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    # fork: workers start instantly and inherit the imports; prctl above ties them to the parent
    ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else None
    pool = ProcessPoolExecutor(workers, mp_context=ctx, initializer=_worker_init)
    finished = False
    try:
        pending = {pool.submit(task, *args): pid for args, pid in jobs}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                pid = pending.pop(fut)
                exc = fut.exception()
                yield pid, exc if exc is not None else fut.result()
        finished = True
    finally:
        # interrupted (Ctrl-C, an error while storing): stop the workers now rather than wait for the
        # patterns in progress, whose results could no longer be stored anyway
        procs = list((getattr(pool, "_processes", None) or {}).values())  # shutdown() forgets them
        pool.shutdown(wait=finished, cancel_futures=True)
        if not finished:
            for proc in procs:
                proc.terminate()


def _dask_client(address: str, timeout: float) -> Any:
    """A connected dask.distributed client; FabpatError if dask is missing or the scheduler is not there."""
    try:
        from dask.distributed import Client
    except ImportError as e:
        raise FabpatError("--dask needs dask.distributed: pip install 'dask[distributed]'") from e
    try:
        return Client(address, timeout=timeout)
    except (OSError, ValueError, TypeError) as e:  # dask raises ValueError for an unknown address scheme
        raise FabpatError(f"cannot connect to the dask scheduler at {address}: {e}") from e


def _run_dask(task: Task, jobs: list[tuple[tuple, str]], client: Any) -> Iterator[tuple[str, object]]:
    """Yield (pattern ID, rows or exception) from a connected dask.distributed client; closes it.

    The workers need fabpat installed (same version, or their rows get other hashes).
    """
    from dask.distributed import as_completed

    try:
        # pure=False: the same pattern asked twice (with --force) must run again, not be deduplicated
        run = uuid.uuid4().hex[:8]
        futures = {client.submit(task, *args, pure=False, key=f"fabpat-{pid}-{run}"): pid for args, pid in jobs}
        for fut in as_completed(list(futures)):
            pid = futures[fut]
            if fut.status == "error":
                yield pid, fut.exception()
            else:
                yield pid, fut.result()
            fut.release()
    finally:
        client.close()


def refinements(db: str | Path, ids: Sequence[str], setup: SweepSetup) -> dict[float, list[str]]:
    """{midpoint member: pattern IDs} that :data:`REFINE_BEND` asks for, from the family rows
    stored so far of ``ids`` at ``setup``'s set-up (any scenario flags a pattern's interval)."""
    import math

    from fabpat.catalog import open_catalog

    key = {"sides": setup.sides, "depth": setup.depth, "edge": float(setup.edge), "thickness": float(setup.thickness),
           "weight": float(setup.weight)}
    with open_catalog(db) as cat:
        rows = [*cat.results(**key), *({**r, "bridge_weight": r["bridge_weight"]} for r in cat.family(**key))]
    wanted = set(ids)
    curves: dict[tuple[str, str], dict[float, float | None]] = {}
    for r in rows:
        if r["id"] in wanted and r["E"] == setup.E and r["nu"] == setup.nu:
            w = float(r.get("bridge_weight") or 1.0)  # type: ignore[arg-type]
            e = float(r["energy"]) if r["converged"] and r["energy"] else None  # type: ignore[arg-type]
            curves.setdefault((str(r["id"]), str(r["scenario"])), {})[w] = e
    out: dict[float, set[str]] = {}

    def slope(curve: dict[float, float | None], a: float | None, b: float | None) -> float | None:
        if a is None or b is None or curve[a] is None or curve[b] is None:
            return None
        return math.log(curve[b] / curve[a]) / math.log(b / a)  # type: ignore[operator]

    for (pid, _), curve in curves.items():
        ws: list[float | None] = [None, *sorted(curve), None]
        for i in range(1, len(ws) - 2):
            a, b = ws[i], ws[i + 1]
            s_ab = slope(curve, a, b)
            if s_ab is None:
                continue
            width = math.log(b / a)  # type: ignore[operator]
            steep = ws[i + 2] is not None and curve[ws[i + 2]] is None  # the next member buckled or failed
            for other in (slope(curve, ws[i - 1], a), slope(curve, b, ws[i + 2])):
                steep |= other is not None and abs(other - s_ab) * width > REFINE_BEND
            if steep:
                mid = float(f"{math.sqrt(a * b):.4g}")
                if mid not in (a, b):
                    out.setdefault(mid, set()).add(pid)
    return {w: sorted(p) for w, p in sorted(out.items())}


def run_sweep(db: str | Path, ids: Sequence[str], setup: SweepSetup = SweepSetup(), *, workers: int | None = None,
              dask: str | None = None, dask_timeout: float = 10.0, force: bool = False, task: Task = simulate_pattern,
              progress: Callable[[int, int], None] | None = None) -> SweepReport:
    """Simulate every pattern of ``ids`` that is not already in catalog ``db``; commit each as it ends.

    workers: local processes (default all cores; 1 runs inline); dask: a scheduler address instead
    (connection timeout ``dask_timeout`` s).
    task: the per-pattern function (default :func:`simulate_pattern`; tests inject a fake).
    progress: called with (rows done, rows total) after each stored pattern.
    Raises CatalogError for an unusable ``db`` and FabpatError for an unreachable dask scheduler.
    """
    t0 = time.perf_counter()
    s = setup
    if task is simulate_pattern:
        # import the pipeline before forking workers: they all run the code the version digest describes,
        # even if a source file is edited while the sweep runs
        import fabpat.geometry.fillet  # noqa: F401
        import fabpat.simulation.convergence  # noqa: F401
        import fabpat.simulation.energies  # noqa: F401
        import fabpat.simulation.mesh  # noqa: F401
        import fabpat.simulation.scenarios  # noqa: F401
    # connect first: an unreachable scheduler must not leave a new, empty catalog behind
    client = _dask_client(dask, dask_timeout) if dask else None
    with contextlib.ExitStack() as stack:
        if client is not None:
            stack.callback(client.close)
        cat = stack.enter_context(open_catalog(db, write=True))
        jobs = plan(cat, ids, s, force)
        total = sum(len(sc) for _, sc in jobs)
        report = SweepReport(len(ids), len(ids) * len(s.scenarios), len(ids) * len(s.scenarios) - total, 0, 0)
        if progress is not None:
            progress(0, total)
        member = (s.bridge_weight,) if s.bridge_weight != 1.0 else ()  # the paper's: the task's arguments as before
        work = [((pid, s.sides, s.depth, s.edge, s.thickness, s.weight, s.E, s.nu, s.h, sc, s.extrapolate, *member),
                 pid) for pid, sc in jobs]
        if client is not None:
            stream = _run_dask(task, work, client)
        else:
            stream = _run_local(task, work, max(1, workers or os.cpu_count() or 1))
        done = 0
        wanted = dict(jobs)
        with contextlib.closing(stream):  # on an interrupt, the executor's cleanup runs now
            for pid, out in stream:
                if isinstance(out, BaseException):
                    report.crashed.append(f"{pid}: {type(out).__name__}: {out}")
                else:
                    rows = list(out)  # type: ignore[call-overload]
                    cat.write_rows(rows)  # one transaction per pattern: all its rows or none
                    results = [r for r in rows if r.get("table") in ("results", "family")]
                    report.computed += len(results)
                    report.failed_rows += sum(1 for r in results if not r.get("converged"))
                done += len(wanted[pid])
                if progress is not None:
                    progress(done, total)
        cat.finish()
    report.seconds = time.perf_counter() - t0
    return report


def refine_family(db: str | Path, ids: Sequence[str], setup: SweepSetup = SweepSetup(), *,
                  workers: int | None = None, dask: str | None = None, force: bool = False,
                  progress: Callable[[int, int], None] | None = None,
                  tell: Callable[[str], None] | None = None) -> list[SweepReport]:
    """The adaptive members of ``fabpat sweep --family`` after the standard ones: up to
    :data:`REFINE_LEVELS` rounds of :func:`refinements`, each member swept for the patterns that ask
    for it (resumable as any sweep). ``tell`` gets one line per member swept. Returns the reports."""
    import dataclasses

    reports = []
    for level in range(REFINE_LEVELS):
        todo = refinements(db, ids, setup)
        if not todo:
            break
        for w, pids in todo.items():
            if tell is not None:
                tell(f"refining: bridge_weight = {w:g} for {len(pids)} patterns (round {level + 1})")
            reports.append(run_sweep(db, pids, dataclasses.replace(setup, bridge_weight=w), workers=workers,
                                     dask=dask, force=force, progress=progress))
    return reports
