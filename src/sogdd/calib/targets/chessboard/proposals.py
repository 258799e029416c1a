"""OpenCV's chessboard detectors as a second source of board candidates.

Where sogdd's own search (X-corners over the pyramid, grown into lattices)
finds no complete board of a given pattern, the view is also shown to OpenCV:
``cv2.findChessboardCorners`` (quads from an adaptive threshold) and then
``cv2.findChessboardCornersSB`` (a localised Radon transform). What they
propose is only a proposal: its corners, in OpenCV's row-by-row order, become
lattice labels ``(k mod cols, k div cols)`` and go through the same refinement,
symmetry test, lattice checks, edge test and labelling as a board that sogdd
grew itself (:func:`sogdd.calib.targets.chessboard.detect_boards`). A board
kept from a proposal says so in :attr:`sogdd.calib.targets.Board.source`.

Both run on a copy reduced to at most :data:`PROPOSAL_PIXELS` pixels: they
only need to find the grid (the corners are measured again at full
resolution), and their cost grows with the frame and with clutter. On a
1440 x 1080 frame of noise, classic took 1.05 s at full size and 30 ms at
640 x 480, SB (``CALIB_CB_EXHAUSTIVE``) 0.61 s at 1 MP and 0.10 s without
the flag at 640 x 480; on the 30 motion-blurred views of ``hik_mono_1440``
the reduced copy found the board in 29 (classic) and 27 (SB) views, at full
size classic in 25.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

__all__ = ["PROPOSAL_PIXELS", "SOURCES", "Proposal", "Source", "propose"]

#: which detector found a board: sogdd's own search, OpenCV's classic detector or its SB detector
Source = Literal["sogdd", "opencv", "opencv-sb"]
SOURCES: tuple[Source, ...] = ("sogdd", "opencv", "opencv-sb")
#: OpenCV's detectors see a copy of the image reduced to at most this many pixels
PROPOSAL_PIXELS = 640 * 480

_CLASSIC = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
_SB = cv2.CALIB_CB_NORMALIZE_IMAGE


@dataclass(frozen=True)
class Proposal:
    """A board proposed by OpenCV: ``xy`` (N, 2) at full resolution, ``labels`` (N, 2), ``source``."""

    xy: np.ndarray
    labels: np.ndarray
    source: Source


def _reduced(grey: np.ndarray) -> tuple[np.ndarray, float]:
    """The image as uint8, reduced to :data:`PROPOSAL_PIXELS` at most, and the factor applied."""
    img = np.clip(np.rint(grey), 0, 255).astype(np.uint8)
    f = min(1.0, float(np.sqrt(PROPOSAL_PIXELS / img.size)))
    if f < 1:
        img = cv2.resize(img, (max(8, round(img.shape[1] * f)), max(8, round(img.shape[0] * f))),
                         interpolation=cv2.INTER_AREA)
    return img, f


def _run(img: np.ndarray, pattern: tuple[int, int], source: Source) -> np.ndarray | None:
    try:
        if source == "opencv":
            ok, pts = cv2.findChessboardCorners(img, pattern, flags=_CLASSIC)
        else:
            ok, pts = cv2.findChessboardCornersSB(img, pattern, flags=_SB)
    except cv2.error:
        return None
    return np.asarray(pts, dtype=np.float64).reshape(-1, 2) if ok and pts is not None else None


def propose(grey: np.ndarray, pattern: tuple[int, int],
            sources: tuple[Source, ...] = ("opencv", "opencv-sb")) -> list[Proposal]:
    """OpenCV's boards of ``pattern`` in a grey image (0-255), in the order of ``sources``, first found first.

    Each source is tried in turn until one finds the board; the points are
    mapped back to full resolution (``x = (x' + 0.5) / f - 0.5``).

    Parameters
    ----------
    grey : (H, W) float
        The grey image on 0-255 (:func:`sogdd.calib.targets.grey.to_grey`).
    pattern : (cols, rows)
        Inner corners, OpenCV's ``patternSize``.
    sources : tuple of "opencv", "opencv-sb"
        The detectors to try, in order.

    Returns
    -------
    list of Proposal
        At most one: the first source's board that was found.

    Examples
    --------
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200.0 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230.0), (0, 0), 1.0)
    >>> p = propose(img, (7, 5))[0]
    >>> p.source, p.xy.shape, p.labels[:2].tolist()
    ('opencv', (35, 2), [[0, 0], [1, 0]])
    >>> propose(np.full((100, 100), 128.0), (7, 5))
    []
    """
    img, f = _reduced(grey)
    cols = int(pattern[0])
    for source in sources:
        pts = _run(img, (int(pattern[0]), int(pattern[1])), source)
        if pts is None:
            continue
        xy = (pts + 0.5) / f - 0.5
        k = np.arange(len(xy))
        return [Proposal(xy, np.stack([k % cols, k // cols], axis=1).astype(np.int64), source)]
    return []
