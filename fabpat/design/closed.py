"""Designing a closed tiling (the truncated icosahedron): one pattern per face group, found by solves.

**Design variables.** The faces fall into groups (:func:`face_groups`): by polygon (hexagons,
pentagons) and, for a target that is not round, by latitude band about the design axis (the
polyhedron's 5-fold axis through face P01's centre: :data:`fabpat.design.target.BANDS` bands of equal
height in cos θ), so that an ellipsoid's poles and equator can differ. Every face of a group takes one
pattern from its polygon's catalog, or one of their family members the catalog holds (a candidate like
any other, named ``"ID bW"``: :mod:`fabpat.assembly.choose.members`, unless ``variations = false``); with
``max_distinct`` K the groups share at most K patterns (a member counts as its own).

**No reduced model.** Unlike a strip (an elastica), the closed shape depends on how each pattern bends
into double curvature, which its three catalog energies describe only loosely: measured on the sphere
(docs/design.md), pairs with the same Dome energies close 0.17 % to 0.7 % out of round. So the search
is Bayesian optimisation over the catalog's pattern features (:func:`pattern_features`): a Gaussian
process of log(relative rms) over the groups' features, fitted to every solve so far (Rasmussen &
Williams, *Gaussian Processes for Machine Learning*, 2006, eq. 2.25–2.26: squared-exponential kernel,
length scale and noise fixed below), and each batch the candidates of lowest lower confidence bound
μ − κσ (Srinivas et al., ICML 2010) among every one-group change of the best design, every symmetric
design (one pattern per polygon) near it, and random designs. A design over the strain limit counts
as unreachable (its error is multiplied by :data:`OVER_LIMIT_PENALTY`).

**Start.** The base spec's own patterns (explicit, or its rule's pair), then space-filling symmetric
designs (farthest-point in feature space) and one single pattern on every face.

**Family members refine a choice** (:data:`MEMBER_SHARE`). A member is its pattern with another bridge
weight, a continuous variation of one discrete choice, and the pools hold about five members per pattern,
so one search over everything samples the patterns six times more thinly: measured on the sphere at
40 solves, that search ended at the hand-picked pair (0.154 %), while the patterns alone found 0x0488 /
0x1c08 (0.146 %, in the 38th solve). So the search runs over the paper's members first and gives its
last share of the budget to the designs whose every group takes the best design's pattern or one of its
members. Features are standardised over the paper's members in both phases, so the first is the
search ``variations = false`` runs.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

Arr = NDArray[np.float64]

#: squared-exponential length scale in standardised feature units, per √(feature count)
LENGTH_SCALE = 0.9
#: GP noise variance over the signal variance (solver tolerance and mesh noise)
NOISE = 1e-3
#: κ of the lower confidence bound μ − κσ
KAPPA = 1.5
#: a design over the strain limit: its error counts this many times (it cannot be built)
OVER_LIMIT_PENALTY = 10.0
#: random designs scored per batch besides the one-group changes
RANDOM_DESIGNS = 3000
#: symmetric space-filling designs solved at the start
START_DESIGNS = 4
#: warm-start every solve from the best design's closed state (the same equilibrium, measured: 5
#: factorizations instead of 20 for a changed pentagon pattern on the shipped sphere)
WARM_START = True
#: a pentagon-free tiling whose unit face normals' mean is at least this long is a cap (:func:`design_axis`): a
#: one-ring flat cap's is 1, a two-ring pentagon dome's 0.93, a closed tiling's 0
CAP_MEAN_NORMAL = 0.5
#: ... and one whose normals' Σ n nᵀ has an eigenvalue at most this fraction of the face count is a tube (0 for a
#: cylinder's faces, 1/3 for a sphere's)
TUBE_EIGENVALUE = 0.05
#: with family members among the candidates, the share of the budget (rounded down) spent on the best
#: design's own patterns and their members after the search over the paper's members (module doc)
MEMBER_SHARE = 1 / 3


def pattern_features(rows: list[dict[str, Any]]) -> tuple[list[str], Arr]:
    """IDs and (n, 5) standardised features of catalog rows: log Dome, Cylinder and Cantilever energies,
    filleted area ratio, log min width (the rows' columns of :func:`fabpat.catalog.catalog`; a family
    member's row, :func:`fabpat.assembly.choose.members.member_rows`, has the same columns and a
    ``bridge_weight``). Standardised by the mean and standard deviation of the paper's members (rows
    without ``bridge_weight``) when there are any, so that adding members moves no pattern's features."""
    keep = [r for r in rows if all(r.get(f"converged_{s}") for s in ("dome", "cylinder", "cantilever"))
            and r.get("min_width")]
    ids = [str(r["id"]) for r in keep]
    F = np.array([[math.log(r["energy_dome"]), math.log(r["energy_cylinder"]), math.log(r["energy_cantilever"]),
                   float(r["filleted_ratio"]), math.log(r["min_width"])] for r in keep], dtype=np.float64)
    paper = np.array(["bridge_weight" not in r for r in keep], dtype=bool)
    ref = F[paper] if paper.any() else F
    sd = ref.std(axis=0)
    return ids, (F - ref.mean(axis=0)) / np.where(sd > 0, sd, 1.0)


