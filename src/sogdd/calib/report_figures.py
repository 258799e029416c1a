"""The one-camera report's figures: residual vectors and their histogram, each view's error, where the
corners fell, the cross-validation map, the lens's distortion field and the board poses in 3-D.

Each function draws one PNG (:func:`~sogdd.calib.figures.save_figure`) from a
:class:`~sogdd.calib.result.Calibration`; the projection comes from the lens
registry (:mod:`sogdd.calib.cameras`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .cameras import to_pixels, undistort
from .figures import PlacedCamera, board_outline, poses_figure, pyplot, save_figure
from .result import Calibration
from .verdict import coverage, cv_inside, used_points

__all__ = ["DistortionField", "camera_poses_figure", "coverage_figure", "cross_validation_figure",
           "distortion_field", "distortion_figure", "residual_figure", "residual_histogram",
           "view_errors_figure"]


def _frame_axes(ax, size: tuple[int, int]) -> None:
    w, h = size
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal")


def residual_figure(cal: Calibration, path: Path) -> None:
    """Every corner's residual (observed - projected) as an arrow at the corner, magnified so that the
    95th percentile of the used ones is 4% of the frame's width; rejected corners red."""
    plt = pyplot()
    w, h = cal.image_size
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6))
    used, bad = [], []
    for b, r, u in zip(cal.boards, cal.residuals, cal.corner_used):
        if b is None or r is None:
            continue
        used.append(np.c_[b.image_points[u], r[u]])
        bad.append(np.c_[b.image_points[~u], r[~u]])
    U = np.concatenate(used) if used else np.zeros((0, 4))
    B = np.concatenate(bad) if bad else np.zeros((0, 4))
    typical = np.percentile(np.hypot(U[:, 2], U[:, 3]), 95) if len(U) else 1.0
    gain = 0.04 * w / max(typical, 1e-9)  # the 95th percentile arrow is 4% of the width
    for arr, colour, lab in ((U, "tab:blue", "used"), (B, "tab:red", "rejected")):
        if len(arr):
            ax.quiver(arr[:, 0], arr[:, 1], arr[:, 2] * gain, arr[:, 3] * gain, color=colour, angles="xy",
                      scale_units="xy", scale=1, width=0.002, label=f"{lab} ({len(arr)})")
    _frame_axes(ax, cal.image_size)
    ax.set_title(f"residuals (observed - projected) x{gain:.0f}; RMS {cal.rms:.3f} px")
    ax.legend(loc="upper right", fontsize=8)
    save_figure(fig, path)


def residual_histogram(cal: Calibration, path: Path) -> int:
    """The histogram of the used corners' residuals, x and y apart, with the normal density of their RMS
    (as mrcal's residual histogram): a fit whose errors are noise follows the curve.

    Returns
    -------
    int
        The number of residual components counted (twice the used corners).
    """
    plt = pyplot()
    r = [res[u] for res, u in zip(cal.residuals, cal.corner_used) if res is not None and u is not None]
    R = np.concatenate(r) if r else np.zeros((0, 2))
    fig, ax = plt.subplots(figsize=(8, 3.6))
    if len(R):
        sigma = float(np.sqrt(np.mean(R ** 2)))
        edge = max(4 * sigma, float(np.max(np.abs(R))), 1e-9)
        bins = np.linspace(-edge, edge, 61)
        ax.hist(R[:, 0], bins, histtype="step", color="tab:blue", label="x")
        ax.hist(R[:, 1], bins, histtype="step", color="tab:orange", label="y")
        t = np.linspace(-edge, edge, 400)
        density = len(R) * (bins[1] - bins[0]) * np.exp(-0.5 * (t / max(sigma, 1e-12)) ** 2) / (
            max(sigma, 1e-12) * np.sqrt(2 * np.pi))
        ax.plot(t, density, "k--", lw=1, label=f"normal, sigma {sigma:.3f} px")
        ax.legend(fontsize=8)
    ax.set_xlabel("residual (px)")
    ax.set_ylabel("corners")
    ax.set_title(f"residuals of the {len(R)} used corners, x and y")
    fig.tight_layout()
    save_figure(fig, path)
    return 2 * len(R)


