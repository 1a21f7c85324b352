"""``fabpat export``: every file it writes read back by an independent reader; bad input → exit 2; an
interrupted or killed ``export --all`` leaves no temporary file behind, and a full disk is named with the target."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from fabpat.io import temp_prefix
from tests.conftest import FABPAT, run_cli
from tests.helpers import default_sigint, in_small_tmpfs, needs_unshare, one_line_error, parts
from tests.helpers import invoke_result as invoke
from tests.test_cad import curve_weights, edge_curves
from tests.test_exchange_dxf import bulge_area, chain, cut_loops, entity_pieces, read, solid_area


def _outline(pattern_id: str, sides: int = 6, edge: float = 36.0, weight: float = 0.2):  # noqa: ANN202
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import enumerate_library

    return fillet_pattern(enumerate_library(sides, 2).pattern(pattern_id, edge), weight).outline


def test_export_one_pattern_every_format(tmp_path: Path) -> None:
    trimesh = pytest.importorskip("trimesh")
    from build123d import import_step

    f = {k: tmp_path / f"p.{k}" for k in ("step", "stl", "3mf", "dxf", "svg")}
    r = run_cli("export", "0x0488", *[a for k, p in f.items() for a in (f"--{k}", str(p))])
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # 0x0488 is wide enough for printing; no kerf, no laser check
    area = _outline("0x0488").area

    solids = import_step(str(f["step"])).solids()
    assert len(solids) == 1 and solids[0].is_valid
    assert solids[0].volume == pytest.approx(2.0 * area, rel=1e-6)
    weights = [w for c in edge_curves(solids[0]) for w in curve_weights(c)]
    assert any(abs(w - 0.2) < 1e-12 for w in weights)  # the interface fillets' configured weight
    assert "PRODUCT('fabpat 0x0488 n6 e36mm t2mm w0.2'" in " ".join(f["step"].read_text().split())

    stl = trimesh.load(f["stl"], file_type="stl")
    assert stl.is_watertight and stl.is_winding_consistent and stl.volume == pytest.approx(2.0 * area, rel=1e-3)
    assert f["3mf"].read_bytes()[:2] == b"PK"

    doc = read(f["dxf"])
    loops = cut_loops(doc)
    assert sum(bulge_area(lp) for lp in loops) == pytest.approx(area, abs=_outline("0x0488").perimeter * 0.01)
    assert f["svg"].read_text().count("<path") == 1


def test_export_weight_thickness_sides_and_spline_kerf(tmp_path: Path) -> None:
    from build123d import import_step

    step, dxf = tmp_path / "p.step", tmp_path / "p.dxf"
    r = run_cli("export", "0xd488", "--sides", "5", "--edge", "30", "--thickness", "1.5", "--weight", "0.3",
                "--step", str(step), "--dxf", str(dxf), "--curves", "spline", "--kerf", "0.2")
    assert r.returncode == 0, r.stderr
    outline = _outline("0xd488", 5, 30.0, 0.3)
    (solid,) = import_step(str(step)).solids()
    assert solid.volume == pytest.approx(1.5 * outline.area, rel=1e-6)
    assert any(abs(w - 0.3) < 1e-12 for c in edge_curves(solid) for w in curve_weights(c))
    doc = read(dxf)
    assert all(e.dxf.degree <= 3 for e in doc.modelspace().query("SPLINE"))  # LibreCAD/Inkscape read ≤ 3
    grown = solid_area(chain(entity_pieces(doc), directed=False))
    # Kerf 0.2: every loop moves 0.1 mm into the void, area grows by ≈ perimeter × 0.1.
    assert grown - outline.area == pytest.approx(outline.perimeter * 0.1, rel=0.05)


def test_dxf_entities_origin_and_svg_curves_options(tmp_path: Path) -> None:
    dxf, svg = tmp_path / "p.dxf", tmp_path / "p.svg"
    r = run_cli("export", "0x0488", "--dxf", str(dxf), "--dxf-entities", "segments", "--origin", "centre",
                "--svg", str(svg), "--svg-curves", "exact")
    assert r.returncode == 0, r.stderr
    doc = read(dxf)
    outline = _outline("0x0488")
    assert not doc.modelspace().query("LWPOLYLINE") and doc.modelspace().query("ARC")
    assert solid_area(chain(entity_pieces(doc), directed=False)) == pytest.approx(outline.area,
                                                                                  abs=outline.perimeter * 0.01)
    ext_min = np.array(doc.header["$EXTMIN"])[:2]
    assert ext_min == pytest.approx(outline.bbox[0], abs=0.01)  # centre: the pattern's own frame
    text = svg.read_text()
    assert " A " in text and "transform" not in text


def test_width_warnings_go_to_stderr(tmp_path: Path) -> None:
    # At edge 12 mm the 1.95 mm necks of 0x0488 (edge 36) are 0.65 mm: below the 0.8 mm print limit.
    r = run_cli("export", "0x0488", "--edge", "12", "--stl", str(tmp_path / "s.stl"))
    assert r.returncode == 0 and (tmp_path / "s.stl").exists()
    assert r.stderr.startswith("fabpat: warning:") and "0.8 mm" in r.stderr and "printing" in r.stderr
    r = run_cli("export", "0x0488", "--dxf", str(tmp_path / "k.dxf"), "--kerf", "1.0")
    assert r.returncode == 0 and "laser" in r.stderr and "2 mm" in r.stderr


@pytest.mark.parametrize(("options", "name"), [(("--sides", "3"), "n3 e36mm"), (("--edge", "6"), "n6 e6mm"),
                                             (("--sides", "5", "--edge", "12"), "n5 e12mm")])
def test_a_label_left_out_is_said_on_stderr(tmp_path: Path, options: tuple[str, ...], name: str) -> None:
    dxf, svg = tmp_path / "t.dxf", tmp_path / "t.svg"
    r = run_cli("export", "0x0488", *options, "--dxf-entities", "segments", "--dxf", str(dxf), "--svg", str(svg))
    assert r.returncode == 0, r.stderr
    assert not read(dxf).modelspace().query("TEXT") and "<text" not in svg.read_text()  # no room: no label
    (line,) = r.stderr.splitlines()
    assert line.startswith("fabpat: warning: fabpat 0x0488 " + name) and "no label on the DXF/SVG" in line
    assert "1 mm" in line and "material" in line


def test_export_all_in_one_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--all`` on a three-pattern library (the whole one is timed by benchmarks/bench_export.py)."""
    from click.testing import CliRunner

    import fabpat.patterns.library
    from fabpat.cli import cli
    from fabpat.patterns.library import Library, enumerate_library

    full = enumerate_library(6, 2)
    monkeypatch.setattr(fabpat.patterns.library, "enumerate_library", lambda s, d: Library(s, d, full.bits[:3], 3))
    out = tmp_path / "parts"
    result = CliRunner().invoke(cli, ["export", "--all", "--out", str(out), "--formats", "dxf,svg,3mf"])
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in out.iterdir())
    assert len(names) == 9 and names[:3] == sorted(f"{i}{s}" for i in full.ids[:1] for s in (".3mf", ".dxf", ".svg"))
    assert "wrote 9 files for 3 patterns" in result.output


