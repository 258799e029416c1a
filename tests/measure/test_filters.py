import numpy as np
import pytest

from sogdd.measure.filters import (
    kernel_radius,
    orientations,
    sogdd_kernel,
    steerable_basis,
    steering_coefficients,
)


@pytest.mark.parametrize("sigma2", [0.7, 1.2, 1.44, 3.0])
@pytest.mark.parametrize("zero_mean", [False, True])
def test_steerability_identity(sigma2, zero_mean):
    r = kernel_radius(sigma2)
    basis = steerable_basis(sigma2, r, zero_mean=zero_mean)
    kern = basis.kernels()
    thetas = np.concatenate([orientations(8), np.random.default_rng(0).uniform(0, np.pi, 7)])
    for theta, w in zip(thetas, steering_coefficients(thetas)):
        steered = np.tensordot(w, kern, axes=1)
        direct = sogdd_kernel(sigma2, theta, r, zero_mean=zero_mean)
        assert np.max(np.abs(steered - direct)) <= 1e-15 * np.max(np.abs(direct)) * 10


def test_kernel_matches_eq22_by_hand():
    # eq. 22 at n = (2, 1), theta = pi/4, sigma^2 = 1.2
    s2, th = 1.2, np.pi / 4
    k = sogdd_kernel(s2, th, 3)
    u = 2 * np.cos(th) + 1 * np.sin(th)
    g = np.exp(-(4 + 1) / (2 * s2)) / (2 * np.pi * s2)
    assert k[3 + 1, 3 + 2] == pytest.approx((u * u / s2 - 1) / s2 * g, rel=1e-14)


def test_radius_rules():
    assert kernel_radius(1.2) == 5  # ceil(4 * 1.095)
    assert kernel_radius(1.44, "authors") == 5
    assert kernel_radius(0.25, "authors") == 3  # max(3, ceil(2))
    assert kernel_radius(0.25) == 2


def test_orientations():
    np.testing.assert_allclose(orientations(4), [0, np.pi / 4, np.pi / 2, 3 * np.pi / 4])
