"""The browsing page's family slider: data from the catalog's family rows, and the dots moving in Chromium."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest

from fabpat.catalog import open_catalog
from fabpat.views.browse import page_data, render_page
from tests.test_browse import CHROMIUM_ARGS
from tests.test_catalog import fake_rows
from tests.test_family import family_rows


@pytest.fixture
def family_db(tmp_path: Path) -> Path:
    path = tmp_path / "f.sqlite"
    with open_catalog(path, write=True) as cat:
        for k, pid in enumerate(("0x0488", "0x2d88", "0x0508")):
            e1 = 20.0 + 10 * k
            cat.write_rows(fake_rows(pid, 6, {"cylinder": e1}))
            if pid != "0x0508":  # one pattern without family rows
                cat.write_rows(family_rows(pid, "cylinder", {0.5: e1 * 0.8, 2.0: e1 * 1.5}))
        cat.finish()
    return path


def test_page_data_carries_each_members_values(family_db: Path) -> None:
    with open_catalog(family_db) as cat:
        d = page_data(cat)
    fam = d["family"]
    assert fam["name"] == "bridge_weight" and fam["weights"] == [0.5, 1.0, 2.0]
    i = d["ids"].index("0x2d88")
    assert fam["values"]["energy_cylinder"][i] == [24.0, 30.0, 45.0]
    assert fam["values"]["min_width"][i][0] == pytest.approx(2 / 1.5)  # the member's own, from its row
    j = d["ids"].index("0x0508")
    assert fam["values"]["energy_cylinder"][j] == [None, 40.0, None]
    assert fam["values"]["specific_stiffness_cylinder"][i][2] == pytest.approx(1 / (45.0 * 1000.0))


def test_no_family_rows_no_slider() -> None:
    with open_catalog() as cat:
        if cat.family(sides=6):
            pytest.skip("the built-in catalog holds family rows: the fake catalog tests the slider")
        assert page_data(cat)["family"] is None


def test_the_slider_moves_the_dots_and_the_export_lines_in_chromium(family_db: Path, tmp_path: Path) -> None:
    chromium = shutil.which("chromium")
    if chromium is None:
        pytest.skip("Debian chromium is not installed (apt-get install chromium): browser test not run")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (pip) is not installed")
    with open_catalog(family_db) as cat:
        data = page_data(cat)
    page_file = tmp_path / "f.html"
    page_file.write_text(render_page(data), encoding="utf-8")
    i = data["ids"].index("0x2d88")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
        try:
            page = browser.new_context(offline=True).new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(page_file.as_uri())
            page.wait_for_function("document.querySelectorAll('#plot2 .scatterlayer .point').length === 3")
            assert page.is_visible("#family")
            y = "document.getElementById('plot2').data[0].y"  # polar moment vs Cylinder energy
            assert page.evaluate(f"{y}[{i}]") == 30.0
            # half-way (in ln w) between 1 and 2: the geometric mean of the members' energies
            w = round(math.sqrt(2), 3 - 1 - int(math.floor(math.log10(math.sqrt(2)))))  # toPrecision(3)
            page.evaluate(f"() => {{ const s = document.getElementById('member'); s.value = Math.log({w});"
                          " s.dispatchEvent(new Event('input')); }")
            page.wait_for_function(f"{y}[{i}] !== 30")
            t = math.log(w) / math.log(2.0)
            assert page.evaluate(f"{y}[{i}]") == pytest.approx(30.0 * 1.5**t, rel=1e-9)
            assert page.evaluate(f"{y}[{data['ids'].index('0x0508')}]") is None  # no family: no dot
            assert page.text_content("#member-value") == f"{w}"
            page.evaluate(f"select([{i}])")
            assert f"--variation bridge_weight={w}" in page.input_value("#commands")
            page.click("#member-paper")
            page.wait_for_function(f"{y}[{i}] === 30")
            assert "--variation" not in page.input_value("#commands")
            assert errors == []
        finally:
            browser.close()


def test_a_member_only_some_patterns_were_swept_at_keeps_every_dot(tmp_path: Path) -> None:
    """The sweep's adaptive midpoints exist for some patterns only: the others get the value the page's
    log–log interpolation between their own members gives (here the geometric mean at the midpoint of
    0.5 and 2 in ln w, w = 1 being the paper's), and a member past one that did not converge stays empty."""
    path = tmp_path / "mid.sqlite"
    with open_catalog(path, write=True) as cat:
        for pid, e1 in (("0x0488", 20.0), ("0x2d88", 30.0)):
            cat.write_rows(fake_rows(pid, 6, {"cylinder": e1}))
        cat.write_rows(family_rows("0x0488", "cylinder", {0.5: 16.0, 0.7071: 18.0, 2.0: 30.0, 2.5: 33.0}))
        cat.write_rows(family_rows("0x2d88", "cylinder", {0.5: 24.0, 2.0: None}))  # 2.0 buckled
        cat.finish()
    with open_catalog(path) as cat:
        d = page_data(cat)
    fam = d["family"]
    assert fam["weights"] == [0.5, 0.7071, 1.0, 2.0, 2.5]
    e = fam["values"]["energy_cylinder"][d["ids"].index("0x2d88")]
    t = (math.log(0.7071) - math.log(0.5)) / (0.0 - math.log(0.5))  # 0.7071 between 0.5 and 1 in ln w
    assert e[0] == 24.0 and e[2] == 30.0 and e[1] == pytest.approx(24.0 * (30.0 / 24.0) ** t, rel=1e-12)
    assert e[3] is None and e[4] is None  # not converged at 2.0, not swept at 2.5: the curve ends
    w = fam["values"]["min_width"][d["ids"].index("0x2d88")]
    assert w[1] == pytest.approx(math.exp(math.log(2 / 1.5) + t * (math.log(2.0) - math.log(2 / 1.5))), rel=1e-12)
    assert fam["values"]["energy_cylinder"][d["ids"].index("0x0488")] == [16.0, 18.0, 20.0, 30.0, 33.0]
