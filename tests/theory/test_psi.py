"""sogdd.theory: the three ways of computing Psi agree; internal identities hold."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import dblquad

from sogdd.theory import (
    Coefficients,
    Wedge,
    centred_wedge,
    coefficients,
    exact_coefficients,
    make_model,
    offset_wedge,
    quadrature_coefficients,
    representation,
)

angle = st.floats(0.05, 0.5 * np.pi - 0.05)
params = dict(
    d=st.floats(0.2, 10.0),
    alpha=angle,
    beta=angle,
    sigma=st.floats(0.25, 6.0),
    T1=st.floats(0.0, 255.0),
    T2=st.floats(0.0, 255.0),
    point=st.sampled_from(["corner", "edge"]),
)


def _rel_err(x, ref):
    return np.max(np.abs(np.asarray(x) - np.asarray(ref))) / np.max(np.abs(ref))


@pytest.mark.parametrize("model", ["end", "l"])
@settings(max_examples=25, deadline=None)
@given(**params)
def test_exact_matches_quadrature(model, d, alpha, beta, sigma, T1, T2, point):
    if abs(T1 - T2) < 1.0:
        T2 = T1 + 10.0
    m = make_model(model, d=d, alpha=alpha, beta=beta, T1=T1, T2=T2)
    ex = exact_coefficients(m, point, sigma).as_array()
    qu = quadrature_coefficients(m, point, sigma).as_array()
    assert _rel_err(qu, ex) <= 1e-9


@settings(max_examples=20, deadline=None)
@given(d=st.floats(0.2, 8.0), alpha=angle, beta=angle, sigma=st.floats(0.3, 5.0))
def test_two_divergence_forms_of_b_agree(d, alpha, beta, sigma):
    # b is the g_xy integral: flux of g_x through n_y or of g_y through n_x
    for model in ("end", "l"):
        m = make_model(model, d=d, alpha=alpha, beta=beta)
        for point in ("corner", "edge"):
            b1 = exact_coefficients(m, point, sigma).b
            b2 = exact_coefficients(m, point, sigma, b_from="gy").b
            assert b1 == pytest.approx(b2, rel=1e-10, abs=1e-14 / sigma**2)


@pytest.mark.parametrize("phi1,phi2", [(0.0, 1.0), (0.3, 4.2), (-1.0, 0.5), (np.pi, 1.5 * np.pi - 0.4)])
def test_centred_wedge_equals_flux_formula_at_origin(phi1, phi2):
    s = 1.3
    a = centred_wedge(phi1, phi2, s).as_array()
    b = offset_wedge(Wedge((0.0, 0.0), phi1, phi2), s).as_array()
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def test_half_plane_and_full_plane_are_invisible():
    s = 0.9
    for p1 in (0.0, 0.4, 2.0):
        half = offset_wedge(Wedge((0.0, 0.0), p1, p1 + np.pi), s).as_array()
        assert np.max(np.abs(half)) < 1e-15
    # psi integrates to zero over the plane, wherever the apex of the "wedge" is
    full = offset_wedge(Wedge((0.7, -1.1), 0.2, 0.2 + 2 * np.pi), s).as_array()
    assert np.max(np.abs(full)) < 1e-13
    # but an offset half-plane is not invisible
    assert np.max(np.abs(offset_wedge(Wedge((0.0, -0.5), 0.0, np.pi), s).as_array())) > 1e-3


def test_corner_wedge_is_pure_cos2():
    # Psi of a wedge centred on the point: [sin 2(phi2 - t) - sin 2(phi1 - t)] / (4 pi s^2)
    s, p1, p2 = 1.1, 0.0, 1.5 * np.pi - np.pi / 8
    th = np.linspace(0, 2 * np.pi, 17)
    want = (np.sin(2 * (p2 - th)) - np.sin(2 * (p1 - th))) / (4 * np.pi * s * s)
    np.testing.assert_allclose(centred_wedge(p1, p2, s)(th), want, atol=1e-15)


def test_direct_double_integral_of_eq3():
    # brute-force 2-D integration of f(x, y) psi_theta(x, y) at one theta, no steering
    m = make_model("end", d=2.0, alpha=0.5, beta=1.1, T1=30.0, T2=200.0)
    s, th, point = 1.2, 0.7, "edge"
    b = m.boundary(point)
    c, sn = np.cos(th), np.sin(th)

    def psi(y, x):
        u = x * c + y * sn
        return (u * u / s**2 - 1.0) / s**2 * np.exp(-(x * x + y * y) / (2 * s * s)) / (2 * np.pi * s * s)

    # the T1 integral of psi minus the upper half-plane's (which is zero), split at the vertices
    tot = 0.0
    xs = [-12.0, *m.boundary(point).vertices[:, 0], 12.0]
    for lo, hi in zip(xs[:-1], xs[1:]):
        val, _ = dblquad(psi, lo, hi, lambda x: float(b(x)), lambda x: 0.0, epsabs=1e-13, epsrel=1e-11)
        tot += val
    direct = m.contrast * tot  # T1 = upper half-plane (adds 0) + {b(x) <= y < 0}
    exact = float(representation("end", point, np.array([th]), s, d=2.0, alpha=0.5, beta=1.1,
                                 T1=30.0, T2=200.0)[0])
    assert direct == pytest.approx(exact, rel=1e-8)
    assert abs(exact) > 1.0


def test_energy_closed_form_matches_numeric_integral():
    co = Coefficients(-1.3, 0.4, 2.2)
    th = np.linspace(0, 2 * np.pi, 257)[:-1]
    numeric = np.mean(co(th) ** 2) * 2 * np.pi  # periodic trapezoid: exact for trig polynomials
    assert co.energy() == pytest.approx(numeric, rel=1e-12)


def test_representation_methods_and_shapes():
    th = np.linspace(0, np.pi, 5).reshape(5, 1)
    kw = dict(d=3.0, alpha=np.pi / 8, beta=np.pi / 3)
    for method in ("exact", "quadrature", "paper"):
        out = representation("end", "corner", th, 1.12, method=method, **kw)
        assert out.shape == th.shape and np.all(np.isfinite(out))
    # Psi is proportional to T1 - T2
    a = representation("l", "edge", th, 1.0, d=3.0, alpha=0.4, T1=0.0, T2=10.0)
    b = representation("l", "edge", th, 1.0, d=3.0, alpha=0.4, T1=100.0, T2=120.0)
    np.testing.assert_allclose(2 * a, b, rtol=1e-12)
    # paper coefficients recovered from three angles reproduce the printed formula everywhere
    m = make_model("end", **kw)
    th2 = np.linspace(0, 2 * np.pi, 31)
    np.testing.assert_allclose(coefficients(m, "edge", 1.12, "paper")(th2),
                               representation("end", "edge", th2, 1.12, method="paper", **kw), atol=1e-12)


@pytest.mark.parametrize("kwargs", [
    dict(model="x", point="corner", d=3, alpha=0.3, beta=0.3),
    dict(model="end", point="corner", d=3, alpha=0.3),  # no beta
    dict(model="l", point="middle", d=3, alpha=0.3),
    dict(model="l", point="edge", d=-1, alpha=0.3),
    dict(model="l", point="edge", d=3, alpha=2.0),
    dict(model="l", point="edge", d=3, alpha=0.3, method="magic"),
])
def test_bad_parameters_raise_valueerror(kwargs):
    model, point = kwargs.pop("model"), kwargs.pop("point")
    with pytest.raises(ValueError):
        representation(model, point, np.zeros(2), 1.0, **kwargs)
    with pytest.raises(ValueError):
        representation("l", "edge", np.zeros(2), -1.0, d=3, alpha=0.3)
