"""``fabpat.validate``: the ranges every option, spec key and API argument is checked against treat numpy
scalars like Python numbers, and refuse what is no number (bool, text, an integer beyond float64)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.errors import FabpatError


def test_ranges_refuse_numpy_scalars_like_python_numbers() -> None:
    from fabpat.validate import check, check_size

    with pytest.raises(FabpatError, match="finite"):
        check("edge", 10**400)  # a TOML integer beyond float64
    with pytest.raises(FabpatError, match="about nan"):
        check_size(math.nan, 10, "cells", "a fixed limit")

    assert check("sides", np.int64(6)) == 6
    assert check("edge", np.float64(36.0)) == 36.0
    with pytest.raises(FabpatError):
        check("sides", True)
    with pytest.raises(FabpatError):
        check("edge", "36")
