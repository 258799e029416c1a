"""The scale rule on the pixel lattice, with the detector's own discrete filters.

The continuous theory (:mod:`.scale_rule`) idealises the detector: the image is
a step function sampled nowhere, the filter is continuous and the corner
measure is replaced by the energy of eq. 15. Here each model is rasterised with
anti-aliasing (supersampling, then block averaging), filtered by the
detector's sampled SOGDD kernels (eq. 22, :mod:`sogdd.measure.filters`) and scored two
ways at the pixel on the evaluation point:

* ``measure``: the detector's Upsilon (eq. 25) from :func:`sogdd.measure.soddc.soddc_measure`
  (K orientations, square window), which is what decides detection;
* ``measure_near``: the largest Upsilon within one pixel (3 x 3) of the
  corner, since the measure's peak sits up to a pixel off the corner;
* ``energy``: ``sum_k l_k^2`` over K equally spaced orientations, the lattice
  analogue of eq. 15 (for K >= 3 this sum is exactly ``K / pi`` times the
  integral over ``[0, pi]`` of the squared steered response).

Conventions: the continuous models live in the paper's coordinates (``y`` up);
images have ``x`` = column and ``y`` = row *down*, pixel centres at integer
coordinates, pixel ``(i, j)`` covering ``[j - 1/2, j + 1/2] x [i - 1/2, i + 1/2]``.
The model is translated so that the evaluation point (corner, or edge point at
``u = d/2``) lies on the centre of the middle pixel; the corner and edge
scores come from two renderings of the same model, which keeps both points on
pixel centres for any ``d`` (the detector is not shift-invariant below a pixel).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..measure.filters import kernel_radius, steerable_basis
from ..measure.soddc import MeasureSpec, soddc_measure
from ..measure.window import window_halfwidths
from .models import CornerModel, make_model
from .steering import Coefficients

__all__ = ["LatticeScores", "LatticeStudy", "lattice_scores", "lattice_study", "rasterise"]


def rasterise(m: CornerModel, point: str, half: int, *, supersample: int = 16) -> np.ndarray:
    """Anti-aliased image of a model, ``(2 half + 1)`` square, evaluation point at the centre.

    Each pixel is the mean of ``supersample^2`` point samples on a regular
    sub-grid, i.e. a box-filtered step image with an area error below
    ``1 / supersample`` of a pixel per boundary pixel.
    """
    if half < 1 or supersample < 1:
        raise ValueError("half and supersample must be positive")
    n, s = 2 * half + 1, int(supersample)
    sub = (np.arange(n * s) + 0.5) / s - 0.5 - half  # sample offsets from the centre pixel
    x = sub  # columns, paper x
    y = -sub  # rows go down, paper y goes up
    b = m.boundary(point)(x)
    inside = y[:, None] >= b[None, :]
    img = np.where(inside, m.T1, m.T2).reshape(n, s, n, s).mean(axis=(1, 3))
    return img


@dataclass(frozen=True)
class LatticeScores:
    """Scores of one rendering at its centre pixel."""

    measure: float  # Upsilon, eq. 25, at the centre pixel
    energy: float  # sum_k l_k^2 over K orientations, at the centre pixel
    measure_near: float  # max of Upsilon over the 3 x 3 pixels around the centre


def lattice_scores(
    m: CornerModel,
    point: str,
    sigma2: float,
    *,
    n_orientations: int = 8,
    window: int = 7,
    supersample: int = 16,
) -> LatticeScores:
    """Upsilon and the lattice energy at the evaluation point of a rasterised model."""
    rk = kernel_radius(sigma2, "paper")
    R = window // 2
    half = rk + R + 2  # reflected borders stay out of reach of the centre pixel
    img = rasterise(m, point, half, supersample=supersample)
    spec = MeasureSpec(float(sigma2), int(n_orientations), window_halfwidths("square", window))
    ups_map = soddc_measure(img, spec, threads=1)
    ups = float(ups_map[half, half])
    near = float(ups_map[half - 1 : half + 2, half - 1 : half + 2].max())
    # the basis kernels are even, so correlation = convolution at the centre pixel
    patch = img[half - rk : half + rk + 1, half - rk : half + rk + 1]
    gxx, gxy, gyy = (float(np.sum(k * patch)) for k in steerable_basis(sigma2, rk).kernels())
    # sum over K equally spaced orientations of Psi^2 = (K / (2 pi)) * int_0^{2 pi} Psi^2
    energy = Coefficients(gxx, gxy, gyy).energy() * n_orientations / (2.0 * np.pi)
    return LatticeScores(ups, energy, near)


@dataclass(frozen=True)
class LatticeStudy:
    """Corner and edge scores over a grid: arrays indexed ``[i_d, i_sigma2]``."""

    model: str
    sigma2s: np.ndarray
    ds: np.ndarray
    measure_corner: np.ndarray
    measure_edge: np.ndarray
    energy_corner: np.ndarray
    energy_edge: np.ndarray
    measure_corner_near: np.ndarray  # max Upsilon within one pixel of the corner

    @property
    def measure_near_wins(self) -> np.ndarray:
        """Where the largest Upsilon within one pixel of the corner beats Upsilon at the edge pixel."""
        return self.measure_corner_near > self.measure_edge

    @property
    def measure_wins(self) -> np.ndarray:
        """Where Upsilon at the corner pixel beats Upsilon at the edge pixel."""
        return self.measure_corner > self.measure_edge

    @property
    def energy_wins(self) -> np.ndarray:
        """Where the lattice energy (eq. 15) at the corner beats the edge."""
        return self.energy_corner > self.energy_edge

    def crossing(self, i_d: int, which: str = "measure") -> float | None:
        """Smallest ``sigma2`` on the grid where the corner stops winning, by linear
        interpolation of ``log(corner / edge)``; ``None`` if it wins throughout."""
        c = getattr(self, f"{which}_corner")[i_d]
        e = getattr(self, f"{which}_edge")[i_d]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.log(np.maximum(c, 1e-300)) - np.log(np.maximum(e, 1e-300))
        for k in range(len(r) - 1):
            if r[k] > 0 >= r[k + 1]:
                lo, hi = self.sigma2s[k], self.sigma2s[k + 1]
                return float(lo + (hi - lo) * r[k] / (r[k] - r[k + 1]))
        return None


def lattice_study(
    model: str,
    sigma2s: np.ndarray,
    ds: np.ndarray,
    *,
    alpha: float,
    beta: float | None = None,
    T1: float = 50.0,
    T2: float = 100.0,
    supersample: int = 16,
) -> LatticeStudy:
    """Corner-versus-edge scores on the lattice over a grid of ``sigma^2`` and ``d``.

    Parameters
    ----------
    model : {"end", "l"}
    sigma2s : array_like
        Filter scales as variances ``sigma^2`` (the detector's parameter).
    ds : array_like
        Corner separations in pixels.
    alpha, beta, T1, T2 : float
        Model parameters (``T1, T2`` on the 0-255 scale of the detector).
    """
    s2 = np.asarray(sigma2s, dtype=np.float64)
    dd = np.asarray(ds, dtype=np.float64)
    out = np.zeros((5, len(dd), len(s2)))
    for i, d in enumerate(dd):
        m = make_model(model, d=float(d), alpha=alpha, beta=beta, T1=T1, T2=T2)
        for j, v in enumerate(s2):
            c = lattice_scores(m, "corner", float(v), supersample=supersample)
            e = lattice_scores(m, "edge", float(v), supersample=supersample)
            out[:, i, j] = (c.measure, e.measure, c.energy, e.energy, c.measure_near)
    return LatticeStudy(str(model).lower(), s2, dd, *out)
