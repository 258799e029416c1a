"""The two halves' cross-validation: two calibrations from the interleaved halves of the used views,
and how far apart they put the same rays (:func:`~sogdd.calib.cameras.projection_difference`).

A model that fits, with enough views, gives a small difference; a wrong model or
too few views a large one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .cameras import ProjectionDifference, project, projection_difference
from .solvers import fit_camera
from .targets.board import Board

__all__ = ["CrossValidation", "cross_validate"]


@dataclass(frozen=True)
class CrossValidation:
    """Two calibrations from the two interleaved halves of the used views, and how far they disagree.

    Two figures, and they differ a lot: ``mean``/``max`` are over the whole
    frame, where beyond the boards both cameras extrapolate; ``mean_within``/
    ``max_within`` are over the grid points inside the convex hull of the used
    corners, where the data pin the model down. The command's summary and
    :func:`~sogdd.calib.verdict.verdict` judge ``mean_within`` (1.8 px there
    against 6.4 px over the frame on one real set); a large ``max`` outside
    the corners says the model is not to be trusted beyond them.

    Attributes
    ----------
    difference : ProjectionDifference
        Camera A against camera B over the image (:func:`projection_difference`
        with ``fit_rotation=True``: the halves' camera frames are free to differ
        by a rotation, fitted inside the convex hull of the used corners;
        ``mean_within``/``max_within`` are the statistics there).
    views_a, views_b : tuple of int
        Indices of the views in each half.
    K_a, dist_a, K_b, dist_b : ndarray
        The two halves' cameras.
    rms_a, rms_b : float
        Their RMS reprojection errors (px).
    """

    difference: ProjectionDifference
    views_a: tuple[int, ...]
    views_b: tuple[int, ...]
    K_a: np.ndarray
    dist_a: np.ndarray
    K_b: np.ndarray
    dist_b: np.ndarray
    rms_a: float
    rms_b: float

    @property
    def mean(self) -> float:
        """Mean projection difference between the halves over the whole frame (px)."""
        return self.difference.mean

    @property
    def max(self) -> float:
        """Largest projection difference between the halves over the whole frame (px)."""
        return self.difference.max

    @property
    def mean_within(self) -> float:
        """Mean projection difference inside the hull of the used corners (px)."""
        return self.difference.mean_within

    @property
    def max_within(self) -> float:
        """Largest projection difference inside the hull of the used corners (px)."""
        return self.difference.max_within


def cross_validate(boards: Sequence[Board], corner_ok: Sequence[np.ndarray], used: np.ndarray, *,
                   square: float, image_size: tuple[int, int], model: str, flags: int,
                   min_views: int, weights: Sequence[np.ndarray] | None = None
                   ) -> tuple[CrossValidation | None, str]:
    """Calibrate the even- and odd-ranked used views separately and compare the two cameras.

    The halves are ``used[0::2]`` and ``used[1::2]`` (disjoint, their union the
    used views); each is calibrated with the same ``model`` and ``flags`` as the
    whole, from the corners ``corner_ok`` keeps. The difference is
    :func:`projection_difference` with ``fit_rotation=True``, the rotation fitted
    inside the convex hull of the used corners. ``weights`` (per view, one per
    kept corner, as the whole's fit used them) weigh each half's fit the same way.

    Returns
    -------
    (CrossValidation, "") or (None, why not)
        None with fewer than ``2 * min_views`` used views, or when OpenCV
        cannot calibrate a half.
    """
    if len(used) < 2 * min_views:
        return None, f"no cross-validation: {len(used)} used views, it needs {2 * min_views} (two halves)"
    halves = (used[0::2], used[1::2])
    fits = []
    for half in halves:
        obj = [boards[v].object_points(square)[corner_ok[v]] for v in half]
        img = [boards[v].image_points[corner_ok[v]] for v in half]
        w = None if weights is None else [weights[v] for v in half]
        try:
            K, D, rv, tv, _ = fit_camera(obj, img, image_size, model, flags, w)
        except cv2.error:
            return None, "no cross-validation: OpenCV could not calibrate one of the halves"
        r = np.concatenate([i - project(o, K, D, model, rv[n], tv[n])
                            for n, (o, i) in enumerate(zip(obj, img))])
        fits.append((K, D, float(np.sqrt(np.mean(np.sum(r * r, axis=1))))))
    (Ka, Da, ra), (Kb, Db, rb) = fits
    pts = np.concatenate([boards[v].image_points[corner_ok[v]] for v in used]).astype(np.float32)
    hull = cv2.convexHull(pts).reshape(-1, 2)
    diff = projection_difference((Ka, Da, model), (Kb, Db, model), image_size, fit_rotation=True,
                                 within=hull if len(hull) >= 3 else None)
    cv = CrossValidation(diff, tuple(int(v) for v in halves[0]), tuple(int(v) for v in halves[1]),
                         Ka, Da, Kb, Db, ra, rb)
    return cv, ""
