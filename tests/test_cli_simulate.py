"""``fabpat simulate`` and ``simulate-assembly`` on the command line: JSON and text output, result files, the
Abaqus deck; a mesh too fine or too coarse to run, or a --png without .png, is one line naming what works."""

import json
from pathlib import Path

import pytest

from tests.conftest import run_cli
from tests.helpers import refusal_in as one_line_error
from tests.helpers import run_in as fabpat


def test_simulate_json_and_files(tmp_path: Path) -> None:
    import meshio

    vtu, png, inp = tmp_path / "c.vtu", tmp_path / "c.png", tmp_path / "c.inp"
    r = run_cli(
        "simulate", "0x7f88", "--scenario", "cantilever", "--h", "3", "--json",
        "--vtu", str(vtu), "--png", str(png), "--export-inp", str(inp),
    )
    assert r.returncode == 0, r.stderr
    row = json.loads(r.stdout)
    for key in ("id", "scenario", "energy", "max_displacement", "converged", "iterations", "seconds", "nodes",
                "elements"):
        assert key in row
    assert row["id"] == "0x7f88" and row["scenario"] == "cantilever" and row["converged"] is True
    # a dense pattern is softer than the solid hexagon (2.6 N·mm) but of the same order
    assert 2.6 < row["energy"] < 30
    m = meshio.read(vtu)
    assert len(m.points) == row["nodes"]
    assert abs(m.point_data["displacement"][:, 2]).max() == pytest.approx(row["max_displacement"], rel=0.05)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert "*NODE" in inp.read_text().upper()


def test_simulate_all_names_files_per_scenario(tmp_path: Path) -> None:
    r = run_cli("simulate", "0x7f88", "--linear", "--h", "4", "--json", "--vtu", str(tmp_path / "r.vtu"))
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert [x["scenario"] for x in rows] == ["cantilever", "cylinder", "dome"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r-cantilever.vtu", "r-cylinder.vtu", "r-dome.vtu"]


@pytest.mark.parametrize(
    "args, words",
    [
        (["--scenario", "twist"], "cantilever"),
        (["--h", "0"], "--h"),
        (["--poisson", "0.7"], "--poisson"),
        (["--sides", "2"], "sides"),
    ],
)
def test_simulate_bad_input(tmp_path: Path, args: list[str], words: str) -> None:
    r = run_cli("simulate", "0x7f88", *args, "--vtu", str(tmp_path / "x.vtu"))
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and words in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_simulate_text_output_is_plain_key_value() -> None:
    """Friction: the text lines were "ID scenario energy=… N·mm …"; now every token is key=value, the
    keys are the JSON field names and every value parses (units are in --help)."""
    args = ("simulate", "0x7f88", "--scenario", "cantilever", "--linear", "--h", "4")
    r = run_cli(*args)
    assert r.returncode == 0, r.stderr
    line = r.stdout.strip().splitlines()[0]
    tokens = line.split()
    assert all(tok.count("=") == 1 for tok in tokens), line
    fields = dict(tok.split("=") for tok in tokens)
    row = json.loads(run_cli(*args, "--json").stdout)
    assert set(fields) == {"id", "scenario", "energy", "max_displacement", "converged", "iterations", "seconds",
                           "nodes", "elements", "h"} <= set(row)
    assert [float(x) for x in fields["h"].split(",")] == row["h"] == [4.0]  # --h alone: that one mesh
    default = dict(tok.split("=") for tok in run_cli(*args[:-2]).stdout.split())
    assert default["h"] == "2.5,1.25"  # the default: extrapolated from a mesh and its nested refinement
    assert fields["id"] == "0x7f88" and fields["scenario"] == "cantilever" and fields["converged"] == "true"
    assert float(fields["energy"]) == pytest.approx(row["energy"], rel=1e-5)
    assert float(fields["max_displacement"]) == pytest.approx(row["max_displacement"], rel=1e-3)
    assert int(fields["nodes"]) == row["nodes"] and int(fields["elements"]) == row["elements"]
    assert "N·mm" in run_cli("simulate", "--help").stdout  # the units live in the help


def test_simulate_infers_the_depth_from_the_id() -> None:
    """Friction: a 16-digit (depth-3) ID was refused without --depth 3 while `export` took it."""
    import fabpat

    pid = "0xc311aba5e62c0080"  # a depth-3 library pattern (sample_library(6, 3, 1, seed=0))
    r = run_cli("simulate", pid, "--scenario", "cantilever", "--linear", "--h", "1.9")  # ≤ 2 × its min_width (0.98 mm)
    assert r.returncode == 0, r.stderr
    fields = dict(tok.split("=") for tok in r.stdout.split())
    ref = fabpat.simulate(fabpat.pattern(pid).fillet(), "cantilever", h=1.9, linear=True)
    assert float(fields["energy"]) == pytest.approx(ref.energy, rel=1e-5) and int(fields["nodes"]) == ref.nodes
    bad = run_cli("simulate", pid, "--depth", "2", "--scenario", "cantilever")
    assert bad.returncode == 2 and "depth 2 needs 4" in bad.stderr and bad.stderr.count("\n") == 1


def test_simulate_assembly_text_output_is_plain_key_value() -> None:
    spec = Path(__file__).resolve().parents[1] / "assemblies" / "test-small.toml"
    args = ("simulate-assembly", str(spec), "--h", "5", "--end-shortening", "0.05", "--steps", "2")
    text, as_json = run_cli(*args), run_cli(*args, "--json")
    assert text.returncode == 0 and as_json.returncode == 0, text.stderr + as_json.stderr
    lines = text.stdout.splitlines()
    assert all("=" in line and " " not in line for line in lines), text.stdout
    fields = dict(line.split("=", 1) for line in lines)
    row = json.loads(as_json.stdout)
    assert list(fields) == list(row)  # the same names, in the same order
    for key in ("energy", "reaction", "max_deflection", "peak", "half_ratio"):
        assert float(fields[key]) == pytest.approx(row[key], rel=1e-5), key
    assert json.loads(fields["plate_energies"]) == pytest.approx(row["plate_energies"], rel=1e-5)
    assert fields["converged"] == "true" and int(fields["plates"]) == 3 and int(fields["sleeves"]) == 2


@pytest.mark.parametrize("element, per_element", [("S6", 6), ("S3", 3), ("STRI3", 3)])
def test_export_inp_element_choice(tmp_path: Path, element: str, per_element: int) -> None:
    inp = tmp_path / "c.inp"
    r = run_cli("simulate", "0x7f88", "--scenario", "dome", "--linear", "--h", "4", "--export-inp", str(inp),
                "--inp-element", element, "--json")
    assert r.returncode == 0, r.stderr
    lines = inp.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.upper().startswith("*ELEMENT"))
    assert f"TYPE={element}" in lines[k].upper()
    assert len(lines[k + 1].split(",")) == 1 + per_element  # element id, then its nodes
    end = next(i for i in range(k + 1, len(lines)) if lines[i].startswith("*"))
    assert end - k - 1 == json.loads(r.stdout)["elements"]  # one line per element of the solver's mesh
    assert all(len(ln.split(",")) == 1 + per_element for ln in lines[k + 1:end])