def pattern_of(candidate: str) -> str:
    """The pattern ID of a candidate name (a family member is ``"ID bW"``)."""
    return candidate.split()[0]


def design_axis(V: Arr, faces: tuple[tuple[int, ...], ...]) -> Arr:
    """Unit design axis: from the polyhedron's centre to the centre of its first pentagon. A tiling without one:
    a cap's (its faces' unit normals' mean, when that is at least :data:`CAP_MEAN_NORMAL` long: they lean round
    one direction), else a tube's (the direction that every face normal is nearly square to: the eigenvector of
    Σ n nᵀ of the smallest eigenvalue, when that is at most :data:`TUBE_EIGENVALUE` of their count; its largest
    component positive), else from the centre to face 0's centre."""
    c = V.mean(axis=0)
    f = next((k for k, loop in enumerate(faces) if len(loop) == 5), None)
    if f is None:
        from fabpat.geometry.polygons import newell_normal

        N = np.array([newell_normal(V[list(loop)] - V[list(loop)].mean(axis=0)) for loop in faces])
        N /= np.maximum(np.linalg.norm(N, axis=1), 1e-300)[:, None]
        mean = N.mean(axis=0)
        if np.linalg.norm(mean) >= CAP_MEAN_NORMAL:
            return mean / np.linalg.norm(mean)
        val, vec = np.linalg.eigh(N.T @ N)
        if val[0] <= TUBE_EIGENVALUE * len(N):
            a = vec[:, 0]
            return a if a[int(np.argmax(np.abs(a)))] > 0 else -a
        f = 0
    a = V[list(faces[f])].mean(axis=0) - c
    return a / np.linalg.norm(a)


def face_groups(V: Arr, faces: tuple[tuple[int, ...], ...], bands: int) -> tuple[list[int], list[int]]:
    """(group of each face, polygon sides of each group): faces grouped by polygon and by ``bands``
    latitude bands of |cos θ| about :func:`design_axis`."""
    axis = design_axis(V, faces)
    c = V.mean(axis=0)
    keys = []
    for loop in faces:
        d = V[list(loop)].mean(axis=0) - c
        cos = abs(float(d @ axis)) / float(np.linalg.norm(d))
        keys.append((len(loop), min(int(cos * bands), bands - 1)))
    order = sorted(set(keys), key=lambda k: (-k[0], k[1]))
    return [order.index(k) for k in keys], [k[0] for k in order]


def solve_closed(spec: Any, patterns: tuple[str, ...], h: float,
                 start: tuple[Arr, Arr, Arr, Arr] | None = None) -> dict[str, Any]:
    """One full closure (the ``simulate-assembly`` path of a closed spec) with face patterns ``patterns``
    (candidate names: a family member is ``"ID bW"``, :func:`fabpat.assembly.choose.members.with_candidates`),
    warm-started
    from ``start`` = the ``state`` of an earlier solve of the same tiling if given.
    Returns plain data: ``faces`` the patterns, ``P`` (n, 3) the deformed plate nodes (mm),
    ``peak_strain``, ``seconds``, ``radius`` and ``sphericity_rms`` of the least-squares sphere,
    ``plate_energies`` (N·mm), ``offsets`` (plates + 1,) each face's first node in P (faces in the tiling's
    order), ``state`` (reference nodes, offsets, displacement, rotation: a later solve's warm start),
    ``factorizations``, ``warm`` (the warm start converged). Raises SolverError, GeometryError."""
    from fabpat.assembly.choose.members import with_candidates
    from fabpat.assembly.solve.closure import closure_setup, run_closure
    from fabpat.assembly.solve.model import warm_guess

    t0 = time.perf_counter()
    spec, ids = with_candidates(spec, patterns)
    setup = closure_setup(spec, ids, h=h)
    m = setup.model
    guess = None if start is None else warm_guess(*start, m.X, m.offsets)
    run = run_closure(setup, strain_limit=spec.material.strain_limit, start=guess)
    n = len(setup.model.X)
    fin = run.result.final
    return {"P": run.x[:n], "peak_strain": run.peak_strain, "radius": run.radius,
            "sphericity_rms": run.sphericity_rms, "seconds": time.perf_counter() - t0,
            "plate_energies": run.plate_energies, "faces": list(patterns),
            "offsets": np.asarray(setup.model.offsets, dtype=np.int64),
            "state": (m.X, np.asarray(m.offsets), fin.displacement, fin.rotation),
            "factorizations": run.result.factorizations, "warm": run.result.warm}


