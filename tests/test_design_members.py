"""Family members as strip-design candidates: names, solves, the written design spec."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from fabpat.assembly.spec.load import load_spec
from fabpat.catalog import open_catalog
from fabpat.design.base import load_base, member_token, split_member
from fabpat.design.outputs import design_spec_data, spec_toml
from fabpat.design.search import with_candidates
from fabpat.errors import SpecError
from tests.test_catalog import fake_rows
from tests.test_design import _base
from tests.test_family import family_rows


def test_member_names_round_trip() -> None:
    assert member_token("0x0488", 1.0) == "0x0488" and member_token("0x0488", 0.63) == "0x0488 b0.63"
    assert split_member("0x0488 b0.63") == ("0x0488", 0.63) and split_member("0x0488") == ("0x0488", 1.0)


@pytest.fixture
def family_base(tmp_path: Path) -> Path:
    db = tmp_path / "fam.sqlite"
    with open_catalog(db, write=True) as cat:
        for pid, e in (("0x0488", 20.0), ("0x0508", 30.0)):
            cat.write_rows(fake_rows(pid, 6, {"cylinder": e}))
        # 0x0488's members: 0.4 (wide necks, 2/(1.4) = 1.43 mm) and 2.5 (did not converge)
        cat.write_rows(family_rows("0x0488", "cylinder", {0.4: 15.0, 2.5: None}))
        cat.write_rows(family_rows("0x0508", "cylinder", {0.4: 24.0, 1.6: 40.0}))
        cat.finish()
    return _base(tmp_path, f'catalog = "{db}"')


def test_the_candidates_include_the_catalogs_converged_members(family_base: Path) -> None:
    base = load_base(family_base)
    assert base.energies == {"0x0488": 20.0, "0x0508": 30.0, "0x0488 b0.4": 15.0, "0x0508 b0.4": 24.0,
                             "0x0508 b1.6": 40.0}


def test_variations_false_and_min_width_narrow_the_members(family_base: Path) -> None:
    text = family_base.read_text()
    off = family_base.with_name("off.toml")
    off.write_text(text.replace("[patterns]\n", "[patterns]\nvariations = false\n"))
    assert set(load_base(off).energies) == {"0x0488", "0x0508"}
    wide = family_base.with_name("wide.toml")  # fake rows: the paper's min_width 2.0, members 2/(1 + w)
    wide.write_text(text.replace("[patterns]\n", "[patterns]\nmin_width = 1.0\n"))
    assert set(load_base(wide).energies) == {"0x0488", "0x0508", "0x0488 b0.4", "0x0508 b0.4"}
    bad = family_base.with_name("bad.toml")
    bad.write_text(text.replace("[patterns]\n", "[patterns]\nvariations = 1\n"))
    with pytest.raises(SpecError, match="patterns.variations = 1 must be true or false"):
        load_base(bad)


def test_a_candidate_strip_gets_its_members(family_base: Path) -> None:
    base = load_base(family_base)
    spec, ids = with_candidates(base.spec, ["0x0488 b0.4", "0x0508", "0x0508 b1.6", "0x0488"])
    assert ids == ["0x0488", "0x0508", "0x0508", "0x0488"]
    assert spec.patterns.bridge_weights == (0.4, 1.0, 1.6, 1.0)
    assert with_candidates(base.spec, ["0x0488"] * 4) == (base.spec, ["0x0488"] * 4)


def test_design_toml_names_each_plates_pattern_and_member(family_base: Path, tmp_path: Path) -> None:
    base = load_base(family_base)
    record = {"patterns": {"T1": "0x0488 b0.4", "T2": "0x0508", "T3": "0x0508 b1.6", "T4": "0x0488"},
              "end_shortening": 0.1}
    data = design_spec_data(SimpleNamespace(base=base, record=record))
    assert data["patterns"] == {"tiles": {"T1": "0x0488", "T2": "0x0508", "T3": "0x0508", "T4": "0x0488"},
                                "bridge_weight": {"T1": 0.4, "T3": 1.6}}
    path = tmp_path / "design.toml"
    path.write_text(spec_toml(data))
    spec = load_spec(path)
    assert spec.patterns.bridge_weights == (0.4, 1.0, 1.6, 1.0)