def view_errors_figure(cal: Calibration, path: Path) -> list[tuple[int, tuple[int, int, int, int]]]:
    """Each view's RMS as a bar (used blue, rejected hatched red) and the overall RMS as a dashed line, as
    MATLAB's "mean reprojection error per image".

    Returns
    -------
    list of (int, (x0, y0, x1, y1))
        Per view, the rectangle of the PNG (pixels, origin top left) over its column: the page's image
        map links each to the view's card.
    """
    plt = pyplot()
    n = len(cal.names)
    fig, ax = plt.subplots(figsize=(min(10.5, max(6.0, 0.22 * n + 2)), 3.6), dpi=100)
    rms = np.asarray(cal.view_rms, float)
    used = np.asarray(cal.view_used, bool)
    x = np.arange(n)
    ax.bar(x[used], rms[used], 0.8, color="tab:blue", label="used")
    bad = ~used & np.isfinite(rms)
    if bad.any():
        ax.bar(x[bad], rms[bad], 0.8, color="none", edgecolor="tab:red", hatch="//", label="rejected")
    ax.axhline(cal.rms, color="k", ls="--", lw=1, label=f"overall RMS {cal.rms:.3f} px")
    ax.set_xlim(-0.5, n - 0.5)
    ax.set_xticks(x)
    ax.set_xticklabels([str(v) for v in x], fontsize=7, rotation=90 if n > 30 else 0)
    ax.set_xlabel("view (click a bar for its picture)")
    ax.set_ylabel("RMS (px)")
    ax.set_title("each view's RMS reprojection error")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.canvas.draw()
    height = fig.bbox.height
    areas = []
    (_, y_bottom), (_, y_top) = ax.transAxes.transform([(0, 0), (0, 1)])
    for v in range(n):
        (x0, _), (x1, _) = ax.transData.transform([(v - 0.5, 0), (v + 0.5, 0)])
        areas.append((v, (int(np.floor(x0)), int(np.floor(height - y_top)), int(np.ceil(x1)),
                          int(np.ceil(height - y_bottom)))))
    save_figure(fig, path)
    return areas


def coverage_figure(cal: Calibration, path: Path) -> None:
    """Where the used corners fell: each cell of an 8 x 6 grid that holds one shaded."""
    plt = pyplot()
    w, h = cal.image_size
    counts, covered, edge = coverage(cal)
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6))
    ax.imshow(counts > 0, extent=(0, w, h, 0), cmap="Greens", vmin=0, vmax=2, alpha=0.6)
    p = used_points(cal)
    ax.plot(p[:, 0], p[:, 1], ".", ms=1.5, color="k")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_title(f"coverage: {len(p)} used corners; {covered:.0%} of cells, {edge:.0%} of border cells")
    save_figure(fig, path)


def cross_validation_figure(cal: Calibration, path: Path) -> bool:
    """The halves' projection difference over the frame; False (nothing drawn) without a cross-validation."""
    cv = cal.cross_validation
    if cv is None:
        return False
    plt = pyplot()
    d = cv.difference
    w, h = cal.image_size
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6), layout="constrained")
    top = max(2 * cv_inside(cv)[1], 1e-3)  # the colours for the data's region; beyond it saturates
    im = ax.imshow(d.distance, extent=(d.xs[0], d.xs[-1], d.ys[-1], d.ys[0]), cmap="viridis", vmin=0,
                   vmax=min(top, float(np.nanmax(d.distance))))
    fig.colorbar(im, ax=ax, label="px", shrink=0.9)
    if d.within is not None:  # the corners' hull: the region the data supports
        ax.contour(d.xs, d.ys, d.within.astype(float), levels=[0.5], colors="w", linewidths=1.5)
    mean, mx = cv_inside(cv)
    ax.set_title(f"cross-validation: {mean:.3f} px mean, {mx:.3f} max inside the corners' hull (white);\n"
                 f"whole frame {d.mean:.3f} mean, {d.max:.3g} max", fontsize=9)
    save_figure(fig, path)
    return True


