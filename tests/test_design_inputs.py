"""What ``fabpat design`` takes, checked before any solve: the tiling kinds a design accepts (a strip; the
truncated icosahedron and Goldberg spheres), hostile targets (ellipsoid ratios that overflow the fit, FIFOs,
devices, a file too large, a CSV whose name is a keyword) and base specs that are no files, from Python as
from the command line. A solve reached where a refusal was due fails the test at once (``no_solve``)."""

from __future__ import annotations

import os
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fabpat.design import TargetError, design
from fabpat.design.target import MAX_CSV_BYTES, read_target
from fabpat.errors import SpecError
from tests.helpers import one_line_error

ROOT = Path(__file__).resolve().parents[1]
SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
STRIP = ROOT / "assemblies" / "graded-strip.toml"
ARCH = "x,z\n0,0\n100,20\n200,0\n"


@pytest.fixture
def no_solve(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every design solve goes through Runner.run: reaching it fails the test (the refusal came too late)."""
    from fabpat.design.search import Runner

    def solved(*_args: Any, **_kw: Any) -> None:
        raise AssertionError("a solve was started before the refusal")

    monkeypatch.setattr(Runner, "run", solved)


def _spec(tmp_path: Path, tiling: str, patterns: str = 'hexagon = "0x0488"\npentagon = "0x0508"') -> Path:
    path = tmp_path / "base.toml"
    path.write_text(f"[tiling]\n{tiling}\n[patterns]\n{patterns}\n[plates]\nthickness = 1.0\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(("tiling", "patterns"), [
    ("panel", ""),
    (f'kind = "mesh"\nfile = "{ROOT / "assemblies" / "panel-squares.obj"}"', 'square = "0x0488"'),
])
def test_kinds_a_design_does_not_take_are_refused_before_any_solve(tmp_path: Path, no_solve: None, tiling: str,
                                                                   patterns: str) -> None:
    """A panel solved two baselines and then crashed on its missing sphericity (TypeError), and a mesh file's
    polygons need not be in a catalog (its ``square`` key was refused as no way of choosing patterns). Each is now
    one line naming the kinds a design takes (a tube and a cap are designed: tests/test_design_open.py)."""
    spec = ROOT / "assemblies" / "panel.toml" if tiling == "panel" else _spec(tmp_path, tiling, patterns)
    for target in ("sphere", "ellipsoid:1,1,1.2"):
        with pytest.raises(SpecError, match="cannot be designed") as e:
            design(target, spec)
        text = str(e.value)
        assert "\n" not in text and '"truncated-icosahedron" or "goldberg"' in text and '"honeycomb-strip"' in text
        assert '"hex-cap" (cap:H)' in text


def _fake_closure(spec: Any, patterns: tuple[str, ...], h: float, start: Any = None) -> dict[str, Any]:
    """A closure without the solver: every face's corners and centre on a sphere of 100 mm, each face pushed
    out by 0 … 4 ‰ by its pattern's name, so that designs differ as real ones do (by face group)."""
    from fabpat.assembly.place.placement import build_tiling

    skel = build_tiling(spec)
    V = np.asarray(skel.V) - np.asarray(skel.V).mean(axis=0)
    nodes, offsets = [], [0]
    for loop, pid in zip(skel.faces, patterns, strict=True):
        pts = np.vstack([V[list(loop)], V[list(loop)].mean(axis=0)])
        r = 100.0 * (1.0 + 0.001 * (zlib.crc32(pid.encode()) % 5))
        nodes.append(pts / np.linalg.norm(pts, axis=1)[:, None] * r)
        offsets.append(offsets[-1] + len(pts))
    P = np.vstack(nodes)
    dist = np.linalg.norm(P, axis=1)
    return {"P": P, "peak_strain": 0.01, "radius": float(dist.mean()),
            "sphericity_rms": float(np.sqrt(np.mean((dist / dist.mean() - 1.0) ** 2))), "seconds": 0.0,
            "plate_energies": np.zeros(len(patterns)), "faces": list(patterns),
            "offsets": np.asarray(offsets, dtype=np.int64), "state": None, "factorizations": 0, "warm": False}


def test_a_goldberg_sphere_is_designed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """GP(2, 0) (30 hexagons, 12 pentagons) goes the truncated icosahedron's way: its faces grouped by polygon,
    both catalogs' candidates, the baselines, and a record naming every plate (the solver replaced by
    ``_fake_closure``; a real GP(2, 0) design at h = 6 mm is in docs/design.md)."""
    monkeypatch.setattr("fabpat.design.closed_api.solve_closed", _fake_closure)
    spec = _spec(tmp_path, 'kind = "goldberg"\nm = 2\nedge = 36.0',  # the paper's members only: 1 s less
                 'hexagon = "0x0488"\npentagon = "0x0508"\nvariations = false')
    res = design("sphere", spec, max_solves=2, h=6.0)
    rec = res.record
    assert rec["kind"] == "goldberg" and len(rec["patterns"]) == 42
    assert sorted({k[0] for k in rec["patterns"]}) == ["H", "P"]
    hexagons = {rec["patterns"][k] for k in rec["patterns"] if k.startswith("H")}
    assert len(hexagons) == 1  # a sphere target: one group per polygon
    assert {"spec", "single"} <= set(rec["baselines"]) and rec["solves"] == 2 + 2
    assert 0.0 <= rec["relative_rms"] <= min(b["relative_rms"] for b in rec["baselines"].values()) + 1e-12


@pytest.mark.parametrize("value", ["1e300", "1e-300", "1e-320", "1e308", "0.09", "10.5", "inf"])
def test_ellipsoid_ratios_out_of_range_are_refused_before_any_solve(value: str, no_solve: None) -> None:
    """1e300 solved first and then failed in scipy's least squares (residuals not finite)."""
    target = f"ellipsoid:1,1,{value}"
    with pytest.raises(TargetError, match=r"axis ratio C .*\[0\.1, 10\]") as e:
        design(target, SPHERE)
    assert "\n" not in str(e.value) and target in str(e.value)
    assert read_target("ellipsoid:0.1,1,10").axes == (0.1, 1.0, 10.0)  # the ends are in


def test_fifo_and_device_inputs_are_refused_from_python(tmp_path: Path, no_solve: None) -> None:
    """The command refused them; design() blocked on a FIFO and ran out of memory on /dev/zero."""
    for name in ("pipe.toml", "pipe.csv", "pipe.obj"):
        os.mkfifo(tmp_path / name)
    cases = [(str(tmp_path / "pipe.csv"), STRIP, TargetError, "FIFO"),
             (str(tmp_path / "pipe.obj"), SPHERE, TargetError, "FIFO"),
             ("/dev/zero", STRIP, TargetError, "character device"),
             ("sphere", tmp_path / "pipe.toml", SpecError, "not a regular file"),
             ("sphere", "/dev/zero", SpecError, "not a regular file")]
    for target, spec, error, words in cases:
        with pytest.raises(error, match=words) as e:
            design(target, spec)
        assert "\n" not in str(e.value), target


def test_a_target_file_larger_than_the_limit_is_refused_unread(tmp_path: Path, no_solve: None) -> None:
    big = tmp_path / "big.csv"
    with big.open("wb") as f:  # sparse: the size without the bytes
        f.write(ARCH.encode())
        f.truncate(200 * 1024 * 1024)
    with pytest.raises(TargetError, match=f"larger than {MAX_CSV_BYTES} bytes"):
        design(str(big), STRIP)
    with (tmp_path / "big.stl").open("wb") as f:
        f.truncate(100 * 1024 * 1024)
    with pytest.raises(TargetError, match="larger than"):
        design(str(tmp_path / "big.stl"), SPHERE)


@pytest.mark.parametrize("name", ["sphere", "ellipsoid-arch.csv", "ellipsoid:1,1,2", "Sphere"])
def test_a_path_that_exists_is_a_file_whatever_its_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                        name: str) -> None:
    monkeypatch.chdir(tmp_path)
    Path(name).write_text(ARCH, encoding="utf-8")
    t = read_target(name)
    assert t.source == name and t.span == 200.0 and t.z.max() == 20.0
    Path(name).unlink()
    if name.lower() == "sphere" or name.startswith("ellipsoid:"):
        assert read_target(name).kind in ("sphere", "ellipsoid")  # without the file: the keyword
        Path(name).mkdir()  # a folder of that name (an earlier run's --out) is no target file
        assert read_target(name).kind in ("sphere", "ellipsoid")
    else:
        with pytest.raises(TargetError, match="cannot read target ellipsoid-arch.csv") as e:
            read_target(name)
        assert "ellipsoid:A,B,C" not in str(e.value)


