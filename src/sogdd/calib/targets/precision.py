"""A board's corner precision: each corner's 1-sigma position uncertainty, measured in its image.

:func:`with_precision` gives a :class:`~sogdd.calib.targets.board.Board` its
``precision``: for each corner, the square root of the largest eigenvalue of the
covariance of its refined position under the image's noise
(:func:`sogdd.calib.targets.refine.corner_covariance`), measured with the
window the refinement used (:func:`windows`). A sharp corner in a clean image
is known to a few thousandths of a pixel; a corner smeared by motion or focus,
or one in a noisy or shaded window, to far less, and the calibration weighs it
accordingly (:mod:`sogdd.calib.weighting`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .board import Board, lattice_cells
from .refine import MAX_WINDOW, corner_covariance, half_widths

__all__ = ["measure_precision", "windows", "with_precision"]

def windows(board: Board) -> np.ndarray:
    """The half-widths (px) of the windows a board's corners are refined with, (N,) int64.

    As the chessboard detector's refinement sets them: 0.65 of the local cell
    (:func:`sogdd.calib.targets.board.lattice_cells`), clipped to [2, 20] px, and the default 5 px for a
    corner without a lattice neighbour
    (:func:`~sogdd.calib.targets.refine.half_widths`).

    Examples
    --------
    >>> grid = np.array([(i, j) for j in range(3) for i in range(4)])
    >>> windows(Board(grid * 20.0 + 50, grid)).tolist() == [13] * 12
    True
    """
    return half_widths(board.image_points, None, lattice_cells(board.image_points, board.labels))


def with_precision(grey: np.ndarray, board: Board, half: np.ndarray | int | None = None) -> Board:
    """The board with each corner's measured precision (``Board.precision``), px.

    For each corner ``k`` the covariance ``C_k`` of its refined position under
    the image's noise (:func:`sogdd.calib.targets.refine.corner_covariance`:
    ``C = sigma_n^2 A^-1 G A^-1`` of the point-symmetry fit, ``sigma_n^2``
    measured from the fit's own residuals) gives its precision
    ``sigma_k = sqrt(lambda_max(C_k))``: the standard deviation along its
    least precise direction. NaN where the fit's normal matrix is singular or
    the corner lies within 3 px of the image's edge.

    Parameters
    ----------
    grey : (H, W) ndarray
        The grey image the board was found in, on the 0-255 scale
        (:func:`sogdd.calib.targets.grey.to_grey`, which the detectors use).
    board : Board
        Its corners refined (they are where the fit's gradient vanishes).
    half : int or (N,) array or None
        The refinement windows' half-widths; None: the chessboard
        refinement's (:func:`windows`).

    Returns
    -------
    Board
        ``board`` with ``precision`` set; everything else as it was.

    Examples
    --------
    >>> from sogdd.evaluation.calibration.render import ChessboardTarget, camera_for, render_view
    >>> cam, target = camera_for(320, 240), ChessboardTarget(6, 4, 1.0)
    >>> rv, tv = np.array([0.2, -0.1, 0.05]), np.array([-2.5, -1.5, 9.0])
    >>> v = render_view(cam, target, rv, tv, blur=1.0, noise=3.0, rng=0)
    >>> from sogdd.calib.targets.refine import refine_corners
    >>> xy = refine_corners(v.image, v.corners + 0.3)
    >>> b = with_precision(v.image.astype(float), Board(xy, v.labels))
    >>> b.precision.shape, bool(np.all((b.precision > 0.005) & (b.precision < 0.05)))
    ((24,), True)
    """
    if not isinstance(board, Board):
        raise TypeError(f"board must be a Board, got {type(board).__name__}")
    img = np.asarray(grey)
    if img.ndim != 2 or img.dtype.kind not in "iuf":
        raise ValueError(f"grey must be a 2-D grey image on the 0-255 scale, got shape {img.shape}, "
                         f"dtype {img.dtype}")
    if len(board) == 0:
        return replace(board, precision=np.zeros(0))
    h = windows(board) if half is None else half
    return replace(board, precision=_sigma(corner_covariance(img, board.image_points, h)))


def _sigma(cov: np.ndarray) -> np.ndarray:
    """``sqrt(lambda_max(C))`` of each covariance, NaN where it is not finite."""
    sigma = np.sqrt(np.clip(np.linalg.eigvalsh(np.nan_to_num(cov))[:, -1], 0.0, None))
    sigma[~np.isfinite(cov).all(axis=(1, 2))] = np.nan
    return sigma


#: the margin (px) around the boards' corners of :func:`measure_precision`'s crop: the largest window, its
#: gradient's pixel and the cut that keeps a window 2 px inside the image (:func:`corner_covariance`)
_MARGIN = MAX_WINDOW + 4


def measure_precision(image: np.ndarray, boards: Sequence[Board]) -> tuple[Board, ...]:
    """:func:`with_precision` for each of an image's boards, the image made grey over the boards alone.

    ``image`` is the image as read (any image :func:`sogdd.image.validate_image`
    takes, on the corner detector's scale); only the rectangle around the
    boards' corners, with a margin of :data:`_MARGIN` px that no window reaches
    beyond, is made grey (:func:`sogdd.image.to_gray255`, the detectors'
    conversion), so that the full frame is made grey once, by the detector. The
    precision is that of :func:`with_precision` on the whole grey image.

    Examples
    --------
    >>> from sogdd.evaluation.calibration.render import ChessboardTarget, camera_for, render_view
    >>> from sogdd.calib.targets.refine import refine_corners
    >>> cam, target = camera_for(320, 240), ChessboardTarget(6, 4, 1.0)
    >>> v = render_view(cam, target, np.array([0.2, -0.1, 0.05]), np.array([-2.5, -1.5, 9.0]), blur=1.0,
    ...                 noise=3.0, rng=0)
    >>> b = Board(refine_corners(v.image, v.corners + 0.3), v.labels)
    >>> (m,) = measure_precision(v.image, [b])
    >>> bool(np.allclose(m.precision, with_precision(v.image.astype(float), b).precision))
    True
    """
    from ...image import to_gray255, validate_image

    if not boards:
        return ()
    img = validate_image(image)
    H, W = img.shape[:2]
    pts = np.concatenate([b.image_points for b in boards])
    if len(pts) == 0:
        return tuple(with_precision(np.zeros((8, 8)), b) for b in boards)
    lo = np.maximum(np.floor(pts.min(axis=0)).astype(int) - _MARGIN, 0)
    hi = np.minimum(np.ceil(pts.max(axis=0)).astype(int) + _MARGIN + 1, [W, H])
    grey = to_gray255(img[lo[1]:hi[1], lo[0]:hi[0]])
    if min(grey.shape) < 8:
        return tuple(replace(b, precision=np.full(len(b), np.nan)) for b in boards)
    return tuple(replace(b, precision=_sigma(corner_covariance(grey, b.image_points - lo, windows(b))))
                 for b in boards)