@pytest.mark.parametrize(
    "args, words",
    [
        (["0x0488", "--thickness", "0", "--step", "{dir}/a.step"], "thickness"),
        (["0x0488", "--thickness", "-1", "--stl", "{dir}/a.stl"], "thickness"),
        (["0x0488", "--weight", "0", "--stl", "{dir}/a.stl"], "weight"),
        (["0x0488", "--kerf", "-0.1", "--dxf", "{dir}/a.dxf"], "kerf"),
        (["0x0488", "--curves", "bezier", "--dxf", "{dir}/a.dxf"], "bezier"),
        (["0x0488", "--curves", "spline", "--dxf-version", "R12", "--dxf", "{dir}/a.dxf"], "R12"),
        (["0x0488", "--dxf-entities", "polyline", "--dxf-version", "R12", "--dxf", "{dir}/a.dxf"], "segments"),
        (["0x0488", "--curves", "spline", "--dxf-entities", "polyline", "--dxf", "{dir}/a.dxf"], "segments"),
        (["0x0488", "--origin", "middle", "--svg", "{dir}/a.svg"], "corner"),
        (["0x0488", "--svg-curves", "arcs", "--svg", "{dir}/a.svg"], "cubic"),
        (["0x0488"], "no output"),
        (["0x0488", "--stl", "{dir}/ok.stl", "--step", "{dir}/missing/a.step"], "does not exist"),
        (["0x0488", "--stl", "{dir}/a.stl", "--3mf", "{dir}/a.stl"], "--3mf must end in .3mf"),  # a 3MF in a .stl
        (["0x0001", "--stl", "{dir}/a.stl"], "not in the"),
        (["--all", "--out", "{dir}/lib", "--formats", "step,obj"], "obj"),
        (["--all", "--out", "{dir}/lib", "--formats", ","], "no format"),
        (["--all", "--out", "{dir}/missing/lib", "--formats", "svg"], "does not exist"),  # no tree of folders
        (["0x0488", "--stl", "/proc/fabpat-test.stl"], "cannot write"),  # a folder that takes no files
        (["--all"], "--out"),
        (["0x0488", "--all", "--out", "{dir}/lib"], "not both"),
        (["--stl", "{dir}/a.stl"], "ID"),
    ],
)
def test_bad_input_is_one_line_exit_2_no_file(tmp_path: Path, args: list[str], words: str) -> None:
    r = run_cli("export", *(a.format(dir=tmp_path) for a in args))
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("fabpat: error:") and words in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_unwritable_path(tmp_path: Path) -> None:
    """A target under a regular file, a target that is a folder, and (unless root) a read-only folder."""
    import os

    (tmp_path / "file.txt").write_text("x")
    (tmp_path / "folder.dxf").mkdir()
    targets = [str(tmp_path / "file.txt" / "a.dxf"), str(tmp_path / "folder.dxf")]
    if os.geteuid() != 0:  # root may write anywhere
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        targets.append(str(locked / "a.dxf"))
    before = sorted(tmp_path.iterdir())
    for target in targets:
        r = run_cli("export", "0x0488", "--svg", str(tmp_path / "a.svg"), "--dxf", target)
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        assert sorted(tmp_path.iterdir()) == before  # not even the SVG


