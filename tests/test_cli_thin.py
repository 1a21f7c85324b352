"""The command line only parses, calls and prints: every command function is short (its work lives in the
library), and a command does the library's work once (one fillet per pattern)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.helpers import invoke

CLI = Path(__file__).resolve().parents[1] / "fabpat" / "cli"
#: the most lines a command function may have, from its ``def`` to its last line (docstring included,
#: the option decorators not): more means library work has crept into the command line
MAX_COMMAND_LINES = 60


def command_functions() -> list[tuple[str, int]]:
    """("file:function", lines) of every function of fabpat/cli decorated as a click command."""
    out = []
    for path in sorted(CLI.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef) and any(
                    "command" in ast.unparse(d) for d in node.decorator_list):
                out.append((f"{path.name}:{node.name}", (node.end_lineno or node.lineno) - node.lineno + 1))
    return out


def test_the_commands_are_found() -> None:
    """The scan sees the commands (a scan that found none would pass the length test vacuously)."""
    names = {name.split(":")[1] for name, _ in command_functions()}
    assert {"simulate_cmd", "sweep_cmd", "export_cmd", "library_cmd", "catalog_cmd"} <= names


@pytest.mark.parametrize("name, lines", command_functions())
def test_command_functions_are_short(name: str, lines: int) -> None:
    assert lines <= MAX_COMMAND_LINES, (f"{name} is {lines} lines (at most {MAX_COMMAND_LINES}): move its work "
                                        "into the library and keep parsing, calling and printing here")


def _count_fillets(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Record the pattern ID of every call of fillet_pattern from now on (every fillet goes through it:
    ``Pattern.fillet`` calls it too)."""
    import fabpat.geometry.fillet as fillet

    calls: list[str] = []
    real = fillet.fillet_pattern

    def counting(pattern, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202 - a pass-through spy
        calls.append(pattern.id)
        return real(pattern, *args, **kwargs)

    monkeypatch.setattr(fillet, "fillet_pattern", counting)
    return calls


def test_export_fillets_the_pattern_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The member the inert-variation warning reads is the part that is written: one fillet, not two."""
    calls = _count_fillets(monkeypatch)
    out = tmp_path / "p.svg"
    r = invoke("export", "0x0488", "--variation", "bridge_weight=0.5", "--svg", str(out))
    assert r.returncode == 0, r.stderr
    assert out.read_text().startswith("<?xml") or "<svg" in out.read_text()
    assert calls == ["0x0488"]


def test_simulate_fillets_the_pattern_once(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = _count_fillets(monkeypatch)
    r = invoke("simulate", "0x7f88", "--scenario", "cantilever", "--linear", "--h", "4", "--no-progress")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("id=0x7f88 scenario=cantilever ")
    assert calls == ["0x7f88"]