def test_export_inp_heading_names_the_pattern_and_its_member(tmp_path: Path) -> None:
    inp = tmp_path / "m.inp"
    r = run_cli("simulate", "0x0488", "--scenario", "dome", "--linear", "--h", "5", "--variation", "bridge_weight=0.5",
                "--export-inp", str(inp), "--json")
    assert r.returncode == 0, r.stderr
    lines = inp.read_text().splitlines()
    assert lines[0] == "*HEADING" and lines[1].startswith("fabpat dome scenario, pattern 0x0488 b0.5 (6-gon), S6, ")


def test_simulate_png_is_captioned_with_the_energy_it_prints(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The picture names the pattern, the scenario and its load, and the energy the JSON reports."""
    from click.testing import CliRunner

    import fabpat.simulation.png_result as png_result
    from fabpat.cli import cli

    titles: list[str] = []
    real = png_result.write_png

    def spy(*args: object, title: str = "", **kw: object) -> object:
        titles.append(title)
        return real(*args, title=title, **kw)

    monkeypatch.setattr(png_result, "write_png", spy)
    r = CliRunner().invoke(cli, ["simulate", "0x7f88", "--scenario", "cantilever", "--h", "3", "--json",
                                 "--png", str(tmp_path / "c.png"), "--no-progress"])
    assert r.exit_code == 0, r.output
    energy = json.loads(r.stdout)["energy"]
    assert len(titles) == 1 and "0x7f88" in titles[0] and "F = 1.5 N" in titles[0]
    assert f"U = {energy:.4g} N·mm" in titles[0]


def test_too_many_elements_is_refused_before_meshing(tmp_path: Path) -> None:
    line = one_line_error(tmp_path, "simulate", "0x2d88", "--h", "0.05")
    assert "--max-elements" in line and "50000" in line and "h ≥" in line
    line = one_line_error(tmp_path, "simulate", "0x2d88", "--edge", "1000")
    assert "mesh elements" in line and "--max-elements" in line
    line = one_line_error(tmp_path, "simulate", "0x2d88", "--h", "2", "--max-elements", "300")
    assert "above the limit of 300" in line
    assert "--h" in one_line_error(tmp_path, "simulate", "0x2d88", "--h", "1e-6")
    assert "--edge" in one_line_error(tmp_path, "simulate", "0x2d88", "--edge", "1e9")
    line = one_line_error(tmp_path, "sweep", "--h", "0.05", "--db", "c.sqlite")
    assert "mesh elements" in line


def test_too_coarse_mesh_names_the_h_that_works(tmp_path: Path) -> None:
    line = one_line_error(tmp_path, "simulate", "0x2d88", "--h", "36", "--scenario", "dome")
    assert "min_width" in line and "2.25 mm" in line and "use h ≤ 4.5 mm" in line
    code, out, err = fabpat(tmp_path, "simulate", "0x2d88", "--h", "4.5", "--scenario", "cantilever", "--linear")
    assert code == 0, err


@pytest.mark.parametrize("name", ["out.txt", "out"])
def test_png_suffix(tmp_path: Path, name: str) -> None:
    line = one_line_error(tmp_path, "simulate", "0x2d88", "--scenario", "cantilever", "--png", name)
    assert "--png" in line and ".png" in line
