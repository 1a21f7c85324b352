"""The ``fabpat`` command group itself: called without a command, it prints its help; an error no check
foresaw (out of memory) is still one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.helpers import invoke_result, one_line_error
from tests.helpers import run_in as fabpat


def test_no_command_prints_the_help(tmp_path: Path) -> None:
    code, out, err = fabpat(tmp_path)
    assert code == 0 and out.startswith("Usage: fabpat") and "simulate" in out and err == ""


def test_running_out_of_memory_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    import fabpat.catalog

    def exhausted(*args: object, **kw: object) -> None:
        raise MemoryError  # as numpy's "Unable to allocate 967. MiB" past every estimate

    monkeypatch.setattr(fabpat.catalog, "open_catalog", exhausted)
    res = invoke_result("catalog")
    one_line_error(res, "out of memory", "ulimit -v", "coarser --h")  # was a traceback
