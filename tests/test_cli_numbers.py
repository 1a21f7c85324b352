"""Every numeric option of every command refuses nan, inf, −1, 0 and 1e308 where they are out of range:
one line on stderr naming the option, exit code 2, nothing written; ``--help`` states each range, a number
that does not parse names it, and one weight check serves every command.

The options are discovered from the click command objects, so a new option is covered without
editing this file; an option parsed as a plain click FLOAT/INT (no range) fails
``test_every_numeric_option_has_a_range``.
"""

from __future__ import annotations

import math
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from fabpat.cli import cli
from fabpat.cli.options import NumberType
from fabpat.validate import RANGES
from tests.helpers import SPECS
from tests.helpers import refusal_in as one_line_error
from tests.helpers import run_in as fabpat

ROOT = Path(__file__).resolve().parents[1]
STRIP_SPEC = str(ROOT / "assemblies" / "test-small.toml")
HOSTILE = {"nan": math.nan, "inf": math.inf, "-1": -1.0, "0": 0.0, "1e308": 1e308}

#: Arguments that make each command otherwise valid; outputs go into the (watched) current folder.
BASE_ARGS: dict[str, list[str]] = {
    "simulate": ["0x0488", "--scenario", "cantilever", "--png", "out.png"],
    "show": ["0x0488", "--svg", "out.svg"],
    "sheet": ["--out", "out.svg"],
    "library": ["--no-fillet"],
    "export": ["0x0488", "--step", "out.step"],
    "sweep": ["--db", "out.sqlite"],
    "catalog": [],
    "variations": [],
    "browse": ["--out", "out.html"],
    "plot": ["--out", "figures"],
    "assemble": [STRIP_SPEC, "--out", "kit"],
    "simulate-strip": [STRIP_SPEC, "--png", "out.png"],
    "simulate-assembly": [STRIP_SPEC, "--png", "out.png"],
    "design": ["target.csv", "--spec", STRIP_SPEC, "--out", "design"],
    "predict": ["0x0488"],
}


def _numeric_options() -> list[tuple[str, click.Option]]:
    out = []
    for name, cmd in sorted(cli.commands.items()):
        for p in cmd.params:
            if isinstance(p, click.Option) and isinstance(p.type, NumberType | click.types.FloatParamType
                                                          | click.types.IntParamType):
                out.append((name, p))
    return out


OPTIONS = _numeric_options()


def _cases() -> list[tuple[str, str, str]]:
    """(command, option, value) for every hostile value outside the option's range."""
    cases = []
    for name, p in OPTIONS:
        r = p.type.range if isinstance(p.type, NumberType) else None
        for text, value in HOSTILE.items():
            if r is not None and math.isfinite(value) and r.contains(value) and (not r.integer or value == int(value)):
                continue  # a valid value (e.g. --kerf 0, --seed 0): not a refusal case
            cases.append((name, p.opts[0], text))
    return cases


def test_every_command_and_numeric_option_is_covered() -> None:
    assert set(BASE_ARGS) == set(cli.commands), "add the new command's required arguments to BASE_ARGS"
    assert len(OPTIONS) >= 30  # sanity: the discovery found the options (35 when written)


def test_every_numeric_option_has_a_range() -> None:
    plain = [f"{c} {p.opts[0]}" for c, p in OPTIONS if not isinstance(p.type, NumberType)]
    assert not plain, f"numeric options without a fabpat.validate range: {plain}"
    for _, p in OPTIONS:
        assert f"Range: {p.type.range.describe()}." in (p.help or "")  # `--help` says the range


def test_each_option_refuses_most_hostile_values() -> None:
    per_option: dict[tuple[str, str], int] = {}
    for c, o, _ in _cases():
        per_option[c, o] = per_option.get((c, o), 0) + 1
    assert all(n >= 3 for n in per_option.values()), per_option  # nan, inf and 1e308 at least
    assert len(per_option) == len(OPTIONS)


@pytest.mark.parametrize(("command", "option", "value"), _cases())
def test_hostile_number_is_one_line_exit_2_nothing_written(tmp_path: Path, command: str, option: str,
                                                           value: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FABPAT_CACHE", "off")
    (tmp_path / "keep.txt").write_text("x")
    before = sorted(p.name for p in tmp_path.iterdir())
    # the bad option first: click checks parameters in command-line order
    result = CliRunner().invoke(cli, [command, option, value, *BASE_ARGS[command]], prog_name="fabpat")
    assert result.exit_code == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("fabpat: error:") and option in lines[0], lines[0]
    assert "Traceback" not in result.output and "Warning" not in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_ranges_are_consistent() -> None:
    for r in RANGES.values():
        assert r.low < r.high and r.describe()


@pytest.mark.parametrize(("args", "words"), [
    (["show", "0x0488", "--edge", "nan", "--svg", "p.svg"], ["--edge", "finite", "[1, 1000] mm"]),
    (["simulate", "0x2d88", "--h", "inf"], ["--h", "finite"]),
    (["sweep", "--edge", "nan", "--db", "c.sqlite"], ["--edge"]),
    (["sweep", "--poisson", "nan", "--db", "c.sqlite"], ["--poisson", "(-1, 0.5)"]),
    (["simulate", "0x2d88", "--thickness", "inf"], ["--thickness"]),
    (["simulate", "0x2d88", "--youngs-modulus", "inf"], ["--youngs-modulus", "N/mm²"]),
    (["library", "--sample", "3", "--seed", "-1"], ["--seed", "[0, 9223372036854775807]"]),
    (["library", "--sides", "9" * 40], ["--sides", "[3, 64]"]),
])
def test_bad_numbers_are_one_line(tmp_path: Path, args: list[str], words: list[str]) -> None:
    line = one_line_error(tmp_path, *args)
    for w in words:
        assert w in line


def test_help_states_the_range(tmp_path: Path) -> None:
    for name in cli.commands:
        code, out, err = fabpat(tmp_path, name, "--help")
        assert code == 0, (name, err)
    code, out, _ = fabpat(tmp_path, "simulate", "--help")
    text = " ".join(out.split())
    assert "Range: [0.01, 10]." in text and "Range: (-1, 0.5)." in text and "Range: [0.001, 1e+07] N/mm²." in text


def test_one_weight_check_for_every_command(tmp_path: Path) -> None:
    a = one_line_error(tmp_path, "simulate", "0x2d88", "--weight", "1e9")
    b = one_line_error(tmp_path, "export", "0x2d88", "--weight", "1e9", "--step", "a.step")
    c = one_line_error(tmp_path, "show", "0x2d88", "--weight", "1e9", "--filleted", "--svg", "a.svg")
    assert a == b == c and "[0.01, 10]" in a


@pytest.mark.parametrize("value", ["0", "0.5", "-0.1", "nan"])
def test_end_shortening_outside_its_range_is_refused(tmp_path: Path, value: str) -> None:
    line = one_line_error(tmp_path, "simulate-assembly", str(SPECS / "test-small.toml"), "--end-shortening", value)
    assert "--end-shortening" in line and "(0, 0.5)" in line


@pytest.mark.parametrize("args", [("library", "--sides", "nan"), ("simulate", "0x0488", "--h", "1e")])
def test_unparsable_number_names_the_range(tmp_path: Path, args: tuple[str, ...]) -> None:
    line = one_line_error(tmp_path, *args)
    assert "must be" in line and "[" in line
