"""The scale rule of eq. 15: for which sigma does the corner out-respond the edge?

``E_i(sigma) = int_0^{2 pi} Psi_i(theta)^2 dtheta`` (``i = 1`` corner, ``2`` edge
point) in closed form from the steering coefficients. ``E_1 / E_2`` does not
depend on ``T1, T2`` (both scale with ``(T1 - T2)^2``), so only ``d``, ``alpha``,
``beta`` and ``sigma`` matter, as the paper says.

The sign of ``E_1 - E_2`` is followed on a fine logarithmic grid of ``sigma``
and every sign change is refined with Brent's method, so the intervals are exact
to ~1e-12 in ``sigma`` as long as no two crossings fall within one grid step
(600 geometrically spaced points over the scan range; the curves are smooth).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .models import CornerModel, make_model
from .psi import coefficients

__all__ = [
    "PAPER_CLAIMS",
    "SigmaScan",
    "crossings",
    "energies",
    "energy_gap",
    "scan_sigma",
    "sigma_range",
    "sigma_range_grid",
]

#: The numbers printed in the paper's text after eqs. 17 and 21 and its conclusion.
PAPER_CLAIMS = {
    "sigma_11": 1.204,  # END, "minimum value of sigma_11", d = 3
    "sigma_21": -25.307,  # END
    "sigma_13": 1.253,  # L, d = 3
    "sigma_23": -2.004,  # L
    "range": (1.0, 1.2),  # the conclusion sigma in (1, 1.2)
}


def energies(m: CornerModel, sigma: float, method: str = "exact") -> tuple[float, float]:
    """``(E_1, E_2)``: eq. 15's integrals at the corner and at the edge point."""
    return (
        coefficients(m, "corner", sigma, method).energy(),
        coefficients(m, "edge", sigma, method).energy(),
    )


def energy_gap(m: CornerModel, sigma: float, method: str = "exact") -> float:
    """``(E_1 - E_2) / (E_1 + E_2)`` in ``[-1, 1]``: positive where the corner wins."""
    e1, e2 = energies(m, sigma, method)
    tot = e1 + e2
    return 0.0 if tot == 0 else (e1 - e2) / tot


@dataclass(frozen=True)
class SigmaScan:
    """Result of a scan: the corner-wins intervals and the crossings ``E_1 = E_2``."""

    intervals: list[tuple[float, float]]
    crossings: list[float]


def scan_sigma(
    m: CornerModel, sigma_min: float = 0.3, sigma_max: float = 6.0, method: str = "exact", n: int = 600
) -> SigmaScan:
    """Corner-wins intervals and crossings of a model over ``[sigma_min, sigma_max]``."""
    if not (0 < sigma_min < sigma_max and np.isfinite(sigma_max)):
        raise ValueError(f"need 0 < sigma_min < sigma_max, got {sigma_min!r}, {sigma_max!r}")
    grid = np.geomspace(sigma_min, sigma_max, n)
    vals = np.array([energy_gap(m, s, method) for s in grid])
    roots = []
    for i in np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]:
        roots.append(
            float(brentq(lambda s: energy_gap(m, s, method), grid[i], grid[i + 1], xtol=1e-13, rtol=1e-13))
        )
    # exact zeros on the grid (unlikely) count as crossings too
    roots += [float(s) for s, v in zip(grid, vals) if v == 0.0]
    roots.sort()
    # the corner wins between consecutive breakpoints where the gap is positive
    bps = [sigma_min, *roots, sigma_max]
    intervals = []
    for lo, hi in zip(bps[:-1], bps[1:]):
        if hi > lo and energy_gap(m, float(np.sqrt(lo * hi)), method) > 0:
            if intervals and intervals[-1][1] == lo:
                intervals[-1] = (intervals[-1][0], hi)
            else:
                intervals.append((lo, hi))
    return SigmaScan(intervals, roots)


def sigma_range(
    model: str,
    *,
    d: float,
    alpha: float,
    beta: float | None = None,
    sigma_min: float = 0.3,
    sigma_max: float = 6.0,
    method: str = "exact",
) -> list[tuple[float, float]]:
    """The ``sigma`` intervals within ``[sigma_min, sigma_max]`` where ``E_1 > E_2``.

    Parameters
    ----------
    model : {"end", "l"}
    d, alpha, beta : float
        Model geometry (``beta`` for END only).
    sigma_min, sigma_max : float
        The scan range (``sigma`` is the standard deviation).
    method : {"exact", "quadrature", "paper"}
        Which Psi to use; ``"paper"`` shows what the printed formulas imply.

    Returns
    -------
    list of (float, float)
        Disjoint intervals, ends at ``sigma_min``/``sigma_max`` where open.
    """
    m = make_model(model, d=d, alpha=alpha, beta=beta)
    return scan_sigma(m, float(sigma_min), float(sigma_max), method).intervals


def crossings(
    model: str,
    *,
    d: float,
    alpha: float,
    beta: float | None = None,
    sigma_min: float = 0.3,
    sigma_max: float = 6.0,
    method: str = "exact",
) -> list[float]:
    """The ``sigma`` in ``[sigma_min, sigma_max]`` where ``E_1 = E_2``."""
    m = make_model(model, d=d, alpha=alpha, beta=beta)
    return scan_sigma(m, float(sigma_min), float(sigma_max), method).crossings


def sigma_range_grid(
    model: str,
    ds: np.ndarray,
    alphas: np.ndarray,
    betas: np.ndarray | None = None,
    *,
    sigma_min: float = 0.3,
    sigma_max: float = 6.0,
    method: str = "exact",
) -> list[dict]:
    """:func:`sigma_range` over a grid; one record per ``(d, alpha[, beta])``.

    Each record has ``d, alpha, beta, intervals, crossings`` and ``first_crossing``
    (the smallest crossing, or ``None`` when the corner wins over the whole range).
    """
    betas_ = [None] if model == "l" else list(betas if betas is not None else [])
    if not betas_:
        raise ValueError("the END model needs betas")
    out = []
    for d in ds:
        for a in alphas:
            for b in betas_:
                m = make_model(model, d=float(d), alpha=float(a), beta=None if b is None else float(b))
                sc = scan_sigma(m, sigma_min, sigma_max, method)
                out.append(
                    dict(d=float(d), alpha=float(a), beta=None if b is None else float(b),
                         intervals=sc.intervals, crossings=sc.crossings,
                         first_crossing=sc.crossings[0] if sc.crossings else None)
                )
    return out
