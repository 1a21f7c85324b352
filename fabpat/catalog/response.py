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

The model (fitting needs scikit-learn; predicting, numpy and numba):

* each target's logarithm is fitted by gradient-boosted regression trees
  (:class:`sklearn.ensemble.GradientBoostingRegressor`, least squares, depth-3 trees), the logarithm because
  the energies span two decades and their errors are relative;
* the interval is split-conformal (Vovk et al., *Algorithmic Learning in a Random World*, 2005; Lei et al.,
  JASA 2018): the :data:`LEVEL` quantile of the absolute out-of-fold residuals of a 5-fold cross-validation,
  taken per depth when both depths were trained on (so depth-3 predictions carry depth-3 residuals), added on
  either side of the prediction in log space. It covers :data:`LEVEL` of patterns drawn like the training
  rows; further from them it is optimistic, which the held-out table in docs/learned-response.md measures.

Stored beside the catalog by :mod:`fabpat.catalog.response_file` (``<catalog>.response.npz``, plain arrays,
with the solver version of the rows it was fitted to: a stale model is refused like a stale row), which also
holds :func:`~fabpat.catalog.response_file.predict` (``fabpat.predict``); ``fabpat sweep`` refits it after it
computes rows.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import CatalogError, PatternError
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
FEATURES_VERSION = 3
#: columns of :func:`cell_features`
N_FEATURES = 82
#: the columns of :func:`cell_features` that the plate model fills (:mod:`fabpat.catalog.response_plate`)
PHYSICS = (76, 77, 78, 79)
#: a depth's own linear model on :data:`PHYSICS` needs this many rows of it (fewer: the pooled one)
MIN_LINEAR_ROWS = 20
FOLDS = 5
#: boosting settings, measured on the hexagon catalog by 5-fold cross-validation (docs/learned-response.md)
TREES, TREE_DEPTH, LEARNING_RATE, SUBSAMPLE = 300, 3, 0.05, 0.8
_LATTICE = 3
TREE_ARRAYS = ("feature", "threshold", "left", "right", "value")  # a Trees' arrays, as stored


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
    from fabpat.catalog.response_plate import face_pairs

    _, F = slice_lattice(_LATTICE)
    hinges, necks = face_pairs(F)
    by_edge = sorted({(h[0], h[1]) for h in hinges})
    return np.array(by_edge, dtype=np.int64).reshape(-1, 2), np.array(necks, dtype=np.int64).reshape(-1, 2)


def _bits(ids: Sequence[str], depth: int) -> NDArray[np.bool_]:
    """(k, 4**depth) bool cells of IDs of one depth, parsed as integers (vectorised: no per-bit Python)."""
    M = 4**depth
    digits = M // 4
    text = np.array([i.lower().removeprefix("0x").rjust(digits, "0") for i in ids], dtype=f"<U{digits}")
    codes = text.view(np.uint32).reshape(len(ids), digits).astype(np.int64)
    nibble = np.where(codes >= ord("a"), codes - ord("a") + 10, codes - ord("0"))
    shifts = np.arange(3, -1, -1)
    return ((nibble[:, :, None] >> shifts) & 1).astype(bool).reshape(len(ids), M)


