"""Exact closed forms of Psi for the END and L models (our derivation).

The ``T1`` region of every model is the upper half-plane ``y >= 0`` plus wedges
(:meth:`CornerModel.wedges`). Psi is linear in the region, so it is the sum of
the contributions of these pieces; all are per unit contrast here and are
multiplied by ``T1 - T2`` at the end.

*Half-plane through the evaluation point.* Its ``g_xx`` and ``g_xy`` integrals
vanish by symmetry in ``x``, and its ``g_yy`` integral is ``int_0^inf g'' = -g'(0) = 0``:
a straight edge through the point is invisible to a second-derivative filter.

*Wedge with its apex at the evaluation point* (the corner itself). In polar
coordinates ``psi_theta = (r^2 cos^2(phi - theta) / s^2 - 1) g / s^2`` and
``int_0^inf r^3 e^{-r^2/2s^2} dr = 2 s^4``, ``int_0^inf r e^{-r^2/2s^2} dr = s^2``, so the
radial integral is ``cos 2(phi - theta) / (2 pi s^2)`` per unit angle and::

    Psi_wedge(theta) = [sin 2(phi2 - theta) - sin 2(phi1 - theta)] / (4 pi s^2)

*Wedge with its apex elsewhere* (the other corner, or both corners seen from the
edge point). Each basis kernel is a derivative, ``g_xx = d/dx g_x``,
``g_xy = d/dy g_x`` and ``g_yy = d/dy g_y``, so by the divergence theorem its
integral over the wedge is the flux through the two boundary rays (the arc at
infinity carries none)::

    a = -(1/s^2) oint x g n_x ds,  b = -(1/s^2) oint x g n_y ds,  c = -(1/s^2) oint y g n_y ds

with ``n`` the outward normal. On a ray ``P(t) = q e_perp + t e`` (``e`` its
direction, ``e_perp = (e_y, -e_x)``, ``q = p x e`` the signed distance of its line
from the origin, ``t >= t0 = p . e``), ``g(P) = exp(-(q^2 + t^2) / 2 s^2) / (2 pi s^2)``
and the line integrals reduce to::

    J0 = int_{t0}^inf exp(-t^2/2s^2) dt = s sqrt(pi/2) erfc(t0 / (s sqrt 2))
    J1 = int_{t0}^inf t exp(-t^2/2s^2) dt = s^2 exp(-t0^2 / 2s^2)
    int x g dt = exp(-q^2/2s^2) (q e_perp,x J0 + e_x J1) / (2 pi s^2)   (same with y)

which is where the ``exp(-d^2 cos^2 / 2 s^2) erfc(d sin / (sqrt 2 s))`` terms of
the paper come from. The divergence form also gives ``b`` a second way (as the
flux of ``g_y`` through ``n_x``), which the tests use as an internal check.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erfc

from .models import CornerModel, Wedge
from .steering import Coefficients

__all__ = [
    "centred_wedge",
    "exact_coefficients",
    "offset_wedge",
    "ray_flux",
]

_SQRT_PI_2 = np.sqrt(0.5 * np.pi)


def centred_wedge(phi1: float, phi2: float, sigma: float) -> Coefficients:
    """Coefficients of a wedge ``phi1 <= phi <= phi2`` with its apex at the origin.

    From ``Psi(theta) = [sin 2(phi2 - theta) - sin 2(phi1 - theta)] / (4 pi s^2)``:
    ``a = -c`` (the Laplacian of a Gaussian has no net radial integral) and
    ``b = [cos 2 phi1 - cos 2 phi2] / (4 pi s^2)``.
    """
    k = 1.0 / (4.0 * np.pi * sigma * sigma)
    a = k * (np.sin(2 * phi2) - np.sin(2 * phi1))
    b = k * (np.cos(2 * phi1) - np.cos(2 * phi2))
    return Coefficients(float(a), float(b), float(-a))


def ray_flux(apex: tuple[float, float], phi: float, normal_sign: float, sigma: float) -> np.ndarray:
    """Fluxes ``(oint g_x n_x, oint g_x n_y, oint g_y n_y, oint g_y n_x)`` through one ray.

    The ray starts at ``apex`` with direction angle ``phi``; its normal is
    ``normal_sign * e_perp`` with ``e_perp = (sin phi, -cos phi)``.
    """
    s2 = sigma * sigma
    ex, ey = np.cos(phi), np.sin(phi)
    px_, py_ = apex
    t0 = px_ * ex + py_ * ey
    q = px_ * ey - py_ * ex
    j0 = sigma * _SQRT_PI_2 * erfc(t0 / (sigma * np.sqrt(2.0)))
    j1 = s2 * np.exp(-0.5 * t0 * t0 / s2)
    pref = np.exp(-0.5 * q * q / s2) / (2.0 * np.pi * s2)
    int_x = pref * (q * ey * j0 + ex * j1)
    int_y = pref * (-q * ex * j0 + ey * j1)
    nx, ny = normal_sign * ey, -normal_sign * ex
    # g_x = -x g / s^2 and g_y = -y g / s^2
    gx, gy = -int_x / s2, -int_y / s2
    return np.array([gx * nx, gx * ny, gy * ny, gy * nx])


def _wedge_fluxes(w: Wedge, sigma: float) -> np.ndarray:
    # counter-clockwise from the first ray lies inside the wedge, so the first
    # ray's outward normal is +e_perp and the second's -e_perp
    return ray_flux(w.apex, w.phi1, 1.0, sigma) + ray_flux(w.apex, w.phi2, -1.0, sigma)


def offset_wedge(w: Wedge, sigma: float, *, b_from: str = "gx") -> Coefficients:
    """Coefficients of a wedge whose apex may lie anywhere, via boundary fluxes.

    ``b_from="gy"`` computes ``b`` as the flux of ``g_y`` through ``n_x`` instead
    of ``g_x`` through ``n_y``; both equal the ``g_xy`` integral.
    """
    f = _wedge_fluxes(w, sigma)
    return Coefficients(float(f[0]), float(f[1] if b_from == "gx" else f[3]), float(f[2]))


def exact_coefficients(model: CornerModel, point: str, sigma: float, *, b_from: str = "gx") -> Coefficients:
    """``(a, b, c)`` of Psi for a model at ``point`` in closed form, times ``T1 - T2``.

    Wedges with their apex at the evaluation point use :func:`centred_wedge`
    (so the corner itself is pure ``cos 2(phi - theta)``); the others use
    :func:`offset_wedge`. The half-plane ``y >= 0`` adds nothing.
    """
    tot = Coefficients(0.0, 0.0, 0.0)
    for w in model.wedges(point):
        if w.apex[0] == 0.0 and w.apex[1] == 0.0:
            tot = tot + centred_wedge(w.phi1, w.phi2, sigma)
        else:
            tot = tot + offset_wedge(w, sigma, b_from=b_from)
    return tot.scale(model.contrast)
