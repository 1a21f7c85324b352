"""The browsing page (paper §4.2, Figs 13–14): one self-contained, offline HTML file of scatter plots.

Dots are patterns; every plot's axes can be switched among all metrics of the catalog (energies and
displacements on log axes). Hovering a dot shows the pattern's picture; a box/lasso selection in any
plot highlights the same patterns in every plot and lists them with pictures, numbers and
ready-to-copy ``fabpat export`` lines. plotly.js is inlined (what ``include_plotlyjs=True`` does), the
pictures are SVG data made from the filleted outlines stored in the catalog, so the page makes no
network request at all.

The page is a template (``fabpat/data/browse_template.html``) filled with one JSON document; the
JavaScript in the template draws the plots (plotly.js is driven directly, which keeps selection
linking in one place).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from importlib import resources
from typing import TypedDict

import numpy as np

from fabpat.catalog import DEFAULT_SETUP, Catalog, CatalogError, missing_polygon_message
from fabpat.catalog.rows import specific_stiffness, stored_float
from fabpat.catalog.schema import Setup
from fabpat.validate import as_float

_LABELS = {
    "area": ("area", "mm²"), "perimeter": ("perimeter", "mm"), "ratio": ("ratio 4πA/P²", ""),
    "polar_moment": ("polar moment", "mm⁴"), "filleted_area": ("filleted area", "mm²"),
    "filleted_perimeter": ("filleted perimeter", "mm"), "filleted_ratio": ("filleted ratio 4πA/P²", ""),
    "filleted_polar_moment": ("filleted polar moment", "mm⁴"), "min_width": ("min width", "mm"),
}
#: the paper's four plots (Figs 13–14): (x, y) metric keys; energies fall back if not simulated
DEFAULT_PLOTS = (("area", "perimeter"), ("polar_moment", "energy_cantilever"), ("polar_moment", "energy_cylinder"),
                 ("polar_moment", "energy_dome"))
_NUMBER = re.compile(r"-?\d+\.\d+(?:e-?\d+)?")


class PageData(TypedDict):
    """The page's JSON document (:func:`page_data`): the set-up shown, per pattern (one entry each, in
    ``ids``' order) its picture's path data (mm) and its ``values`` per metric (None: not computed), the
    metrics' labels (:func:`metric_info`), the plots' axes, the slider data (:func:`family_data`), the
    polygon's outline and view box (mm) and where the numbers come from."""

    setup: Setup
    ids: list[str]
    paths: list[str]
    values: dict[str, list[float | None]]
    metrics: list[dict[str, object]]
    plots: list[dict[str, str]]
    family: dict[str, object] | None
    polygon: str
    viewbox: list[float]
    source: dict[str, object]


def metric_info(key: str) -> dict[str, object]:
    """Label, unit and whether the axis is logarithmic for a metric column of the wide rows."""
    if key in _LABELS:
        label, unit = _LABELS[key]
        return {"key": key, "label": label, "unit": unit, "log": False}
    for prefix, label, unit in (("energy_", "energy", "N·mm"), ("max_displacement_", "max displacement", "mm"),
                                ("specific_stiffness_", "stiffness per mass", "1/(N·mm³)")):
        if key.startswith(prefix):
            return {"key": key, "label": f"{label}, {key[len(prefix):]}", "unit": unit, "log": True}
    return {"key": key, "label": key, "unit": "", "log": False}


def _setup(row: Mapping[str, object]) -> Setup:
    """The set-up of a row of :meth:`Catalog.setups` (checked there: whole sides and depth, numbers)."""
    return Setup(sides=int(as_float(row["sides"])), depth=int(as_float(row["depth"])),
                 edge=as_float(row["edge"]), thickness=as_float(row["thickness"]), weight=as_float(row["weight"]))


