"""A board's labels: right-handed, and the same physical corner ``(0, 0)`` in every view.

Labels
------
Labels are right-handed: ``i`` runs along the board's first axis, ``j`` along the
second, and ``(a_i, a_j)`` (the image directions of ``+i`` and ``+j``) turn like
the image's ``(x, y)`` (``i`` left to right, ``j`` top to bottom on an upright
board seen face on; the board frame ``(i, j, 0)`` has its normal pointing away
from the camera).

- Known size ``pattern=(cols, rows)`` (inner corners, OpenCV's ``patternSize``) and
  the whole board seen: labels ``0 .. cols - 1`` along ``i`` and ``0 .. rows - 1``
  along ``j``, ``Board.size = (cols, rows)``. Which corner is ``(0, 0)``: when
  ``cols + rows`` is odd the board is not symmetric under a half turn, and
  ``(0, 0)`` is the corner whose outer square (the one beyond ``(0, 0)`` in
  ``-i, -j``) is dark: the same physical corner in every view. Otherwise (the
  half turn maps the board onto itself, colours included) ``(0, 0)`` is the end
  that puts ``+i`` closest to the image's ``+x`` direction (left to right).
- Unknown size, or a board larger than seen (partial, occluded): ``Board.size`` is
  None and the labels are relative: the rotation (of four) that puts ``+i``
  closest to the image's ``+x``, shifted so that the smallest ``i`` and ``j`` are 0.
  They are consistent within the view, not across views.
"""

from __future__ import annotations

import numpy as np

from ..board import LABEL_TURNS, label_neighbours
from .xcorners import XCorners

__all__ = ["label_axes", "orient", "outer_square_dark"]


def label_axes(xy: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Mean image displacement per label step along ``i`` and ``j``: rows ``a_i``, ``a_j``."""
    nb = label_neighbours(labels)
    out = np.zeros((2, 2))
    for ax in range(2):
        k = np.flatnonzero(nb[:, 2 * ax] >= 0)  # the neighbour at (+1, 0), then at (0, +1)
        if len(k):
            out[ax] = (xy[nb[k, 2 * ax]] - xy[k]).sum(axis=0) / len(k)  # np.mean's sum and division
    return out


def outer_square_dark(xc: XCorners, idx: np.ndarray, labels: np.ndarray, axes: np.ndarray) -> bool:
    """Majority vote: is the square beyond label (0, 0) in ``-i, -j`` dark (module doc)?"""
    diag = [np.arctan2(*(axes[0] + axes[1])[::-1]), np.arctan2(*(axes[0] - axes[1])[::-1])]
    light = xc.light[idx]
    on_pp = np.abs(np.cos(light - diag[0])) > np.abs(np.cos(light - diag[1]))  # (+i, +j) wedge light
    parity = (labels.sum(axis=1) % 2).astype(bool)
    # the (-i, -j) wedge has the (+i, +j) wedge's colour; it turns with each label step
    light_at_origin = on_pp ^ parity
    return bool(np.count_nonzero(light_at_origin) * 2 < len(light_at_origin))


def orient(xc: XCorners, idx: np.ndarray, xy: np.ndarray, labels: np.ndarray,
            pattern: tuple[int, int] | None) -> tuple[np.ndarray, tuple[int, int] | None] | None:
    """Final labels and size (module doc), or None when the grid cannot be ``pattern``."""
    axes = label_axes(xy, labels)
    ext = labels.max(axis=0) - labels.min(axis=0) + 1
    full = pattern is not None and sorted(ext.tolist()) == sorted(pattern)
    if pattern is not None and not full and (ext.max() > max(pattern) or ext.min() > min(pattern)):
        return None
    rots = LABEL_TURNS
    if full:
        rots = [R for R in LABEL_TURNS if (np.abs(R) @ ext).tolist() == list(pattern)]
    scores = []
    for R in rots:
        a_i = R.T[:, 0] @ axes  # the image direction of the new +i: A R^-1 e_i
        scores.append(a_i[0] / max(np.hypot(*a_i), 1e-12))
    best = rots[int(np.argmax(scores))]
    lab = labels @ best.T
    lab -= lab.min(axis=0)
    if not full:
        return lab, None
    c, r = pattern  # type: ignore[misc]
    if (c + r) % 2 == 1:
        new_axes = label_axes(xy, lab)
        if not outer_square_dark(xc, idx, lab, new_axes):
            lab = np.array([c - 1, r - 1]) - lab  # the half turn
    return lab, (c, r)
