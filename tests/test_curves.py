"""Rational Bézier mathematics checked against closed forms (circle, parabola, hyperbola, ellipse).

Expected values come from textbook formulas or from test-local explicit evaluations, never from the
code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.spatial import cKDTree
from scipy.special import ellipe

from fabpat.errors import GeometryError
from fabpat.geometry import conics, curves

RNG = np.random.default_rng(20240611)


# ------------------------------------------------------------------------------ test-local helpers


def circle_arc(R: float, phi0: float, theta: float, centre=(0.0, 0.0)) -> tuple[np.ndarray, float]:
    """Standard-form quadratic of a circular arc: equal legs, w = cos(θ/2) (θ signed, |θ| < π)."""
    c = np.asarray(centre, dtype=float)
    p0 = c + R * np.array([math.cos(phi0), math.sin(phi0)])
    p2 = c + R * np.array([math.cos(phi0 + theta), math.sin(phi0 + theta)])
    mid = phi0 + theta / 2
    p1 = c + R / math.cos(theta / 2) * np.array([math.cos(mid), math.sin(mid)])
    return np.array([p0, p1, p2]), math.cos(theta / 2)


def rq(P: np.ndarray, w: float, t: np.ndarray) -> np.ndarray:
    """Explicit standard-form quadratic rational: ((1−t)²P0 + 2wt(1−t)P1 + t²P2) / W."""
    t = np.asarray(t, dtype=float)[:, None]
    b0, b1, b2 = (1 - t) ** 2, 2 * w * t * (1 - t), t**2
    return (b0 * P[0] + b1 * P[1] + b2 * P[2]) / (b0 + b1 + b2)


def dist_to_polyline(X: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Distance of each point X (m, 2) to the open polyline V (k, 2).

    Exact point-to-segment distances on the segments next to the 8 nearest vertices (a k-d tree
    finds them), which contain the closest segment for any polyline finer than the curvature.
    """
    k = min(8, len(V))
    _, idx = cKDTree(V).query(X, k=k)
    idx = idx.reshape(len(X), k)
    out = np.full(len(X), np.inf)
    for i0 in np.concatenate([idx - 1, idx], axis=1).T:
        i0 = np.clip(i0, 0, len(V) - 2)
        a, d = V[i0], V[i0 + 1] - V[i0]
        s = np.clip(np.einsum("ij,ij->i", X - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0, 1)
        out = np.minimum(out, np.linalg.norm(X - (a + s[:, None] * d), axis=1))
    return out


def shoelace_between_chord_and_arc(P: np.ndarray, w: float, n: int = 400_001) -> float:
    """Signed area of arc + closing chord by a dense polygon (error O(1/n²))."""
    X = rq(P, w, np.linspace(0, 1, n))
    x, y = X[:, 0], X[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def bulge_points(s, e, bulge: float, n: int = 2001) -> np.ndarray:
    """Points on a DXF bulge arc, computed here from first principles."""
    s, e = np.asarray(s, float), np.asarray(e, float)
    theta = 4 * math.atan(bulge)
    if abs(theta) < 1e-14:
        return s + np.linspace(0, 1, n)[:, None] * (e - s)
    chord = e - s
    L = np.linalg.norm(chord)
    R = L / (2 * math.sin(theta / 2))  # signed
    # centre: perpendicular bisector, on the left of the chord for a CCW arc below 180°
    left = np.array([-chord[1], chord[0]]) / L
    c = (s + e) / 2 + left * R * math.cos(theta / 2)
    a0 = math.atan2(*(s - c)[::-1])
    a = a0 + theta * np.linspace(0, 1, n)
    return c + abs(R) * np.column_stack([np.cos(a), np.sin(a)])


# ------------------------------------------------------------------------------------ evaluation


@pytest.mark.parametrize("theta_deg", [10.0, 60.0, 90.0, 135.0, 170.0, -120.0])
def test_circular_arc_points_lie_on_circle(theta_deg: float) -> None:
    R, c = 7.5, (3.0, -2.0)
    theta = math.radians(theta_deg)
    P, w = circle_arc(R, 0.3, theta, c)
    X = curves.evaluate(P, [1, w, 1], np.linspace(0, 1, 1001))
    assert np.abs(np.linalg.norm(X - c, axis=1) - R).max() < 1e-12 * R
    # the curve sweeps monotonically from φ0 to φ0 + θ
    ang = np.unwrap(np.arctan2(X[:, 1] - c[1], X[:, 0] - c[0]))
    assert ang[-1] - ang[0] == pytest.approx(theta, abs=1e-12)
    assert np.all(np.diff(ang) * np.sign(theta) > 0)


def test_evaluate_matches_explicit_quadratic_and_cubic() -> None:
    P = RNG.normal(size=(3, 2))
    t = np.linspace(0, 1, 57)
    for w in (0.05, 0.2, 1.0, 4.0):
        assert np.allclose(curves.evaluate(P, [1, w, 1], t), rq(P, w, t), atol=1e-13, rtol=0)
    # a cubic with arbitrary weights in 3-D, against the Bernstein formula
    P3, W3 = RNG.normal(size=(4, 3)), np.array([1.0, 0.3, 2.5, 0.7])
    B = np.stack([math.comb(3, i) * t**i * (1 - t) ** (3 - i) for i in range(4)], axis=1)
    expected = (B * W3) @ P3 / (B @ W3)[:, None]
    assert np.allclose(curves.evaluate(P3, W3, t), expected, atol=1e-13, rtol=0)
    assert curves.evaluate(P3, W3, 0.25).shape == (3,)


def test_derivative_is_exact() -> None:
    P, w = circle_arc(2.0, 0.0, math.radians(120), (1.0, 1.0))
    t = np.linspace(0, 1, 41)
    D = curves.derivative(P, [1, w, 1], t)
    X = rq(P, w, t)
    # tangent of a circle is perpendicular to the radius
    assert np.abs(np.einsum("ij,ij->i", D, X - (1.0, 1.0))).max() < 1e-12
    # against a high-order central difference of the explicit formula
    h = 1e-4
    fd = (-rq(P, w, t + 2 * h) + 8 * rq(P, w, t + h) - 8 * rq(P, w, t - h) + rq(P, w, t - 2 * h)) / (12 * h)
    assert np.allclose(D, fd, atol=1e-9)
    # end tangents of a standard-form quadratic: 2w(P1 − P0) and 2w(P2 − P1)
    assert np.allclose(curves.derivative(P, [1, w, 1], 0.0), 2 * w * (P[1] - P[0]), atol=1e-13)
    assert np.allclose(curves.derivative(P, [1, w, 1], 1.0), 2 * w * (P[2] - P[1]), atol=1e-13)


# ------------------------------------------------------------------------------------ subdivision


@pytest.mark.parametrize("w", [0.2, 1.0, 3.0])
def test_split_reproduces_curve(w: float) -> None:
    P = np.array([[0.0, 0.0], [2.0, 3.0], [5.0, -1.0]])
    t = 0.37
    (PL, WL), (PR, WR) = curves.split(P, [1, w, 1], t)
    u = np.linspace(0, 1, 33)
    # unnormalised pieces are the curve restricted to [0, t] and [t, 1], linearly reparametrised
    assert np.allclose(curves.evaluate(PL, WL, u), rq(P, w, t * u), atol=1e-13)
    assert np.allclose(curves.evaluate(PR, WR, u), rq(P, w, t + (1 - t) * u), atol=1e-13)


@pytest.mark.parametrize("w", [0.2, 0.7, 1.0, 2.5])
def test_split_quad_gives_standard_form_pieces_on_the_same_conic(w: float) -> None:
    P = np.array([[0.0, 0.0], [2.0, 3.0], [5.0, -1.0]])
    (PL, wL), (PR, wR) = curves.split_quad(P, w, 0.5)
    assert wL == pytest.approx(math.sqrt((1 + w) / 2), rel=1e-14)
    assert wR == pytest.approx(math.sqrt((1 + w) / 2), rel=1e-14)
    # the pieces join at the curve's midpoint and keep the original end points
    assert np.allclose(PL[0], P[0]) and np.allclose(PR[2], P[2])
    assert np.allclose(PL[2], rq(P, w, [0.5])[0]) and np.allclose(PR[0], PL[2])
    # every point of the pieces satisfies the original conic τ1² = 4w²τ0τ2 (barycentric coordinates)
    T = np.linalg.inv(np.vstack([P.T, np.ones(3)]))
    for Q, wq in ((PL, wL), (PR, wR)):
        X = rq(Q, wq, np.linspace(0, 1, 50))
        tau = T @ np.vstack([X.T, np.ones(len(X))])
        assert np.abs(tau[1] ** 2 - 4 * w * w * tau[0] * tau[2]).max() < 1e-12


def test_standardize_is_a_moebius_reparametrisation() -> None:
    P = np.array([[1.0, 0.0], [3.0, 2.0], [0.0, 4.0]])
    W = np.array([2.0, 3.0, 0.5])
    Ps, w = curves.standardize_quad(P, W)
    assert w == pytest.approx(3.0 / math.sqrt(2.0 * 0.5))
    s = np.linspace(0, 1, 21)
    rho = math.sqrt(W[0] / W[2])
    t = rho * s / ((1 - s) + rho * s)  # original parameter of the standard form's parameter s
    assert np.allclose(curves.evaluate(P, W, t), rq(Ps, w, s), atol=1e-13)


def test_subcurve() -> None:
    P, W = RNG.normal(size=(4, 2)), np.array([1.0, 2.0, 0.5, 1.5])
    Ps, Ws = curves.subcurve(P, W, 0.2, 0.7)
    u = np.linspace(0, 1, 11)
    assert np.allclose(curves.evaluate(Ps, Ws, u), curves.evaluate(P, W, 0.2 + 0.5 * u), atol=1e-12)


# ------------------------------------------------------------------------------------- flattening


@pytest.mark.parametrize("w", [0.05, 0.2, math.cos(math.radians(50)), 1.0, 3.0])
@pytest.mark.parametrize("tol", [1e-2, 1e-4])
def test_flatten_within_tolerance(w: float, tol: float) -> None:
    P = np.array([[0.0, 0.0], [6.0, 9.0], [12.0, 0.0]])
    V = curves.flatten_quad(P, w, tol)
    assert np.allclose(V[0], P[0]) and np.allclose(V[-1], P[2])
    dense = rq(P, w, np.linspace(0, 1, 20001))
    dev = dist_to_polyline(dense, V).max()
    assert dev <= tol
    assert dev > 0.25 * tol  # adaptive: not wastefully fine
    # the vertices are on the curve
    _, ts = curves.flatten_quad(P, w, tol, return_params=True)
    assert np.allclose(V, rq(P, w, ts), atol=1e-12)


def test_flatten_curve_that_overshoots_its_chord() -> None:
    # nearly collinear control points with P1 far beyond P2: tiny sagitta about the chord *line*,
    # but the curve runs out to x ≈ 5 and back, far from the chord *segment* [0, 1]
    P = np.array([[0.0, 0.0], [10.0, 0.001], [1.0, 0.0]])
    V = curves.flatten_quad(P, 1.0, 0.01)
    assert dist_to_polyline(rq(P, 1.0, np.linspace(0, 1, 5001)), V).max() <= 0.01


def test_flatten_circle_segment_count_is_near_optimal() -> None:
    R, theta, tol = 5.0, math.radians(150), 1e-3
    P, w = circle_arc(R, 0.0, theta)
    V = curves.flatten_quad(P, w, tol)
    optimal = math.ceil(theta / (2 * math.acos(1 - tol / R)))  # equal chords with sagitta = tol
    assert optimal <= len(V) - 1 <= 2 * optimal


def test_flatten_generic_degree() -> None:
    P = np.array([[0.0, 0.0], [1.0, 3.0], [4.0, 3.0], [5.0, 0.0]])
    W = np.array([1.0, 0.5, 2.0, 1.0])
    V = curves.flatten(P, W, 1e-3)
    t = np.linspace(0, 1, 5001)
    B = np.stack([math.comb(3, i) * t**i * (1 - t) ** (3 - i) for i in range(4)], axis=1)
    dense = (B * W) @ P / (B @ W)[:, None]
    assert dist_to_polyline(dense, V).max() <= 1e-3


# ---------------------------------------------------------------------------- area, moment, length


@pytest.mark.parametrize("theta_deg", [30.0, 90.0, 160.0])
def test_circular_arc_area_moment_length(theta_deg: float) -> None:
    R, theta = 4.0, math.radians(theta_deg)
    P, w = circle_arc(R, 0.7, theta)
    # centred at the origin the radii contribute nothing: the arc alone gives the sector
    assert curves.quad_area(P, w) == pytest.approx(0.5 * R * R * theta, rel=1e-14)
    assert curves.quad_polar_moment(P, w) == pytest.approx(R**4 * theta / 4, rel=1e-13)
    assert curves.quad_arc_length(P, w) == pytest.approx(R * theta, rel=1e-12)
    # circular segment between chord and arc
    seg = 0.5 * R * R * (theta - math.sin(theta))
    chord_term = 0.5 * (P[0, 0] * P[2, 1] - P[0, 1] * P[2, 0])
    assert curves.quad_area(P, w) - chord_term == pytest.approx(seg, rel=1e-13)


def test_parabola_closed_forms() -> None:
    # y = x² from x = −1 to 2: tangents meet at (1/2, −2)
    P, w = np.array([[-1.0, 1.0], [0.5, -2.0], [2.0, 4.0]]), 1.0
    chord_term = 0.5 * (P[0, 0] * P[2, 1] - P[0, 1] * P[2, 0])
    # Archimedes: ∫(x + 2 − x²) dx = 9/2; arc (below) then chord back is counter-clockwise: positive
    assert curves.quad_area(P, w) - chord_term == pytest.approx(4.5, rel=1e-14)
    assert curves.quad_polar_moment(P, w) == pytest.approx((33 / 5 + 129 / 7) / 4, rel=1e-13)

    def F(x: float) -> float:
        return x * math.sqrt(1 + 4 * x * x) / 2 + math.asinh(2 * x) / 4

    assert curves.quad_arc_length(P, w) == pytest.approx(F(2) - F(-1), rel=1e-12)


def test_hyperbola_closed_forms() -> None:
    # xy = 1 from (1, 1) to (2, 1/2); tangents meet at (4/3, 2/3), w = 3√2/4 puts the shoulder on it
    w = 3 * math.sqrt(2) / 4
    P = np.array([[1.0, 1.0], [4 / 3, 2 / 3], [2.0, 0.5]])
    X = rq(P, w, np.linspace(0, 1, 101))
    assert np.abs(X[:, 0] * X[:, 1] - 1).max() < 1e-13
    chord_term = 0.5 * (P[0, 0] * P[2, 1] - P[0, 1] * P[2, 0])
    # area between chord and curve is 3/4 − ln 2; arc below the chord, travelled left to right: positive
    assert curves.quad_area(P, w) - chord_term == pytest.approx(0.75 - math.log(2), rel=1e-13)
    # ∫ (x² + y²)(x dy − y dx)/4 with y = 1/x is −∫₁² (x + x⁻³)/2 dx = −15/16
    assert curves.quad_polar_moment(P, w) == pytest.approx(-15 / 16, rel=1e-13)
    expected, _ = quad(lambda x: math.sqrt(1 + x**-4), 1, 2, epsabs=1e-14)
    assert curves.quad_arc_length(P, w) == pytest.approx(expected, rel=1e-11)


def test_quarter_ellipse_length_and_moment() -> None:
    a, b = 5.0, 2.0
    P, w = np.array([[a, 0.0], [a, b], [0.0, b]]), math.cos(math.pi / 4)
    assert np.abs((rq(P, w, np.linspace(0, 1, 99)) ** 2 / [a * a, b * b]).sum(1) - 1).max() < 1e-13
    assert curves.quad_arc_length(P, w) == pytest.approx(a * ellipe(1 - b * b / (a * a)), rel=1e-12)
    assert curves.quad_area(P, w) == pytest.approx(math.pi * a * b / 4, rel=1e-14)
    assert curves.quad_polar_moment(P, w) == pytest.approx(math.pi * a * b * (a * a + b * b) / 16, rel=1e-13)


@pytest.mark.parametrize("w", [0.01, 0.2, 0.5, 0.83, 0.84, 0.95, 1.0 - 1e-9, 1.05, 1.13, 1.15, 2.0, 6.0])
def test_segment_area_against_dense_polygon(w: float) -> None:
    # the closed form switches to a series near w = 1; check both regimes and the switch points
    P = np.array([[0.0, 0.0], [1.5, 2.0], [4.0, 0.5]])
    chord_term = 0.5 * (P[0, 0] * P[2, 1] - P[0, 1] * P[2, 0])
    expected = shoelace_between_chord_and_arc(P, w)
    assert curves.quad_area(P, w) - chord_term == pytest.approx(expected, rel=1e-9)


def test_polar_moment_of_full_offset_circle_and_ellipse() -> None:
    R, c = 3.0, (4.0, -1.5)
    arcs = [circle_arc(R, k * math.pi / 2, math.pi / 2, c) for k in range(4)]
    J = sum(curves.quad_polar_moment(P, w) for P, w in arcs)
    assert J == pytest.approx(math.pi * R**4 / 2 + math.pi * R * R * (c[0] ** 2 + c[1] ** 2), rel=1e-13)
    A = sum(curves.quad_area(P, w) for P, w in arcs)
    assert A == pytest.approx(math.pi * R * R, rel=1e-14)


@pytest.mark.parametrize("w", [0.02, 0.3, 3.0, 10.0, 50.0])
def test_polar_moment_extreme_weights_against_adaptive_quadrature(w: float) -> None:
    # far from w = 1 the integrand's poles approach [0, 1]; compare with QUADPACK on the explicit form
    P = np.array([[1.0, 2.0], [3.0, 0.5], [4.0, 3.0]])

    def integrand(t: float) -> float:
        # quotient rule on the explicit form A / W
        b, db = np.array([(1 - t) ** 2, 2 * w * t * (1 - t), t * t]), np.array([2 * t - 2, 2 * w * (1 - 2 * t), 2 * t])
        A, dA, W, dW = b @ P, db @ P, b.sum(), db.sum()
        X, D = A / W, (dA * W - A * dW) / W**2
        return (X @ X) * (X[0] * D[1] - X[1] * D[0]) / 4

    expected, _ = quad(integrand, 0, 1, epsabs=0, epsrel=1e-13, limit=500)
    assert curves.quad_polar_moment(P, w) == pytest.approx(expected, rel=1e-12)


def test_bbox_of_circular_arc() -> None:
    R = 2.0
    P, w = circle_arc(R, math.radians(-30), math.radians(150))  # from −30° to 120°, passes 0° and 90°
    bb = curves.quad_bbox(P, w)
    assert np.allclose(bb, [[R * math.cos(math.radians(120)), R * math.sin(math.radians(-30))], [R, R]])


# ------------------------------------------------------------------------------- conic conversion


@pytest.mark.parametrize("ccw", [True, False])
@pytest.mark.parametrize("rot_deg", [0.0, 35.0, 90.0])
def test_ellipse_conversion_reproduces_points(ccw: bool, rot_deg: float) -> None:
    a, b, c = 6.0, 2.5, np.array([1.0, -3.0])
    rot = math.radians(rot_deg)
    Rm = np.array([[math.cos(rot), -math.sin(rot)], [math.sin(rot), math.cos(rot)]])
    phi0, span = 0.4, 1.9 if ccw else -1.9

    def E(phi: float) -> np.ndarray:
        return c + Rm @ np.array([a * math.cos(phi), b * math.sin(phi)])

    h = span / 2
    mid = phi0 + h
    P = np.array([E(phi0), c + Rm @ np.array([a * math.cos(mid), b * math.sin(mid)]) / math.cos(h), E(phi0 + span)])
    w = math.cos(h)
    con = conics.quad_to_conic(P, w)
    assert con.kind == "ellipse"
    e = con.ellipse
    assert e is not None
    assert np.allclose(e.center, c, atol=1e-12)
    assert e.semi_axes == pytest.approx((a, b), rel=1e-12)
    assert e.ratio == pytest.approx(b / a, rel=1e-12)
    # major axis along the rotated x axis (either sign)
    assert abs(math.sin(e.rotation - rot)) < 1e-12
    assert e.end_param > e.start_param
    assert e.reversed == (not ccw)
    # DXF sampling: every point is on the ellipse and the run goes P0 -> P2 (or P2 -> P0 if reversed)
    psi = np.linspace(e.start_param, e.end_param, 200)
    X = e.point(psi)
    local = (X - c) @ Rm
    assert np.abs((local**2 / [a * a, b * b]).sum(1) - 1).max() < 1e-12
    first, last = (P[2], P[0]) if e.reversed else (P[0], P[2])
    assert np.allclose(X[0], first, atol=1e-12) and np.allclose(X[-1], last, atol=1e-12)
    # and it is the Bézier arc, not the complementary one: the curve's samples are on the DXF run
    curve = rq(P, w, np.linspace(0, 1, 300))
    assert dist_to_polyline(curve, e.point(np.linspace(e.start_param, e.end_param, 20001))).max() < 1e-6
    # implicit coefficients vanish on the curve
    A, B, C, D, F_, G = con.coefficients
    x, y = curve.T
    assert np.abs(A * x * x + B * x * y + C * y * y + D * x + F_ * y + G).max() < 1e-12


def test_circle_conversion() -> None:
    P, w = circle_arc(2.0, 0.5, 1.2, (1.0, 1.0))
    e = conics.quad_to_conic(P, w).ellipse
    assert e is not None
    assert e.ratio == pytest.approx(1.0, abs=1e-12)
    assert e.semi_axes[0] == pytest.approx(2.0, rel=1e-12)
    assert e.end_param - e.start_param == pytest.approx(1.2, rel=1e-12)


def test_parabola_and_hyperbola_implicit_coefficients() -> None:
    par = conics.quad_to_conic(np.array([[-1.0, 1.0], [0.5, -2.0], [2.0, 4.0]]), 1.0)
    assert par.kind == "parabola" and par.ellipse is None
    k = np.array(par.coefficients) / par.coefficients[0]
    assert np.allclose(k, [1, 0, 0, 0, -1, 0], atol=1e-12)  # x² − y = 0
    hyp = conics.quad_to_conic(np.array([[1.0, 1.0], [4 / 3, 2 / 3], [2.0, 0.5]]), 3 * math.sqrt(2) / 4)
    assert hyp.kind == "hyperbola"
    k = np.array(hyp.coefficients) / hyp.coefficients[1]
    assert np.allclose(k, [0, 1, 0, 0, 0, -1], atol=1e-12)  # xy − 1 = 0


def test_conic_of_straight_arc_raises() -> None:
    with pytest.raises(GeometryError):
        conics.quad_to_conic(np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]), 0.5)


