"""rule = "roundest" with bridge_weight = "rule": the catalog's swept family members join the candidate
pairs (fabpat.assembly.choose.members, as in fabpat design), a pair is always two patterns, a polygon without family
rows
is named, and the closure is given the member itself. No solve: the closure is replaced where it is used."""

from __future__ import annotations

import tomllib
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from fabpat.assembly.choose.choice import candidate_pairs, with_members
from fabpat.assembly.spec.load import parse_spec
from fabpat.catalog import open_catalog
from fabpat.errors import SpecError
from tests.test_catalog import fake_rows
from tests.test_family import family_rows

ROOT = Path(__file__).resolve().parents[1]
SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
# Dome energies (N·mm). The median hexagon is 0x0508 (200) and its pentagon partner 0x0488 (199); the
# hexagon members 0x0488 b1.6 (150) and 0x0588 b0.4 (240) come between the patterns
HEX = {"0x0488": 100.0, "0x0508": 200.0, "0x0588": 300.0}
PENT = {"0x0488": 199.0, "0x0588": 600.0, "0x0688": 900.0}
HEX_MEMBERS = {"0x0488": {1.6: 150.0}, "0x0588": {0.4: 240.0}}


def _catalog(path: Path, pentagon_members: bool) -> Path:
    with open_catalog(path, write=True) as cat:
        for sides, table in ((6, HEX), (5, PENT)):
            for pid, e in table.items():
                cat.write_rows(fake_rows(pid, sides, {"dome": e}))
        for pid, members in HEX_MEMBERS.items():
            cat.write_rows(family_rows(pid, "dome", members))
        if pentagon_members:  # 0x0688's pentagon at 0.25: 245 N·mm, the partner of 0x0588 b0.4 (240)
            cat.write_rows([{**r, "sides": 5} for r in family_rows("0x0688", "dome", {0.25: 245.0})])
        cat.finish()
    return path


def _spec(tmp_path: Path, pentagon_members: bool = False, members: bool = True) -> Any:
    db = _catalog(tmp_path / f"c{int(pentagon_members)}.sqlite", pentagon_members)
    data = tomllib.loads(SPHERE.read_text(encoding="utf-8"))
    data["patterns"] = {"rule": "roundest", "scenario": "dome", "candidates": 2, "catalog": str(db),
                        **({"bridge_weight": "rule"} if members else {})}
    return parse_spec(data, str(tmp_path / "s.toml"))


def test_the_pairs_take_members_and_name_the_polygon_without_family_rows(tmp_path: Path) -> None:
    """By hand: the 4 hexagon entries nearest the median 200 are 0x0508, 0x0588 b0.4 (240), 0x0488 b1.6
    (150) and 0x0588 (300); their partners 0x0488 (ratio 1.005), 0x0488 (1.21), 0x0588 (4: not 0x0488's own
    pentagon, 199) and 0x0488 (1.51). Without members the second pair is 0x0588 / 0x0488 (1.51)."""
    assert candidate_pairs(_spec(tmp_path, members=False)) == [("0x0508", "0x0488"), ("0x0588", "0x0488")]
    notes: list[str] = []
    spec = _spec(tmp_path)
    assert candidate_pairs(spec, notes=notes) == [("0x0508", "0x0488"), ("0x0588 b0.4", "0x0488")]
    assert len(notes) == 1 and "no family rows for 5-sided plates" in notes[0] and "--sides 5 --family" in notes[0]
    assert with_members(spec) is spec  # the closures choose the members, not the energy match


def test_pentagon_members_are_used_when_the_catalog_has_them(tmp_path: Path) -> None:
    notes: list[str] = []
    pairs = candidate_pairs(_spec(tmp_path, pentagon_members=True), notes=notes)
    assert pairs == [("0x0508", "0x0488"), ("0x0588 b0.4", "0x0688 b0.25")] and notes == []


def test_roundest_keeps_the_rounder_member_pair_and_closes_the_member_itself(tmp_path: Path,
                                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    import fabpat.assembly.solve.predict as predict
    from fabpat.assembly.place.placement import build_tiling

    spec = _spec(tmp_path)
    faces = [len(f) for f in build_tiling(spec).faces]
    hexagon = faces.index(6)
    given: list[tuple[str, float]] = []

    def close(s: Any, ids: list[str], h: float, tell: Any = None) -> Any:
        w = s.patterns.bridge_weight_of(hexagon)
        given.append((ids[hexagon], w))
        rms = 0.002 if (ids[hexagon], w) == ("0x0588", 0.4) else 0.005
        return SimpleNamespace(radius=90.0, sphericity_rms=rms, sphericity_max=2 * rms, peak_strain=0.01,
                               over_limit=[])

    monkeypatch.setattr(predict, "close", close)
    fitted: list[tuple[float, ...]] = []
    names, run, _, tried = predict.choose_roundest(spec, candidate_pairs(spec), faces, 3.0, False,
                                                   lambda s, ids: fitted.append(s.patterns.bridge_weights))
    assert given == [("0x0508", 1.0), ("0x0588", 0.4)]
    assert run.sphericity_rms == 0.002 and [t["chosen"] for t in tried] == [False, True]
    assert tried[1]["hexagon"] == "0x0588 b0.4" and tried[1]["pentagon"] == "0x0488"
    assert names[hexagon] == "0x0588 b0.4" and names[faces.index(5)] == "0x0488"
    assert fitted[0] == () and fitted[1] == tuple(0.4 if n == 6 else 1.0 for n in faces)


def test_bridge_weight_names_roundest_only_as_rule(tmp_path: Path) -> None:
    data = tomllib.loads(SPHERE.read_text(encoding="utf-8"))
    data["patterns"] = {"rule": "roundest", "scenario": "dome", "bridge_weight": "roundest"}
    with pytest.raises(SpecError, match='patterns.rule = .roundest. and patterns.bridge_weight = "rule"'):
        parse_spec(data, "s.toml")