def choose_setup(cat: Catalog, sides: int | None = None, depth: int | None = None) -> Setup:
    """The set-up to show: the default one if present (and matching ``sides`` and ``depth``), else the largest
    of that polygon (and depth). :class:`CatalogError` if the catalog has no patterns (of that polygon: the
    message names the ``fabpat sweep --sides`` command that adds them; of that depth: the depths it holds)."""
    setups = [s for s in cat.setups() if sides is None or s["sides"] == sides]
    if not setups:
        if sides is not None:
            raise CatalogError(missing_polygon_message(cat, sides))
        raise CatalogError(f"catalog {cat.path} has no patterns; fill it with `fabpat sweep --db {cat.path}`")
    if depth is not None:
        held = sorted({int(as_float(s["depth"])) for s in setups})
        setups = [s for s in setups if s["depth"] == depth]
        if not setups:
            raise CatalogError(f"catalog {cat.path} has no depth-{depth} patterns of that polygon: it holds depth "
                               f"{', '.join(map(str, held))} (`fabpat sweep --depth {depth} --sample N` adds some)")
    for s in setups:
        if all(s[k] == v for k, v in DEFAULT_SETUP.items() if k != "depth" or depth is None):
            return _setup(s)
    return _setup(max(setups, key=lambda s: as_float(s["patterns"])))


def _short_path(d: str) -> str:
    """SVG path data with numbers rounded to 0.01 mm (a 100-px thumbnail needs no more; ~3× smaller)."""
    return _NUMBER.sub(lambda m: f"{float(m.group()):.2f}".rstrip("0").rstrip("."), d)


def _lattice_path(pattern_id: str, sides: int, depth: int, edge: float) -> str:
    """Fallback picture: the solid lattice triangles as path data (for rows without an outline)."""
    from fabpat.patterns.pattern import Pattern

    try:
        p = Pattern.from_id(pattern_id, sides, depth, edge)
    except Exception:  # noqa: BLE001 - a bad ID in a foreign catalog: no picture rather than no page
        return ""
    tris = p.V[p.solid_faces]
    return " ".join("M " + " L ".join(f"{x:.2f} {y:.2f}" for x, y in t) + " Z" for t in tris)


def page_data(cat: Catalog, sides: int | None = None, depth: int | None = None) -> PageData:
    """Everything the page shows, as one JSON-ready dict (columnar values, one entry per pattern) for the set-up
    :func:`choose_setup` picks."""
    from fabpat.patterns.lattice import polygon_vertices

    setup = choose_setup(cat, sides, depth)
    rows = cat.pattern_rows(pictures=True, **setup)
    keys = [k for k in rows[0] if k not in ("id", "sides", "depth", "edge", "thickness", "weight", "svg_path")
            and not k.startswith("converged_")] if rows else []
    keys = [k for k in keys if any(isinstance(r[k], int | float) for r in rows)]  # drop never-computed ones
    values = {k: [stored_float(r[k]) for r in rows] for k in keys}
    n, d, edge = setup["sides"], setup["depth"], setup["edge"]
    paths = [_short_path(str(r["svg_path"])) if r["svg_path"] else _lattice_path(str(r["id"]), n, d, edge)
             for r in rows]
    plots = []
    for x, y in DEFAULT_PLOTS:
        if y not in values:  # a geometry-only catalog: show other geometric pairs instead
            y = {"energy_cantilever": "min_width", "energy_cylinder": "filleted_ratio"}.get(y, "filleted_area")
        plots.append({"x": x if x in values else keys[0], "y": y if y in values else keys[-1]})
    corners = polygon_vertices(n, edge)
    r = float(np.abs(corners).max()) * 1.04
    from fabpat import __version__

    versions = sorted({str(q["solver_version"]) for q in cat.query(
        "SELECT DISTINCT solver_version FROM results WHERE sides = ? AND depth = ? AND edge = ?", (n, d, edge))})
    return {
        "setup": setup, "ids": [str(r_["id"]) for r_ in rows], "paths": paths, "values": values,
        "metrics": [metric_info(k) for k in keys], "plots": plots, "family": family_data(cat, setup, rows),
        "polygon": " ".join(f"{x:.3f},{-y:.3f}" for x, y in corners), "viewbox": [-r, -r, 2 * r, 2 * r],
        "source": {"catalog": cat.path.name, "fabpat": __version__, "solver": versions},
    }


