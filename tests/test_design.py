"""``fabpat design`` on strips: a reachable round trip, every refusal, the design spec's new keys, and an
unreachable target. Solves run at h = 6 mm on a 1 × 4 strip (a few seconds each)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fabpat.cli import cli
from fabpat.errors import SpecError
from tests.helpers import invoke

ROOT = Path(__file__).resolve().parents[1]
H = "6"
COLUMNS = 4


def _base(folder: Path, patterns: str) -> Path:
    text = (ROOT / "assemblies" / "test-small.toml").read_text(encoding="utf-8")
    text = text.replace("columns = 3", f"columns = {COLUMNS}")
    head, _, rest = text.partition("[patterns]")
    rest = rest[rest.index("[plates]"):]
    p = folder / "base.toml"
    p.write_text(head + "[patterns]\n" + patterns + "\n\n" + rest, encoding="utf-8")
    return p


@pytest.fixture(scope="module")
def setup(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """A base spec with the pattern choice left open, and the target CSV of random column patterns."""
    from fabpat import catalog
    from fabpat.design.api import _geometry
    from fabpat.design.base import load_base
    from fabpat.design.search import solve_candidate
    from fabpat.design.strip import predicted_at
    from fabpat.design.target import write_target_csv

    folder = tmp_path_factory.mktemp("design")
    e = catalog.energies(None, "cylinder", 6)
    ids = sorted(e, key=lambda k: (e[k], k))
    allowed = [ids[10], ids[len(ids) // 2], ids[-10]]
    # every catalog pattern is a candidate, the paper member of each (family members: test_design_members.py)
    spec = _base(folder, "variations = false")
    base = load_base(spec)
    length, labels, face_col, _ = _geometry(base, allowed[0], float(H))
    cols = list(np.random.default_rng(7).choice(ids, COLUMNS))
    res = solve_candidate(base.spec, tuple(cols[c] for c in face_col), float(H), 0.1 * length)
    x = np.linspace(0.0, 0.9 * length, 41)
    target = folder / "target.csv"
    write_target_csv(target, x, predicted_at(res["x"], res["z"], x))
    return {"folder": folder, "spec": spec, "target": target, "span": 0.9 * length, "length": length,
            "labels": labels, "cols": cols}


def _refused(args: list[str], out: Path) -> str:
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 2, (r.exit_code, r.output)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("fabpat: error: "), r.stderr
    assert not out.exists()
    return lines[0]


@pytest.mark.slow
def test_round_trip_matches_the_target(setup: dict) -> None:
    """A target made by the solver is designed back within 0.5 % of the span, verified by simulate-assembly.
    A budget of 1 solve (with the uniform baseline, 2): the design is found by the first search solve (0.34 %
    of the span, the same design with budgets 1, 2, 3 and 6, measured), so 6 only spent time."""
    from fabpat.assembly.choose.choice import face_patterns
    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.assembly.spec.load import load_spec
    from fabpat.design.strip import errors, midline

    out = setup["folder"] / "round"
    # in-process: the design's files are the point (test_design_closed runs `fabpat design` as a real process)
    r = invoke("design", str(setup["target"]), "--spec", str(setup["spec"]), "--out", str(out), "--h", H,
                "--max-solves", "1", "--no-progress")
    assert r.returncode == 0, r.stderr
    rec = json.loads((out / "design.json").read_text())
    assert set(rec["patterns"]) == set(setup["labels"])
    assert rec["solves"] >= 2 and rec["reachable"] is True and "single" in rec["baselines"]
    spec = load_spec(out / "design.toml")  # the spec the design wrote: explicit tiles, [load] end_shortening
    assert face_patterns(spec) == [rec["patterns"][lab] for lab in setup["labels"]]
    assert spec.end_shortening == pytest.approx(rec["end_shortening"])
    sim = simulate_assembly(out / "design.toml", h=float(H))  # no --end-shortening: the spec's [load]
    assert sim.run.end_shortening == pytest.approx(rec["end_shortening"])
    x, z = midline(sim.run.setup, sim.run.result.final.displacement)
    t = np.loadtxt(setup["target"], delimiter=",", skiprows=1)
    rms = errors(x, z, t[:, 0], t[:, 1])[0]
    assert rms <= 0.005 * setup["span"]
    assert (out / "design.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_design_spec_is_a_kit_plan(setup: dict, tmp_path: Path) -> None:
    """A tiles table by plate label places as the kit (labels and patterns), as `fabpat assemble` plans it."""
    from fabpat.assembly.kit.build import plan
    from fabpat.assembly.spec.load import load_spec

    ids = setup["cols"]
    table = ", ".join(f'{lab} = "{ids[i]}"' for i, lab in enumerate(setup["labels"]))
    p = _base(tmp_path, f"tiles = {{{table}}}")
    asm, _ = plan(load_spec(p))
    assert [(pl.label, pl.type.pattern_id) for pl in asm.plates] == list(zip(setup["labels"], ids, strict=True))


@pytest.mark.parametrize("table, word", [("T1 = \"0x0488\"", "no pattern for plate T2"),
                                         ("T9 = \"0x0488\"", "not a plate of this strip")])
def test_tiles_table_refuses_wrong_labels(tmp_path: Path, table: str, word: str) -> None:
    from fabpat.assembly.spec.load import load_spec

    with pytest.raises(SpecError, match=word):
        load_spec(_base(tmp_path, f"tiles = {{{table}}}"))


def test_load_end_shortening_is_refused_on_a_closed_tiling(tmp_path: Path) -> None:
    from fabpat.assembly.spec.load import load_spec

    text = (ROOT / "assemblies" / "truncated-icosahedron.toml").read_text() + "\n[load]\nend_shortening = 0.1\n"
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(SpecError, match="applies to strips"):
        load_spec(tmp_path / "s.toml")


def _csv(folder: Path, name: str, text: str) -> str:
    p = folder / name
    p.write_text(text)
    return str(p)


def test_bad_inputs_are_one_line_and_write_nothing(setup: dict, tmp_path: Path) -> None:
    spec, out = str(setup["spec"]), tmp_path / "out"
    span = setup["span"]
    good = "x,z\n" + "".join(f"{x},{0.1 * x * (span - x) / span}\n" for x in np.linspace(0, span, 9))
    cases = {
        "at least 3": _csv(tmp_path, "two.csv", "x,z\n0,0\n1,0\n"),
        "increase strictly": _csv(tmp_path, "back.csv", "x,z\n0,0\n5,1\n3,1\n10,0\n"),
        "not finite": _csv(tmp_path, "nan.csv", "x,z\n0,0\n5,nan\n10,0\n"),
        "not a strip curve": _csv(tmp_path, "text.csv", "hello world\nthis is no curve\n"),
        "both ends are the pins": _csv(tmp_path, "end.csv", "x,z\n0,0\n100,40\n200,30\n"),
        "arc length": _csv(tmp_path, "flat.csv", good),  # a nearly flat arch: 10 % shorter than the strip
        "closed-tiling target": "sphere",
        "ellipsoid:A,B,C": "ellipsoid:1,2",
    }
    for word, target in cases.items():
        line = _refused(["design", target, "--spec", spec, "--out", str(out), "--h", H], out)
        assert word in line, (word, line)
    line = _refused(["design", _csv(tmp_path, "ok.csv", good), "--spec",
                     str(ROOT / "assemblies" / "truncated-icosahedron.toml"), "--out", str(out)], out)
    assert "closed tiling" in line and "sphere, ellipsoid:A,B,C or a surface mesh" in line
    empty = _base(tmp_path, 'allowed = ["0x0488"]\nmin_width = 1000.0')
    line = _refused(["design", _csv(tmp_path, "ok2.csv", good), "--spec", str(empty), "--out", str(out)], out)
    assert "no candidate pattern" in line


def test_arc_length_message_names_both_lengths(setup: dict, tmp_path: Path) -> None:
    from fabpat.design import TargetError, design

    span = setup["span"]
    x = np.linspace(0, span, 21)
    with pytest.raises(TargetError) as e:
        design(np.c_[x, 0.5 * x * (span - x) / span], setup["spec"], h=float(H))
    arc = float(np.hypot(np.diff(x), np.diff(0.5 * x * (span - x) / span)).sum())
    assert f"{arc:.1f} mm" in str(e.value) and f"{setup['length']:.1f} mm" in str(e.value)


@pytest.mark.slow
def test_unreachable_target_warns_once_and_writes_the_best(setup: dict, tmp_path: Path) -> None:
    """Two humps cannot be made by a pinned strip: reachable false, one warning line, files written."""
    from fabpat.design.target import write_target_csv

    span, length = setup["span"], setup["length"]
    x = np.linspace(0.0, span, 121)
    shape = np.sin(2 * np.pi * x / span) ** 2
    lo, hi = 0.0, span
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.hypot(np.diff(x), np.diff(mid * shape)).sum() < length else (lo, mid)
    target = tmp_path / "humps.csv"
    write_target_csv(target, x, lo * shape)
    out = tmp_path / "out"
    r = invoke("design", str(target), "--spec", str(setup["spec"]), "--out", str(out), "--h", H,
                "--max-solves", "1", "--no-progress")
    assert r.returncode == 0, r.stderr
    warnings = [ln for ln in r.stderr.splitlines() if ln.startswith("fabpat: warning:")]
    assert len(warnings) == 1 and "target not reached" in warnings[0] and "turn the wrong way" in warnings[0]
    rec = json.loads((out / "design.json").read_text())
    assert rec["reachable"] is False and rec["relative_rms"] > rec["tolerance"]
    assert (out / "design.toml").is_file()


def test_out_keeps_a_users_file(tmp_path: Path) -> None:
    """An earlier design folder with a file the user put there is refused, never replaced."""
    from fabpat.design.outputs import GENERATOR, check_design_out
    from fabpat.errors import ExportError

    out = tmp_path / "d"
    out.mkdir()
    (out / "design.json").write_text(json.dumps({"generator": GENERATOR}))
    assert check_design_out(out) == out  # an earlier output alone may be replaced
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ExportError, match="notes.txt"):
        check_design_out(out)
    assert (out / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("kw, word", [({"h": "3"}, "h must be a number"), ({"h": float("nan")}, "finite"),
                                      ({"out": 5}, "file name"), ({"out": "a\0b"}, "NUL"),
                                      ({"dask": 3}, "scheduler address"), ({"progress": 5}, "callable"),
                                      ({"max_solves": 1.5}, "max_solves"), ({"tolerance": 2.0}, "tolerance"),
                                      ({"kit": "yes"}, "True or False"), ({"kit": True}, "give out"),
                                      ({"scale_target": "no"}, "True or False")])
def test_design_api_refuses_bad_arguments_with_fabpat_errors(kw: dict, word: str) -> None:
    """Found by a hostile pass: these were raw TypeErrors (h, out) or silently accepted (dask, progress)."""
    from fabpat.design import design
    from fabpat.errors import FabpatError

    with pytest.raises(FabpatError, match=word):
        design([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]], ROOT / "assemblies" / "test-small.toml", **kw)


@pytest.mark.slow
def test_a_target_the_elastica_cannot_follow_is_designed_by_the_search(setup: dict, tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """When the reduced model's Newton iteration fails for the target (a skewed arch did this on the
    2 × 15 strip), the design goes on with the pattern search over the solves' budget instead of crashing."""
    import fabpat.design.mapping as mapping
    from fabpat.design import design
    from fabpat.errors import SolverError

    def lost(*args: object, **kwargs: object) -> None:
        raise SolverError("strip elastica: Newton did not converge in 60 iterations")

    monkeypatch.setattr(mapping, "fit_stiffness", lost)
    res = design(setup["target"], setup["spec"], out=tmp_path / "d", h=float(H), max_solves=2, workers=1)
    rec = json.loads((tmp_path / "d" / "design.json").read_text(encoding="utf-8"))
    assert rec["solves"] == res.record["solves"] >= 2 and rec["relative_rms"] > 0
    assert rec["rms_error"] <= rec["baselines"]["single"]["rms_error"] + 1e-9


@pytest.mark.slow
def test_kit_is_built_and_predicted_at_the_designs_mesh_edge(setup: dict, tmp_path: Path) -> None:
    """``--kit`` writes the assemble kit of design.toml into DIR/kit, its prediction solved at the design's
    own h (design.json ``h``), so the kit's prediction is the designed strip's solve."""
    from fabpat.design import design

    res = design(setup["target"], setup["spec"], out=tmp_path / "d", h=float(H), max_solves=1, workers=1, kit=True)
    rec = json.loads((tmp_path / "d" / "design.json").read_text(encoding="utf-8"))
    assert rec["h"] == float(H) == res.record["h"]
    manifest = json.loads((tmp_path / "d" / "kit" / "manifest.json").read_text(encoding="utf-8"))
    assert "prediction.json" in manifest["files"]
    pred = json.loads((tmp_path / "d" / "kit" / "prediction.json").read_text(encoding="utf-8"))
    assert pred["h"] == float(H)
