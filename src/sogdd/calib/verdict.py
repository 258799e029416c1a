"""What a calibration is worth, in plain words: where its corners fell, and :func:`verdict`.

The analysis behind the report (:mod:`.report` draws it) and the command's summary.
"""

from __future__ import annotations

import cv2
import numpy as np

from .result import Calibration

__all__ = ["coverage", "cv_inside", "used_points", "verdict"]

# the verdict's limits, each stated where it is used
_FEW_VIEWS = 10            # fewer used views than this is "few"
_RMS_HIGH, _RMS_FAIR = 0.5, 0.2  # px
_CV_LARGE, _CV_FAIR = 2.0, 0.5   # px, mean cross-validation difference
_EDGE_BAND = 0.15          # the frame's outer band, as a fraction of each side
_EDGE_CELLS = 0.5          # share of the band's cells that should hold a corner
_TILT_MIN = 15.0           # degrees: some view should tilt the board at least this much
_GRID = (8, 6)             # coverage cells across and down


def used_points(cal: Calibration) -> np.ndarray:
    """Every corner the calibration used, (N, 2)."""
    pts = [b.image_points[u] for b, u in zip(cal.boards, cal.corner_used) if b is not None and u is not None]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def coverage(cal: Calibration, grid: tuple[int, int] = _GRID) -> tuple[np.ndarray, float, float]:
    """Where the used corners fell: counts per cell and the shares of cells (all, outer ring) covered.

    The frame is cut into ``grid`` = (columns, rows) equal cells; the outer ring
    is every cell on the border of that grid.

    Returns
    -------
    counts : (rows, columns) int
    covered : float
        Share of cells with at least one used corner.
    edge_covered : float
        Share of the outer ring's cells with at least one used corner.

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> counts, covered, edge = coverage(demo_calibration())
    >>> counts.shape, 0 < edge <= covered <= 1
    ((6, 8), True)
    """
    gx, gy = grid
    w, h = cal.image_size
    p = used_points(cal)
    cx = np.clip((p[:, 0] + 0.5) / w * gx, 0, gx - 1e-9).astype(int)
    cy = np.clip((p[:, 1] + 0.5) / h * gy, 0, gy - 1e-9).astype(int)
    counts = np.zeros((gy, gx), int)
    np.add.at(counts, (cy, cx), 1)
    ring = np.ones((gy, gx), bool)
    ring[1:-1, 1:-1] = False
    return counts, float(np.mean(counts > 0)), float(np.mean(counts[ring] > 0))


def _tilts(cal: Calibration) -> np.ndarray:
    """Angle (degrees) between each used view's board normal and the optical axis: a board
    parallel to the image plane maps to it by an affine map, which says nothing of the focal length."""
    out = []
    for v in np.flatnonzero(cal.view_used):
        R, _ = cv2.Rodrigues(cal.rvecs[v])
        out.append(np.degrees(np.arccos(min(1.0, abs(float(R[2, 2]))))))
    return np.array(out)


def verdict(cal: Calibration) -> list[tuple[str, str]]:
    """Plain-words findings on a calibration, each ``(level, text)`` with level "ok", "warn" or "bad".

    The rules: fewer than 10 used views is few; RMS above 0.5 px is high (0.2
    px: fair); a mean cross-validation difference inside the corners' hull
    above 2 px is large (0.5 px: fair), and outside it a difference above
    both 2 px and 3 times the largest inside is extrapolation; corners in
    fewer than half of the outer ring of an 8 x 6 grid of the frame cover
    "only the centre"; no view tilting the board 15 degrees or
    more leaves the focal length weak; more than a fifth of the views rejected
    is reported. Without any finding the verdict is one "ok".

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> [level for level, text in verdict(demo_calibration())][:1]
    ['warn']
    """
    out: list[tuple[str, str]] = []
    n, total = cal.n_used, len(cal.names)
    if n < _FEW_VIEWS:
        out.append(("warn", f"few views ({n} used): calibrate with 10-20 views, the board tilted "
                            "differently and placed over the whole frame"))
    if cal.rms > _RMS_HIGH:
        out.append(("bad", f"high RMS reprojection error ({cal.rms:.2f} px): check blur and focus, motion, "
                           "a board that is not flat, or a lens the model does not fit"))
    elif cal.rms > _RMS_FAIR:
        out.append(("warn", f"fair RMS reprojection error ({cal.rms:.2f} px): sharp, well-lit views do better"))
    out += _coverage_findings(cal)
    out += _cross_validation_findings(cal)
    rejected = total - n - sum(r == "no board" for r in cal.reasons)
    if rejected > 0.2 * total:
        out.append(("warn", f"{rejected} of {total} views rejected (see views.csv): check those images"))
    missing = sum(r == "no board" for r in cal.reasons)
    if missing:
        out.append(("warn" if missing > 0.2 * total else "ok", f"no board found in {missing} of {total} views"))
    if not any(level != "ok" for level, _ in out):
        cv = cal.cross_validation
        out.insert(0, ("ok", f"the calibration looks sound: {n} views, RMS {cal.rms:.3f} px"
                             + (f", halves agree to {cv_inside(cv)[0]:.2f} px" if cv is not None else "")))
    return out


def _coverage_findings(cal: Calibration) -> list[tuple[str, str]]:
    out = []
    _, covered, edge = coverage(cal)
    if edge < _EDGE_CELLS:
        out.append(("bad" if edge < 0.25 else "warn",
                    f"the corners cover only the centre ({edge:.0%} of the frame's border cells, "
                    f"{covered:.0%} of all cells): add views with the board near the edges and corners of "
                    "the frame"))
    tilts = _tilts(cal)
    if len(tilts) and tilts.max() < _TILT_MIN:
        out.append(("warn", f"the board faces the camera in every view (largest tilt {tilts.max():.0f} deg): "
                            "tilt it 20-45 deg in some views to pin down the focal length"))
    return out


def _cross_validation_findings(cal: Calibration) -> list[tuple[str, str]]:
    cv = cal.cross_validation
    if cv is None:
        return [("warn", (cal.notes[0] if cal.notes else "no cross-validation")
                 + ": the calibration's stability is unknown")]
    mean, mx = cv_inside(cv)
    out = []
    if mean > _CV_LARGE:
        out.append(("bad", f"large cross-validation difference ({mean:.2f} px mean, {mx:.2f} max where the "
                           "corners are): the two halves of the views disagree; the model may not fit the lens "
                           "(try the rational or fisheye model) or more views are needed"))
    elif mean > _CV_FAIR:
        out.append(("warn", f"fair cross-validation difference ({mean:.2f} px mean, {mx:.2f} max where the "
                            "corners are): more views, tilted and near the edges, would pin the camera down"))
    if np.isfinite(cv.max) and cv.max > max(_CV_LARGE, 3 * mx):
        out.append(("warn", f"outside the corners the halves differ by up to {cv.max:.3g} px: the model "
                            "extrapolates there; do not trust it beyond the area the boards covered"))
    return out


def cv_inside(cv) -> tuple[float, float]:
    """The cross-validation's mean and max inside the corners' hull (whole image without one)."""
    if np.isfinite(cv.mean_within):
        return cv.mean_within, cv.max_within
    return cv.mean, cv.max
