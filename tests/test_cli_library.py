import json
from pathlib import Path
from xml.etree import ElementTree

import pytest

from tests.conftest import run_cli


def test_library_json_fields() -> None:
    r = run_cli("library", "--sides", "5", "--format", "json", "--no-fillet")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert len(rows) == 430
    assert {"id", "sides", "area", "perimeter", "ratio", "polar_moment"} <= set(rows[0])
    assert all(row["sides"] == 5 for row in rows)


def test_library_filleted_columns() -> None:
    r = run_cli("library", "--sample", "6", "--seed", "2", "--format", "json", "--weight", "0.3")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert len(rows) == 6
    for row in rows:
        assert row["weight"] == 0.3
        assert 1.0 < row["min_width"] < 10.0
        # filleting changes the area by a few percent (see test_fillet for the accounting)
        assert 0 < row["filleted_area"] / row["area"] - 1 < 0.25
        assert row["filleted_ratio"] == pytest.approx(
            4 * 3.141592653589793 * row["filleted_area"] / row["filleted_perimeter"] ** 2, rel=1e-6
        )


def test_library_csv_and_table() -> None:
    r = run_cli("library", "--depth", "1", "--format", "csv", "--no-fillet")
    assert r.returncode == 0
    lines = r.stdout.strip().splitlines()
    assert lines[0].startswith("id,sides")
    assert len(lines) == 3
    t = run_cli("library", "--depth", "1")
    assert "0xa" in t.stdout and "2 patterns" in t.stdout and "min_width" in t.stdout
    assert "filleted_polar_moment" in t.stdout and "…" not in t.stdout  # piped: nothing truncated


def test_library_sample_depth3() -> None:
    r = run_cli("library", "--depth", "3", "--sample", "5", "--seed", "3", "--format", "json", "--no-fillet")
    assert r.returncode == 0, r.stderr
    ids = [row["id"] for row in json.loads(r.stdout)]
    assert len(set(ids)) == 5 and all(len(i) == 18 for i in ids)


def test_library_count_is_exact_and_says_so(tmp_path: Path) -> None:
    from fabpat.patterns.enumeration import count_library
    from tests.helpers import invoke, refusal_in

    r = invoke("library", "--depth", "2", "--sides", "7", "--count", "--format", "json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) | {"method": ""} == {"sides": 7, "depth": 2, "count": 430, "exact": True, "low": 430,
                                                     "high": 430, "edge_rule_slices": 512, "draws": 0, "method": ""}
    deep = invoke("library", "--depth", "3", "--count")
    assert deep.returncode == 0, deep.stderr
    assert deep.stdout.split()[0] == str(count_library(6, 3)) and "exact" in deep.stdout
    assert deep.stdout.count("\n") == 1
    assert "takes no --sample" in refusal_in(tmp_path, "library", "--depth", "3", "--count", "--sample", "2")
    assert "[3, 64]" in refusal_in(tmp_path, "library", "--count", "--sides", "2")


def test_show_writes_svg(tmp_path: Path) -> None:
    out = tmp_path / "p.svg"
    r = run_cli("show", "0x0688", "--sides", "7", "--edge", "20", "--svg", str(out))
    assert r.returncode == 0, r.stderr
    root = ElementTree.parse(out).getroot()
    assert root.tag.endswith("svg") and root.get("width") is not None


def test_show_without_output_option_writes_the_svg_to_stdout(tmp_path: Path) -> None:
    """Friction: `fabpat show ID` used to demand --svg; now the SVG goes to stdout, byte for byte the
    file --svg writes."""
    r = run_cli("show", "0x0488", "--filleted")
    assert r.returncode == 0, r.stderr
    root = ElementTree.fromstring(r.stdout.split("\n", 1)[1])
    assert root.tag.endswith("svg") and root.get("width").endswith("mm")
    out = tmp_path / "p.svg"
    assert run_cli("show", "0x0488", "--filleted", "--svg", str(out)).returncode == 0
    assert out.read_text() == r.stdout and list(tmp_path.iterdir()) == [out]


