"""The figure helpers the calibration reports share: pyplot on Agg, saving a PNG, and the 3-D view of
cameras and board poses (one camera's report and the rig's report draw it alike)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..formats.safe_write import atomic_write

__all__ = ["COLOURS", "PlacedCamera", "board_outline", "poses_figure", "pyplot", "save_figure"]

#: the colours of the cameras, in order (matplotlib's first six)
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed), imported when a figure is drawn."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> None:
    """Write a figure as a PNG (100 dpi), atomically, and close it."""
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    pyplot().close(fig)


@dataclass(frozen=True)
class PlacedCamera:
    """A camera as :func:`poses_figure` draws it: ``x_cam = R x_ref + T`` in the reference's frame.

    Attributes
    ----------
    name : str
    K : (3, 3) float64
    R : (3, 3) float64
    T : (3,) float64
    image_size : (int, int)
    """

    name: str
    K: np.ndarray
    R: np.ndarray
    T: np.ndarray
    image_size: tuple[int, int]


def board_outline(board, rvec: np.ndarray, tvec: np.ndarray, square: float) -> np.ndarray | None:
    """The rectangle of a board's corners (5, 3), closed, in the camera's frame; None without a pose.

    ``board`` is a :class:`~sogdd.calib.targets.board.Board` (its object points span the
    rectangle), ``rvec``/``tvec`` its pose: :math:`x = R(\\mathrm{rvec}) X + \\mathrm{tvec}`.

    Examples
    --------
    >>> from sogdd.calib.targets.board import Board
    >>> b = Board(np.zeros((4, 2)), [(0, 0), (2, 0), (0, 1), (2, 1)])
    >>> board_outline(b, np.zeros(3), np.array([0, 0, 10.0]), 1.0)[:3].tolist()
    [[0.0, 0.0, 10.0], [2.0, 0.0, 10.0], [2.0, 1.0, 10.0]]
    """
    if board is None or not np.all(np.isfinite(rvec)) or not np.all(np.isfinite(tvec)):
        return None
    obj = board.object_points(square)
    (x0, y0), (x1, y1) = obj[:, :2].min(axis=0), obj[:, :2].max(axis=0)
    quad = np.array([(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0), (x0, y0, 0)], float)
    R, _ = cv2.Rodrigues(np.asarray(rvec, float).reshape(3, 1))
    return quad @ R.T + np.asarray(tvec, float).reshape(1, 3)


def poses_figure(cameras: Sequence[PlacedCamera], outlines: Sequence[np.ndarray], title: str,
                 path: Path) -> None:
    """The cameras (frusta) and the board outlines in 3-D, in the first camera's frame, as MATLAB's
    extrinsics view: x right, z (depth) into the page, y down; the cameras named in a legend.

    Parameters
    ----------
    cameras : sequence of PlacedCamera
        The reference first (``R = I``, ``T = 0``).
    outlines : sequence of (5, 3) arrays
        Each board pose's rectangle (:func:`board_outline`), in the reference's frame.
    title : str
    path : Path
        The PNG written.
    """
    plt = pyplot()
    fig = plt.figure(figsize=(8, 6.5))
    ax = fig.add_subplot(projection="3d")

    def show(p):
        return p[..., 0], p[..., 2], -p[..., 1]

    pts = [np.asarray(q) for q in outlines]
    for q in pts:
        ax.plot(*show(q), color="0.45", lw=0.8)
    scale = 0.15 * (np.ptp(np.concatenate(pts), axis=0).max() if pts else 1.0)
    for k, cam in enumerate(cameras):
        centre = -cam.R.T @ cam.T  # the camera's centre in the reference's frame
        w, h = cam.image_size
        frame = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1], [0, 0, 1]], float)
        rays = np.linalg.solve(cam.K, frame.T).T
        far = centre + (rays * scale) @ cam.R  # R^T applied to each ray
        colour = COLOURS[k % len(COLOURS)]
        ax.plot(*show(far), color=colour, label=cam.name)
        for corner in far[:4]:
            ax.plot(*show(np.array([centre, corner])), color=colour, lw=0.8)
        ax.scatter(*show(centre[None]), color=colour, s=12)
        pts.append(np.array([centre]))
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    mid, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-9)
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[2] - half, mid[2] + half)
    ax.set_zlim(-mid[1] - half, -mid[1] + half)
    ax.set_xlabel("x")
    ax.set_ylabel("z (depth)")
    ax.set_zlabel("-y")
    ax.view_init(elev=25, azim=-65)
    ax.legend(loc="upper left", fontsize=8, title="cameras", title_fontsize=8)
    ax.set_title(title, fontsize=10)
    fig.subplots_adjust(left=0.0, right=0.95, bottom=0.03, top=0.95)
    save_figure(fig, path)
