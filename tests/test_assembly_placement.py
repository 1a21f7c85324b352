"""``fabpat.assembly.place.placement.check_geometry``: the geometric bounds a spec's keys must meet (sleeve depth,
edge, plate weight), named up front with the keys they come from, before any plate is built."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabpat.assembly.place.placement import check_geometry
from fabpat.assembly.spec.load import load_spec, parse_spec
from fabpat.errors import SpecError
from tests.helpers import FLAT_SPHERE as SPHERE
from tests.helpers import ROOT, edited, one_line_error, strip
from tests.helpers import SMALL_SPEC as SMALL
from tests.helpers import invoke_result as invoke


@pytest.mark.parametrize("changes, words", [
    ({"depth": "0.001"}, ("sleeve.depth = 0.001", "must be ≥ 1.44 mm", "sleeve.wall")),
    # values inside the keys' physical ranges (fabpat.validate: edge ≥ 1 mm, weight ≤ 10) that break
    # the geometric bounds; 0.001 and 1e6 are refused by those ranges first (tests/test_assembly_spec.py)
    ({"edge": "2"}, ("tiling.edge = 2", "must be ≥ 3.8 mm", "sleeve.margin")),
    ({"weight": "5", "mesh_tolerance": "0.1"}, ("plates.weight = 5", "must be in (0, 3.5]", "output.mesh_tolerance")),
])
def test_downstream_errors_are_named_up_front(tmp_path: Path, changes: dict[str, str], words: tuple[str, ...]) -> None:
    spec = edited(SPHERE, tmp_path / "s.toml", **changes)
    with pytest.raises(SpecError) as err:
        check_geometry(load_spec(spec))
    for w in words:
        assert w in str(err.value)
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress")
    one_line_error(res, *words)
    assert "intersect" not in res.stderr and "manifold" not in res.stderr and "midpoint" not in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_ranges_follow_the_geometry() -> None:
    """The bounds move with the keys they come from, and the shipped values lie inside them."""
    for path in (SPHERE, SMALL, ROOT / "assemblies" / "graded-strip.toml"):
        check_geometry(load_spec(path))
    # a flat strip: both plates of a joint have one setback, so the least depth is the wall
    data = strip(pattern="0x0488")
    data["sleeve"] = {"depth": 1.19, "wall": 1.2}
    with pytest.raises(SpecError, match=r"sleeve.depth = 1.19 mm must be ≥ 1.2 mm"):
        check_geometry(parse_spec(data, "s.toml"))
    data["sleeve"] = {"depth": 1.2, "wall": 1.2}
    check_geometry(parse_spec(data, "s.toml"))
    data["sleeve"] = {"margin": 10.0}  # a longer sleeve needs a longer edge: (10 + 2.4) / (1 − 1/9.6)
    data["tiling"]["edge"] = 13.8
    with pytest.raises(SpecError, match=r"tiling.edge = 13.8 mm must be ≥ 13.8[0-9]? mm"):
        check_geometry(parse_spec(data, "s.toml"))
    data["sleeve"] = {}
    data["tiling"]["edge"] = 36.0
    data["output"] = {"mesh_tolerance": 0.05}  # coarser STL: a shorter interface is no longer resolved
    data["plates"] = {"weight": 9.0}
    with pytest.raises(SpecError, match=r"plates.weight = 9 must be in \(0, 8]"):
        check_geometry(parse_spec(data, "s.toml"))
