"""The paper's printed formulas for Psi, transcribed literally (eqs. 4, 6, 12, 14).

Nothing here is corrected: these functions exist so that the printed formulas
can be compared with the exact values (:mod:`.closed_form`, :mod:`.quadrature`).
The paper does not define ``Phi``; the arguments ``sqrt(2) d sin(beta) / (2 sigma)``
have the form ``z / (sqrt 2 sigma)`` that goes with the error function
(``1 - erf = erfc`` appears in the exact result), so ``Phi = erf`` by default;
``phi="normal_cdf"`` selects the standard normal CDF instead.

All functions take ``theta`` as an array and return an array of the same shape.

``erratum=True`` applies the two corrections that we found make all four
formulas agree with the exact values to rounding (see docs/theory.md):

1. every ``sqrt(pi) cos^2(theta) / (2 tan)`` should read ``cos^2(theta) / tan``
   (a spurious factor ``sqrt(pi)/2`` on the ``cos^2`` terms, in all four
   equations);
2. in eq. 4 the two brackets ``(sin 2theta - sqrt(pi) cos^2 / (2 tan beta) -
   sin^2 / tan beta)`` have the wrong sign on their ``cos^2`` term.

The default (``erratum=False``) is the literal transcription.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf, ndtr

__all__ = ["paper_end_corner", "paper_end_edge", "paper_l_corner", "paper_l_edge"]


def _Phi(z: float, phi: str) -> float:
    if phi == "erf":
        return float(erf(z))
    if phi == "normal_cdf":
        return float(ndtr(z))
    raise ValueError(f"phi must be 'erf' or 'normal_cdf', not {phi!r}")


def _sqrt_pi(erratum: bool) -> float:
    # the printed sqrt(pi)/2 is 1 in the exact result, i.e. sqrt(pi) -> 2
    return 2.0 if erratum else float(np.sqrt(np.pi))


def _trig(theta):
    t = np.asarray(theta, dtype=np.float64)
    return np.cos(t) ** 2, np.sin(t) ** 2, np.sin(2.0 * t)


def paper_end_corner(
    theta: np.ndarray, sigma: float, d: float, alpha: float, beta: float,
    T1: float = 50.0, T2: float = 100.0, *, phi: str = "erf", erratum: bool = False,
) -> np.ndarray:
    """Eq. 4: Psi_1 of the END model at the corner ``u = 0``, as printed."""
    c2, s2, sin2 = _trig(theta)
    sp, rp = _sqrt_pi(erratum), np.sqrt(2.0 * np.pi)
    ta, tb = np.tan(alpha), np.tan(beta)
    ed = np.exp(-(d**2) / (2 * sigma**2))
    eb = np.exp(-(d**2) * np.cos(beta) ** 2 / (2 * sigma**2))
    tail = 1.0 - _Phi(np.sqrt(2.0) * d * np.sin(beta) / (2 * sigma), phi)
    t1 = np.sin(alpha) ** 2 / (2 * np.pi * sigma**2) * (sp * c2 / (2 * ta) - s2 / ta - sin2)
    sgn = 1.0 if erratum else -1.0  # printed: "sin 2theta - sqrt(pi) cos^2 theta / (2 tan beta) - ..."
    br = sin2 + sgn * sp * c2 / (2 * tb) - s2 / tb
    t2 = np.sin(beta) ** 2 / (2 * np.pi * sigma**2) * ed * br
    t3 = rp * d * np.sin(beta) ** 3 / (4 * np.pi * sigma**3) * eb * tail * br
    t4 = sin2 / (2 * np.pi * sigma**2) * (1.0 - ed)
    t5 = rp * d * np.sin(beta) / (4 * np.pi * sigma**3) * eb * tail * (sin2 + sp * c2 / (2 * tb))
    return (T1 - T2) * (t1 + t2 - t3 + t4 + t5)


def paper_end_edge(
    theta: np.ndarray, sigma: float, d: float, alpha: float, beta: float,
    T1: float = 50.0, T2: float = 100.0, *, phi: str = "erf", erratum: bool = False,
) -> np.ndarray:
    """Eq. 6: Psi_2 of the END model at the edge point ``u = d/2``, as printed."""
    c2, s2, sin2 = _trig(theta)
    sp, rp = _sqrt_pi(erratum), np.sqrt(2.0 * np.pi)
    ta, tb = np.tan(alpha), np.tan(beta)
    sa, sb = np.sin(alpha), np.sin(beta)
    ea = np.exp(-(d**2) * np.cos(alpha) ** 2 / (8 * sigma**2))
    eb = np.exp(-(d**2) * np.cos(beta) ** 2 / (8 * sigma**2))
    tail_a = 1.0 - _Phi(np.sqrt(2.0) * d * sa / (4 * sigma), phi)
    tail_b = 1.0 - _Phi(np.sqrt(2.0) * d * sb / (4 * sigma), phi)
    t1 = -rp * sa / 2 * ea * tail_a * (d / 2 * sin2 - sp * d * c2 / (4 * ta))
    t2 = rp * d * sa**3 / 4 * ea * tail_a * (sp * c2 / (2 * ta) - sin2 - s2 / ta)
    t3 = rp * d * sb**3 / 4 * eb * tail_b * (sp * c2 / (2 * tb) + sin2 - s2 / tb)
    t4 = rp * sb / 2 * eb * tail_b * (d / 2 * sin2 + sp * d * c2 / (4 * tb))
    t5 = sigma * np.exp(-(d**2) / (8 * sigma**2)) * (
        sa**2 * (sp * c2 / (2 * ta) - sin2 - s2 / ta) + sb**2 * (sp * c2 / (2 * tb) + sin2 - s2 / tb)
    )
    return (T1 - T2) / (2 * np.pi * sigma**3) * (t1 - t2 - t3 + t4 + t5)


def paper_l_corner(
    theta: np.ndarray, sigma: float, d: float, alpha: float,
    T1: float = 50.0, T2: float = 100.0, *, erratum: bool = False,
) -> np.ndarray:
    """Eq. 12: Psi_1 of the L model at the corner ``u = 0``, as printed (no ``d``)."""
    c2, s2, sin2 = _trig(theta)
    ta = np.tan(alpha)
    sp = _sqrt_pi(erratum)
    inner = -sin2 + np.sin(alpha) ** 2 * (-sp * c2 / (2 * ta) + sin2 + s2 / ta)
    return (T2 - T1) / (2 * np.pi * sigma**2) * inner


def paper_l_edge(
    theta: np.ndarray, sigma: float, d: float, alpha: float,
    T1: float = 50.0, T2: float = 100.0, *, phi: str = "erf", erratum: bool = False,
) -> np.ndarray:
    """Eq. 14: Psi_2 of the L model at the edge point ``u = d/2``, as printed."""
    c2, s2, sin2 = _trig(theta)
    sp, rp = _sqrt_pi(erratum), np.sqrt(2.0 * np.pi)
    ta, sa = np.tan(alpha), np.sin(alpha)
    e8 = np.exp(-(d**2) / (8 * sigma**2))
    ea = np.exp(-(d**2) * np.cos(alpha) ** 2 / (8 * sigma**2))
    tail = 1.0 - _Phi(np.sqrt(2.0) * d * sa / (4 * sigma), phi)
    shape = -sp * c2 / (2 * ta) + sin2 + s2 / ta
    t1 = sigma * sa**2 * e8 * shape
    t2 = sigma * sin2 * e8
    t3 = rp * d * sa**3 / 4 * ea * tail * shape
    t4 = rp * sa / 2 * ea * tail * (d / 2 * sin2 - sp * d * c2 / (4 * ta))
    return (T2 - T1) / (2 * np.pi * sigma**3) * (t1 - t2 - t3 + t4)
