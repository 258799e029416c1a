"""Steerability: Psi(theta) is fixed by three numbers.

The SOGDD filter of eq. 2 is ``psi_theta = cos^2 g_xx + 2 sin cos g_xy + sin^2 g_yy``
pointwise, so for any image ``f`` the representation of eq. 3 is::

    Psi(theta) = a cos^2(theta) + 2 b sin(theta) cos(theta) + c sin^2(theta)

with ``a, b, c`` the integrals of ``f`` against ``g_xx, g_xy, g_yy``. Writing
``Psi = m + p cos 2theta + b sin 2theta`` (``m = (a+c)/2``, ``p = (a-c)/2``) gives
the energy of eq. 15 in closed form::

    int_0^{2 pi} Psi^2 dtheta = pi (2 m^2 + p^2 + b^2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Coefficients", "fit_coefficients"]


@dataclass(frozen=True)
class Coefficients:
    """``(a, b, c)`` with ``Psi(theta) = a cos^2 + 2 b sin cos + c sin^2``."""

    a: float
    b: float
    c: float

    def __add__(self, other: Coefficients) -> Coefficients:
        return Coefficients(self.a + other.a, self.b + other.b, self.c + other.c)

    def scale(self, k: float) -> Coefficients:
        """All three coefficients times ``k``."""
        return Coefficients(k * self.a, k * self.b, k * self.c)

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        """Psi at an array of angles."""
        t = np.asarray(theta, dtype=np.float64)
        c, s = np.cos(t), np.sin(t)
        return self.a * c * c + 2.0 * self.b * s * c + self.c * s * s

    def energy(self) -> float:
        """``int_0^{2 pi} Psi(theta)^2 dtheta`` (eq. 15), exactly."""
        m, p = 0.5 * (self.a + self.c), 0.5 * (self.a - self.c)
        return float(np.pi * (2.0 * m * m + p * p + self.b * self.b))

    def as_array(self) -> np.ndarray:
        return np.array([self.a, self.b, self.c])


def fit_coefficients(psi) -> Coefficients:
    """Recover ``(a, b, c)`` from a callable ``psi(theta)`` that is steerable.

    Uses ``Psi(0) = a``, ``Psi(pi/2) = c`` and ``Psi(pi/4) = (a + c)/2 + b``.
    """
    v0, v45, v90 = (float(np.asarray(psi(np.array([t])))[0]) for t in (0.0, 0.25 * np.pi, 0.5 * np.pi))
    return Coefficients(v0, v45 - 0.5 * (v0 + v90), v90)