# ------------------------------------------------------------------------------------ arc fitting


@pytest.mark.parametrize("w", [0.2, 1.0, 2.0])
@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_fit_arcs_within_tolerance(w: float, tol: float) -> None:
    P = np.array([[0.0, 0.0], [4.0, 6.0], [9.0, 1.0]])  # turns clockwise
    arcs = conics.fit_arcs(P, w, tol)
    assert np.allclose(arcs[0][0], P[0], atol=0) and np.allclose(arcs[-1][1], P[2], atol=0)
    for (_, e1, _), (s2, _, _) in zip(arcs[:-1], arcs[1:], strict=True):
        assert e1 == s2
    assert all(b < 0 for _, _, b in arcs)  # clockwise pieces have negative bulge
    arc_pts = np.vstack([bulge_points(s, e, b, 400) for s, e, b in arcs])
    curve = rq(P, w, np.linspace(0, 1, 20001))
    assert dist_to_polyline(curve, arc_pts).max() <= tol
    assert dist_to_polyline(arc_pts, curve).max() <= tol
    # G1 arc spline: the end tangent of each arc equals the start tangent of the next
    def tangents(s, e, b):
        X = bulge_points(s, e, b, 100001)
        return (X[1] - X[0]) / np.linalg.norm(X[1] - X[0]), (X[-1] - X[-2]) / np.linalg.norm(X[-1] - X[-2])

    for A1, A2 in zip(arcs[:-1], arcs[1:], strict=True):
        assert np.allclose(tangents(*A1)[1], tangents(*A2)[0], atol=1e-4)


def test_fit_arcs_of_circle_is_one_exact_arc() -> None:
    P, w = circle_arc(3.0, 0.2, 2.0, (1.0, 2.0))
    arcs = conics.fit_arcs(P, w, 1e-6)
    assert len(arcs) == 1
    assert arcs[0][2] == pytest.approx(math.tan(2.0 / 4), rel=1e-12)
    X = bulge_points(*arcs[0])
    assert np.abs(np.linalg.norm(X - (1.0, 2.0), axis=1) - 3.0).max() < 1e-12
