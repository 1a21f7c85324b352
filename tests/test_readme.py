"""The README is a short front door whose links, pictures and commands hold; LICENSE and CITATION.cff agree."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def test_short() -> None:
    assert len(README.splitlines()) <= 150


def test_links_and_pictures_resolve() -> None:
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README) + re.findall(r'<img src="([^"]+)"', README)
    local = [t for t in targets if "://" not in t]
    assert len(local) >= 10  # the docs pages, both pictures, LICENSE, CITATION.cff
    for target in local:
        assert (ROOT / target).is_file(), target
    for picture in ("docs/img/sphere-assembly.png", "docs/img/library-sheet.png"):
        assert picture in README
        assert (ROOT / picture).stat().st_size < 150_000  # committed pictures stay small


def test_speaks_to_users() -> None:
    lowered = README.lower()
    for internal in ("issue", "shared/reference", "the notes", "this machine", "on this 2-core"):
        assert internal not in lowered, internal


def test_quickstart_matches_ci() -> None:
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    test_command = ".venv/bin/python -m pytest -n 2 tests"
    assert test_command in README and test_command in ci
    assert ".venv/bin/fabpat assemble assemblies/truncated-icosahedron.toml --out sphere-kit" in README
    assert (ROOT / "assemblies" / "truncated-icosahedron.toml").is_file()


def test_licence_and_citation_agree_with_pyproject() -> None:
    assert PYPROJECT["project"]["license"] == "MIT"  # an SPDX expression (PEP 639)
    licence = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert licence.startswith("MIT License") and "fabpat contributors" in licence
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"] == "1.2.0"
    assert cff["license"] == "MIT" and cff["version"] == PYPROJECT["project"]["version"]
    conference, journal = cff["references"]
    assert (conference["type"], conference["title"], conference["doi"], conference["year"]) == (
        "conference-paper", "Computational Design of Fabricable Geometric Patterns", "10.2312/stag.20231297", 2023)
    assert (journal["type"], journal["title"], journal["doi"], journal["journal"], journal["year"]) == (
        "article", "Procedural generation of geometric patterns for thin shell fabrication",
        "10.1016/j.cag.2024.103958", "Computers & Graphics", 2024)
    authors = ["Scandurra", "Laccone", "Malomo", "Callieri", "Cignoni", "Giorgi"]
    for paper in (conference, journal):
        assert [a["family-names"] for a in paper["authors"]] == authors
    citing = README[README.index("## Citing"):README.index("## Licence")]
    for text in ("Computational Design of Fabricable Geometric Patterns", "STAG 2023", "10.2312/stag.20231297",
                 "Procedural generation of geometric patterns for thin shell fabrication", "10.1016/j.cag.2024.103958",
                 "E. Scandurra, F. Laccone, L. Malomo, M. Callieri, P. Cignoni and\nD. Giorgi"):
        assert text in citing, text
    assert "not recorded" not in citing and "not known" not in citing
