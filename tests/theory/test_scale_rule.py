"""The scale rule (eq. 15) and its lattice counterpart."""

import numpy as np
import pytest

from sogdd.measure.filters import kernel_radius, steerable_basis
from sogdd.theory import (
    PAPER_CLAIMS,
    coefficients,
    crossings,
    energies,
    energy_gap,
    exact_coefficients,
    lattice_scores,
    lattice_study,
    make_model,
    rasterise,
    sigma_range,
)

A, B = np.pi / 8, np.pi / 3


def test_sigma_range_intervals_are_where_the_corner_wins():
    ivs = sigma_range("end", d=3.0, alpha=A, beta=B)
    assert ivs and all(lo < hi for lo, hi in ivs)
    m = make_model("end", d=3.0, alpha=A, beta=B)
    grid = np.geomspace(0.3, 6.0, 97)
    inside = np.array([any(lo <= s <= hi for lo, hi in ivs) for s in grid])
    gaps = np.array([energy_gap(m, s) for s in grid])
    assert np.all(gaps[inside] >= -1e-12) and np.all(gaps[~inside] <= 1e-12)
    # crossings are where E1 = E2, confirmed by the independent quadrature
    for c in crossings("end", d=3.0, alpha=A, beta=B):
        lo, hi = (energies(m, s, "quadrature") for s in (c * (1 - 1e-6), c * (1 + 1e-6)))
        assert (lo[0] - lo[1]) * (hi[0] - hi[1]) < 0


def test_crossing_scales_with_d():
    # Psi * sigma^2 depends on d / sigma only, so sigma* is proportional to d
    c1 = crossings("end", d=2.0, alpha=0.3, beta=0.7, sigma_min=0.05, sigma_max=50)
    c2 = crossings("end", d=5.0, alpha=0.3, beta=0.7, sigma_min=0.05, sigma_max=50)
    assert len(c1) == len(c2) >= 1
    np.testing.assert_allclose(np.array(c2) / np.array(c1), 2.5, rtol=1e-9)


def test_energy_ratio_independent_of_grey_levels():
    m1 = make_model("end", d=3.0, alpha=A, beta=B, T1=50, T2=100)
    m2 = make_model("end", d=3.0, alpha=A, beta=B, T1=200, T2=10)
    e1, e2 = energies(m1, 1.3), energies(m2, 1.3)
    assert e1[0] / e1[1] == pytest.approx(e2[0] / e2[1], rel=1e-12)


def test_paper_sigma_claims_against_exact():
    # at the paper's claimed END bound sigma_11 the corner still wins clearly
    m = make_model("end", d=3.0, alpha=A, beta=B)
    assert energy_gap(m, PAPER_CLAIMS["sigma_11"]) > 0.1
    # the L model has no crossing at all for the paper's parameters
    assert crossings("l", d=3.0, alpha=A, sigma_min=0.05, sigma_max=50) == []
    assert sigma_range("l", d=3.0, alpha=A) == [(0.3, 6.0)]


def test_small_sigma_always_favours_the_corner():
    # for sigma << d the edge point sees a straight edge (Psi -> 0), the corner a wedge
    rng = np.random.default_rng(3)
    for _ in range(10):
        model = "end" if rng.random() < 0.5 else "l"
        d, a, b = rng.uniform(1, 8), rng.uniform(0.1, 1.4), rng.uniform(0.1, 1.4)
        ivs = sigma_range(model, d=d, alpha=a, beta=b, sigma_min=0.05 * d, sigma_max=10 * d)
        assert ivs[0][0] == pytest.approx(0.05 * d)


def test_sigma_range_validates():
    with pytest.raises(ValueError):
        sigma_range("end", d=3.0, alpha=A, beta=B, sigma_min=2.0, sigma_max=1.0)
    with pytest.raises(ValueError):
        sigma_range("end", d=3.0, alpha=A)


def test_rasterise_conventions():
    m = make_model("end", d=4.0, alpha=A, beta=B, T1=50, T2=100)
    img = rasterise(m, "corner", 8)
    assert img.shape == (17, 17) and img.min() >= 50 and img.max() <= 100
    # paper y is up: T1 (50) on top, T2 (100) below; the edge y = 0 runs through the
    # centre row, which is half covered between the corners
    assert np.all(img[:8] == 50) and img[-1, 8 + 2] == 100
    assert np.allclose(img[8, 9:12], 75.0)
    # the edge-point rendering is the corner rendering moved left by d/2 = 2 columns
    edge = rasterise(m, "edge", 8)
    np.testing.assert_array_equal(edge[:, :-2], img[:, 2:])


def test_lattice_filters_agree_with_continuous_theory():
    # the detector's discrete kernels on the anti-aliased model approach the exact
    # coefficients (b flips sign: image rows go down, paper y goes up)
    s2 = 4.0
    rk = kernel_radius(s2)
    for model, point in (("end", "corner"), ("l", "edge")):
        m = make_model(model, d=4.0, alpha=A, beta=B)
        img = rasterise(m, point, rk + 2)
        c = rk + 2
        patch = img[c - rk : c + rk + 1, c - rk : c + rk + 1]
        lat = np.array([np.sum(k * patch) for k in steerable_basis(s2, rk).kernels()])
        ex = exact_coefficients(m, point, np.sqrt(s2)).as_array()
        flip = np.array([1.0, -1.0, 1.0])
        assert np.max(np.abs(lat - flip * ex)) < 0.05 * np.max(np.abs(ex))
        assert np.max(np.abs(lat - ex)) > 0.3 * np.max(np.abs(ex))


def test_lattice_energy_matches_coefficients_and_study_shapes():
    m = make_model("l", d=6.0, alpha=A)
    sc = lattice_scores(m, "corner", 2.0)
    assert sc.measure > 0 and sc.energy > 0 and sc.measure_near >= sc.measure
    # far-apart corners are resolved: the corner out-scores the edge point 3 px away
    st = lattice_study("l", [1.2, 2.0], [8.0], alpha=A)
    assert st.measure_corner.shape == (1, 2) and np.all(st.measure_wins) and np.all(st.energy_wins)
    # and the continuous energy of a far-away edge point is tiny, as on the lattice
    e1, e2 = coefficients(m, "corner", 1.0).energy(), coefficients(m, "edge", 1.0).energy()
    assert e2 < 0.05 * e1
