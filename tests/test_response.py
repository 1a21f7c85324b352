"""The learned response (fabpat.catalog.response and response_file, ``fabpat predict``): its features, its trees against
scikit-learn's, its accuracy on patterns it never saw, its stored file, and what it refuses."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import spearmanr

import fabpat
from fabpat.catalog import response as R
from fabpat.catalog import response_file as RF
from fabpat.errors import CatalogError, PatternError
from fabpat.patterns.lattice import bits_to_id, id_to_bits
from fabpat.patterns.library import is_connected, is_tileable

ENERGIES = ("energy_cantilever", "energy_cylinder", "energy_dome")


@pytest.fixture(scope="module")
def hexagons() -> tuple[list[str], np.ndarray]:
    return R.training_arrays(fabpat.catalog(sides=6))


def test_a_depth_2_pattern_and_its_depth_3_refinement_have_the_same_cells() -> None:
    # 0x0488 drawn on the depth-3 lattice by hand: each depth-2 cell becomes its four children
    ids2 = ["0x0488", "0x0508", "0xda08"]
    ids3 = [bits_to_id(id_to_bits(i, 2)[R._refinement(2)]) for i in ids2]
    X2, X3 = R.cell_features(ids2), R.cell_features(ids3)
    assert np.array_equal(X2[:, :75], X3[:, :75])
    assert list(X2[:, 75]) == [2, 2, 2] and list(X3[:, 75]) == [3, 3, 3]
    assert list(X2[:, 74]) == [4 * id_to_bits(i, 2).sum() for i in ids2]  # solid cells: 4 per depth-2 cell


@pytest.mark.parametrize("sides", [5, 6])
def test_the_compiled_connectivity_check_agrees_with_the_library_on_every_depth_2_slice(sides: int) -> None:
    bits = ((np.arange(1, 2**16)[:, None] >> np.arange(15, -1, -1)) & 1).astype(bool)  # every depth-2 slice
    bits = bits[is_tileable(bits, 2)]
    ids = [bits_to_id(b) for b in bits]
    want = is_connected(bits, sides, 2)
    assert want.sum() == 430  # the paper's count (notes: the same for every n)
    good = [i for i, w in zip(ids, want, strict=True) if w]
    assert R.check_ids(good, sides) == good
    for i in [i for i, w in zip(ids, want, strict=True) if not w][:5]:
        with pytest.raises(PatternError, match="disconnected"):
            R.check_ids([i], sides)


def test_the_trees_walk_like_scikit_learns(hexagons: tuple[list[str], np.ndarray]) -> None:
    ids, Y = hexagons
    X = R.cell_features(ids)
    model = R._regressor(3).fit(X[:200], np.log(Y[:200, 1]))
    assert np.allclose(R._trees(model).predict(X), model.predict(X), rtol=0, atol=1e-12)


def test_energies_of_patterns_it_never_saw(hexagons: tuple[list[str], np.ndarray]) -> None:
    """5-fold cross-validation on the hexagon catalog (every pattern predicted by a model that never saw it):
    rank correlation ≥ 0.95 and median relative error ≤ 5 % per scenario; intervals calibrated on the
    even-numbered patterns cover 85–95 % of the odd-numbered ones."""
    ids, Y = hexagons
    Y = Y[:, :3]
    oof = R.out_of_fold(R.cell_features(ids), Y)
    resid = oof - np.log(Y)
    for j, name in enumerate(ENERGIES):
        rho = spearmanr(oof[:, j], np.log(Y[:, j])).statistic
        median = np.median(np.abs(np.expm1(resid[:, j])))
        q = R.conformal_quantile(resid[0::2, j])
        cover = np.mean(np.abs(resid[1::2, j]) <= q)
        assert rho >= 0.95, (name, rho)
        assert median <= 0.05, (name, median)
        assert 0.85 <= cover <= 0.95, (name, cover)


def test_conformal_quantile() -> None:
    r = np.arange(1.0, 20.0)  # 19 residuals: the ceil(20 * 0.9) = 18th smallest
    assert R.conformal_quantile(r) == 18.0
    assert R.conformal_quantile(-r) == 18.0
    assert R.conformal_quantile(np.array([0.5, 0.1])) == 0.5


def _small_response(hexagons: tuple[list[str], np.ndarray], version: str) -> R.Response:
    ids, Y = hexagons
    rows = [{"id": i, **dict(zip(R.TARGETS, y, strict=True))} for i, y in zip(ids[:60], Y[:60], strict=True)]
    return R.fit_response(rows, 6, version, trees=10)  # few trees: this is about the file, not accuracy


def test_a_stored_response_predicts_the_same_and_a_stale_one_is_refused(
        hexagons: tuple[list[str], np.ndarray], tmp_path) -> None:  # noqa: ANN001
    db = tmp_path / "mine.sqlite"
    fresh = _small_response(hexagons, fabpat.catalog.solver_version())
    path = RF.save_responses([fresh], RF.response_path(db))
    assert path.name == "mine.sqlite.response.npz"
    ids = hexagons[0][100:110]
    a, b = fresh.predict(ids), RF.predict(ids, 6, db)
    for t in R.TARGETS:
        assert np.array_equal(a.values[t], b.values[t]) and np.array_equal(a.intervals[t], b.intervals[t])
        assert np.all(b.intervals[t][:, 0] <= b.values[t]) and np.all(b.values[t] <= b.intervals[t][:, 1])
    with pytest.raises(CatalogError, match="no learned response for the 5-gon"):
        RF.predict(ids, 5, db)
    deeper = bits_to_id(id_to_bits(ids[0], 2)[R._refinement(2)])  # a depth-3 ID: a depth the model never saw
    with pytest.raises(PatternError, match="fitted to depth 2 patterns only, not depth 3"):
        RF.predict([deeper], 6, db)
    assert fresh.predict([deeper], extrapolate=True).values["energy_dome"].shape == (1,)
    RF.save_responses([dataclasses.replace(fresh, solver_version="fabpat 0.0.1+000000000000")], RF.response_path(db))
    with pytest.raises(CatalogError, match="stale"):
        RF.predict(ids, 6, db)
    r = subprocess.run([sys.executable, "-m", "fabpat", "predict", ids[0], "--db", str(db)], capture_output=True,
                       text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.count("\n") == 1 and "stale" in r.stderr


@pytest.mark.parametrize("bad, reason", [("0xzz88", "hex"), ("0x0001", "tileable"), ("0x048", "digits"),
                                         ("0x" + "0" * 63 + "1", "depths 2 and 3")])
def test_bad_ids_are_refused_by_name(bad: str, reason: str) -> None:
    with pytest.raises(PatternError) as e:
        fabpat.predict(bad)
    assert reason in str(e.value) or bad.removeprefix("0x") in str(e.value)


def test_predict_on_the_command_line() -> None:
    """The built-in response is shipped, current, and answers in the documented JSON form."""
    r = subprocess.run([sys.executable, "-m", "fabpat", "predict", "0x0488", "0X0508", "--json"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert [o["id"] for o in out] == ["0x0488", "0x0508"]
    truth = {row["id"]: row for row in fabpat.catalog(sides=6)}
    for o in out:
        for t in R.TARGETS:
            low, high = o[f"{t}_interval"]
            assert 0 < low <= o[t] <= high
            assert abs(o[t] / truth[o["id"]][t] - 1) < 0.5  # trained on these rows: far from exact would be a bug
    bad = subprocess.run([sys.executable, "-m", "fabpat", "predict", "0x0001"], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.startswith("fabpat: error: 0x0001 is not tileable")
    assert bad.stderr.count("\n") == 1


def test_learning_picks_the_pools_printable_extremes(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    from fabpat.catalog import learn
    from fabpat.catalog.learn import SCENARIO, choose
    from fabpat.patterns.library import sample_library

    assert learn.printable_floor() == 0.8  # mm: two perimeters of a 0.4 mm nozzle
    pool = list(sample_library(6, 3, 300, seed=4).ids)
    model = learn.model_for(tmp_path / "none.sqlite", 6)
    p = model.predict(pool, extrapolate=True)
    lows, highs = p.intervals[SCENARIO][:, 0], p.intervals[SCENARIO][:, 1]
    # the two extremes are not printable: the choice must skip them (a fake width, so no fillet is needed)
    bad = {p.ids[int(np.argmin(lows))], p.ids[int(np.argmax(highs))]}
    monkeypatch.setattr(learn, "exact_min_width", lambda i, sides: 0.5 if i in bad else 1.0)
    chosen = choose(tmp_path / "none.sqlite", 6, pool, 4)
    assert len(chosen) == len(set(chosen)) == 4 and set(chosen) <= set(pool) and not bad & set(chosen)
    ok = np.array([i not in bad for i in p.ids])
    at = {i: k for k, i in enumerate(p.ids)}
    assert lows[at[chosen[0]]] == lows[ok].min()  # the stiffest the interval allows, first
    assert highs[at[chosen[1]]] == highs[ok].max()  # then the softest
    assert choose(tmp_path / "none.sqlite", 6, pool, 4) == chosen  # a re-run (an interrupted sweep) resumes


def test_the_exact_min_width_of_a_depth_3_pattern() -> None:
    from fabpat.catalog.learn import exact_min_width

    # 0x0488 drawn at depth 3 is the same outline but for its finer fillets: half the depth-2 neck of 1.95 mm
    deeper = bits_to_id(id_to_bits("0x0488", 2)[R._refinement(2)])
    truth = {row["id"]: row["min_width"] for row in fabpat.catalog(sides=6)}["0x0488"]
    assert exact_min_width("0x0488", 6) == pytest.approx(truth, rel=1e-9)
    assert exact_min_width(deeper, 6) < 1.5


@pytest.mark.parametrize("args, says", [(["--learn", "0", "--depth", "3"], "--learn"),
                                        (["--learn", "2"], "give --depth 3")])
def test_bad_learn_options(args: list[str], says: str, tmp_path) -> None:  # noqa: ANN001
    r = subprocess.run([sys.executable, "-m", "fabpat", "sweep", *args, "--db", str(tmp_path / "c.sqlite")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and says in r.stderr
    assert not (tmp_path / "c.sqlite").exists()


@pytest.mark.parametrize("damage", ["feature out of range", "child before parent", "a cycle", "float32 features",
                                    "truncated", "empty", "meta a list", "nan init", "negative spread"])
def test_a_damaged_response_file_is_refused_by_name(damage: str, hexagons: tuple[list[str], np.ndarray],
                                                    tmp_path) -> None:  # noqa: ANN001
    db = tmp_path / "c.sqlite"
    path = RF.save_responses([_small_response(hexagons, fabpat.catalog.solver_version())], RF.response_path(db))
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    key = "6/energy_dome/"
    meta = json.loads(str(arrays["meta"]))
    if damage == "feature out of range":
        arrays[key + "feature"] = arrays[key + "feature"] + 1000
    elif damage == "child before parent":
        arrays[key + "left"] = np.where(arrays[key + "left"] > 0, 0, arrays[key + "left"])
    elif damage == "a cycle":
        arrays[key + "left"][:, :] = 0
        arrays[key + "right"][:, :] = 0
    elif damage == "float32 features":
        arrays[key + "feature"] = arrays[key + "feature"].astype(np.float32)
    elif damage == "meta a list":
        arrays["meta"] = np.array(json.dumps([meta]))
    elif damage == "nan init":
        meta["responses"][0]["init"]["energy_dome"] = float("nan")
        arrays["meta"] = np.array(json.dumps(meta))
    elif damage == "negative spread":
        meta["responses"][0]["spread"]["energy_dome"]["2"] = -1.0
        arrays["meta"] = np.array(json.dumps(meta))
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[:100])
    elif damage == "empty":
        path.write_bytes(b"")
    else:
        np.savez(path.open("wb"), **arrays)
    with pytest.raises(CatalogError, match="c.sqlite.response.npz"):
        fabpat.predict(["0x0488"], 6, db)


def test_a_fifo_or_an_empty_name_is_refused_not_opened(tmp_path) -> None:  # noqa: ANN001
    import os

    os.mkfifo(tmp_path / "f.sqlite.response.npz")
    with pytest.raises(CatalogError, match="not a regular file"):
        fabpat.predict(["0x0488"], 6, tmp_path / "f.sqlite")  # a FIFO opened for reading would block
    for bad in ("", 3, "/"):
        with pytest.raises(CatalogError, match="file name"):
            fabpat.predict(["0x0488"], 6, bad)  # type: ignore[arg-type]


def test_ids_on_standard_input_and_the_exact_area() -> None:
    ids = [row["id"] for row in fabpat.catalog(sides=5)][:40]
    r = subprocess.run([sys.executable, "-m", "fabpat", "predict", "-", "--sides", "5", "--json"],
                       input="\n".join(ids), capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    truth = {row["id"]: row["area"] for row in fabpat.catalog(sides=5)}
    assert [o["id"] for o in out] == ids
    for o in out:
        assert o["area"] == pytest.approx(truth[o["id"]], rel=1e-12) and o["area_interval"] == [o["area"]] * 2
