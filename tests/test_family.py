"""The catalog over the family: the sweep's family rows, an old catalog without them, the interpolant."""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import pytest
from click.testing import CliRunner

from fabpat.catalog import CatalogError, open_catalog
from fabpat.catalog.family import family_curves, family_energy, match_energy
from fabpat.catalog.sweep import FAMILY_SAMPLES, SweepSetup, result_hash, run_sweep, simulate_pattern
from fabpat.cli import cli
from tests.test_catalog import fake_rows

KEY = {"sides": 6, "depth": 2, "edge": 36.0, "thickness": 2.0, "weight": 0.2}


def power_law(w: float, e1: float, p: float) -> float:
    """A family whose energy is e1 · w^p: straight in (ln w, ln E), so the interpolant must be exact."""
    return e1 * w**p


def family_rows(pid: str, scenario: str, energy: dict[float, float | None]) -> list[dict[str, object]]:
    """Hand-made family rows (None: a member that did not converge)."""
    return [{"table": "family", "id": pid, **KEY, "scenario": scenario, "bridge_weight": w, "E": 1000.0,
             "nu": 0.35, "h": 2.5, "nonlinear": 1, "energy": e, "max_displacement": 3.0 if e else None,
             "converged": int(e is not None), "solver_version": "test", "input_hash": "x", "computed_at": "now",
             "min_width": 2.0 / (1 + w), "filleted_area": 1000.0, "error": None if e else "SolverError: buckled"}
            for w, e in energy.items()]


@pytest.fixture
def db(tmp_path: Path) -> Path:
    path = tmp_path / "family.sqlite"
    with open_catalog(path, write=True) as cat:
        cat.write_rows(fake_rows("0xaaaa", 6, {"cylinder": 20.0}))
        cat.write_rows(family_rows("0xaaaa", "cylinder", {w: power_law(w, 20.0, 0.3) for w in FAMILY_SAMPLES}))
        cat.write_rows(fake_rows("0xbbbb", 6, {"cylinder": 30.0}))
        # a soft member: 2.5 buckled, so the curve ends at 1.6
        cat.write_rows(family_rows("0xbbbb", "cylinder", {**{w: power_law(w, 30.0, 0.5) for w in FAMILY_SAMPLES[:-1]},
                                                           2.5: None}))
        cat.write_rows(fake_rows("0xcccc", 6, {"cylinder": 25.0}))  # no family rows: a one-member curve
        cat.finish()
    return path


@pytest.mark.parametrize("w", [0.25, 0.3, 0.5, 0.77, 1.0, 1.3, 2.1, 2.5])
def test_the_interpolant_is_exact_for_a_power_law(db: Path, w: float) -> None:
    assert family_energy("0xaaaa", "cylinder", w, db=db) == pytest.approx(power_law(w, 20.0, 0.3), rel=1e-12)


def test_a_member_that_did_not_converge_ends_the_curve(db: Path) -> None:
    curves = family_curves("cylinder", db=db)
    assert curves["0xbbbb"].range == (0.25, 1.6)
    assert curves["0xcccc"].range == (1.0, 1.0) and curves["0xcccc"].energy(1.0) == 25.0
    with pytest.raises(CatalogError, match=r"covers bridge_weight 0.25 … 1.6, not 2"):
        curves["0xbbbb"].energy(2.0)
    with pytest.raises(CatalogError, match="0xdddd"):
        family_energy("0xdddd", "cylinder", 1.0, db=db)


def test_match_energy_finds_every_pattern_and_member_closest_to_the_paper_first(db: Path) -> None:
    target = 24.0  # 0xaaaa at w = 1.2^(1/0.3), 0xbbbb at w = 0.8^2, 0xcccc only at 25
    matches = match_energy("cylinder", target, db=db)
    got = {m.pattern_id: m.bridge_weight for m in matches}
    assert got == pytest.approx({"0xaaaa": 1.2 ** (1 / 0.3), "0xbbbb": 0.8**2}, rel=1e-9)
    assert [m.pattern_id for m in matches] == sorted(got, key=lambda p: abs(math.log(got[p])))
    assert all(m.energy == target for m in matches)
    wide = match_energy("cylinder", target, db=db, min_width=1.2)  # 2/(1 + w) ≥ 1.2 ⇒ w ≤ 0.667
    assert [m.pattern_id for m in wide] == ["0xbbbb"]
    assert match_energy("cylinder", 1e6, db=db) == []
    with pytest.raises(CatalogError, match="positive"):
        match_energy("cylinder", -1.0, db=db)