class _GP:
    """Gaussian-process regression with a squared-exponential kernel on standardised targets (Rasmussen &
    Williams 2006, eq. 2.25–2.26); length scale :data:`LENGTH_SCALE`·√d, noise :data:`NOISE`."""

    def __init__(self, X: Arr, y: Arr) -> None:
        self.X = X
        self.ell = LENGTH_SCALE * math.sqrt(X.shape[1])
        self.mean, self.sd = float(y.mean()), float(y.std()) or 1.0
        self.L = np.linalg.cholesky(self._k(X, X) + NOISE * np.eye(len(X)))
        self.alpha = np.linalg.solve(self.L.T, np.linalg.solve(self.L, (y - self.mean) / self.sd))

    def _k(self, A: Arr, B: Arr) -> Arr:
        d2 = (A * A).sum(axis=1)[:, None] + (B * B).sum(axis=1)[None, :] - 2.0 * A @ B.T
        return np.exp(-0.5 * np.maximum(d2, 0.0) / (self.ell * self.ell))

    def predict(self, Xc: Arr) -> tuple[Arr, Arr]:
        """Posterior mean and standard deviation at the rows of Xc (the targets' units)."""
        Ks = self._k(Xc, self.X)
        v = np.linalg.solve(self.L, Ks.T)
        sigma = np.sqrt(np.maximum(1.0 - (v * v).sum(axis=0), 0.0))
        return self.mean + self.sd * (Ks @ self.alpha), self.sd * sigma


@dataclass(frozen=True, eq=False)
class ClosedEvaluated:
    """A solved closed design: ``key`` the candidate index per group, the fit, the solve's data."""

    key: tuple[int, ...]
    fit: Any
    data: dict[str, Any]
    over_limit: bool

    @property
    def rms(self) -> float:
        """RMS distance from the target (mm)."""
        return float(self.fit.rms)

    @property
    def max(self) -> float:
        """Largest distance from the target (mm)."""
        return float(self.fit.max)

    def parts(self, face_group: list[int], groups: int) -> tuple[Arr, Arr, Arr]:
        """(within, offset, weight), each (groups,): per face group the RMS of the signed distances about
        the group's mean, that mean (both over the radius) and the group's share of the nodes, so that
        relative_rms² = Σ weight·(within² + offset²) exactly."""
        off = self.data["offsets"]
        d = self.fit.signed / self.fit.radius
        node_group = np.repeat(np.asarray(face_group), np.diff(off))
        within, offset, weight = np.zeros(groups), np.zeros(groups), np.zeros(groups)
        for g in range(groups):
            x = d[node_group == g]
            offset[g] = x.mean()
            within[g] = np.sqrt(np.mean((x - offset[g]) ** 2))
            weight[g] = len(x) / len(d)
        return within, offset, weight

    @property
    def score(self) -> float:
        """What the search minimises: relative rms, penalised over the strain limit."""
        return float(self.fit.relative_rms) * (OVER_LIMIT_PENALTY if self.over_limit else 1.0)