def test_command_refusals_are_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, no_solve: None) -> None:
    """Including with a folder ``sphere`` where the command runs (an earlier ``--out sphere``): the keyword,
    not "TARGET sphere is a directory"."""
    from click.testing import CliRunner

    from fabpat.cli import cli

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sphere").mkdir()

    for args, words in ((["ellipsoid:1,1,1e300", "--spec", str(SPHERE)], "axis ratio C"),
                        (["sphere", "--spec", str(ROOT / "assemblies" / "panel.toml")], "cannot be designed")):
        out = tmp_path / "out"
        r = CliRunner().invoke(cli, ["design", *args, "--out", str(out), "--no-progress"])
        one_line_error(r, words)
        assert not out.exists()


@pytest.mark.parametrize("x, z", [(None, [0, 1, 0]), ("abc", [0, 1, 0]), ([0, 1, 2], "xyz"), (1.5, 2.5),
                                  ([0, 1, 2], [0, 1]), ([[0, 1, 2]], [[0, 1, 0]])])
def test_check_strip_refuses_what_is_not_two_sequences_of_numbers(x: object, z: object) -> None:
    from fabpat.design.target import check_strip
    from fabpat.errors import FabpatError

    with pytest.raises(FabpatError, match="target t"):
        check_strip("t", x, z)  # type: ignore[arg-type]


