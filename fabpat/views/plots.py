"""Static scatter plots of a catalog (paper Figs 13–14), PNG and SVG, with matplotlib.

Figures: ``perimeter_area`` (geometry), ``polar_moment_energy_<scenario>`` for each simulated scenario
(energy on a log axis), and ``overview`` with all panels side by side. Highlighted IDs are drawn in
colour on every panel (the paper's clusters) and named in a legend.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from fabpat.catalog import Catalog
from fabpat.catalog.rows import polygon_name
from fabpat.errors import PatternError
from fabpat.views.browse import choose_setup, metric_info

PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#e377c2", "#17becf", "#8c564b", "#bcbd22",
           "#7f7f7f")


def _axis_label(key: str) -> str:
    m = metric_info(key)
    return f"{m['label']} ({m['unit']})" if m["unit"] else str(m["label"])


def _panel(ax, rows: list[dict[str, object]], x: str, y: str, highlight: Sequence[int]) -> None:  # noqa: ANN001
    pts = [(r[x], r[y]) for r in rows if r[x] is not None and r[y] is not None]
    if pts:
        xs, ys = zip(*pts, strict=True)
        ax.scatter(xs, ys, s=9, c="#4a4a4a", alpha=0.6, linewidths=0, label=None)
    for j, i in enumerate(highlight):
        r = rows[i]
        if r[x] is not None and r[y] is not None:
            ax.scatter([r[x]], [r[y]], s=40, c=PALETTE[j % len(PALETTE)], edgecolors="black", linewidths=0.5,
                       label=str(r["id"]), zorder=3)
    ax.set_xlabel(_axis_label(x))
    ax.set_ylabel(_axis_label(y))
    if metric_info(y)["log"]:
        from matplotlib.ticker import LogFormatter

        ax.set_yscale("log")
        # plain numbers (20, 30 …), not 2×10¹: energies span about one decade, so minor ticks get labels
        ax.yaxis.set_major_formatter(LogFormatter(labelOnlyBase=False))
        ax.yaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
    ax.grid(True, alpha=0.3)
    if highlight:
        ax.legend(fontsize=7, loc="best")


def plot_catalog(cat: Catalog, out: str | Path, highlight: Sequence[str] = (), sides: int | None = None,
                 dpi: int = 150) -> list[Path]:
    """Write the figures into folder ``out`` (created if missing; its parent must exist); returns the
    files written. A folder created here is removed again when the figures cannot be written.

    ``sides``: the polygon whose rows (and energies) to draw; None: the default set-up's (see
    :func:`fabpat.views.browse.choose_setup`). Raises PatternError if a highlighted ID is not among them,
    CatalogError if the catalog has no patterns of ``sides`` (naming the ``fabpat sweep`` command that
    adds them) or holds a bad value, ExportError if ``out`` cannot be written (a full disk is named as such).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fabpat.io import atomic_outputs, output_folder

    setup = choose_setup(cat, sides)
    rows = cat.pattern_rows(**setup)
    index = {str(r["id"]): i for i, r in enumerate(rows)}
    missing = [h for h in highlight if h not in index]
    if missing:
        raise PatternError(f"--highlight: {', '.join(missing)} not in the catalog's {setup['sides']}-gon patterns")
    marks = [index[h] for h in highlight]
    panels = [("perimeter_area", "area", "perimeter", "perimeter vs area")]
    for s in cat.scenarios():
        if any(r.get(f"energy_{s}") is not None for r in rows):
            panels.append((f"polar_moment_energy_{s}", "polar_moment", f"energy_{s}", f"{s}: energy vs polar moment"))
    figures = []
    for name, x, y, title in panels:
        fig, ax = plt.subplots(figsize=(5, 4), layout="constrained")
        _panel(ax, rows, x, y, marks)
        ax.set_title(f"{title} ({len(rows)} {polygon_name(int(setup['sides']))})", fontsize=10)
        figures.append((name, fig))
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.8), layout="constrained", squeeze=False)
    for ax, (_, x, y, title) in zip(axes[0], panels, strict=True):
        _panel(ax, rows, x, y, marks)
        ax.set_title(title, fontsize=10)
    figures.append(("overview", fig))
    paths = [Path(out) / f"{name}.{ext}" for name, _ in figures for ext in ("png", "svg")]
    try:
        # a folder created here is removed again if the figures cannot be written (a full disk)
        with output_folder(out), atomic_outputs(*paths) as temps:
            for k, (_, f) in enumerate(figures):
                f.savefig(temps[2 * k], dpi=dpi, format="png", facecolor="white")
                f.savefig(temps[2 * k + 1], format="svg", facecolor="white")
    finally:
        for _, f in figures:
            plt.close(f)
    return paths