@dataclass(frozen=True)
class DistortionField:
    """Distorted minus ideal (pinhole, same K) pixel over a grid of the frame.

    Attributes
    ----------
    xs, ys : 1-D float64
        The grid's pixel columns and rows; the first and last are the frame's edge pixels (0, w - 1).
    dx, dy : (len(ys), len(xs)) float64
        The pixel minus where the pinhole camera of the same K puts its ray; NaN where the model
        cannot be inverted.
    """

    xs: np.ndarray
    ys: np.ndarray
    dx: np.ndarray
    dy: np.ndarray

    @property
    def magnitude(self) -> np.ndarray:
        """:math:`\\sqrt{dx^2 + dy^2}` (px)."""
        return np.hypot(self.dx, self.dy)

    @property
    def max(self) -> float:
        """The largest magnitude over the grid (px); NaN if nothing could be inverted."""
        m = self.magnitude
        return float(np.nanmax(m)) if np.isfinite(m).any() else float("nan")


def distortion_field(cal: Calibration, grid: tuple[int, int] = (33, 25)) -> DistortionField:
    """The distortion of the chosen model over the frame: each grid pixel's ray
    (:func:`~sogdd.calib.cameras.undistort`) projected by the pinhole of the same K, subtracted from it.

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> f = distortion_field(demo_calibration())
    >>> f.dx.shape, bool(f.magnitude[12, 16] < 0.5 < f.max)  # nothing at the centre, most at a corner
    ((25, 33), True)
    """
    w, h = cal.image_size
    xs, ys = np.linspace(0, w - 1, grid[0]), np.linspace(0, h - 1, grid[1])
    X, Y = np.meshgrid(xs, ys)
    pixels = np.c_[X.ravel(), Y.ravel()]
    xy, ok = undistort(pixels, cal.K, cal.dist, cal.model)
    d = pixels - to_pixels(xy, cal.K)
    d[~ok] = np.nan
    return DistortionField(xs, ys, d[:, 0].reshape(X.shape), d[:, 1].reshape(X.shape))


def distortion_figure(cal: Calibration, path: Path) -> DistortionField:
    """The distortion field's magnitude as colours, with arrows from the ideal pixel's place (as mrcal's
    ``show-distortion-off-pinhole``, MATLAB's "undistort" in reverse); returns the field drawn."""
    plt = pyplot()
    f = distortion_field(cal)
    w, h = cal.image_size
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6), layout="constrained")
    mag = f.magnitude
    top = f.max if np.isfinite(f.max) and f.max > 0 else 1.0
    im = ax.imshow(mag, extent=(f.xs[0], f.xs[-1], f.ys[-1], f.ys[0]), cmap="viridis", vmin=0, vmax=top)
    fig.colorbar(im, ax=ax, label="distorted - ideal (px)", shrink=0.9)
    step = 3
    sx, sy = np.meshgrid(f.xs[::step], f.ys[::step])
    ax.quiver(sx, sy, f.dx[::step, ::step], f.dy[::step, ::step], color="w", angles="xy", width=0.002)
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_title(f"{cal.model} distortion: distorted minus ideal pinhole pixel (same K); "
                 f"max {f.max:.2f} px", fontsize=9)
    save_figure(fig, path)
    return f


def camera_poses_figure(cal: Calibration, path: Path) -> int:
    """The camera and each used view's board in 3-D, in the camera's frame
    (:func:`~sogdd.calib.figures.poses_figure`, as the rig report draws a rig); returns the poses drawn."""
    outlines = [q for v in np.flatnonzero(cal.view_used)
                if (q := board_outline(cal.boards[v], cal.rvecs[v], cal.tvecs[v], cal.square)) is not None]
    cam = PlacedCamera("camera", cal.K, np.eye(3), np.zeros(3), cal.image_size)
    poses_figure([cam], outlines, f"the camera and its {len(outlines)} board poses", path)
    return len(outlines)
