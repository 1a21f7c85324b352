"""Learned responses on disk: one ``<catalog>.response.npz`` beside each catalog, read back as checked arrays.

:mod:`fabpat.catalog.response` fits a :class:`~fabpat.catalog.response.Response`; this module stores it
(:func:`save_responses`: plain arrays, no pickles, so no scikit-learn is needed to read; with the solver version
and the IDs of the rows it was fitted to), reads it back (:func:`load_responses`: every array checked before a
walk uses it), hands out the current one (:func:`response`: a stale model is refused like a stale row), predicts
from it (:func:`predict`, ``fabpat.predict``) and refits it after a sweep (:func:`refit_responses`).
"""

from __future__ import annotations

import io
import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fabpat.catalog.response import (
    DEPTHS,
    FEATURES_VERSION,
    LEARNED,
    LEVEL,
    N_FEATURES,
    PHYSICS,
    TREE_ARRAYS,
    Prediction,
    Response,
    Trees,
    check_ids,
    fit_response,
    training_arrays,
)
from fabpat.catalog.schema import builtin_path
from fabpat.catalog.version import solver_version
from fabpat.errors import CatalogError, FabpatError
from fabpat.patterns.lattice import check_sides

#: the fewest usable patterns of a polygon that ``fabpat sweep`` refits a response to (fewer: left alone)
MIN_ROWS = 50


def response_path(catalog: str | Path | None) -> Path:
    """Where the responses of a catalog live: ``<catalog>.response.npz`` beside it (``None``: the built-in).
    Raises :class:`~fabpat.errors.CatalogError` for a catalog that is not a file name."""
    if catalog is not None and (not isinstance(catalog, str | os.PathLike) or not os.fspath(catalog)
                                or not Path(catalog).name):
        raise CatalogError(f"a catalog is a file name or None (the built-in one), got {catalog!r}")
    p = builtin_path() if catalog is None else Path(catalog)
    return p.with_name(p.name + ".response.npz")


def save_responses(responses: Sequence[Response], path: str | Path) -> Path:
    """Write responses (one per polygon) to an ``.npz`` of plain arrays, atomically; returns the path."""
    from fabpat.io import atomic_outputs

    arrays: dict[str, NDArray] = {}
    entries: list[dict[str, object]] = []
    meta: dict[str, object] = {"features_version": FEATURES_VERSION, "level": LEVEL, "targets": list(LEARNED),
                               "responses": entries}
    for r in responses:
        entry = {"sides": r.sides, "solver_version": r.solver_version, "rows": {str(d): n for d, n in r.rows.items()},
                 "spread": {t: {str(d): q for d, q in r.spread[t].items()} for t in LEARNED},
                 "init": {t: r.models[t].init for t in LEARNED}, "rate": {t: r.models[t].rate for t in LEARNED}}
        entries.append(entry)
        for t in LEARNED:
            m = r.models[t]
            for field in TREE_ARRAYS:
                arrays[f"{r.sides}/{t}/{field}"] = getattr(m, field)
            arrays[f"{r.sides}/{t}/linear"] = m.linear
        arrays[f"{r.sides}/ids"] = np.array(sorted(r.ids), dtype="<U16")
    arrays["meta"] = np.array(json.dumps(meta))
    path = Path(path)
    savez: Callable[..., None] = np.savez_compressed  # numpy's stubs read **arrays as its keyword options
    with atomic_outputs(path) as (tmp,):
        with open(tmp, "wb") as fh:
            savez(fh, **arrays)
    return path


#: the largest response file read (the built-in one is 0.4 MB)
MAX_RESPONSE_BYTES = 64 * 2**20


