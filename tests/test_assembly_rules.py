"""Pattern choice from energies: grading rule and similar pairs (no catalog needed)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fabpat.assembly.choose import rules
from fabpat.assembly.choose.choice import candidate_pairs, face_patterns
from fabpat.assembly.spec.load import parse_spec
from fabpat.errors import SpecError
from fabpat.patterns.library import enumerate_library
from tests.test_catalog import fake_catalog


def fake_energies(ids: list[str], lo: float = 1.0, hi: float = 1000.0) -> dict[str, float]:
    """Energies spread geometrically from lo to hi over the IDs (a deterministic stand-in catalog)."""
    n = len(ids)
    return {pid: lo * (hi / lo) ** (k / (n - 1)) for k, pid in enumerate(ids)}


def test_graded_is_ordered_stiff_to_soft_and_well_separated() -> None:
    ids = [f"0x{k:04x}" for k in range(1, 201)]
    e = fake_energies(ids)
    picks = rules.graded(e, 5)
    assert len(set(picks)) == 5
    energies = [e[p] for p in picks]
    assert energies == sorted(energies)  # stiff (small energy) first
    assert rules.separation(e, picks) > 3.0  # ~ (1000 · 0.9)^(1/4) over the trimmed range


def test_graded_refuses_crowded_catalogs() -> None:
    e = {f"0x{k:04x}": 10.0 + 0.01 * k for k in range(20)}
    with pytest.raises(SpecError, match="too close"):
        rules.graded(e, 5)
    with pytest.raises(SpecError, match="fewer than"):
        rules.graded({"0x0001": 1.0, "0x0002": 2.0}, 5)


def test_graded_ignores_non_finite_energies() -> None:
    e = fake_energies([f"0x{k:04x}" for k in range(1, 51)])
    e["0xdead"] = math.inf
    e["0xbeef"] = float("nan")
    assert not {"0xdead", "0xbeef"} & set(rules.graded(e, 4))


def test_similar_pair_compares_each_polygons_own_energies() -> None:
    hexa = {"0x0001": 1.0, "0x0002": 5.0, "0x0003": 10.0, "0x0004": 50.0, "0x0005": 100.0}
    penta = {"0x0001": 9.0, "0x0003": 10.0, "0x0005": 30.0}
    # median hexagon 0x0003 (10); the nearest *pentagon* energy of another ID is 0x0001's 9, although the
    # hexagon energies alone would have paired it with 0x0002 (5) or 0x0004 (50)
    assert rules.similar_pair(hexa, penta) == ("0x0003", "0x0001")
    assert rules.similar_pairs(hexa, penta, 1) == [("0x0003", "0x0001")]


@pytest.mark.parametrize("pentagon", [None, {}, {"0x0001": math.inf, "0x0002": -5.0}])
def test_similar_pair_without_pentagon_energies_is_refused(pentagon: dict[str, float] | None) -> None:
    """No silent fallback to comparing hexagon energies with hexagon energies."""
    hexa = {"0x0001": 1.0, "0x0002": 5.0, "0x0003": 10.0}
    for call in (lambda: rules.similar_pair(hexa, pentagon), lambda: rules.similar_pairs(hexa, pentagon, 2)):
        with pytest.raises(SpecError, match="pentagon energ"):
            call()  # type: ignore[no-untyped-call]


def test_strip_grading_through_the_spec() -> None:
    ids = list(enumerate_library(6, 2).ids)
    e = fake_energies(ids)
    spec = parse_spec({
        "tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 2, "columns": 15},
        "patterns": {"rule": "graded", "scenario": "cylinder", "count": 5, "group_columns": 3},
        "sheet": {"width": 600.0, "height": 400.0},
    })
    faces = face_patterns(spec, lambda sides: e)
    assert len(faces) == 30
    columns = [faces[2 * c] for c in range(15)]  # faces are column-major, two rows
    assert all(faces[2 * c] == faces[2 * c + 1] for c in range(15))
    groups = [columns[3 * g] for g in range(5)]
    assert len(set(groups)) == 5 and all(columns[3 * g + k] == groups[g] for g in range(5) for k in range(3))
    assert [e[g] for g in groups] == sorted(e[g] for g in groups)  # stiff end at column 0


SPHERE = {"tiling": {"kind": "truncated-icosahedron", "edge": 36.0}, "patterns": {"rule": "similar-energy"},
          "sheet": {"width": 600.0, "height": 400.0}}


def test_sphere_similar_energy_through_the_spec() -> None:
    ids = list(enumerate_library(6, 2).ids)
    hexa = fake_energies(ids)
    penta = {pid: 1.7 * e for pid, e in hexa.items()}  # every pentagon plate 1.7× softer than its hexagon
    faces = face_patterns(parse_spec(SPHERE), lambda sides: hexa if sides == 6 else penta)
    assert len(set(faces[:20])) == 1 and len(set(faces[20:])) == 1 and faces[0] != faces[20]
    hid, pid = faces[0], faces[20]
    # the pentagon chosen is the one whose own (pentagon) energy is nearest the hexagon's energy
    assert pid == min((k for k in penta if k != hid), key=lambda k: abs(math.log(penta[k] / hexa[hid])))
    assert penta[pid] == pytest.approx(hexa[hid], rel=0.02) and hexa[pid] < hexa[hid]


HEX = {"0x0488": {"dome": 100.0}, "0x0508": {"dome": 200.0}, "0x0588": {"dome": 300.0}}
# pentagon plates: 0x0488's is the one of similar energy to the median hexagon (0x0508, 200 N·mm); by the
# hexagon energies it would have been 0x0588 (300 against 100)
PENT = {"0x0488": {"dome": 199.0}, "0x0588": {"dome": 600.0}, "0x0688": {"dome": 900.0}}


def _sphere_spec(tmp_path: Path, db: Path, thickness: float, rule: str = "similar-energy"):  # type: ignore[no-untyped-def]
    patterns = {"rule": rule, "catalog": str(db), **({"candidates": 2} if rule == "roundest" else {})}
    return parse_spec({**SPHERE, "patterns": patterns, "plates": {"thickness": thickness}}, str(tmp_path / "s.toml"))


@pytest.mark.parametrize("thickness", [1.0, 2.0])
def test_sphere_rule_reads_the_pentagons_own_catalog_rows(tmp_path: Path, thickness: float) -> None:
    """A catalog at the default set-up (2 mm) with hexagon and pentagon rows: the pair compares the hexagon's
    hexagon energy with the pentagon's pentagon energy, also for 1 mm plates (the shipped sphere's), where
    the pentagons used to be looked up at 1 mm only and then replaced by hexagon energies."""
    db = fake_catalog(tmp_path / "c.sqlite", {6: HEX, 5: PENT})
    spec = _sphere_spec(tmp_path, db, thickness)
    faces = face_patterns(spec)
    assert (faces[0], faces[20]) == ("0x0508", "0x0488")
    assert candidate_pairs(_sphere_spec(tmp_path, db, thickness, "roundest"))[0] == ("0x0508", "0x0488")


def test_a_catalog_without_pentagons_refuses_the_rule_naming_the_sweep(tmp_path: Path) -> None:
    db = fake_catalog(tmp_path / "c.sqlite", {6: HEX})
    for rule in ("similar-energy", "roundest"):
        spec = _sphere_spec(tmp_path, db, 1.0, rule)
        with pytest.raises(SpecError) as err:
            face_patterns(spec) if rule == "similar-energy" else candidate_pairs(spec)
        msg = str(err.value)
        assert "\n" not in msg and "no catalog energies for pentagons (sides = 5)" in msg, msg
        assert f"run `fabpat sweep --sides 5 --db {db}`" in msg, msg


def test_a_strip_ranks_its_hexagons_by_hexagon_rows_only(tmp_path: Path) -> None:
    """Pentagon rows in the catalog never enter a hexagon strip's grading."""
    hexa = {f"0x{k:04x}": {"cylinder": 10.0 * 2.0**k} for k in range(1, 7)}
    penta = {"0x0fff": {"cylinder": 1e-3}, "0x0ffe": {"cylinder": 1e6}}  # far outside the hexagons' range
    db = fake_catalog(tmp_path / "c.sqlite", {6: hexa, 5: penta})
    spec = parse_spec({"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
                       "patterns": {"rule": "graded", "count": 3, "catalog": str(db)},
                       "sheet": {"width": 600.0, "height": 400.0}}, str(tmp_path / "s.toml"))
    faces = face_patterns(spec)
    assert set(faces) <= set(hexa) and len(set(faces)) == 3