def family_data(cat: Catalog, setup: Setup, rows: list[dict[str, object]]) -> dict[str, object] | None:
    """The page's slider data: the swept members of ``bridge_weight`` (the paper's 1 among them) and, per
    metric that changes with it (``energy_<s>``, ``specific_stiffness_<s>``, ``min_width``,
    ``filleted_area``), one list per pattern of its value at each member (None: not converged, or outside
    the pattern's own swept members). A member that some patterns were swept at and others not (the
    sweep's adaptive midpoints, :func:`fabpat.catalog.sweep.run_sweep`) is filled in for the others linearly in
    log–log between their own neighbouring swept members (:func:`_fill`), as the page interpolates, so a
    dot does not vanish there. None when the catalog holds no family rows for this set-up."""
    fam = cat.family(**setup)
    if not fam:
        return None
    weights = sorted({1.0, *(as_float(r["bridge_weight"]) for r in fam)})
    col = {w: k for k, w in enumerate(weights)}
    row_of = {str(r["id"]): i for i, r in enumerate(rows)}
    scen = sorted({str(r["scenario"]) for r in fam})
    keys = [*(f"energy_{s}" for s in scen), *(f"specific_stiffness_{s}" for s in scen), "min_width", "filleted_area"]
    table: dict[str, list[list[float | None]]] = {k: [[None] * len(weights) for _ in rows] for k in keys}
    swept: dict[str, set[tuple[int, int]]] = {k: set() for k in keys}
    for i, r in enumerate(rows):  # the paper's member: the catalog's own row
        for k in keys:
            v = r.get(k)
            table[k][i][col[1.0]] = stored_float(v)
            swept[k].add((i, col[1.0]))
    for f in fam:
        at = row_of.get(str(f["id"]))
        if at is None:
            continue
        i, j, s = at, col[as_float(f["bridge_weight"])], str(f["scenario"])
        for k in (f"energy_{s}", f"specific_stiffness_{s}", "min_width", "filleted_area"):
            swept[k].add((i, j))
        e = stored_float(f["energy"]) if f["converged"] else None
        table[f"energy_{s}"][i][j] = e
        table[f"specific_stiffness_{s}"][i][j] = specific_stiffness(e, stored_float(f["filleted_area"]))
        table["min_width"][i][j] = stored_float(f["min_width"])
        table["filleted_area"][i][j] = stored_float(f["filleted_area"])
    logw = [math.log(w) for w in weights]
    for k in keys:
        for i, values in enumerate(table[k]):
            _fill(values, [(i, j) in swept[k] for j in range(len(weights))], logw)
    return {"name": "bridge_weight", "weights": weights, "values": table}


def _fill(values: list[float | None], swept: list[bool], logw: list[float]) -> None:
    """Fill, in place, each value not swept (``swept`` False) that lies between two swept, positive values
    of the same pattern: linear in (ln w, ln value) between them; a gap next to a member that did not
    converge, or beyond the pattern's swept members, stays None."""
    known = [j for j, s in enumerate(swept) if s]
    for a, b in zip(known[:-1], known[1:], strict=True):
        va, vb = values[a], values[b]
        if b - a < 2 or va is None or vb is None or va <= 0 or vb <= 0:
            continue
        for j in range(a + 1, b):
            t = (logw[j] - logw[a]) / (logw[b] - logw[a])
            values[j] = math.exp(math.log(va) + t * (math.log(vb) - math.log(va)))


def render_page(data: PageData) -> str:
    """The HTML document: the template with plotly.js and the data inlined."""
    from plotly.offline import get_plotlyjs  # the exact script that include_plotlyjs=True embeds

    template = (resources.files("fabpat") / "data" / "browse_template.html").read_text(encoding="utf-8")
    # "</" inside a <script> would end it early: escape it in the JSON (still valid JSON)
    blob = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    from fabpat.catalog.rows import polygon_name

    sides = int(data["setup"]["sides"])
    depth = int(data["setup"]["depth"])
    deeper = "" if depth == 2 else f"depth-{depth} "  # the paper's library is depth 2; others are said
    title = f"fabpat library: {len(data['ids'])} {deeper}{polygon_name(sides)}"
    return (template.replace("{{TITLE}}", title)
            .replace("{{DATA}}", blob)
            .replace("{{PLOTLYJS}}", get_plotlyjs()))


def write_page(cat: Catalog, out: str, sides: int | None = None, depth: int | None = None) -> int:
    """Write the browsing page of the polygon ``sides`` (None: the default set-up's) and subdivision ``depth``
    (None: the paper's 2 where held) to ``out`` atomically; returns the number of patterns shown.
    :class:`CatalogError` as :func:`choose_setup`, or for a bad stored value."""
    from fabpat.io import atomic_outputs

    data = page_data(cat, sides, depth)
    html = render_page(data)
    with atomic_outputs(out) as (tmp,):
        tmp.write_text(html, encoding="utf-8")
    return len(data["ids"])
