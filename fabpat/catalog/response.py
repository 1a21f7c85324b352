"""Learned responses: a pattern's scenario energies, min width and area predicted from its cells in microseconds.

The paper proposes "learned responses replacing computationally-intensive, physically-based simulations of the
generic patterned surfaces" (§6). A :class:`Response` is that model for one polygon: fitted to a catalog's
simulated rows, it maps a pattern ID to the catalog's columns :data:`TARGETS` — ``energy_cantilever``,
``energy_cylinder``, ``energy_dome`` (N·mm) and ``min_width`` (mm), learned, each with an interval that holds the
truth with probability :data:`LEVEL` (90 %), and ``area`` (mm²), the lattice area, which is a sum over the cells
and computed exactly (:func:`lattice_area`; its interval is that one value).

What it reads (:func:`cell_features`, cheap: no filleting, no mesh): the slice's cells drawn on the depth-3
lattice (a depth-2 cell is its four depth-3 children, so one model serves both depths), the number of solid
cells per row (how far from the centre the material lies), the number of solid cell pairs that share an edge
(bars wide enough to carry moment) and that share only a vertex (the non-manifold joints that the fillet
bridges), and the depth.

The model (training only needs scikit-learn; prediction is numpy alone):

* each target's logarithm is fitted by gradient-boosted regression trees
  (:class:`sklearn.ensemble.GradientBoostingRegressor`, least squares, depth-3 trees), the logarithm because
  the energies span two decades and their errors are relative;
* the interval is split-conformal (Vovk et al., *Algorithmic Learning in a Random World*, 2005; Lei et al.,
  JASA 2018): the :data:`LEVEL` quantile of the absolute out-of-fold residuals of a 5-fold cross-validation,
  taken per depth when both depths were trained on (so depth-3 predictions carry depth-3 residuals), added on
  either side of the prediction in log space. It covers :data:`LEVEL` of patterns drawn like the training
  rows; further from them it is optimistic, which the held-out table in docs/learned-response.md measures.

Stored beside the catalog (:func:`response_path`: ``<catalog>.response.npz``; the built-in catalog's in
``fabpat/data``) as plain arrays (``numpy.load(..., allow_pickle=False)``: no pickles, no scikit-learn needed to
read): the trees, the residual quantiles, and the solver version of the rows it was fitted to. A model whose
solver version is not :func:`fabpat.catalog.solver_version` is refused, like a stale row
(:class:`~fabpat.errors.CatalogError`); ``fabpat sweep`` refits it after it computes rows.
"""

from __future__ import annotations

import io
import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.catalog.schema import builtin_path
from fabpat.catalog.version import solver_version
from fabpat.errors import CatalogError, FabpatError, PatternError
from fabpat.patterns.lattice import check_sides, depth_of_id, slice_lattice

if TYPE_CHECKING:
    from sklearn.ensemble import GradientBoostingRegressor

#: the catalog columns a response predicts, in this order
TARGETS = ("energy_cantilever", "energy_cylinder", "energy_dome", "min_width", "area")
#: the targets a response learns; ``area`` (the lattice area) is a sum over the cells, computed exactly
LEARNED = TARGETS[:4]
#: the probability that an interval holds the truth
LEVEL = 0.90
#: the depths a response reads (its features are drawn on the depth-3 lattice)
DEPTHS = (2, 3)
#: the layout of :func:`cell_features`; a stored model of another layout is refused
FEATURES_VERSION = 2
#: columns of :func:`cell_features`
N_FEATURES = 82
FOLDS = 5
#: boosting settings, measured on the hexagon catalog by 5-fold cross-validation (docs/learned-response.md)
TREES, TREE_DEPTH, LEARNING_RATE, SUBSAMPLE = 300, 3, 0.05, 0.8
_LATTICE = 3
_TREE_ARRAYS = ("feature", "threshold", "left", "right", "value")  # a Trees' arrays, as stored


