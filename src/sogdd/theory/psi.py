"""One entry point for Psi(theta), by any of the three methods."""

from __future__ import annotations

import numpy as np

from .closed_form import exact_coefficients
from .models import POINTS, CornerModel, make_model
from .paper_formulas import paper_end_corner, paper_end_edge, paper_l_corner, paper_l_edge
from .quadrature import quadrature_coefficients
from .steering import Coefficients, fit_coefficients

__all__ = ["METHODS", "coefficients", "representation"]

METHODS = ("exact", "quadrature", "paper")


def _paper_callable(m: CornerModel, point: str, sigma: float):
    args = dict(sigma=sigma, d=m.d, alpha=m.alpha, T1=m.T1, T2=m.T2)
    if m.kind == "end":
        f = paper_end_corner if point == "corner" else paper_end_edge
        return lambda th: f(th, beta=m.beta, **args)
    f = paper_l_corner if point == "corner" else paper_l_edge
    return lambda th: f(th, **args)


def _check(point: str, sigma: float, method: str) -> None:
    if point not in POINTS:
        raise ValueError(f"point must be 'corner' or 'edge', not {point!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, not {method!r}")
    if not (np.isfinite(sigma) and sigma > 0):
        raise ValueError(f"sigma must be a positive number, not {sigma!r}")


def coefficients(m: CornerModel, point: str, sigma: float, method: str = "exact") -> Coefficients:
    """Steering coefficients ``(a, b, c)`` of Psi (including ``T1 - T2``).

    For ``method="paper"`` they are read off the printed formula at three angles;
    every printed formula is a combination of ``cos^2, sin^2`` and ``sin 2theta``,
    so this is exact.
    """
    _check(point, sigma, method)
    if method == "exact":
        return exact_coefficients(m, point, sigma)
    if method == "quadrature":
        return quadrature_coefficients(m, point, sigma)
    return fit_coefficients(_paper_callable(m, point, sigma))


def representation(
    model: str,
    point: str,
    theta: np.ndarray,
    sigma: float,
    *,
    d: float,
    alpha: float,
    beta: float | None = None,
    T1: float = 50.0,
    T2: float = 100.0,
    method: str = "exact",
) -> np.ndarray:
    """The SOGDD representation Psi(theta) of eq. 3 for a corner model.

    Parameters
    ----------
    model : {"end", "l"}
        END type (eq. 3) or L type (eq. 11).
    point : {"corner", "edge"}
        Evaluate at the corner ``u = 0`` or at the edge point ``u = d/2``.
    theta : array_like
        Filter orientations (radians), in the paper's coordinates (``y`` up).
    sigma : float
        Gaussian scale (standard deviation, not variance).
    d, alpha, beta : float
        Model geometry; ``beta`` is required for END and ignored for L.
    T1, T2 : float
        Grey levels above and below the boundary.
    method : {"exact", "quadrature", "paper"}
        Our closed form, numerical integration, or the paper's printed formula
        (eqs. 4, 6, 12, 14), which is *not* always correct.

    Returns
    -------
    numpy.ndarray
        Psi at each ``theta``, same shape as ``theta``.
    """
    m = make_model(model, d=d, alpha=alpha, beta=beta, T1=T1, T2=T2)
    _check(point, sigma, method)
    th = np.asarray(theta, dtype=np.float64)
    if method == "paper":
        return np.asarray(_paper_callable(m, point, float(sigma))(th), dtype=np.float64)
    return coefficients(m, point, float(sigma), method)(th)
