"""Continuous variations (bridge_weight): tileable, symmetric, exact, fabricable, and everywhere a
pattern goes (Python, CLI, files)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import fabpat
from fabpat.cli import cli
from fabpat.errors import FabpatError, GeometryError
from fabpat.geometry.fillet import fillet_pattern, vertex_stars
from fabpat.geometry.outline import RationalQuad
from fabpat.patterns.library import enumerate_library, get_pattern
from fabpat.patterns.variation import PAPER_VARIATION, Variation, variations
from fabpat.validate import RANGES

LOW, HIGH = RANGES["bridge_weight"].low, RANGES["bridge_weight"].high
#: mm: two 0.4 mm extrusion lines, the thinnest wall a slicer prints solid (and the CLI's print warning)
FABRICATION_LIMIT = 0.8


def _arcs(fp: fabpat.FilletedPattern) -> list[RationalQuad]:
    return [s for lp in fp.outline.loops for s in lp.segments if isinstance(s, RationalQuad)]


def test_the_paper_variation_is_the_default_outline() -> None:
    p = get_pattern("0x0488")
    a, b = p.fillet(), p.fillet(bridge_weight=1.0)
    assert b.variation.is_paper and a.variation == PAPER_VARIATION
    assert a.outline.to_svg_path() == b.outline.to_svg_path()


@pytest.mark.parametrize("sides", [6, 5])
def test_two_patterns_at_two_variations_meet_at_identical_interface_geometry(sides: int) -> None:
    a = fillet_pattern(get_pattern("0x0488", sides), 0.2, Variation(LOW))
    b = fillet_pattern(get_pattern("0x2d88", sides), 0.2, Variation(HIGH))
    assert np.array_equal(a.interface_segments, b.interface_segments)  # bit for bit, not just close
    for (a1, a2), (b1, b2) in zip(a.interface_arcs, b.interface_arcs, strict=True):
        for x, y in ((a1, b1), (a2, b2)):
            assert np.array_equal(x.P0, y.P0) and np.array_equal(x.P1, y.P1) and np.array_equal(x.P2, y.P2)
            assert x.w == y.w == 0.2


def test_the_bridge_arcs_carry_the_weight_and_nothing_else_changes() -> None:
    p = get_pattern("0x0488")  # has non-manifold vertices
    assert any(v.kind == "non-manifold" for v in vertex_stars(p))
    paper, varied = _arcs(p.fillet()), _arcs(p.fillet(bridge_weight=0.4))
    assert len(paper) == len(varied)
    changed = [(x.w, y.w) for x, y in zip(paper, varied, strict=True) if x.w != y.w]
    assert changed and all(x == 1.0 and y == 0.4 for x, y in changed)
    for x, y in zip(paper, varied, strict=True):  # same control points: only weights move
        assert np.array_equal(x.P0, y.P0) and np.array_equal(x.P1, y.P1) and np.array_equal(x.P2, y.P2)


def test_a_pattern_without_non_manifold_vertices_has_a_one_member_family() -> None:
    lib = enumerate_library(6, 2)
    plain = next(i for i in lib.ids if not any(v.kind == "non-manifold" for v in vertex_stars(lib.pattern(i))))
    p = lib.pattern(plain)
    assert p.fillet(bridge_weight=LOW).outline.to_svg_path() == p.fillet(bridge_weight=HIGH).outline.to_svg_path()
    # the member is the paper's outline, so it is recorded, labelled and named as the paper's
    member = p.fillet(bridge_weight=LOW)
    assert member.variation.is_paper and member.label == plain
    bridged = next(i for i in lib.ids if any(v.kind == "non-manifold" for v in vertex_stars(lib.pattern(i))))
    assert lib.pattern(bridged).fillet(bridge_weight=LOW).variation == Variation(LOW)


def test_cli_warns_when_a_variation_does_not_change_the_pattern(tmp_path: Path) -> None:
    out = tmp_path / "plain.svg"
    r = CliRunner().invoke(cli, ["show", "0x0f88", "--variation", "bridge_weight=0.5", "--svg", str(out)])
    assert r.exit_code == 0, r.output
    assert "0x0f88 has no non-manifold vertex, so bridge_weight=0.5 does not change it" in r.stderr
    assert "<title>0x0f88 (6-gon" in out.read_text()
    r = CliRunner().invoke(cli, ["show", "0x0488", "--variation", "bridge_weight=0.5"])
    assert r.exit_code == 0 and "warning" not in r.stderr and "<title>0x0488 b0.5 (6-gon" in r.stdout


def test_wider_necks_for_smaller_weights() -> None:
    """B(½) = V + (M − V)/(1 + w): the material at the vertex, area and neck width, falls as w grows, and
    a symmetric neck's width is 2/(1 + w) times the paper's (0x0488's necks are its narrowest feature)."""
    p = get_pattern("0x0488")
    ws = [LOW, 0.5, 1.0, 1.6, HIGH]
    fps = [p.fillet(bridge_weight=w) for w in ws]
    areas = [fp.metrics.area for fp in fps]
    assert all(a > b for a, b in zip(areas, areas[1:], strict=False))
    paper_width = fps[2].min_width()
    for w, fp in zip(ws[2:], fps[2:], strict=True):
        assert fp.min_width() == pytest.approx(paper_width * 2 / (1 + w), abs=0.02)  # 2 × the 0.01 mm flattening


@pytest.mark.parametrize("sides", [6, 5])
def test_min_width_stays_above_the_fabrication_limit_across_the_library(sides: int) -> None:
    """At the narrow end of the range every library pattern keeps ≥ 0.8 mm at the paper's 36 mm edge
    (the bound in fabpat.validate.RANGES says so); each outline is valid and n-fold symmetric."""
    lib = enumerate_library(sides, 2)
    narrowest = min(fillet_pattern(lib.pattern(i), 0.2, Variation(HIGH)).min_width() for i in lib.ids)
    assert narrowest >= FABRICATION_LIMIT


@pytest.mark.parametrize("w", [LOW, HIGH])
def test_each_member_is_a_valid_symmetric_outline(w: float) -> None:
    lib = enumerate_library(6, 2)
    rng = np.random.default_rng(7)
    for pid in rng.choice(lib.ids, 12, replace=False):
        fp = fillet_pattern(lib.pattern(str(pid)), 0.2, Variation(w))
        report = fp.validate(raise_on_error=False)  # checks closure, simplicity, G1 and n-fold symmetry
        assert report.ok, (pid, w, report)


@pytest.mark.parametrize("bad", [{"bridge_weight": 0.1}, {"bridge_weight": 3.0}, {"bridge_weight": "x"},
                                 {"bridge_weight": float("nan")}, {"neck": 1.0}])
def test_bad_variations_raise_a_fabpat_error(bad: dict[str, object]) -> None:
    with pytest.raises(GeometryError):
        get_pattern("0x0488").fillet(**bad)  # type: ignore[arg-type]
    with pytest.raises(FabpatError):
        Variation.from_values(bad)
    with pytest.raises(GeometryError):
        fillet_pattern(get_pattern("0x0488"), 0.2, bad)  # type: ignore[arg-type]  # not a Variation


@pytest.mark.parametrize("values", ["bridge_weight=0.5", [("bridge_weight", 0.5)], 0.5])
def test_from_values_refuses_what_is_not_a_mapping(values: object) -> None:
    with pytest.raises(GeometryError, match="must be a mapping name → number") as e:
        Variation.from_values(values)  # type: ignore[arg-type]
    assert ("command line's spelling" in str(e.value)) == isinstance(values, str)


def test_a_decimal_is_a_number() -> None:
    from decimal import Decimal

    assert Variation.from_values({"bridge_weight": Decimal("0.5")}) == Variation(0.5)
    with pytest.raises(GeometryError, match="out of range"):
        Variation(Decimal("3"))  # type: ignore[arg-type]


def test_fillet_takes_a_variation_object_or_its_values_not_both() -> None:
    p = get_pattern("0x0488")
    by_object = p.fillet(0.2, Variation(0.5))
    assert by_object.variation == p.fillet(0.2, bridge_weight=0.5).variation == Variation(0.5)
    assert by_object.outline.to_svg_path() == p.fillet(bridge_weight=0.5).outline.to_svg_path()
    with pytest.raises(GeometryError, match="give the variation once"):
        p.fillet(0.2, Variation(0.5), bridge_weight=0.5)
    with pytest.raises(GeometryError, match="must be a fabpat.Variation"):
        p.fillet(0.2, {"bridge_weight": 0.5})  # type: ignore[arg-type]


@pytest.mark.parametrize(("w", "tag"), [(1.0, ""), (0.5, "b0.5"), (2.5, "b2.5"), (1.0000001, "b1.0000001"),
                                        (0.7937005259840998, "b0.7937005259840998")])
def test_tags_never_name_another_member(w: float, tag: str) -> None:
    v = Variation(w)
    assert v.tag() == tag
    assert (v.label() == "") == (tag == "")
    if tag:  # the tag reads back as the very member
        assert float(tag.removeprefix("b")) == w and float(v.label().partition("=")[2]) == w
    from fabpat.assembly.place.placement import PlateType
    from fabpat.design.base import member_token, split_member

    assert split_member(member_token("0x0488", w)) == ("0x0488", w)
    assert PlateType(6, "0x0488", w).label == ("hex 0x0488" + (f" {tag}" if tag else ""))


def test_the_result_names_the_member() -> None:
    r = fabpat.simulate(get_pattern("0x0488").fillet(bridge_weight=0.5), "dome", h=4.0, linear=True)
    assert r.label == "0x0488 b0.5" and r.member == "b0.5"
    assert repr(r).startswith("ScenarioResult('0x0488 b0.5', 'dome'") and r.caption().startswith("0x0488 b0.5 · Dome")


def test_variations_lists_every_parameter_with_its_range() -> None:
    rows = variations()
    assert [r["name"] for r in rows] == ["bridge_weight"]
    assert set(rows[0]) == {"name", "min", "max", "default", "unit", "meaning"}
    assert rows[0]["min"] == LOW and rows[0]["max"] == HIGH and rows[0]["default"] == 1.0
    assert fabpat.variations() == rows


def test_cli_variations_json_and_text() -> None:
    r = CliRunner().invoke(cli, ["variations", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output) == variations()
    r = CliRunner().invoke(cli, ["variations"])
    assert r.exit_code == 0 and r.output.startswith("bridge_weight: 0.25 … 2.5, default 1")


@pytest.mark.parametrize(("args", "words"), [
    (["--variation", "bridge_weight=9"], "out of range: must be in [0.25, 2.5]"),
    (["--variation", "bridge=1"], "unknown variation 'bridge'; valid: bridge_weight"),
    (["--variation", "bridge_weight"], "is not NAME=VALUE"),
    (["--variation", "bridge_weight=abc"], "is not a number; bridge_weight is a number in [0.25, 2.5]"),
    (["--variation", "bridge_weight=1_0"], "is not a number"),  # float() would read 10
    (["--variation", "bridge_weight=\u0660.\u0665"], "is not a number"),  # Arabic-Indic 0.5
    (["--variation", "bridge_weight=inf"], "is not a finite number"),
    (["--variation", "bridge_weight= 1"], "no spaces around the name or the value"),  # was read as 1
    (["--variation", "bridge_weight =1"], "no spaces around the name or the value"),
    (["--variation", "bridge_weight=1", "--variation", "bridge_weight=2"], "given twice"),
])
@pytest.mark.parametrize("command", [["show", "0x0488"], ["export", "0x0488", "--step", "never.step"],
                                     ["simulate", "0x0488"]])
def test_cli_bad_variation_is_one_line_exit_2_and_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         command: list[str], args: list[str], words: str) -> None:
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(cli, [*command, *args])
    assert r.exit_code == 2
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "--variation" in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_cli_show_draws_the_varied_outline(tmp_path: Path) -> None:
    paper = CliRunner().invoke(cli, ["show", "0x0488", "--filleted"]).output
    varied = CliRunner().invoke(cli, ["show", "0x0488", "--variation", "bridge_weight=0.4"]).output
    path = get_pattern("0x0488").fillet(bridge_weight=0.4).outline.to_svg_path()
    assert path in varied and path not in paper


def test_cli_show_with_the_paper_value_given_still_draws_the_filleted_outline() -> None:
    """--variation implies --filleted even when its value is the paper's (1): the user asked for a member."""
    given = CliRunner().invoke(cli, ["show", "0x0488", "--variation", "bridge_weight=1"])
    filleted = CliRunner().invoke(cli, ["show", "0x0488", "--filleted"])
    lattice = CliRunner().invoke(cli, ["show", "0x0488"])
    assert given.exit_code == 0 and given.output == filleted.output != lattice.output


def test_cli_simulate_text_echoes_a_variation_given_at_the_paper_value() -> None:
    args = ["simulate", "0x0488", "--scenario", "cylinder", "--h", "3", "--linear", "--no-progress"]
    given = CliRunner().invoke(cli, [*args, "--variation", "bridge_weight=1"])
    plain = CliRunner().invoke(cli, args)
    assert given.exit_code == 0 and plain.exit_code == 0
    assert given.stdout.strip().endswith(" bridge_weight=1") and "bridge_weight" not in plain.stdout


def test_export_names_and_labels_the_member_and_keeps_its_weight_exact(tmp_path: Path) -> None:
    step, svg = tmp_path / "v.step", tmp_path / "v.svg"
    r = CliRunner().invoke(cli, ["export", "0x0488", "--variation", "bridge_weight=0.4", "--step", str(step),
                                 "--svg", str(svg)])
    assert r.exit_code == 0, r.output
    text = step.read_text()
    assert "RATIONAL_B_SPLINE_CURVE((1.,0.4,1.))" in text  # the bridge arcs, exact
    assert "PRODUCT('fabpat 0x0488 n6 e36mm t2mm w0.2 bridge_weight=0.4'" in " ".join(text.split())
    assert "0x0488 b0.4" in svg.read_text()
    from build123d import import_step

    solid = import_step(str(step)).solids()[0]
    area = get_pattern("0x0488").fillet(bridge_weight=0.4).metrics.area
    assert solid.is_valid and solid.volume == pytest.approx(2.0 * area, rel=1e-6)


def test_cli_simulate_json_carries_the_variation() -> None:
    r = CliRunner().invoke(cli, ["simulate", "0x0488", "--scenario", "cylinder", "--h", "3", "--linear",
                                 "--variation", "bridge_weight=0.5", "--json", "--no-progress"])
    assert r.exit_code == 0, r.output
    row = json.loads(r.stdout)
    paper = json.loads(CliRunner().invoke(cli, ["simulate", "0x0488", "--scenario", "cylinder", "--h", "3",
                                                "--linear", "--json", "--no-progress"]).stdout)
    assert row["bridge_weight"] == 0.5 and paper["bridge_weight"] == 1.0
    assert row["energy"] < paper["energy"]  # wider necks: a stiffer plate stores less energy under the same load


def test_cli_simulate_nonconvergence_names_the_scenario_and_the_member(monkeypatch: pytest.MonkeyPatch) -> None:
    """A scenario the solver cannot finish is one error line that says which scenario of which member."""
    import fabpat.simulation.energies as energies
    from fabpat.errors import SolverError

    def lost(*args: object, **kwargs: object) -> None:
        raise SolverError("Newton–Raphson did not converge at load fraction λ = 0.8604")

    monkeypatch.setattr(energies, "run_converged", lost)  # the command's pipeline solves through it
    r = CliRunner().invoke(cli, ["simulate", "0x0488", "--scenario", "dome", "--h", "2.5", "--no-progress",
                                 "--variation", "bridge_weight=1.6"])
    assert r.exit_code == 2
    lines = r.output.strip().splitlines()
    assert lines == ["fabpat: error: dome scenario of 0x0488 bridge_weight=1.6: Newton–Raphson did not converge "
                     "at load fraction λ = 0.8604"]