def test_cli_start_up_does_not_load_cad_libraries() -> None:
    """``fabpat library`` must stay fast: OCP, build123d, ezdxf and trimesh load only when exporting."""
    import subprocess
    import sys

    code = "import sys, fabpat.cli; print(sorted({'OCP', 'build123d', 'ezdxf', 'trimesh'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("option,name", [("--dxf", "out.dwg"), ("--stl", "x.step"), ("--svg", "x.dxf"),
                                         ("--step", "x.stl"), ("--3mf", "x.stl"), ("--3dm", "x.dxf")])
def test_a_file_option_refuses_another_formats_suffix(tmp_path: Path, option: str, name: str) -> None:
    """``--dxf out.dwg`` wrote DXF into a .dwg; the CLI refuses as ``FilletedPattern.export`` does."""
    r = run_cli("export", "0x0488", option, str(tmp_path / name))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith(f"fabpat: error: {option} must end in") and name in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_file_option_takes_its_formats_suffixes_in_any_case(tmp_path: Path) -> None:
    r = run_cli("export", "0x0488", "--step", str(tmp_path / "a.STP"), "--svg", str(tmp_path / "a.SVG"))
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.STP", "a.SVG"]


def test_show_refuses_an_svg_under_another_suffix(tmp_path: Path) -> None:
    r = run_cli("show", "0x0488", "--svg", str(tmp_path / "p.png"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--svg must end in .svg" in r.stderr
    assert list(tmp_path.iterdir()) == []


@needs_unshare
def test_export_on_a_full_disk_names_the_target(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    res = in_small_tmpfs(disk, "for f in a.step a.stl; do $FAB export 0x0488 --${f#a.} disk/$f; echo rc=$?; done; "
                               "dd if=/dev/zero of=disk/fill bs=1k count=56 2>/dev/null; "
                               "$FAB export 0x0488 --dxf disk/a.dxf; echo rc=$?; ls -A disk")
    assert res.stdout.split() == ["rc=2", "rc=2", "rc=2", "fill"], (res.stdout, res.stderr)
    lines = res.stderr.splitlines()
    assert len(lines) == 3, res.stderr
    for line, name in zip(lines, ("a.step", "a.stl", "a.dxf"), strict=True):
        assert line.startswith(f"fabpat: error: cannot write disk/{name}: the disk is full"), line
        assert ".part" not in line


def test_export_all_with_no_formats_is_an_error(tmp_path: Path) -> None:
    res = invoke("export", "--all", "--out", str(tmp_path / "o"), "--formats", "")
    one_line_error(res, "no format", "step, stl, 3mf, dxf, svg")
    res = invoke("export", "--all", "--out", str(tmp_path / "o"), "--formats", " , ")
    one_line_error(res, "no format")
    assert not (tmp_path / "o").exists()


def _export_all(out: Path) -> subprocess.Popen[str]:
    env = dict(os.environ, FABPAT_CACHE="off")
    return subprocess.Popen([*FABPAT, "export", "--all", "--out", str(out), "--formats", "svg,dxf"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=default_sigint)  # SIGINT is ignored in a background job's children


def _wait_for_parts(proc: subprocess.Popen[str], out: Path) -> None:
    t0 = time.monotonic()
    while not parts(out):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < 120, "export --all wrote no temporary file"
        time.sleep(0.05)
    time.sleep(0.3)  # well inside the writing of 860 files


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_interrupted_export_all_leaves_no_part_files(tmp_path: Path, sig: signal.Signals) -> None:
    out = tmp_path / "parts"
    proc = _export_all(out)
    _wait_for_parts(proc, out)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, err  # 143 for SIGTERM, 130 for Ctrl-C
    assert parts(out) == []
    assert not out.exists()  # the folder this run created is removed again


def test_stale_part_files_are_removed_by_the_next_run(tmp_path: Path) -> None:
    out = tmp_path / "parts"
    proc = _export_all(out)
    _wait_for_parts(proc, out)
    proc.kill()  # SIGKILL: no cleanup can run
    proc.wait()
    stale = parts(out)
    assert stale
    live = out / f"{temp_prefix('keep')}abcdefgh.part.svg"  # this process is alive: its file stays
    live.write_text("")
    res = invoke("export", "0x0488", "--svg", str(out / "p.svg"))
    assert res.exit_code == 0, res.stderr
    assert parts(out) == [live.name]
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["p.svg"]