@dataclass
class ClosedSearch:
    """State of one closed design search. ``pools[g]`` (IDs, features) of group g's polygon,
    ``face_group`` the group of every face, ``target`` the ClosedTarget, ``axis`` the design axis."""

    pools: list[tuple[list[str], Arr]]
    face_group: list[int]
    group_sides: list[int]
    target: Any
    axis: Arr
    strain_limit: float
    max_distinct: int | None
    runner: Any
    seed: int = 0
    seen: dict[tuple[int, ...], ClosedEvaluated | None] = field(default_factory=dict)
    best: ClosedEvaluated | None = None
    #: per group the pool indices the search may propose (None: the whole pool): :meth:`papers_only`,
    #: :meth:`around_best`
    allowed: list[list[int]] | None = None
    #: propose only changes of the best design (one group, or every group of a polygon), no random designs: a
    #: refinement from a seeded best (:meth:`seeded`)
    local: bool = False

    def choices(self, g: int) -> list[int]:
        """Pool indices of group g that the search may propose now."""
        return list(range(len(self.pools[g][0]))) if self.allowed is None else self.allowed[g]

    def has_members(self) -> bool:
        """Whether any pool holds a family member (a candidate named ``"ID bW"``)."""
        return any(" " in pid for ids, _ in self.pools for pid in ids)

    def papers_only(self) -> None:
        """Propose the paper's members only (module doc: family members refine a choice)."""
        self.allowed = [[i for i, pid in enumerate(ids) if " " not in pid] for ids, _ in self.pools]

    def around_best(self) -> None:
        """Propose, per group, only the best design's pattern and its family members."""
        assert self.best is not None
        self.allowed = []
        for g, (ids, _) in enumerate(self.pools):
            own = pattern_of(ids[self.best.key[g]])
            self.allowed.append([i for i, pid in enumerate(ids) if pattern_of(pid) == own])

    def faces(self, key: tuple[int, ...]) -> tuple[str, ...]:
        """Face patterns of a design."""
        return tuple(self.pools[self.face_group[f]][0][key[self.face_group[f]]] for f in range(len(self.face_group)))

    def key_of(self, faces: list[str]) -> tuple[int, ...] | None:
        """The design whose face patterns are ``faces`` (one per group), or None if it is not one."""
        key = []
        for g in range(len(self.pools)):
            ids = {faces[f] for f in range(len(faces)) if self.face_group[f] == g}
            if len(ids) != 1 or next(iter(ids)) not in self.pools[g][0]:
                return None
            key.append(self.pools[g][0].index(next(iter(ids))))
        return tuple(key)

    def seeded(self, coarse: ClosedSearch) -> None:
        """Take every solve of ``coarse``, a search over coarser groups of the same faces and the same pools per
        polygon (face f's group there: ``coarse.face_group[f]``), as solves of this one, its best as this one's
        best, and propose only changes of the best from now on (:attr:`local`): the refinement that starts at
        the coarse optimum, so it ends no worse than it (a change is kept only when its solve is better)."""
        def key(k: tuple[int, ...]) -> tuple[int, ...]:
            return tuple(k[coarse.face_group[f]] for f in range(len(self.face_group)))

        for k, ev in coarse.seen.items():
            self.seen[key(k)] = None if ev is None else ClosedEvaluated(key(k), ev.fit, ev.data, ev.over_limit)
        if coarse.best is not None:
            self.best = self.seen[key(coarse.best.key)]
        self.local = True
        # per face the candidates the groups' solves tried on its polygon, and the best's own pattern with its family
        # members: the surrogate knows those, and 32 faces × every candidate would be ~80 000 designs a batch
        tried = {s: {k[g] for k in coarse.seen for g, gs in enumerate(coarse.group_sides) if gs == s}
                 for s in set(self.group_sides)}
        self.allowed = []
        for f, (ids, _) in enumerate(self.pools):
            own = pattern_of(ids[self.best.key[f]]) if self.best is not None else None
            family = {i for i, pid in enumerate(ids) if pattern_of(pid) == own}
            self.allowed.append(sorted(tried[self.group_sides[f]] | family))

    def evaluate(self, keys: list[tuple[int, ...]]) -> list[ClosedEvaluated | None]:
        """Solve the designs not seen yet (one batch, warm-started from the best design so far); None for a
        failed solve."""
        new = list(dict.fromkeys(k for k in keys if k not in self.seen))
        state = None if self.best is None or not WARM_START else self.best.data.get("state")
        warm = None if state is None else (state,)

        def finished(i: int, res: dict[str, Any] | BaseException) -> None:  # as it comes: a stop keeps it
            self.seen[new[i]] = None if isinstance(res, BaseException) else self.record(new[i], res)

        self.runner.run([self.faces(k) for k in new], warm, finished)
        return [self.seen[k] for k in keys]

    def record(self, key: tuple[int, ...], res: dict[str, Any]) -> ClosedEvaluated:
        """A solve's evaluation (the target fitted to its nodes); updates ``best``."""
        ev = ClosedEvaluated(key, self.target.fit(res["P"], self.axis), res, res["peak_strain"] > self.strain_limit)
        if self.best is None or ev.score < self.best.score:
            self.best = ev
        return ev

    def distinct_ok(self, key: tuple[int, ...]) -> bool:
        """Whether ``key`` uses at most max_distinct distinct patterns."""
        if self.max_distinct is None:
            return True
        return len({self.pools[g][0][i] for g, i in enumerate(key)}) <= self.max_distinct

    def _x(self, keys: list[tuple[int, ...]]) -> Arr:
        return np.array([np.concatenate([self.pools[g][1][i] for g, i in enumerate(k)]) for k in keys])

    def start(self) -> list[tuple[int, ...]]:
        """Space-filling symmetric designs: farthest-point picks per polygon (the first the pool's median
        by Dome energy), the same pick for every group of one polygon."""
        picks: dict[int, list[int]] = {}
        for sides in set(self.group_sides):
            g = self.group_sides.index(sides)
            idx = np.asarray(self.choices(g), dtype=np.int64)
            F = self.pools[g][1][idx]
            chosen = [int(np.argsort(F[:, 0])[len(F) // 2])]
            while len(chosen) < min(START_DESIGNS, len(F)):
                d = np.min(np.linalg.norm(F[:, None, :] - F[chosen][None, :, :], axis=2), axis=1)
                chosen.append(int(np.argmax(d)))
            picks[sides] = [int(idx[c]) for c in chosen]
        keys = []
        for j in range(START_DESIGNS):
            key = tuple(picks[s][j % len(picks[s])] for s in self.group_sides)
            if self.distinct_ok(key):
                keys.append(key)
        return keys

    def _candidates(self, rng: np.random.Generator) -> list[tuple[int, ...]]:
        assert self.best is not None
        b = self.best.key
        out = set()
        choices = [self.choices(g) for g in range(len(b))]
        for g in range(len(b)):
            for i in choices[g]:
                out.add(b[:g] + (i,) + b[g + 1:])
        for sides in set(self.group_sides):  # every group of one polygon changed together
            gs = [g for g, s in enumerate(self.group_sides) if s == sides]
            for i in choices[gs[0]]:
                out.add(tuple(i if g in gs else b[g] for g in range(len(b))))
        for _ in range(0 if self.local else RANDOM_DESIGNS):
            out.add(tuple(c[int(rng.integers(len(c)))] for c in choices))
        return [k for k in out if k not in self.seen and self.distinct_ok(k)]

    def propose(self, count: int, rng: np.random.Generator) -> list[tuple[int, ...]]:
        """The ``count`` unseen designs of lowest lower confidence bound of the predicted relative rms
        (module doc: the within-group and offset surrogates); designs predicted over the strain limit
        with confidence are left out."""
        done = [(k, ev) for k, ev in self.seen.items() if ev is not None]
        cands = self._candidates(rng)
        if not done or not cands:
            return cands[:count]
        G = len(self.pools)
        parts = [ev.parts(self.face_group, G) for _, ev in done]
        weight = self.best.parts(self.face_group, G)[2] if self.best is not None else parts[-1][2]
        Xd, Xc = self._x([k for k, _ in done]), self._x(cands)
        tot2 = np.zeros(len(cands))
        var = np.zeros(len(cands))
        o_mu, o_sd = [], []
        for g in range(G):  # within: a property of the group's own pattern, seen in every solve that used it
            Fg = self.pools[g][1]
            w_mu, w_sd = _GP(Fg[[k[g] for k, _ in done]], np.log([p[0][g] for p in parts])).predict(
                Fg[[k[g] for k in cands]])
            W = np.exp(w_mu)
            mu, sd = _GP(Xd, np.array([p[1][g] for p in parts])).predict(Xc)  # offsets: of the whole design
            o_mu.append(mu)
            o_sd.append(sd)
            tot2 += weight[g] * W * W
            var += (weight[g] * W * W * w_sd) ** 2
        off = np.array(o_mu)
        off = off - (weight[:, None] * off).sum(axis=0)  # the fit centres the target on the nodes
        tot2 += (weight[:, None] * off * off).sum(axis=0)
        var += ((weight[:, None] * off * np.array(o_sd)) ** 2).sum(axis=0)
        tot = np.sqrt(tot2)
        lcb = tot - KAPPA * np.sqrt(var) / np.maximum(tot, 1e-300)
        s_mu, s_sd = _GP(Xd, np.log([ev.data["peak_strain"] for _, ev in done])).predict(Xc)
        feasible = s_mu - KAPPA * s_sd <= math.log(self.strain_limit)
        order = [int(j) for j in np.argsort(lcb, kind="stable") if feasible[j]]
        order += [int(j) for j in np.argsort(lcb, kind="stable") if not feasible[j]]
        return [cands[j] for j in order[:count]]

    def refine(self, budget: int, batch: int) -> None:
        """Batches of proposals until ``budget`` solves are spent or nothing is left to try."""
        rng = np.random.default_rng(self.seed)
        while self.runner.solves < budget and self.best is not None:
            props = self.propose(min(batch, budget - self.runner.solves), rng)
            if not props:
                return
            self.evaluate(props)