def test_sweep_stores_a_member_in_the_family_table_and_resumes(tmp_path: Path) -> None:
    db = tmp_path / "c.sqlite"
    setup = SweepSetup(bridge_weight=0.4, h=3.0, extrapolate=False, scenarios=("cylinder",))
    first = run_sweep(db, ["0x0488"], setup, workers=1)
    again = run_sweep(db, ["0x0488"], setup, workers=1)
    assert (first.computed, again.computed, again.skipped) == (1, 0, 1)
    with open_catalog(db) as cat:
        (row,) = cat.family()
        assert cat.results() == [] and cat.pattern_rows() == []  # the paper's rows are not touched
    assert row["bridge_weight"] == 0.4 and row["converged"] == 1
    assert row["min_width"] == pytest.approx(1.9486 * 2 / 1.4, abs=0.01)  # the member's own necks
    paper = simulate_pattern("0x0488", 6, 2, 36.0, 2.0, 0.2, 1000.0, 0.35, 3.0, ["cylinder"])
    assert row["energy"] < paper[1]["energy"]  # wider necks: stiffer, less energy under the same load
    assert row["input_hash"] != paper[1]["input_hash"]
    # the paper's member hashes as before families existed (the built-in catalog stays valid)
    args = ("0x0488", 6, 2, 36.0, 2.0, 0.2, 1000.0, 0.35, 3.0, "cylinder", "v")
    assert result_hash(*args) == result_hash(*args, None, 1.0) != result_hash(*args, None, 0.4)


def test_a_catalog_made_before_the_family_table_reads_and_gains_it(tmp_path: Path) -> None:
    db = tmp_path / "old.sqlite"
    with open_catalog(db, write=True) as cat:
        cat.write_rows(fake_rows("0xaaaa", 6, {"cylinder": 20.0}))
        cat.finish()
    with sqlite3.connect(db) as conn:
        conn.execute("DROP TABLE family")
    with open_catalog(db) as cat:
        assert not cat.has_family() and cat.family() == []
    assert family_curves("cylinder", db=db)["0xaaaa"].range == (1.0, 1.0)
    with open_catalog(db, write=True) as cat:
        assert cat.has_family()


def test_cli_sweep_family_and_variation_are_exclusive(tmp_path: Path) -> None:
    r = CliRunner().invoke(cli, ["sweep", "--db", str(tmp_path / "x.sqlite"), "--family",
                                 "--variation", "bridge_weight=2"])
    assert r.exit_code == 2 and "--family" in r.output and not (tmp_path / "x.sqlite").exists()


def test_refinements_bisect_where_the_curve_bends_or_buckles(tmp_path: Path) -> None:
    from fabpat.catalog.sweep import refinements

    db = tmp_path / "r.sqlite"
    with open_catalog(db, write=True) as cat:
        for pid in ("0xaaaa", "0xbbbb", "0xcccc"):
            cat.write_rows(fake_rows(pid, 6, {"dome": 100.0}))
        # a power law: smooth, nothing to refine
        cat.write_rows(family_rows("0xaaaa", "dome", {w: power_law(w, 100.0, 0.3) for w in FAMILY_SAMPLES}))
        # a kink at w = 1: slope 0.1 below, 1.2 above (0x1908's Dome curve, roughly)
        cat.write_rows(family_rows("0xbbbb", "dome", {w: 100.0 * w ** (0.1 if w < 1 else 1.2) for w in FAMILY_SAMPLES}))
        # buckles after 1.6: the last interval is refined even though it is straight
        cat.write_rows(family_rows("0xcccc", "dome", {**{w: power_law(w, 100.0, 0.3) for w in FAMILY_SAMPLES[:-1]},
                                                       2.5: None}))
        cat.finish()
    todo = refinements(db, ["0xaaaa", "0xbbbb", "0xcccc"], SweepSetup(E=1000.0, nu=0.35))
    assert todo == {0.7937: ["0xbbbb"], 1.265: ["0xbbbb", "0xcccc"]}


@pytest.mark.parametrize("bad", ["abc", float("nan"), -1.0, 3.0, None])
def test_family_energy_refuses_a_bad_member_as_a_range_error(bad: object) -> None:
    """A value that is no member at all is the caller's mistake (RangeError naming the range), not a gap
    in the catalog (CatalogError) and never a raw ValueError."""
    from fabpat.catalog.family import family_energy
    from fabpat.errors import RangeError

    with pytest.raises(RangeError, match=r"bridge_weight .*\[0\.25, 2\.5\]"):
        family_energy("0x0488", "dome", bad)  # type: ignore[arg-type]
