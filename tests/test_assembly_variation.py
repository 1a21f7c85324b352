"""Family members in assembly specs: ``[patterns] bridge_weight`` for every plate or per plate label."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from fabpat.assembly.kit.build import plan
from fabpat.assembly.spec.load import load_spec
from fabpat.errors import SpecError
from fabpat.patterns.library import get_pattern
from tests.helpers import invoke

SMALL = Path(__file__).parent.parent / "assemblies" / "test-small.toml"


def _spec(tmp_path: Path, line: str) -> Path:
    text = SMALL.read_text().replace("group_columns = 1", f"group_columns = 1\n{line}", 1)
    path = tmp_path / "v.toml"
    path.write_text(text)
    return path


def test_one_number_sets_every_plate_and_a_table_names_plates(tmp_path: Path) -> None:
    every = load_spec(_spec(tmp_path, "bridge_weight = 0.5"))
    assert every.patterns.bridge_weights == (0.5, 0.5, 0.5)
    some = load_spec(_spec(tmp_path, "bridge_weight = {T1 = 0.5, T3 = 2.0}"))
    assert some.patterns.bridge_weights == (0.5, 1.0, 2.0)
    assert load_spec(SMALL).patterns.bridge_weight_of(0) == 1.0


@pytest.mark.parametrize(("line", "words"), [
    ("bridge_weight = {T9 = 0.5}", "patterns.bridge_weight.T9 is not a plate of this honeycomb-strip (labels T1 … T3)"),
    ("bridge_weight = 3.0", "patterns.bridge_weight = 3 is out of range: must be in [0.25, 2.5]"),
    ("bridge_weight = {T2 = 0.1}", "patterns.bridge_weight.T2 = 0.1 is out of range"),
    ("bridge_weight = \"wide\"", "patterns.bridge_weight must be a number (every plate), a table"),
    ("bridge_weight = \"graded\"", "write patterns.rule = 'graded' and patterns.bridge_weight = \"rule\""),
])
def test_bad_bridge_weights_are_one_line(tmp_path: Path, line: str, words: str) -> None:
    with pytest.raises(SpecError, match=None) as e:
        load_spec(_spec(tmp_path, line))
    assert words in str(e.value) and "\n" not in str(e.value)


def test_each_member_is_its_own_plate_type_with_its_own_outline(tmp_path: Path) -> None:
    spec = load_spec(_spec(tmp_path, "bridge_weight = {T1 = 0.5, T3 = 2.0}"))
    assembly, filleted = plan(spec)
    labels = [p.type.label for p in assembly.plates]
    assert labels == ["hex 0x0488 b0.5", "hex 0x0508", "hex 0x0588 b2"]
    for pt, fp in filleted.items():
        direct = get_pattern(pt.pattern_id).fillet(bridge_weight=pt.bridge_weight)
        assert fp.outline.to_svg_path() == direct.outline.to_svg_path()
        assert fp.metrics.area == pytest.approx(direct.metrics.area, rel=1e-12)


def test_the_kit_names_members_and_does_not_borrow_the_papers_energies(tmp_path: Path) -> None:
    spec = _spec(tmp_path, "bridge_weight = {T1 = 0.5}")
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-predict")
    assert res.returncode == 0, res.stderr
    with (tmp_path / "kit" / "bom.csv").open() as f:
        rows = {r["part"]: r for r in csv.DictReader(f)}
    assert {"hex 0x0488 b0.5", "hex 0x0508", "hex 0x0588"} <= set(rows)
    member, paper = rows["hex 0x0488 b0.5"], rows["hex 0x0508"]
    assert paper["energy_cylinder_Nmm"] != ""  # the catalog's own energy of the paper's member
    # the built-in catalog holds no family rows for it: blank, not the paper member's number
    manifest = json.loads((tmp_path / "kit" / "manifest.json").read_text())
    rec = next(r for r in manifest["patterns"] if r["part"] == "hex 0x0488 b0.5")
    assert rec["bridge_weight"] == 0.5
    if member["energy_cylinder_Nmm"] == "":
        assert "outside the catalog's family" in rec["note"]
    else:  # a catalog with the family: the interpolated energy, below the paper's (wider necks: stiffer)
        from fabpat.catalog import energies, open_catalog

        with open_catalog() as cat:
            paper_0488 = energies(cat, "cylinder")["0x0488"]
        assert "interpolated" in rec["note"]
        assert float(member["energy_cylinder_Nmm"]) < paper_0488
    assert (tmp_path / "kit" / "parts" / "plate-hex-0x0488-b0.5.stl").is_file()


# -- the rules choose members: bridge_weight = "rule" ----------------------------------------------------


class PowerCurve:
    """A hand-made family curve E(w) = e1 · w^p over [lo, hi] (what fabpat.catalog.family.FamilyCurve offers)."""

    def __init__(self, e1: float, p: float, lo: float = 0.25, hi: float = 2.5) -> None:
        self.e1, self.p, self.range = e1, p, (lo, hi)

    def energy(self, w: float) -> float:
        return self.e1 * w**self.p

    def members_for(self, e: float) -> list[float]:
        w = (e / self.e1) ** (1 / self.p)
        return [w] if self.range[0] <= w <= self.range[1] else []


def test_nearest_member_hits_the_target_or_stops_at_the_family_end() -> None:
    from fabpat.assembly.choose.rules import nearest_member

    c = PowerCurve(20.0, 0.5)
    assert nearest_member(c, 25.0) == pytest.approx(1.5625)  # (25/20)^2
    assert nearest_member(c, 1000.0) == 2.5 and nearest_member(c, 1.0) == 0.25


def test_graded_targets_are_log_spaced_between_the_trimmed_extremes() -> None:
    from fabpat.assembly.choose.rules import graded, graded_targets

    energies = {f"0x{k:04x}": 10.0 * 1.1**k for k in range(40)}  # 40 patterns: 2 trimmed at each end
    t = graded_targets(energies, 5)
    assert t[0] == pytest.approx(10 * 1.1**2) and t[-1] == pytest.approx(10 * 1.1**37)
    ratios = [b / a for a, b in zip(t, t[1:], strict=False)]
    assert ratios == pytest.approx([ratios[0]] * 4)
    assert len(graded(energies, 5)) == 5


def _rule_spec(tmp_path: Path, extra: str) -> Path:
    text = SMALL.read_text().replace('groups = ["0x0488", "0x0508", "0x0588"]',
                                     f'rule = "graded"\ncount = 3\n{extra}', 1)
    path = tmp_path / "r.toml"
    path.write_text(text)
    return path


def test_graded_rule_with_members_hits_every_target(tmp_path: Path) -> None:
    from fabpat.assembly.choose.choice import face_patterns, with_members
    from fabpat.assembly.choose.rules import graded_targets

    spec = load_spec(_rule_spec(tmp_path, 'bridge_weight = "rule"'))
    assert spec.patterns.member_rule and spec.patterns.bridge_weights == ()
    energies = {"0x0488": 10.0, "0x0508": 13.0, "0x0588": 40.0, "0x0688": 41.0}
    curves = {pid: PowerCurve(e, 0.8) for pid, e in energies.items()}
    resolved = with_members(spec, lambda n: energies, lambda n: curves)
    ids = face_patterns(resolved)
    targets = graded_targets(energies, 3)  # 10, ≈ 20.2, 41: without members the middle one gets 13 (0x0508)
    got = [curves[pid].energy(w) for pid, w in zip(ids, resolved.patterns.bridge_weights, strict=True)]
    assert got == pytest.approx(targets, rel=1e-12)
    # 20.2 is reached by 0x0508 at w = (20.2/13)^1.25 ≈ 1.74 and by 0x0588 at ≈ 0.43: the first is nearer 1
    assert list(resolved.patterns.groups) == ["0x0488", "0x0508", "0x0688"]
    assert resolved.patterns.bridge_weights[1] == pytest.approx((targets[1] / 13.0) ** 1.25)
    assert with_members(load_spec(SMALL)) == load_spec(SMALL)  # other specs unchanged


def test_similar_energy_tunes_the_pentagon_to_the_hexagon() -> None:
    import dataclasses

    from fabpat.assembly.choose.choice import face_patterns, with_members

    base = load_spec(Path(__file__).parent.parent / "assemblies" / "truncated-icosahedron.toml")
    spec = dataclasses.replace(base, patterns=dataclasses.replace(base.patterns, rule="similar-energy",
                                                                  member_rule=True))
    hexagon = {"0x0488": 100.0, "0x0508": 150.0, "0x0588": 220.0}
    pentagon = {"0x0488": 90.0, "0x0508": 140.0, "0x0588": 200.0}
    get = lambda n: hexagon if n == 6 else pentagon  # noqa: E731
    curves = {(5, pid): PowerCurve(e, 0.3) for pid, e in pentagon.items()}
    resolved = with_members(spec, get, lambda n: {pid: curves.get((n, pid), PowerCurve(hexagon[pid], 0.3, 1, 1))
                                                  for pid in hexagon})
    ids = face_patterns(resolved, get)
    (hid,) = {i for i, n in zip(ids, base_sides(resolved), strict=True) if n == 6}
    (pid,) = {i for i, n in zip(ids, base_sides(resolved), strict=True) if n == 5}
    w = {n: {x for x, m in zip(resolved.patterns.bridge_weights, base_sides(resolved), strict=True) if m == n}
         for n in (5, 6)}
    assert w[6] == {1.0}
    (wp,) = w[5]
    assert curves[(5, pid)].energy(wp) == pytest.approx(hexagon[hid], rel=1e-12)


def base_sides(spec: object) -> list[int]:
    from fabpat.assembly.place.placement import build_tiling

    return [len(f) for f in build_tiling(spec).faces]  # type: ignore[arg-type]


def test_bridge_weight_rule_needs_a_rule_that_can_use_it(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match='bridge_weight = "rule" goes with patterns.rule'):
        load_spec(_spec(tmp_path, 'bridge_weight = "rule"'))


def test_a_member_beyond_the_converged_family_says_so_and_not_sweep_again(tmp_path: Path) -> None:
    """0x0488's Dome buckles beyond bridge_weight 1 in the built-in catalog's family: the note says the
    family converged only up to there, and does not send the user to a sweep that would add nothing."""
    spec = _spec(tmp_path, "bridge_weight = {T1 = 2.5}")
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-predict")
    assert res.returncode == 0, res.stderr
    manifest = json.loads((tmp_path / "kit" / "manifest.json").read_text())
    note = next(r for r in manifest["patterns"] if r["part"] == "hex 0x0488 b2.5")["note"]
    assert "dome: converged only over 0.25 … 1" in note and "sweep" not in note