def _checked_trees(path: Path, where: str, arrays: dict[str, NDArray], init: float, rate: float) -> Trees:
    """A :class:`Trees` from stored arrays, or CatalogError: the dtypes and shapes a walk relies on, feature
    indices in range, children after their parent (so every walk ends: sklearn numbers nodes depth first),
    a finite linear part of the right shape."""
    linear = arrays["linear"]
    if linear.dtype != np.float64 or linear.shape != (len(DEPTHS), len(PHYSICS) + 1) or not np.isfinite(linear).all():
        raise CatalogError(f"{path}: {where} linear part is not a finite ({len(DEPTHS)}, {len(PHYSICS) + 1}) float64 "
                           "array")
    want = {"feature": np.int64, "left": np.int64, "right": np.int64, "threshold": np.float64, "value": np.float64}
    for name, dtype in want.items():
        a = arrays[name]
        if a.dtype != dtype or a.ndim != 2 or a.shape != arrays["feature"].shape or a.size == 0:
            raise CatalogError(f"{path}: {where} {name} is not a (trees, nodes) {np.dtype(dtype).name} array like "
                               "the rest")
    feature, left, right = arrays["feature"], arrays["left"], arrays["right"]
    nodes = np.arange(feature.shape[1])
    inner = left >= 0
    if (np.any((left >= 0) != (right >= 0)) or np.any(inner & ((left <= nodes) | (right <= nodes)))
            or np.any(left >= feature.shape[1]) or np.any(right >= feature.shape[1])
            or np.any(inner & ((feature < 0) | (feature >= N_FEATURES)))):
        raise CatalogError(f"{path}: {where} is not a tree (a child before its parent, out of range, or a "
                           "feature the response does not read)")
    if not (np.isfinite(arrays["threshold"]).all() and np.isfinite(arrays["value"]).all() and math.isfinite(init)
            and math.isfinite(rate)):
        raise CatalogError(f"{path}: {where} holds a value that is not finite")
    return Trees(feature, arrays["threshold"], left, right, arrays["value"], init, rate, linear)


def _responses_from(path: Path, z: Mapping[str, NDArray]) -> dict[int, Response]:
    meta = json.loads(str(z["meta"]))
    if not isinstance(meta, dict) or meta.get("features_version") != FEATURES_VERSION or meta.get("level") != LEVEL \
            or meta.get("targets") != list(LEARNED):
        raise CatalogError(f"{path}: not a learned response of this layout (features {FEATURES_VERSION}, level "
                           f"{LEVEL}); refit it with fabpat sweep")
    out = {}
    for e in meta["responses"]:
        s = int(e["sides"])
        models = {t: _checked_trees(path, f"the {s}-gon's {t}",
                                    {f: np.asarray(z[f"{s}/{t}/{f}"]) for f in (*TREE_ARRAYS, "linear")},
                                    float(e["init"][t]), float(e["rate"][t])) for t in LEARNED}
        spread = {t: {int(d): float(q) for d, q in e["spread"][t].items()} for t in LEARNED}
        if any(not spread[t] or not all(math.isfinite(q) and q >= 0 for q in spread[t].values()) for t in LEARNED):
            raise CatalogError(f"{path}: the {s}-gon's interval widths are missing, negative or not finite")
        ids = tuple(str(i) for i in np.asarray(z[f"{s}/ids"])) if f"{s}/ids" in z else ()
        out[s] = Response(s, models, spread, str(e["solver_version"]), {int(d): int(n) for d, n in e["rows"].items()},
                          frozenset(ids))
    return out


def load_responses(path: str | Path) -> dict[int, Response]:
    """Read :func:`save_responses`' file: ``{sides: Response}``. Raises CatalogError if it is missing, not a
    regular file (a FIFO is not opened), larger than :data:`MAX_RESPONSE_BYTES`, unreadable, of another layout,
    or holds trees that a walk could not finish (every array is checked before it is used)."""
    from fabpat.io import read_input

    path = Path(path)
    try:
        data = read_input(path, "learned response", MAX_RESPONSE_BYTES)
    except FileNotFoundError as exc:
        raise CatalogError(f"{path}: no learned response beside this catalog (fabpat sweep fits one "
                           f"once it holds {MIN_ROWS} simulated patterns of a polygon)") from exc
    except OSError as exc:
        raise CatalogError(f"{path}: cannot read the learned response ({exc.strerror or exc})") from exc
    except FabpatError as exc:
        raise CatalogError(str(exc)) from exc
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            return _responses_from(path, {k: z[k] for k in z.files})
    except CatalogError:
        raise
    except Exception as exc:  # noqa: BLE001 - any damage (zip, JSON, keys, types) is one refusal naming the file
        raise CatalogError(f"{path}: not a learned response fabpat wrote ({type(exc).__name__}: {exc})") from exc


