"""The browsing page (data, HTML, and a real headless Chromium) and the static figures; `browse --out` never
replaces the catalog it reads."""

from __future__ import annotations

import json
import re
import shlex
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from fabpat.catalog import open_catalog
from fabpat.views.browse import page_data, render_page
from tests.conftest import run_cli
from tests.helpers import digest, one_line_error
from tests.helpers import invoke_result as invoke
from tests.test_catalog import _tiny

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run"]


@pytest.fixture(scope="module")
def page_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("browse") / "library.html"
    res = run_cli("browse", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert "430 patterns" in res.stdout
    return out


def test_page_data_of_builtin_catalog() -> None:
    with open_catalog() as cat:
        d = page_data(cat)
    assert len(d["ids"]) == 430 and all(p.startswith("M ") for p in d["paths"])
    m = {x["key"]: x for x in d["metrics"]}
    assert {"area", "perimeter", "ratio", "polar_moment", "min_width"} <= set(m)
    assert m["energy_dome"]["log"] and m["max_displacement_cantilever"]["log"] and not m["area"]["log"]
    assert d["plots"] == [{"x": "area", "y": "perimeter"}, {"x": "polar_moment", "y": "energy_cantilever"},
                          {"x": "polar_moment", "y": "energy_cylinder"}, {"x": "polar_moment", "y": "energy_dome"}]
    assert all(len(v) == 430 for v in d["values"].values())


def test_html_is_self_contained(page_file: Path) -> None:
    html = page_file.read_text(encoding="utf-8")
    assert not re.search(r"<(script|img|link|iframe)[^>]*\s(src|href)\s*=\s*[\"']?(https?:)?//", html, re.I)
    assert "{{" not in html.split("<script>", 1)[0] and "{{DATA}}" not in html
    assert "default-src 'none'" in html  # CSP: the browser itself refuses any fetch
    assert html.count("data:image/svg+xml") >= 1 and len(html) < 8_000_000


def test_geometry_only_catalog_falls_back(tmp_path: Path) -> None:
    db = tmp_path / "c.sqlite"
    _tiny(db)
    with open_catalog(db, write=True) as cat:
        cat.conn.execute("DELETE FROM results")
        cat.conn.commit()
        d = page_data(cat)
        assert render_page(d).startswith("<!DOCTYPE html>")
    keys = {m["key"] for m in d["metrics"]}
    assert not any(k.startswith("energy_") for k in keys)
    assert all(p["x"] in keys and p["y"] in keys for p in d["plots"])


def test_static_plots(tmp_path: Path) -> None:
    out = tmp_path / "figs"
    res = invoke("plot", "--out", str(out), "--highlight", "0x0488,0xf608")
    assert res.exit_code == 0, res.stderr
    names = sorted(p.name for p in out.iterdir())
    stems = ["overview", "perimeter_area", "polar_moment_energy_cantilever", "polar_moment_energy_cylinder",
             "polar_moment_energy_dome"]
    assert names == sorted(f"{s}.{e}" for s in stems for e in ("png", "svg"))
    for s in stems:
        assert (out / f"{s}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert ET.parse(out / f"{s}.svg").getroot().tag.endswith("svg")
    res = invoke("plot", "--out", str(tmp_path / "x"), "--highlight", "0x0001")
    assert res.exit_code == 2 and "0x0001" in res.stderr and not (tmp_path / "x").exists()
    res = invoke("plot", "--out", str(tmp_path / "missing" / "figs"))
    assert res.exit_code == 2 and "does not exist" in res.stderr and not (tmp_path / "missing").exists()


def _spec_fragment_assembles(fragment: str, ids: list[str], tmp_path: Path) -> None:
    """The page's "assembly spec" lines, pasted into a spec with the other tables, build a kit of exactly
    the selected patterns (`fabpat assemble`, BOM only and no prediction, to stay fast)."""
    import csv

    spec = tmp_path / "pasted.toml"
    spec.write_text('name = "pasted"\n\n' + fragment + "\n\n[plates]\nprocess = \"laser\"\n\n[sheet]\n"
                    "width = 600.0\nheight = 400.0\n\n[output]\nformats = [\"bom\"]\n")
    res = run_cli("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress", "--no-predict")
    assert res.returncode == 0, res.stderr
    rows = list(csv.DictReader((tmp_path / "kit" / "bom.csv").open()))
    assert sorted(r["part"] for r in rows if r["kind"] == "plate") == sorted(f"hex {i}" for i in ids)


def test_in_chromium_offline(page_file: Path, tmp_path: Path) -> None:
    """Loads with networking off and no request but the file itself; 430 dots per plot; hover shows a
    picture; a box selection lists the patterns and recolours the other plots; screenshot saved."""
    chromium = shutil.which("chromium")
    if chromium is None:
        pytest.skip("Debian chromium is not installed (apt-get install chromium): browser test not run")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (pip) is not installed")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
        try:
            context = browser.new_context(offline=True, viewport={"width": 1300, "height": 1000})
            page = context.new_page()
            requests: list[str] = []
            errors: list[str] = []
            page.on("request", lambda r: requests.append(r.url))
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.goto(page_file.as_uri())
            page.wait_for_function("document.querySelectorAll('.plot .scatterlayer .point').length >= 4 * 430",
                                   timeout=60_000)
            counts = page.evaluate("[...document.querySelectorAll('.plot')].map(d => "
                                   "d.querySelectorAll('.scatterlayer .point').length)")
            assert counts == [430, 430, 430, 430]
            assert page.evaluate("document.getElementById('plot1').layout.yaxis.type") == "log"

            dot = page.locator("#plot3 .scatterlayer .point").nth(17).bounding_box()
            page.mouse.move(dot["x"] + dot["width"] / 2, dot["y"] + dot["height"] / 2)
            page.wait_for_function("getComputedStyle(document.getElementById('hover')).display === 'block'")
            src = page.get_attribute("#hover img", "src")
            assert src.startswith("data:image/svg+xml") and "%3Cpath" in src
            assert re.fullmatch(r"0x[0-9a-f]{4}", page.text_content("#hover .id"))
            assert page.evaluate("document.querySelector('#hover img').naturalWidth") > 0  # the SVG decodes
            page.screenshot(path=str(tmp_path / "hover.png"))

            # box-select around one geometric cluster of the perimeter/area plot (2–10 patterns on one spot)
            target = page.evaluate("""() => {
                const D = JSON.parse(document.getElementById('data').textContent);
                const gd = document.getElementById('plot0');
                const xs = D.values.area, ys = D.values.perimeter, groups = {};
                xs.forEach((x, i) => { (groups[x.toFixed(3) + ',' + ys[i].toFixed(3)] ??= []).push(i); });
                const g = Object.values(groups).find(g => g.length >= 2 && g.length <= 10);
                const L = gd._fullLayout;
                return {n: g.length, ids: g.map(i => D.ids[i]), x: L.xaxis.d2p(xs[g[0]]), y: L.yaxis.d2p(ys[g[0]])};
            }""")
            box = page.locator("#plot0 .nsewdrag").bounding_box()
            cx, cy = box["x"] + target["x"], box["y"] + target["y"]
            page.mouse.move(cx - 12, cy - 12)
            page.mouse.down()
            page.mouse.move(cx, cy, steps=5)
            page.mouse.move(cx + 12, cy + 12, steps=5)
            page.mouse.up()
            page.wait_for_function("document.querySelectorAll('#cards .card').length > 0")
            n = page.locator("#cards .card").count()
            assert n == target["n"]
            assert sorted(page.locator("#cards .card .id").all_text_contents()) == sorted(target["ids"])
            assert page.text_content("#count").startswith(f"{n} pattern")
            lines = page.input_value("#commands").splitlines()
            assert all(re.fullmatch(r"fabpat export 0x[0-9a-f]{4} --step .*", x) for x in lines[:n])
            fragment = "\n".join(lines[n:])
            assert not fragment.startswith("fabpat") and "[patterns]" in fragment
            assert page.locator("#cards .card img").first.evaluate("i => i.naturalWidth") > 0
            from fabpat.cli.export_cmds import export_cmd  # the lines parse as real `fabpat export` commands

            ctx = export_cmd.make_context("export", shlex.split(lines[0])[2:])
            assert ctx.params["pattern_id"] in target["ids"]
            assert ctx.params["step"].endswith(".step") and ctx.params["sides"] == 6
            # the same patterns are highlighted in every other plot (bigger, coloured dots)
            for k in (1, 2, 3):
                sel = page.evaluate(f"document.getElementById('plot{k}').data[0].selectedpoints")
                assert len(sel) == n
                big = page.evaluate(f"[...document.querySelectorAll('#plot{k} .scatterlayer .point')]"
                                    ".filter(e => e.getBBox().width > 8).length")
                assert big == n
            page.screenshot(path=str(tmp_path / "selection.png"), full_page=True)
            _spec_fragment_assembles(fragment, target["ids"], tmp_path)

            # a click in another plot replaces the box selection everywhere: no stale box in plot 0, the
            # new patterns drawn selected (not faded) in every plot
            spot = page.evaluate("""(old) => {
                const D = JSON.parse(document.getElementById('data').textContent);
                const xs = D.values.polar_moment, ys = D.values.energy_cylinder;
                const L = document.getElementById('plot2')._fullLayout;
                const px = xs.map((x, i) => [L.xaxis.d2p(x), L.yaxis.d2p(ys[i])]);
                // the dot farthest from any other (a click there cannot hit a neighbour), not in the box
                let j = -1, best = -1;
                px.forEach(([x, y], i) => {
                    if (old.includes(D.ids[i]) || ys[i] === null) return;
                    const d = Math.min(...px.map(([u, v], k) => k === i ? Infinity : Math.hypot(u - x, v - y)));
                    if (d > best) { best = d; j = i; }
                });
                const same = D.ids.map((_, i) => i).filter(i => xs[i] === xs[j] && ys[i] === ys[j]);
                return {same, x: px[j][0], y: px[j][1]};
            }""", target["ids"])
            box2 = page.locator("#plot2 .nsewdrag").bounding_box()
            page.mouse.click(box2["x"] + spot["x"], box2["y"] + spot["y"])
            page.wait_for_function(f"document.querySelectorAll('#cards .card').length === {len(spot['same'])}")
            page.wait_for_function("[0, 1, 2, 3].every(k => JSON.stringify(document.getElementById('plot' + k)"
                                   f".data[0].selectedpoints) === '{json.dumps(spot['same'], separators=(',', ':'))}')")
            for k in range(4):
                state = page.evaluate(f"""() => {{
                    const gd = document.getElementById('plot{k}');
                    const pts = [...gd.querySelectorAll('.scatterlayer .point')];
                    return {{boxes: (gd.layout.selections || []).length,
                             outlines: gd.querySelectorAll('.selectionlayer path, .select-outline').length,
                             opacity: gd.data[0].selectedpoints.map(i => getComputedStyle(pts[i]).opacity)}};
                }}""")
                assert state["boxes"] == 0 and state["outlines"] == 0, (k, state)
                assert state["opacity"] == ["1"] * len(spot["same"]), (k, state)
            page.screenshot(path=str(tmp_path / "click-after-box.png"), full_page=True)

            page.mouse.dblclick(cx + 30, cy + 30)  # double-click clears the selection everywhere
            page.wait_for_function("document.querySelectorAll('#cards .card').length === 0")
            # plotly counts a click within its doubleClickDelay (300 ms) of the last one as part of a
            # double-click: a user's next click comes later, and so does this one
            page.wait_for_timeout(400)
            page.mouse.click(cx, cy)  # a click selects the whole cluster under the cursor
            page.wait_for_function(f"document.querySelectorAll('#cards .card').length === {n}")

            page.select_option(".panel:first-child select[data-axis='y']", "energy_dome")
            page.wait_for_function("document.getElementById('plot0').layout.yaxis.type === 'log'")
            assert errors == []
            assert all(u.startswith("file:") for u in requests), requests
            print(f"screenshots: {tmp_path / 'hover.png'}, {tmp_path / 'selection.png'}")
        finally:
            browser.close()


def test_browse_refuses_a_page_that_is_not_html(tmp_path: Path) -> None:
    r = run_cli("browse", "--out", str(tmp_path / "x.png"))
    assert r.returncode == 2 and "must end in .html" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.png").exists()


def test_browse_out_equal_to_db_is_refused(small_catalog: Path, tmp_path: Path) -> None:
    db = tmp_path / "g.db"
    shutil.copy(small_catalog, db)
    (tmp_path / "hard.db").hardlink_to(db)
    (tmp_path / "sym.db").symlink_to(db)
    before = digest(db)
    for db_arg, out in ((db, db), (db, tmp_path / "hard.db"), (tmp_path / "sym.db", db)):
        res = invoke("browse", "--db", str(db_arg), "--out", str(out))
        one_line_error(res, "is the input --db", str(out))
        assert digest(db) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.db", "hard.db", "sym.db"]