@pytest.mark.parametrize("scale, says", [(1e300, r"coordinate of 1e\+300"), (1e150, r"coordinate of 1e\+150"),
                                         (1e-300, "mean edge")])
def test_a_mesh_target_at_a_scale_floating_point_cannot_hold_is_refused_by_name(scale: float, says: str,
                                                                                 tmp_path: Path) -> None:
    import warnings

    corners = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    path = tmp_path / "t.obj"
    path.write_text("".join(f"v {a * scale} {b * scale} {c * scale}\n" for a, b, c in corners)
                    + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow warnings came before the wrong reason
        with pytest.raises(TargetError, match=says):
            read_target(str(path))


def _strip_base(folder: Path, patterns: str) -> Path:
    text = (Path(__file__).resolve().parents[1] / "assemblies" / "test-small.toml").read_text(encoding="utf-8")
    head, _, rest = text.partition("[patterns]")
    p = folder / "base.toml"
    p.write_text(head + "[patterns]\n" + patterns + "\n\n" + rest[rest.index("[plates]"):], encoding="utf-8")
    return p


def test_depth_3_adds_the_catalogs_depth_3_patterns_to_a_strips_candidates(tmp_path: Path) -> None:
    from fabpat.catalog import open_catalog
    from fabpat.design.base import load_base
    from tests.test_catalog import fake_rows

    deep = {"0xfffef677a0778080": 13.25, "0xc9eb400a41358080": 72.3}  # depth-3 IDs, Cylinder energies (N·mm)
    db = tmp_path / "deep.sqlite"
    with open_catalog(db, write=True) as cat:
        for pid, e in deep.items():
            cat.write_rows([dict(r, depth=3) for r in fake_rows(pid, 6, {"cylinder": e})])
        cat.finish()
    base = load_base(_strip_base(tmp_path, f'depth = 3\ncatalog = "{db}"\nvariations = false'))
    assert {k: base.energies[k] for k in deep} == deep
    assert sum(len(k) == 6 for k in base.energies) == 430  # the built-in depth-2 candidates stay
    plain = load_base(_strip_base(tmp_path, "variations = false"))
    assert not set(deep) & set(plain.energies)
    shipped = load_base(_strip_base(tmp_path, "depth = 3\nvariations = false"))  # the built-in's depth-3 hexagons
    import fabpat

    want = {str(r["id"]) for r in fabpat.catalog(depth=3) if r["energy_cylinder"] is not None}
    assert {k for k in shipped.energies if len(k) == 18} == want and len(want) >= 100
    with pytest.raises(SpecError, match="must be 2"):
        load_base(_strip_base(tmp_path, "depth = 4"))


def test_an_empty_ply_target_is_refused_without_pythons_words(tmp_path: Path) -> None:
    path = tmp_path / "e.ply"
    path.write_text("ply\n")
    with pytest.raises(TargetError) as e:
        read_target(str(path))
    assert "is not a surface mesh" in str(e.value) and "index" not in str(e.value)
