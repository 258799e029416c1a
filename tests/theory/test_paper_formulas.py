"""The paper's printed formulas (eqs. 4, 6, 12, 14): transcription and comparison.

The hand-reduced values below were obtained by setting theta = 0 or pi/2 in the
printed equations by hand (cos^2, sin^2 and sin 2theta become 0 or 1) and
simplifying ``sin^2 x / tan x = sin x cos x``; they check the transcription term
by term, independently of how the functions are written.
"""

from math import cos, erfc, exp, pi, sin, sqrt

import numpy as np
import pytest

from sogdd.theory import (
    make_model,
    paper_end_corner,
    paper_end_edge,
    paper_l_corner,
    paper_l_edge,
    representation,
)

S, D, A, B, T1, T2 = 1.3, 2.5, 0.45, 1.05, 40.0, 180.0
ZERO, HALF = np.array([0.0]), np.array([pi / 2])


def _end_corner_hand(theta0: bool) -> float:
    ed = exp(-D * D / (2 * S * S))
    K = exp(-D * D * cos(B) ** 2 / (2 * S * S)) * erfc(D * sin(B) / (sqrt(2) * S))
    r = sqrt(2 * pi)
    if theta0:
        val = (sqrt(pi) / 2) * (sin(A) * cos(A) / (2 * pi * S * S) - sin(B) * cos(B) * ed / (2 * pi * S * S)
                                + r * D * cos(B) * (1 + sin(B) ** 2) * K / (4 * pi * S**3))
    else:
        val = (-sin(A) * cos(A) / (2 * pi * S * S) - sin(B) * cos(B) * ed / (2 * pi * S * S)
               + r * D * sin(B) ** 2 * cos(B) * K / (4 * pi * S**3))
    return (T1 - T2) * val


def _end_edge_hand(theta0: bool) -> float:
    ea, eb = (exp(-D * D * cos(x) ** 2 / (8 * S * S)) for x in (A, B))
    Ka, Kb = (erfc(D * sin(x) / (2 * sqrt(2) * S)) for x in (A, B))
    e8, r = exp(-D * D / (8 * S * S)), sqrt(2 * pi)
    sc = sin(A) * cos(A) + sin(B) * cos(B)
    pref = (T1 - T2) / (2 * pi * S**3)
    if theta0:
        return pref * sqrt(pi) * (r * D / 8 * (cos(A) ** 3 * ea * Ka + cos(B) ** 3 * eb * Kb) + S * e8 * sc / 2)
    return pref * (r * D / 4 * (sin(A) ** 2 * cos(A) * ea * Ka + sin(B) ** 2 * cos(B) * eb * Kb) - S * e8 * sc)


def _l_edge_hand(theta0: bool) -> float:
    ea, Ka = exp(-D * D * cos(A) ** 2 / (8 * S * S)), erfc(D * sin(A) / (2 * sqrt(2) * S))
    e8, r = exp(-D * D / (8 * S * S)), sqrt(2 * pi)
    pref = (T2 - T1) / (2 * pi * S**3)
    if theta0:
        return -pref * sqrt(pi) * (S * e8 * sin(A) * cos(A) / 2 + r * D * cos(A) ** 3 * ea * Ka / 8)
    return pref * (S * sin(A) * cos(A) * e8 - r * D * sin(A) ** 2 * cos(A) * ea * Ka / 4)


@pytest.mark.parametrize("theta0", [True, False])
def test_transcription_at_hand_computed_points(theta0):
    th = ZERO if theta0 else HALF
    got = [
        paper_end_corner(th, S, D, A, B, T1, T2)[0],
        paper_end_edge(th, S, D, A, B, T1, T2)[0],
        paper_l_edge(th, S, D, A, T1, T2)[0],
    ]
    want = [_end_corner_hand(theta0), _end_edge_hand(theta0), _l_edge_hand(theta0)]
    np.testing.assert_allclose(got, want, rtol=1e-13)


def test_eq12_transcription_and_known_discrepancy():
    # the fact stated: theta = 0, sigma^2 = 1.2, alpha = pi/8, T1 = 50, T2 = 100
    s = sqrt(1.2)
    printed = paper_l_corner(ZERO, s, 3.0, pi / 8)[0]
    assert printed == pytest.approx(-2.0778, abs=5e-5)
    for method in ("exact", "quadrature"):
        val = representation("l", "corner", ZERO, s, d=3.0, alpha=pi / 8, method=method)[0]
        assert val == pytest.approx(-2.3446, abs=5e-5)
    # theta = pi/2 by hand: (T2 - T1) / (2 pi s^2) * sin(a) cos(a)
    assert paper_l_corner(HALF, s, 3.0, pi / 8)[0] == pytest.approx(
        50 / (2 * pi * 1.2) * sin(pi / 8) * cos(pi / 8), rel=1e-13)


def _max_rel(model, point, f, erratum, d, a, b, s):
    th = np.linspace(0, np.pi, 25)
    kw = dict(sigma=s, d=d, alpha=a, erratum=erratum)
    if model == "end":
        kw["beta"] = b
    ex = representation(model, point, th, s, d=d, alpha=a, beta=b)
    return np.max(np.abs(f(th, **kw) - ex)) / np.max(np.abs(ex))


FORMULAS = [("end", "corner", paper_end_corner), ("end", "edge", paper_end_edge),
            ("l", "corner", paper_l_corner), ("l", "edge", paper_l_edge)]


@pytest.mark.parametrize("model,point,f", FORMULAS)
def test_printed_formulas_are_wrong_and_the_erratum_fixes_them(model, point, f):
    rng = np.random.default_rng(7)
    for _ in range(8):
        d, a, b, s = rng.uniform(0.5, 6), rng.uniform(0.1, 1.4), rng.uniform(0.1, 1.4), rng.uniform(0.4, 4)
        assert _max_rel(model, point, f, False, d, a, b, s) > 1e-3
        assert _max_rel(model, point, f, True, d, a, b, s) < 1e-10


@pytest.mark.parametrize("model,point,f", FORMULAS)
def test_printed_sin2_and_sin2theta_parts_are_right(model, point, f):
    # only the cos^2(theta) coefficient (a) of the printed formulas is wrong
    m = make_model(model, d=2.0, alpha=0.6, beta=0.9)
    from sogdd.theory import coefficients

    ex, pr = coefficients(m, point, 1.4, "exact"), coefficients(m, point, 1.4, "paper")
    assert pr.b == pytest.approx(ex.b, rel=1e-10) and pr.c == pytest.approx(ex.c, rel=1e-10)
    assert abs(pr.a - ex.a) > 1e-3 * abs(ex.a)


def test_phi_choice():
    a = paper_end_edge(ZERO, S, D, A, B, phi="erf")
    b = paper_end_edge(ZERO, S, D, A, B, phi="normal_cdf")
    assert np.all(np.isfinite(a)) and not np.allclose(a, b)
    with pytest.raises(ValueError):
        paper_end_edge(ZERO, S, D, A, B, phi="nope")