@cache
def _refinement(depth: int) -> NDArray[np.int64]:
    """(4**3,) int: the depth-``depth`` cell that holds each depth-3 cell (by its centroid)."""
    IJ3, F3 = slice_lattice(_LATTICE)
    c = IJ3[F3].mean(axis=1) * 2.0 ** (depth - _LATTICE)  # centroids in depth-`depth` lattice units
    i, j = c[:, 0], c[:, 1]
    r = np.floor(i + j).astype(np.int64)
    fi, fj = np.floor(i).astype(np.int64), np.floor(j).astype(np.int64)
    down = (fi + fj) != r  # a centroid above the anti-diagonal of its unit square lies in a "down" cell
    k = np.where(down, 2 * fj + 1, 2 * fj)
    out = r * r + k  # row r starts at face r², position k in the row (lattice module's order)
    out.setflags(write=False)
    return out


@cache
def _adjacency() -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Pairs of depth-3 cells sharing an edge (e, 2) and sharing only a vertex (v, 2)."""
    _, F = slice_lattice(_LATTICE)
    edges: dict[tuple[int, int], list[int]] = {}
    verts: dict[int, list[int]] = {}
    for f, tri in enumerate(F.tolist()):
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            edges.setdefault((min(a, b), max(a, b)), []).append(f)
        for a in tri:
            verts.setdefault(a, []).append(f)
    by_edge = {tuple(sorted(v)) for v in edges.values() if len(v) == 2}
    by_vertex = {(a, b) for fs in verts.values() for a in fs for b in fs if a < b} - by_edge
    return np.array(sorted(by_edge), dtype=np.int64), np.array(sorted(by_vertex), dtype=np.int64)


def _bits(ids: Sequence[str], depth: int) -> NDArray[np.bool_]:
    """(k, 4**depth) bool cells of IDs of one depth, parsed as integers (vectorised: no per-bit Python)."""
    M = 4**depth
    digits = M // 4
    text = np.array([i.lower().removeprefix("0x").rjust(digits, "0") for i in ids], dtype=f"<U{digits}")
    codes = text.view(np.uint32).reshape(len(ids), digits).astype(np.int64)
    nibble = np.where(codes >= ord("a"), codes - ord("a") + 10, codes - ord("0"))
    shifts = np.arange(3, -1, -1)
    return ((nibble[:, :, None] >> shifts) & 1).astype(bool).reshape(len(ids), M)


def cell_features(ids: Sequence[str]) -> NDArray[np.float64]:
    """(k, 82) float features of valid pattern IDs of depth 2 or 3 (checked by :func:`check_ids`).

    Columns: the 64 depth-3 cells (1 solid), solid cells per row from the centre (8), solid pairs sharing
    an edge, sharing only a vertex, solid cells, the depth; and 6 zero columns kept for later features."""
    k = len(ids)
    X = np.zeros((k, N_FEATURES))
    depths = np.array([depth_of_id(i) for i in ids], dtype=np.int64)
    for d in DEPTHS:
        sel = np.nonzero(depths == d)[0]
        if sel.size:
            X[sel, :64] = _bits([ids[int(s)] for s in sel], d)[:, _refinement(d)]
    cells = X[:, :64]
    row = np.floor(np.sqrt(np.arange(64))).astype(np.int64)
    for r in range(8):
        X[:, 64 + r] = cells[:, row == r].sum(axis=1)
    by_edge, by_vertex = _adjacency()
    X[:, 72] = (cells[:, by_edge[:, 0]] * cells[:, by_edge[:, 1]]).sum(axis=1)
    X[:, 73] = (cells[:, by_vertex[:, 0]] * cells[:, by_vertex[:, 1]]).sum(axis=1)
    X[:, 74] = cells.sum(axis=1)
    X[:, 75] = depths
    return X


def lattice_area(X: NDArray[np.float64], sides: int, edge: float | None = None) -> NDArray[np.float64]:
    """(k,) lattice area in mm² (the catalog's ``area``) of :func:`cell_features` rows, exactly: the solid share
    of the 64 depth-3 cells times the ``sides``-gon's area, n·e²/(4·tan(π/n)), at the catalog's default edge."""
    from fabpat.catalog.schema import DEFAULT_SETUP

    e = float(str(DEFAULT_SETUP["edge"])) if edge is None else float(edge)
    return X[:, 74] / 64.0 * sides * e * e / (4.0 * math.tan(math.pi / sides))


def check_ids(ids: Sequence[str], sides: int) -> list[str]:
    """The IDs normalised (``0x``, lower case), each a connected, tileable pattern of depth 2 or 3.

    Raises :class:`~fabpat.errors.PatternError` naming the first ID that is not (not hexadecimal, another
    depth, fails the edge rule, or its solid pattern on the ``sides``-gon is in pieces)."""
    from fabpat.patterns.library import is_tileable

    if isinstance(ids, str) or not isinstance(ids, Sequence) or not ids:
        raise PatternError(f"pattern IDs must be a non-empty list of strings, got {ids!r}")
    sides = check_sides(sides)
    out = []
    for i in ids:
        if not isinstance(i, str):
            raise PatternError(f"a pattern ID is a string such as '0x0488', got {i!r}")
        d = depth_of_id(i)
        if d not in DEPTHS:
            raise PatternError(f"{i}: the learned response covers depths 2 and 3 (4 or 16 hex digits), "
                               f"not depth {d}")
        out.append("0x" + i.strip().lower().removeprefix("0x"))  # depth_of_id has checked the digits
    from fabpat.catalog.response_kernels import one_piece
    from fabpat.patterns.pattern import pattern_topology

    depths = np.array([depth_of_id(i) for i in out])
    for d in DEPTHS:
        sel = np.nonzero(depths == d)[0]
        if not sel.size:
            continue
        b = _bits([out[s] for s in sel], d)
        bad = ~is_tileable(b, d)
        if bad.any():
            raise PatternError(f"{out[sel[np.argmax(bad)]]} is not tileable: of the slice faces on the polygon edge "
                               "exactly the middle one must be solid (fabpat library lists valid IDs)")
        topo = pattern_topology(sides, d)
        bad = ~one_piece(np.ascontiguousarray(b[:, topo.slice_face]), np.ascontiguousarray(topo.F), topo.n_vertices)
        if bad.any():
            raise PatternError(f"{out[sel[np.argmax(bad)]]} is disconnected: its solid pattern on the {sides}-gon "
                               "is in pieces (fabpat library lists valid IDs)")
    return out


@dataclass(frozen=True, eq=False)
class Trees:
    """One boosted ensemble as arrays, padded to one node count: ``feature``, ``left``, ``right`` (T, n) int
    (−1 at a leaf), ``threshold`` and ``value`` (T, n) float; ``init`` and ``rate`` its offset and step."""

    feature: NDArray[np.int64]
    threshold: NDArray[np.float64]
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    value: NDArray[np.float64]
    init: float
    rate: float

    def predict(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """(k,) predictions for (k, f) features (:func:`~fabpat.catalog.response_kernels.walk_trees`)."""
        from fabpat.catalog.response_kernels import walk_trees

        leaves = walk_trees(np.ascontiguousarray(X, dtype=np.float64), self.feature, self.threshold, self.left,
                            self.right, self.value)
        return self.init + self.rate * leaves


@dataclass(frozen=True, eq=False)
class Prediction:
    """Predictions for ``ids`` (k,): ``values[name]`` (k,) and ``intervals[name]`` (k, 2) [low, high] at
    :data:`LEVEL`, for each name of :data:`TARGETS` (N·mm, mm, mm²)."""

    ids: tuple[str, ...]
    sides: int
    values: Mapping[str, NDArray[np.float64]]
    intervals: Mapping[str, NDArray[np.float64]]

    def records(self) -> list[dict[str, object]]:
        """One dict per ID: ``id``, ``sides``, each target and ``<target>_interval`` = [low, high]."""
        out: list[dict[str, object]] = []
        for n, i in enumerate(self.ids):
            rec: dict[str, object] = {"id": i, "sides": self.sides}
            for t in TARGETS:
                rec[t] = float(self.values[t][n])
                rec[f"{t}_interval"] = [float(x) for x in self.intervals[t][n]]
            out.append(rec)
        return out


@dataclass(frozen=True, eq=False)
class Response:
    """A learned response for one polygon: a :class:`Trees` per target (of its logarithm) and the residual
    quantiles ``spread[target][depth]`` (log units) that make the :data:`LEVEL` intervals.

    ``solver_version``: the rows' (see module doc); ``rows``: how many patterns it was fitted to, per depth;
    ``ids``: those patterns."""

    sides: int
    models: Mapping[str, Trees]
    spread: Mapping[str, Mapping[int, float]]
    solver_version: str
    rows: Mapping[int, int]
    ids: frozenset[str] = frozenset()

    def predict(self, ids: Sequence[str], *, extrapolate: bool = False, checked: bool = False) -> Prediction:
        """Predict every target for pattern IDs (checked by :func:`check_ids`; raises PatternError).

        A depth the model was fitted to no pattern of is refused (PatternError) unless ``extrapolate``: a
        depth-2 model ranks depth-3 patterns poorly (docs/learned-response.md), and its intervals would
        claim a coverage they do not have. With ``extrapolate`` such a depth gets the widest spread known.
        ``checked``: the IDs are :func:`check_ids`' answer already (not checked twice)."""
        ids = list(ids) if checked else check_ids(ids, self.sides)
        X = cell_features(ids)
        depth = X[:, 75].astype(np.int64)
        unseen = sorted(set(depth.tolist()) - set(self.rows))
        if unseen and not extrapolate:
            raise PatternError(f"the learned response of the {self.sides}-gon was fitted to depth "
                               f"{', '.join(map(str, sorted(self.rows)))} patterns only, not depth "
                               f"{', '.join(map(str, unseen))} (fabpat sweep --depth 3 --learn N adds such rows "
                               "and refits it)")
        values, intervals = {}, {}
        for t in LEARNED:
            log = self.models[t].predict(X)
            known = self.spread[t]
            fallback = max(known.values())
            q = np.array([known.get(int(d), fallback) for d in depth])
            values[t] = np.exp(log)
            intervals[t] = np.column_stack([np.exp(log - q), np.exp(log + q)])
        values["area"] = lattice_area(X, self.sides)
        intervals["area"] = np.column_stack([values["area"], values["area"]])  # exact: no interval
        return Prediction(tuple(ids), self.sides, values, intervals)


def _trees(model: GradientBoostingRegressor) -> Trees:
    """A fitted GradientBoostingRegressor's trees as padded arrays."""
    est = [e[0].tree_ for e in model.estimators_]
    n = max(t.node_count for t in est)

    def pad(get: str, fill: float, dtype: type) -> NDArray:
        out = np.full((len(est), n), fill, dtype=dtype)
        for k, t in enumerate(est):
            a = getattr(t, get)
            out[k, : t.node_count] = a.reshape(t.node_count, -1)[:, 0] if a.ndim > 1 else a
        return out

    init = float(np.ravel(model.init_.predict(np.zeros((1, model.n_features_in_))))[0])
    return Trees(pad("feature", 0, np.int64), pad("threshold", 0.0, np.float64), pad("children_left", -1, np.int64),
                 pad("children_right", -1, np.int64), pad("value", 0.0, np.float64), init,
                 float(model.learning_rate))


def _regressor(seed: int, trees: int = TREES) -> GradientBoostingRegressor:
    try:
        from sklearn.ensemble import GradientBoostingRegressor
    except ImportError as exc:  # a core dependency; an odd install may still lack it
        raise CatalogError("fitting a learned response needs scikit-learn (pip install scikit-learn)") from exc
    return GradientBoostingRegressor(n_estimators=trees, max_depth=TREE_DEPTH, learning_rate=LEARNING_RATE,
                                     subsample=SUBSAMPLE, random_state=seed)


def conformal_quantile(residuals: NDArray[np.float64], level: float = LEVEL) -> float:
    """The split-conformal radius: the ⌈(n + 1)·level⌉-th smallest absolute residual (Lei et al. 2018, §2)."""
    r = np.sort(np.abs(np.asarray(residuals, dtype=float)))
    k = min(math.ceil((r.size + 1) * level), r.size)
    return float(r[k - 1])


def training_arrays(rows: Sequence[Mapping[str, object]]) -> tuple[list[str], NDArray[np.float64]]:
    """IDs and (k, 5) targets of catalog rows (``fabpat.catalog()``'s dicts) with every target a positive
    finite number; rows without (a scenario that did not converge, a pattern that failed) are left out."""
    ids, Y = [], []
    for r in rows:
        y = [r.get(t) for t in TARGETS]
        if all(isinstance(v, int | float) and math.isfinite(v) and v > 0 for v in y):
            ids.append(str(r["id"]))
            Y.append(y)
    return ids, np.array(Y, dtype=float).reshape(-1, len(TARGETS))


def out_of_fold(X: NDArray[np.float64], Y: NDArray[np.float64], seed: int = 0, trees: int = TREES
                ) -> NDArray[np.float64]:
    """(k, m) out-of-fold predictions of log(Y) for targets Y (k, m) by :data:`FOLDS`-fold cross-validation
    (shuffled, seeded): each row predicted by a model that never saw it."""
    from sklearn.model_selection import KFold

    pred = np.zeros_like(Y)
    for train, test in KFold(FOLDS, shuffle=True, random_state=seed).split(X):
        for j in range(Y.shape[1]):
            m = _regressor(seed, trees).fit(X[train], np.log(Y[train, j]))
            pred[test, j] = m.predict(X[test])
    return pred


def fit_response(rows: Sequence[Mapping[str, object]], sides: int, version: str, *, seed: int = 0,
                 trees: int = TREES) -> Response:
    """Fit a :class:`Response` to catalog rows of one polygon (depth 2 and/or 3; see :func:`training_arrays`).

    ``version``: the solver version the rows were computed with; ``trees``: boosting stages per target.
    Costs ``FOLDS + 1`` fits per target (about 10 s for 430 rows on 2 cores). Raises
    :class:`~fabpat.errors.CatalogError` with fewer than 20 usable rows."""
    ids, Y = training_arrays(rows)
    if len(ids) < 20:
        raise CatalogError(f"a learned response needs at least 20 simulated patterns of the {sides}-gon, "
                           f"the catalog has {len(ids)} (run fabpat sweep first)")
    ids = check_ids(ids, sides)
    X = cell_features(ids)
    depth = X[:, 75].astype(np.int64)
    resid = out_of_fold(X, Y[:, : len(LEARNED)], seed, trees) - np.log(Y[:, : len(LEARNED)])
    models, spread = {}, {}
    for j, t in enumerate(LEARNED):
        models[t] = _trees(_regressor(seed, trees).fit(X, np.log(Y[:, j])))
        spread[t] = {int(d): conformal_quantile(resid[depth == d, j]) for d in np.unique(depth)}
    counts = {int(d): int((depth == d).sum()) for d in np.unique(depth)}
    return Response(sides, models, spread, version, counts, frozenset(ids))


# --- stored beside the catalog ----------------------------------------------------------------------------


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
            for field in _TREE_ARRAYS:
                arrays[f"{r.sides}/{t}/{field}"] = getattr(m, field)
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
    indices in range, children after their parent (so every walk ends: sklearn numbers nodes depth first)."""
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
    return Trees(feature, arrays["threshold"], left, right, arrays["value"], init, rate)


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
                                    {f: np.asarray(z[f"{s}/{t}/{f}"]) for f in _TREE_ARRAYS},
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


#: the fewest usable patterns of a polygon that ``fabpat sweep`` refits a response to (fewer: left alone)
MIN_ROWS = 50


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
        try:
            found = read_catalog(path, sides=sides, edge=DEFAULT_SETUP["edge"], thickness=DEFAULT_SETUP["thickness"],
                                 weight=DEFAULT_SETUP["weight"])
        except CatalogError:  # another catalog without this polygon or set-up adds nothing
            return []
        return [r for r in found if r["depth"] in DEPTHS]

    for s in polygons:
        rows = rows_of(catalog, s) + [r for extra in also for r in rows_of(extra, s)]
        if len(training_arrays(rows)[0]) >= min_rows:
            fitted.append(fit_response(rows, s, current, seed=seed))
    return save_responses(fitted, response_path(catalog)) if fitted else None
