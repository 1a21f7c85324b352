"""``fabpat plot``: an empty --highlight list is an error, a full disk leaves no folder, and a figure is never
written over the command's own --db."""

from __future__ import annotations

import shutil
from pathlib import Path

from tests.helpers import digest, one_line_error
from tests.helpers import invoke_result as invoke


def test_plot_never_writes_over_its_catalog_inside_the_folder(small_catalog: Path, tmp_path: Path) -> None:
    """A catalog that happens to sit in --out under a figure's name is an input, not a figure."""
    out = tmp_path / "figures"
    out.mkdir()
    db = out / "overview.png"
    shutil.copy(small_catalog, db)
    before = digest(db)
    res = invoke("plot", "--db", str(db), "--out", str(out))
    one_line_error(res, "is the input --db", "overview.png")
    assert digest(db) == before
