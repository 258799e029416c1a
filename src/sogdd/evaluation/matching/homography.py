"""Homography accuracy: H estimated from the matches, its corner error, and the AUC of the errors.

MMA counts correct matches; this measures whether the geometry is recovered,
the metric of SuperGlue, LoFTR and their successors on HPatches.

1. **Estimate.** ``H_est`` is fitted to the matched points with OpenCV's
   MAGSAC++ (``cv2.findHomography(..., cv2.USAC_MAGSAC)``, reprojection
   threshold :data:`RANSAC_THRESHOLD` px, at most :data:`RANSAC_MAX_ITERS`
   iterations, confidence :data:`RANSAC_CONFIDENCE`). The USAC framework seeds
   its own generator from a fixed state on every call, so the estimate is
   deterministic; ``cv2.setRNGSeed`` does not reach it (tested).
2. **Corner error.** The four corner pixels of the reference image
   ``(0, 0), (w-1, 0), (w-1, h-1), (0, h-1)`` (pixel centres) are mapped by
   ``H_est`` and by the ground truth ``H``; the pair's error is the mean of the
   four distances, in target-image pixels:

   .. math:: e = \\tfrac14 \\sum_{i=1}^{4} \\lVert \\pi(H_{est} c_i) - \\pi(H c_i) \\rVert_2 .

   A pair with fewer than 4 matches, or where no model is found, has
   ``e = inf`` (it counts as a failure at every threshold).
3. **AUC.** SuperGlue's convention (``pose_auc``), used by LoFTR for HPatches:
   with the errors ``e_(1) <= ... <= e_(n)`` of the ``n`` pairs, the cumulative
   curve ``r(e) = #{e_(j) <= e} / n`` is drawn through the points
   ``(0, 0), (e_(k), k/n)``, held flat after the last error below ``t``, and
   integrated with the trapezoidal rule from 0 to ``t``:

   .. math:: \\mathrm{AUC}(t) = \\frac{1}{t} \\int_0^t r(e)\\, de ,

   so a perfect estimate everywhere gives 1 and a failure contributes 0.
   Thresholds :data:`AUC_THRESHOLDS` = 1, 3, 5 px.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

__all__ = ["AUC_THRESHOLDS", "RANSAC_CONFIDENCE", "RANSAC_MAX_ITERS", "RANSAC_THRESHOLD", "auc_of_errors",
           "corner_error", "estimate_homography"]

AUC_THRESHOLDS: tuple[int, ...] = (1, 3, 5)
RANSAC_THRESHOLD = 3.0
RANSAC_MAX_ITERS = 10_000
RANSAC_CONFIDENCE = 0.999


def estimate_homography(src: np.ndarray, dst: np.ndarray, *, threshold: float = RANSAC_THRESHOLD,
                        max_iters: int = RANSAC_MAX_ITERS, confidence: float = RANSAC_CONFIDENCE
                        ) -> tuple[np.ndarray | None, int]:
    """MAGSAC++ homography from matched points: ``(H mapping src to dst or None, inlier count)``.

    Parameters
    ----------
    src, dst : (N, 2) arrays
        Matched positions (x, y) in the reference and the target image.
    threshold, max_iters, confidence
        ``cv2.findHomography``'s ``ransacReprojThreshold``, ``maxIters`` and ``confidence``.

    Returns
    -------
    H : (3, 3) float64 normalised to ``H[2, 2] = 1``, or None
        None with fewer than 4 matches or when OpenCV finds no model.
    inliers : int

    Examples
    --------
    >>> import numpy as np
    >>> h = np.array([[1.0, 0.1, 5.0], [0.0, 0.9, -3.0], [0.0, 0.0, 1.0]])
    >>> src = np.random.default_rng(0).uniform(0, 100, (50, 2))
    >>> dst = src @ h[:2, :2].T + h[:2, 2]
    >>> est, n = estimate_homography(src, dst)
    >>> n, bool(corner_error(est, h, (100, 100)) < 0.01)
    (50, True)
    """
    src = np.asarray(src, dtype=np.float64).reshape(-1, 2)
    dst = np.asarray(dst, dtype=np.float64).reshape(-1, 2)
    if len(src) != len(dst):
        raise ValueError(f"src and dst differ in length ({len(src)} and {len(dst)})")
    if len(src) < 4:
        return None, 0
    try:
        h, mask = cv2.findHomography(src, dst, cv2.USAC_MAGSAC, ransacReprojThreshold=float(threshold),
                                     maxIters=int(max_iters), confidence=float(confidence))
    except cv2.error:  # degenerate sets (all points collinear, ...) raise in some OpenCV builds
        return None, 0
    if h is None or not np.all(np.isfinite(h)) or abs(h[2, 2]) < 1e-12:
        return None, 0
    return h / h[2, 2], int(mask.sum()) if mask is not None else 0


def corner_error(h_est: np.ndarray | None, h_gt: np.ndarray, shape: tuple[int, int]) -> float:
    """Mean distance (px) between the reference image's 4 corners mapped by ``h_est`` and by ``h_gt``.

    ``shape`` is the reference image's ``(height, width)``; ``inf`` when
    ``h_est`` is None or maps a corner to infinity.

    Examples
    --------
    >>> import numpy as np
    >>> shifted = np.array([[1.0, 0, 3], [0, 1, 4], [0, 0, 1]])
    >>> corner_error(shifted, np.eye(3), (480, 640))
    5.0
    >>> corner_error(None, np.eye(3), (480, 640))
    inf
    """
    if h_est is None:
        return float("inf")
    h, w = int(shape[0]), int(shape[1])
    c = np.array([[0.0, 0.0, 1.0], [w - 1.0, 0.0, 1.0], [w - 1.0, h - 1.0, 1.0], [0.0, h - 1.0, 1.0]])
    with np.errstate(divide="ignore", invalid="ignore"):
        pe = c @ np.asarray(h_est, dtype=np.float64).T
        pg = c @ np.asarray(h_gt, dtype=np.float64).T
        d = np.linalg.norm(pe[:, :2] / pe[:, 2:] - pg[:, :2] / pg[:, 2:], axis=1)
    e = float(np.mean(d))
    return e if np.isfinite(e) else float("inf")


def auc_of_errors(errors: Sequence[float] | np.ndarray,
                  thresholds: Sequence[float] = AUC_THRESHOLDS) -> list[float]:
    """Area under the cumulative error curve up to each threshold, over ``t`` (module doc, step 3).

    ``inf`` (or NaN) errors are failures; no errors at all give 0.

    Examples
    --------
    >>> auc_of_errors([0.5, 2.0, float("inf")], thresholds=(1, 3))
    [0.25, 0.5]
    """
    e = np.asarray(errors, dtype=np.float64).reshape(-1)
    if e.size == 0:
        return [0.0 for _ in thresholds]
    e = np.sort(np.where(np.isnan(e), np.inf, e))
    recall = np.r_[0.0, np.arange(1, e.size + 1) / e.size]
    e = np.r_[0.0, e]
    out = []
    for t in thresholds:
        last = int(np.searchsorted(e, t))  # points (e_k, r_k) with e_k < t, then flat to t
        r = np.r_[recall[:last], recall[last - 1]]
        x = np.r_[e[:last], t]
        out.append(float(np.sum((x[1:] - x[:-1]) * (r[1:] + r[:-1]) / 2.0) / t))
    return out
