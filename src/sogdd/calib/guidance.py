"""What to do next after a calibration: where the next views should put the board, and how to tilt it.

The frame is cut into a 3 x 3 grid of regions; each region gets the share of
the used corners that fell in it (:func:`~sogdd.calib.verdict.coverage`) and
the worst far-point projection uncertainty over it
(:func:`~sogdd.calib.uncertainty.image_uncertainty` from
``Calibration.covariance``, the map behind the verdict's uncertainty finding).
The used views' board poses give how far each view tilts the board about the
image's vertical and horizontal axes. :func:`guidance` turns both into a few
short sentences, the most useful first; none when nothing is needed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .result import Calibration
from .uncertainty import UNCERTAIN_PX, image_uncertainty
from .verdict import board_normals, coverage

__all__ = ["REGIONS", "TILT_DEG", "Guidance", "Region", "board_tilts", "guidance"]

#: the 3 x 3 regions of the frame, row by row from the top left
REGIONS = ("top left", "top", "top right", "left", "centre", "right", "bottom left", "bottom", "bottom right")
#: a view tilts the board "about an axis" when its normal turns this far (degrees) about it: 30-45 deg
#: tilts are what calibration guides ask for, and what separates the focal length from the distance
TILT_DEG = 30.0
# an axis is tilted enough when at least this share of the used views, and _TILTED_VIEWS of them, tilt
# about it: a few strongly tilted views pin the focal length, one alone is a single pose the fit can bend to
_TILTED_SHARE = 0.2
_TILTED_VIEWS = 2
# a region is advised when it is this many times worse than the best-pinned region: below that, the whole
# frame is about as loose as its best part, which more views anywhere shrink, not views in that region
_WORSE = 1.2
# without a covariance, a region holding less than a quarter of its even share of the corners (1/9) is empty
_SPARSE = 0.25 / 9
_MAX_REGIONS = 3       # the region sentences name the worst few: a list of nine says nothing
_SAMPLES = 5           # uncertainty samples across and down each region, its edges included
_WHERE = {"top left": "the top-left corner", "top": "the top edge", "top right": "the top-right corner",
          "left": "the left edge", "centre": "the centre", "right": "the right edge",
          "bottom left": "the bottom-left corner", "bottom": "the bottom edge",
          "bottom right": "the bottom-right corner"}


@dataclass(frozen=True)
class Region:
    """One of the frame's 3 x 3 regions.

    Attributes
    ----------
    name : str
        One of :data:`REGIONS`.
    coverage : float
        The share of the used corners that fell in it (0-1).
    uncertainty_px : float
        The worst far-point projection uncertainty over it (px, 1 sigma); NaN without a covariance.
    """

    name: str
    coverage: float
    uncertainty_px: float


@dataclass(frozen=True)
class Guidance:
    """Where the next views should put the board (the result of :func:`guidance`).

    Attributes
    ----------
    regions : tuple of Region
        The nine regions, in the order of :data:`REGIONS`.
    tilts : (V, 2) float64
        Per used view, the board's tilt about the image's vertical and horizontal axes (degrees,
        :func:`board_tilts`).
    advice : tuple of str
        Short sentences, the most useful first; empty when nothing is needed.
    """

    regions: tuple[Region, ...]
    tilts: np.ndarray
    advice: tuple[str, ...]

    def tilted(self) -> tuple[int, int]:
        """How many used views tilt the board :data:`TILT_DEG` or more about the vertical and the
        horizontal axis."""
        t = self.tilts.reshape(-1, 2)
        return int(np.sum(t[:, 0] >= TILT_DEG)), int(np.sum(t[:, 1] >= TILT_DEG))

    def as_dict(self) -> dict:
        """Plain JSON-able data (NaN as None): ``regions`` (``name``, ``coverage``, ``uncertainty_px``),
        ``tilts`` (``views``, ``tilted_about_vertical``, ``tilted_about_horizontal``, ``threshold_deg``)
        and ``advice``.

        Examples
        --------
        >>> g = Guidance((Region("centre", 1.0, float("nan")),), np.array([[35.0, 5.0]]), ())
        >>> d = g.as_dict()
        >>> d["regions"], d["tilts"]["tilted_about_vertical"], d["advice"]
        ([{'name': 'centre', 'coverage': 1.0, 'uncertainty_px': None}], 1, [])
        """
        about_v, about_h = self.tilted()
        return {"regions": [{"name": r.name, "coverage": r.coverage,
                             "uncertainty_px": float(r.uncertainty_px) if np.isfinite(r.uncertainty_px)
                             else None} for r in self.regions],
                "tilts": {"views": len(self.tilts), "tilted_about_vertical": about_v,
                          "tilted_about_horizontal": about_h, "threshold_deg": TILT_DEG},
                "advice": list(self.advice)}


def board_tilts(cal: Calibration) -> np.ndarray:
    """Per used view, the board's tilt about the image's vertical and horizontal axes (degrees), (V, 2).

    With :math:`n = R e_z` the board's normal in the camera's frame
    (:func:`~sogdd.calib.verdict.board_normals`), the tilt about the vertical (y) axis is the angle of ``n``'s
    projection on the x-z plane from the optical axis, :math:`\\arctan(|n_x| / |n_z|)`,
    and about the horizontal (x) axis :math:`\\arctan(|n_y| / |n_z|)`. A board
    parallel to the image plane (both 0) maps to it by an affine map, which cannot
    separate the focal length from the distance.

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> t = board_tilts(demo_calibration())
    >>> t.shape, bool(np.all((t >= 0) & (t < 30)))
    ((8, 2), True)
    """
    n = board_normals(cal)
    return np.degrees(np.arctan2(np.abs(n[:, :2]), np.abs(n[:, 2:])))


def _region_uncertainty(cal: Calibration) -> np.ndarray:
    """The worst far-point uncertainty (px) over each region, (9,) in :data:`REGIONS`' order; NaN without a
    covariance or where no sample of a region has a ray."""
    if cal.covariance.size == 0:
        return np.full(9, np.nan)
    w, h = cal.image_size
    xs = [np.linspace(c * (w - 1) / 3, (c + 1) * (w - 1) / 3, _SAMPLES) for c in range(3)]
    ys = [np.linspace(r * (h - 1) / 3, (r + 1) * (h - 1) / 3, _SAMPLES) for r in range(3)]
    pixels = np.concatenate([np.stack(np.meshgrid(xs[c], ys[r]), -1).reshape(-1, 2)
                             for r in range(3) for c in range(3)])
    _, sigma = image_uncertainty(cal.K, cal.dist, cal.model, cal.image_size, cal.covariance, pixels)
    s = sigma.reshape(9, -1)
    return np.array([np.nanmax(row) if np.isfinite(row).any() else np.nan for row in s])


def guidance(cal: Calibration) -> Guidance:
    """Where the next views should put the board to shrink the largest uncertainty, and how to tilt it.

    Regions: the frame cut into 3 x 3 equal regions; a region's ``coverage`` is
    the share of the used corners in it, its ``uncertainty_px`` the largest
    :math:`\\sqrt{\\lambda_{\\max}(J_q \\Sigma J_q^T)}` over a 5 x 5 grid of its
    pixels (a far point's 1-sigma projection uncertainty,
    :func:`~sogdd.calib.uncertainty.image_uncertainty`). The advice, most useful
    first:

    - each region worse than :data:`~sogdd.calib.uncertainty.UNCERTAIN_PX` (1 px)
      and than 1.2 times the best region, the worst first and at most three: put
      the board there. When even the best region is worse than 1 px, the frame as a
      whole is loose: add sharp views over all of it. Without a covariance
      (omnidir, extra OpenCV flags) each region holding less than a quarter of its
      even share of the corners (1/36), the emptiest first;
    - an axis about which fewer than a fifth of the used views (or fewer than 2)
      tilt the board :data:`TILT_DEG` (30 deg) or more (:func:`board_tilts`): tilt
      it 30-45 deg about that axis. These come first when even the best region is
      worse than 1 px: then the views as a whole leave the camera loose, and
      placing the board elsewhere helps less than tilting it and adding views.

    No advice when every region is within 1 px (without a covariance: none is empty) and both axes are
    tilted enough.

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> g = guidance(demo_calibration())
    >>> [r.name for r in g.regions][:3], round(sum(r.coverage for r in g.regions), 6)
    (['top left', 'top', 'top right'], 1.0)
    >>> g.advice[0]
    'tilt the board 30-45 deg about the vertical axis (0 of 8 views tilted so)'
    """
    counts, _, _ = coverage(cal, grid=(3, 3))
    total = counts.sum()
    share = counts.ravel() / total if total else np.zeros(9)
    sigma = _region_uncertainty(cal)
    regions = tuple(Region(n, float(c), float(s)) for n, c, s in zip(REGIONS, share, sigma))

    floor = float(np.nanmin(sigma)) if np.isfinite(sigma).any() else float("nan")
    if np.isfinite(floor):
        bad = [i for i in np.argsort(-np.nan_to_num(sigma, nan=-1.0))
               if sigma[i] > max(UNCERTAIN_PX, _WORSE * floor)]
        place = [f"put the board at {_WHERE[REGIONS[i]]} of the frame ({sigma[i]:.2g} px there, "
                 f"{share[i]:.0%} of the corners)" for i in bad[:_MAX_REGIONS]]
    else:
        empty = [i for i in np.argsort(share, kind="stable") if share[i] < _SPARSE]
        place = [f"put the board at {_WHERE[REGIONS[i]]} of the frame ({share[i]:.0%} of the corners)"
                 for i in empty[:_MAX_REGIONS]]

    tilts = board_tilts(cal)
    n = len(tilts)
    need = max(_TILTED_VIEWS, int(np.ceil(_TILTED_SHARE * n)))
    tilt = [f"tilt the board 30-45 deg about the {axis} axis ({k} of {n} views tilted so)"
            for axis, k in zip(("vertical", "horizontal"), np.sum(tilts >= TILT_DEG, axis=0)) if k < need]

    if floor > UNCERTAIN_PX:  # the whole frame is loose: more and tilted views first, then the worst regions
        whole = [f"add sharp views over the whole frame: even its best-pinned region is {floor:.2g} px"]
        advice = tilt + whole + place
    else:
        advice = place + tilt
    return Guidance(regions, tilts, tuple(advice))