def test_commands_taking_an_id_infer_its_depth(tmp_path: Path) -> None:
    """Friction: `show` and `simulate` refused a 16-digit ID without --depth 3 while `export` took it."""
    pid = "0xc311aba5e62c0080"  # a depth-3 library pattern (sample_library(6, 3, 1, seed=0))
    shown = run_cli("show", pid)
    assert shown.returncode == 0, shown.stderr
    assert f"<title>{pid} (6-gon" in shown.stdout
    assert run_cli("export", pid, "--svg", str(tmp_path / "e.svg")).returncode == 0
    one = run_cli("show", "0xa", "--sides", "5")  # a 1-digit ID is depth 1
    assert one.returncode == 0 and "<title>0xa (5-gon" in one.stdout
    for cmd in (["show", pid, "--depth", "2"], ["export", "0x0488", "--depth", "3", "--svg", str(tmp_path / "x.svg")]):
        bad = run_cli(*cmd)
        assert bad.returncode == 2 and "hex digits" in bad.stderr and bad.stderr.count("\n") == 1, cmd
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.svg"]


def test_show_filleted_draws_true_curves(tmp_path: Path) -> None:
    out = tmp_path / "f.svg"
    r = run_cli("show", "0x2d88", "--filleted", "--svg", str(out))
    assert r.returncode == 0, r.stderr
    root = ElementTree.parse(out).getroot()
    paths = [e.get("d") for e in root.iter() if e.tag.endswith("path")]
    assert len(paths) == 1
    assert " A" in paths[0] or "A " in paths[0] or " Q" in paths[0]  # arcs stay curves, not polylines


def test_sheet_png_and_svg(tmp_path: Path) -> None:
    png, svg = tmp_path / "s.png", tmp_path / "s.svg"
    assert run_cli("sheet", "--depth", "1", "--out", str(png)).returncode == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert run_cli("sheet", "--out", str(svg)).returncode == 0
    assert svg.read_text().count("<text") == 430


@pytest.mark.parametrize(
    "args, words",
    [
        (["show", "0xzz", "--svg", "{out}"], "not hexadecimal"),
        (["show", "0x12345", "--svg", "{out}"], "hex digits"),
        (["show", "0x0001", "--svg", "{out}"], "not in the"),
        (["show", "0x0488", "--sides", "2", "--svg", "{out}"], "sides"),
        (["show", "0x0488", "--depth", "0", "--svg", "{out}"], "depth"),
        (["sheet", "--sides", "1", "--out", "{out}"], "sides"),
        (["sheet", "--out", "{dir}/x.gif"], ".svg or .png"),
        (["library", "--format", "xml"], "table"),
        (["library", "--depth", "3"], "--sample"),
        (["show", "0x0488", "--svg", "/proc/fabpat-test.svg"], "cannot write"),  # a folder that takes no files
        (["show", "0x0488", "--svg", "/proc/version/a.svg"], "not a folder"),  # the parent is a file
        (["sheet", "--out", "{dir}/missing/x.svg"], "does not exist"),
    ],
)
def test_bad_input_is_one_line_exit_2_no_file(tmp_path: Path, args: list[str], words: str) -> None:
    out = tmp_path / "out.svg"
    r = run_cli(*(a.format(out=out, dir=tmp_path) for a in args))
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and words in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_filleted_columns_cache_follows_the_pipeline_code(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    import fabpat.catalog
    from fabpat.cli.library_cmds import _cache_path, library_rows
    from fabpat.patterns.library import enumerate_library

    monkeypatch.setenv("FABPAT_CACHE", str(tmp_path))
    lib = enumerate_library(6, 1)
    first = library_rows(lib)
    assert len(list(tmp_path.glob("library-*.json"))) == 1
    assert library_rows(lib) == first  # read back from the cache
    jobs = [(r["id"], 6, 1, 36.0, 0.2) for r in first]
    before = _cache_path(jobs)
    monkeypatch.setattr(fabpat.catalog, "solver_version", lambda: "fabpat 0+edited")
    assert _cache_path(jobs) != before  # edited pipeline code: another cache file
    monkeypatch.setenv("FABPAT_CACHE", "off")
    assert _cache_path(jobs) is None
