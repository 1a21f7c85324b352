"""What a ScenarioResult shows: its one-line repr, its notebook picture, the caption's numbers (the
API's, not the finest mesh's), and the VTU as ParaView's Warp By Vector reads it."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

import fabpat
from fabpat.simulation.png_result import draw
from fabpat.simulation.scenarios import load_label

matplotlib.use("Agg")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def extrapolated():
    """A mesh-converged (two-mesh, extrapolated) dome of 0x0488: its energy differs from the fine mesh's."""
    return fabpat.simulate(fabpat.pattern("0x0488").fillet(), "dome", h=3.5, extrapolate=True)


def test_repr_is_short_and_names_the_run(extrapolated) -> None:
    text = repr(extrapolated)
    assert len(text) < 300 and "array" not in text and "\n" not in text
    assert "'0x0488'" in text and "'dome'" in text and f"energy={extrapolated.energy:.6g} N·mm" in text
    assert f"{extrapolated.nodes} nodes" in text and "converged=True" in text


def test_repr_png_is_a_png(extrapolated) -> None:
    data = extrapolated._repr_png_()
    assert data[:8] == PNG_SIGNATURE and len(data) > 10_000


def test_caption_prints_the_api_energy_not_the_fine_mesh(extrapolated) -> None:
    r = extrapolated
    fine = r.mesh_energies[-1]
    assert len(r.mesh_energies) == 2 and f"{fine:.4g}" != f"{r.energy:.4g}"  # the case the picture got wrong
    assert r.result.energy == pytest.approx(fine)
    caption = r.caption()
    assert f"U = {r.energy:.4g} N·mm" in caption and f"{fine:.4g}" not in caption
    assert caption.startswith("0x0488 · Dome, M = 100 N·mm\n")
    fig = draw(r.mesh.V, r.mesh.F, r.result, caption=caption)
    try:
        assert fig.axes[0].get_title() == caption
    finally:
        matplotlib.pyplot.close(fig)


def test_to_png_title_keeps_the_energy_line(extrapolated, tmp_path, monkeypatch) -> None:
    seen: list[str] = []
    import fabpat.simulation.png_result as png

    real = png.write_png
    monkeypatch.setattr(png, "write_png", lambda *a, title="", **k: seen.append(title) or real(*a, title=title, **k))
    out = extrapolated.to_png(tmp_path / "d.png", title="my plate")
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    assert seen == [f"my plate\nU = {extrapolated.energy:.4g} N·mm, max |u| = {extrapolated.max_displacement:.3g} mm"]


@pytest.mark.parametrize(("scenario", "label"), [("cantilever", "Cantilever, F = 1.5 N"),
                                                 ("cylinder", "Cylinder, M = 50 N·mm"),
                                                 ("dome", "Dome, M = 100 N·mm")])
def test_load_labels_are_the_papers_loads(scenario: str, label: str) -> None:
    assert load_label(scenario) == label  # paper §4.1: F = 1.5 N, M = 50 and 100 N·mm


def test_vtu_warps_to_the_deformed_shape(extrapolated, tmp_path) -> None:
    import meshio

    r = extrapolated
    m = meshio.read(r.to_vtu(tmp_path / "d.vtu"))
    reference = np.column_stack([r.mesh.V, np.zeros(r.nodes)])
    assert np.array_equal(m.points, reference)  # points are the undeformed mesh
    warped = m.points + m.point_data["displacement"]  # what ParaView's Warp By Vector (scale 1) draws
    assert np.allclose(warped, reference + r.result.displacement, atol=1e-12)
    assert np.max(np.linalg.norm(warped - reference, axis=1)) == pytest.approx(r.max_displacement)
