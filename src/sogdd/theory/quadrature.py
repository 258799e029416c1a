"""Psi by numerical integration of eq. 3 (the reference for the closed forms).

Since ``psi`` integrates to zero over the plane, ``Psi = (T1 - T2) * I`` with
``I`` the integral of ``psi`` over the ``T1`` region ``{y >= b(x)}``. By
steerability only the integrals of ``g_xx, g_xy, g_yy`` over that region are
needed, and for each the inner integral over ``y >= b(x)`` is elementary. With
``phi_s`` the 1-D normal density of standard deviation ``s = sigma`` and
``Q(z) = erfc(z / sqrt 2) / 2``::

    int_b^inf phi_s(y) dy                       = Q(b / s)
    int_b^inf y phi_s(y) dy                     = s^2 phi_s(b)
    int_b^inf (y^2 / s^4 - 1 / s^2) phi_s(y) dy = b phi_s(b) / s^2

so, with ``b = b(x)``::

    a = int (x^2/s^4 - 1/s^2) phi_s(x) Q(b/s) dx
    b = int x phi_s(x) phi_s(b) / s^2 dx
    c = int phi_s(x) b phi_s(b) / s^2 dx

The remaining ``x`` integrals are done with adaptive Gauss-Kronrod quadrature
(``scipy.integrate.quad``) on each linear piece of ``b``, where the integrands are
smooth, truncated at ``|x| = 40 sigma`` (the Gaussian is below 1e-300 there).
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.integrate import IntegrationWarning, quad
from scipy.special import erf

from .models import Boundary, CornerModel
from .steering import Coefficients

__all__ = ["region_coefficients", "quadrature_coefficients"]

_SQRT2PI = np.sqrt(2.0 * np.pi)


def _phi(y: float, s: float) -> float:
    return float(np.exp(-0.5 * (y / s) ** 2) / (s * _SQRT2PI))


def region_coefficients(boundary: Boundary, sigma: float, *, epsrel: float = 1e-12) -> Coefficients:
    """Integrals of ``g_xx, g_xy, g_yy`` over ``{y >= b(x)}`` by quadrature.

    Parameters
    ----------
    boundary : Boundary
        The polyline ``b``, in coordinates centred on the filter.
    sigma : float
        Gaussian scale (standard deviation).
    epsrel : float
        Relative tolerance passed to ``quad`` on each piece.
    """
    s = float(sigma)
    lim = 40.0 * s
    xs = np.clip(boundary.vertices[:, 0], -lim, lim)
    edges = np.unique(np.concatenate([[-lim], xs, [lim]]))
    s2, s4 = s * s, s**4

    # The upper half-plane y >= 0 contributes exactly zero (int g_xx dx = 0,
    # int x phi(x) dx = 0 and b phi(b) = 0 at b = 0), so it is subtracted from the
    # integrands: Q(b/s) -> Q(b/s) - 1/2 = -erf(b / (s sqrt 2)) / 2 and
    # phi(b) -> phi(b) - phi(0). Otherwise a far-away corner's tiny contribution
    # would drown in the rounding of the half-plane's O(1) cancelling integrand.
    phi0 = _phi(0.0, s)

    def fa(x: float) -> float:
        return -(x * x / s4 - 1.0 / s2) * _phi(x, s) * 0.5 * float(erf(boundary(x) / (s * np.sqrt(2.0))))

    def fb(x: float) -> float:
        return x * _phi(x, s) * (_phi(float(boundary(x)), s) - phi0) / s2

    def fc(x: float) -> float:
        bx = float(boundary(x))
        return _phi(x, s) * bx * _phi(bx, s) / s2

    out = []
    with warnings.catch_warnings():
        # a piece whose integral cancels to ~0 (e.g. g_xx over a symmetric range)
        # cannot meet a relative tolerance and quad says so; the result is still
        # accurate to rounding of the integrand's scale, which the tests check
        # against the closed forms
        warnings.simplefilter("ignore", IntegrationWarning)
        for f in (fa, fb, fc):
            tot = 0.0
            for lo, hi in zip(edges[:-1], edges[1:]):
                val, _ = quad(f, lo, hi, epsabs=0.0, epsrel=epsrel, limit=200)
                tot += val
            out.append(tot)
    return Coefficients(*out)


def quadrature_coefficients(model: CornerModel, point: str, sigma: float) -> Coefficients:
    """``(a, b, c)`` of Psi for a model at ``point``, including the factor ``T1 - T2``."""
    return region_coefficients(model.boundary(point), sigma).scale(model.contrast)