def cell_features(ids: Sequence[str], sides: int = 6) -> NDArray[np.float64]:
    """(k, 82) float features of valid pattern IDs of depth 2 or 3 (checked by :func:`check_ids`) on the
    ``sides``-gon.

    Columns: the 64 depth-3 cells (1 solid), solid cells per row from the centre (8), solid pairs sharing
    an edge, sharing only a vertex, solid cells, the depth; the plate model's log cantilever, cylinder and
    dome compliances and log dome membrane energy (:data:`PHYSICS`,
    :func:`~fabpat.catalog.response_plate.plate_features`, on the pattern's own lattice); 2 zero columns."""
    from fabpat.catalog.response_plate import plate_features

    k = len(ids)
    X = np.zeros((k, N_FEATURES))
    depths = np.array([depth_of_id(i) for i in ids], dtype=np.int64)
    for d in DEPTHS:
        sel = np.nonzero(depths == d)[0]
        if sel.size:
            bits = _bits([ids[int(s)] for s in sel], d)
            X[sel, :64] = bits[:, _refinement(d)]
            X[np.ix_(sel, np.array(PHYSICS))] = plate_features(bits, sides, d)
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
    """One target's model: a linear model per depth on the :data:`PHYSICS` columns plus boosted trees on what
    it leaves. Trees as arrays padded to one node count: ``feature``, ``left``, ``right`` (T, n) int (−1 at a
    leaf), ``threshold`` and ``value`` (T, n) float; ``init`` and ``rate`` their offset and step;
    ``linear`` (len(DEPTHS), len(PHYSICS) + 1): per depth of :data:`DEPTHS`, the coefficients and the
    intercept (zero: trees alone)."""

    feature: NDArray[np.int64]
    threshold: NDArray[np.float64]
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    value: NDArray[np.float64]
    init: float
    rate: float
    linear: NDArray[np.float64] = dataclasses.field(
        default_factory=lambda: np.zeros((len(DEPTHS), len(PHYSICS) + 1)))

    def predict(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """(k,) predictions for (k, f) features (:func:`~fabpat.catalog.response_kernels.walk_trees`)."""
        from fabpat.catalog.response_kernels import walk_trees

        leaves = walk_trees(np.ascontiguousarray(X, dtype=np.float64), self.feature, self.threshold, self.left,
                            self.right, self.value)
        return self.init + self.rate * leaves + _linear(self.linear, X)


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
        X = cell_features(ids, self.sides)
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


def _linear(coef: NDArray[np.float64], X: NDArray[np.float64]) -> NDArray[np.float64]:
    """(k,) the per-depth linear part (:class:`Trees`' ``linear``) of (k, f) features."""
    row = np.clip(X[:, 75].astype(np.int64) - DEPTHS[0], 0, len(DEPTHS) - 1)
    c = coef[row]
    return np.einsum("kj,kj->k", X[:, list(PHYSICS)], c[:, :-1]) + c[:, -1]


def _fit_linear(X: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """(len(DEPTHS), len(PHYSICS) + 1) least-squares fits of y on the :data:`PHYSICS` columns, one per depth
    with at least :data:`MIN_LINEAR_ROWS` rows, the fit to every row for the others."""
    A = np.column_stack([X[:, list(PHYSICS)], np.ones(len(X))])
    pooled = np.linalg.lstsq(A, y, rcond=None)[0]
    out = np.tile(pooled, (len(DEPTHS), 1))
    for k, d in enumerate(DEPTHS):
        sel = X[:, 75] == d
        if sel.sum() >= MIN_LINEAR_ROWS:
            out[k] = np.linalg.lstsq(A[sel], y[sel], rcond=None)[0]
    return out


def _fit_target(X: NDArray[np.float64], y: NDArray[np.float64], seed: int, trees: int) -> Trees:
    """One target's :class:`Trees`: the linear model per depth, then the boosted trees on its residuals."""
    coef = _fit_linear(X, y)
    return _trees(_regressor(seed, trees).fit(X, y - _linear(coef, X)), coef)


def _trees(model: GradientBoostingRegressor, linear: NDArray[np.float64] | None = None) -> Trees:
    """A fitted GradientBoostingRegressor's trees as padded arrays (``linear``: :class:`Trees`' linear part,
    default none)."""
    est = [e[0].tree_ for e in model.estimators_]
    n = max(t.node_count for t in est)

    def pad(get: str, fill: float, dtype: type) -> NDArray:
        out = np.full((len(est), n), fill, dtype=dtype)
        for k, t in enumerate(est):
            a = getattr(t, get)
            out[k, : t.node_count] = a.reshape(t.node_count, -1)[:, 0] if a.ndim > 1 else a
        return out

    init = float(np.ravel(model.init_.predict(np.zeros((1, model.n_features_in_))))[0])
    coef = np.zeros((len(DEPTHS), len(PHYSICS) + 1)) if linear is None else np.asarray(linear, dtype=np.float64)
    return Trees(pad("feature", 0, np.int64), pad("threshold", 0.0, np.float64), pad("children_left", -1, np.int64),
                 pad("children_right", -1, np.int64), pad("value", 0.0, np.float64), init,
                 float(model.learning_rate), coef)


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
            pred[test, j] = _fit_target(X[train], np.log(Y[train, j]), seed, trees).predict(X[test])
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
    X = cell_features(ids, sides)
    depth = X[:, 75].astype(np.int64)
    resid = out_of_fold(X, Y[:, : len(LEARNED)], seed, trees) - np.log(Y[:, : len(LEARNED)])
    models, spread = {}, {}
    for j, t in enumerate(LEARNED):
        models[t] = _fit_target(X, np.log(Y[:, j]), seed, trees)
        spread[t] = {int(d): conformal_quantile(resid[depth == d, j]) for d in np.unique(depth)}
    counts = {int(d): int((depth == d).sum()) for d in np.unique(depth)}
    return Response(sides, models, spread, version, counts, frozenset(ids))


# --- stored beside the catalog ----------------------------------------------------------------------------