def response(sides: int = 6, catalog: str | Path | None = None) -> Response:
    """The learned response of a catalog (``None``: the built-in one) for the ``sides``-gon.

    Raises :class:`~fabpat.errors.CatalogError` if there is none for that polygon, or if it was fitted to
    rows of another solver version than this fabpat's (:func:`fabpat.catalog.solver_version`)."""
    sides = check_sides(sides)
    path = response_path(catalog)
    held = load_responses(path)
    if sides not in held:
        raise CatalogError(f"{path}: no learned response for the {sides}-gon; it holds "
                           f"{', '.join(str(s) for s in sorted(held)) or 'none'}")
    r = held[sides]
    if r.solver_version != solver_version():
        raise CatalogError(f"{path}: the learned response was fitted to rows of {r.solver_version}, not "
                           f"{solver_version()} (stale, like a row of another solver); refit it with "
                           "fabpat sweep")
    return r


def predict(ids: Sequence[str] | str, sides: int = 6, catalog: str | Path | None = None) -> Prediction:
    """Predict the scenario energies (N·mm), ``min_width`` (mm) and ``area`` (mm²) of patterns, with
    :data:`LEVEL` intervals, from the learned response of ``catalog`` (``None``: the built-in one).

    ``fabpat.predict(["0x0488"]).records()`` → ``[{"id": "0x0488", "energy_dome": …,
    "energy_dome_interval": [low, high], …}]``. Raises :class:`~fabpat.errors.PatternError` for an invalid,
    untileable or disconnected ID and :class:`~fabpat.errors.CatalogError` for a missing or stale model."""
    checked = check_ids([ids] if isinstance(ids, str) else ids, sides)  # a bad ID is named before any file is read
    return response(sides, catalog).predict(checked, checked=True)


def refit_responses(catalog: str | Path | None, *, also: Sequence[str | Path] = (), min_rows: int = MIN_ROWS,
                    seed: int = 0) -> Path | None:
    """Fit a response per polygon that the catalog holds ≥ ``min_rows`` usable patterns of, at the default
    set-up (:data:`fabpat.catalog.schema.DEFAULT_SETUP`'s edge, thickness and weight; depths 2 and 3 together),
    and write them beside it (:func:`response_path`). ``also``: more catalogs whose rows of the same set-up join
    the training (the built-in response also learns from the depth-3 rows in ``benchmarks/data``). Returns the
    path, or None if no polygon had enough rows.

    Raises :class:`~fabpat.errors.CatalogError` if the rows come from another solver version than this
    fabpat's (a model of stale rows would be stale itself)."""
    from fabpat.catalog.read import catalog as read_catalog
    from fabpat.catalog.schema import DEFAULT_SETUP
    from fabpat.catalog.store import open_catalog

    with open_catalog(catalog) as cat:
        polygons = [int(str(r["sides"])) for r in cat.query("SELECT DISTINCT sides FROM patterns ORDER BY sides")]
        versions = {str(r["solver_version"]) for r in cat.query("SELECT DISTINCT solver_version FROM results")}
    for extra in also:
        with open_catalog(extra) as cat:
            versions |= {str(r["solver_version"]) for r in cat.query("SELECT DISTINCT solver_version FROM results")}
    current = solver_version()
    if versions - {current}:
        other = ", ".join(sorted(versions - {current}))
        raise CatalogError(f"{catalog or 'the built-in catalog'} holds rows of {other}, "
                           f"not {current}: run fabpat sweep on it before fitting a learned response")
    fitted = []
    def rows_of(path: str | Path | None, sides: int) -> list[dict[str, object]]:
        found: list[dict[str, object]] = []
        for depth in DEPTHS:  # each asked for: a reading without depth is the paper's depth 2 alone
            try:
                found += read_catalog(path, sides=sides, depth=depth, edge=DEFAULT_SETUP["edge"],
                                      thickness=DEFAULT_SETUP["thickness"], weight=DEFAULT_SETUP["weight"])
            except CatalogError:  # a catalog without this polygon, depth or set-up adds nothing
                pass
        return found

    for s in polygons:
        rows = rows_of(catalog, s) + [r for extra in also for r in rows_of(extra, s)]
        if len(training_arrays(rows)[0]) >= min_rows:
            fitted.append(fit_response(rows, s, current, seed=seed))
    return save_responses(fitted, response_path(catalog)) if fitted else None