@pytest.mark.parametrize("bad", [math.inf, -5.0, "abc", 0.0])
def test_a_poisoned_energy_is_refused_not_used(tmp_path: Path, bad: object) -> None:
    db = fake_catalog(tmp_path / "c.sqlite", {6: {**HEX, "0x0688": {"dome": bad}}, 5: PENT})
    with pytest.raises(SpecError) as err:
        face_patterns(_sphere_spec(tmp_path, db, 2.0))
    msg = str(err.value)
    assert "\n" not in msg and str(db) in msg and "pattern 0x0688, scenario dome" in msg and repr(bad) in msg, msg


def test_a_poisoned_catalog_in_assemble_is_one_line(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from fabpat.cli import cli

    fake_catalog(tmp_path / "c.sqlite", {6: {**HEX, "0x0688": {"dome": -5.0}}, 5: PENT})
    spec = tmp_path / "s.toml"  # its patterns.catalog, c.sqlite, is next to it
    spec.write_text('[tiling]\nkind = "truncated-icosahedron"\nedge = 36.0\n[patterns]\nrule = "similar-energy"\n'
                    'catalog = "c.sqlite"\n[sheet]\nwidth = 600.0\nheight = 400.0\n')
    res = CliRunner().invoke(cli, ["assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress"])
    assert res.exit_code == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith("fabpat: error:") and "energy = -5.0" in res.stderr and "Traceback" not in res.output
    assert not (tmp_path / "kit").exists()
