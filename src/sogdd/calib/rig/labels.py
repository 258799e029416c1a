"""Chessboard labels that mean the same physical corner in every camera of a frame.

A detector labels each view on its own (:mod:`sogdd.calib.targets.chessboard`): a
complete board whose ``cols + rows`` is even is symmetric under a half turn (a
square one under quarter turns too), so its ``(0, 0)`` is chosen by image
direction and may differ between cameras; a partial board (``Board.size`` None)
has relative labels. The labels of two views of one frame then differ by a
*relabelling* :math:`G`: a turn :math:`R_k` of ``k`` quarter turns and an integer
offset :math:`o`, :math:`l' = R_k l + o`; in board coordinates
:math:`X' = \\hat R_k X + s\\,(o, 0)`, with :math:`\\hat R_k` the turn about the
board's normal and ``s`` the square.

- :func:`ambiguity` says which observations are ambiguous.
- :func:`consensus` finds a camera's pose relative to the reference from frames that
  both saw, over every relabelling candidate of each frame: the candidate most
  other frames agree with (rotation within :data:`ROT_TOL`, translation within a
  share of the boards' distance) wins, and the consensus is the mean of the
  frames that agree with it (one candidate each).
- :func:`resolve` relabels one observation against the frame's board pose predicted
  from another camera of the frame: the candidate of the smallest reprojection RMS,
  kept when it is below :data:`MAX_CELL` of a cell and :data:`MARGIN` times
  smaller than the next.
"""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
from scipy.spatial import cKDTree

from ..cameras import project
from ..targets.board import LABEL_TURNS, Board

__all__ = ["MARGIN", "MAX_CELL", "ROT_TOL", "ambiguity", "consensus", "discrete", "inside", "relabel",
           "resolve", "transform"]

#: a relabelling is kept when its reprojection RMS is below this share of a cell ...
MAX_CELL = 0.25
#: ... and the next candidate's is this many times larger
MARGIN = 3.0
#: two frames' relative poses agree within this rotation (degrees) ...
ROT_TOL = 5.0
#: ... and this share of the boards' median distance from the camera
DIST_TOL = 0.2



def ambiguity(board: Board, pattern: tuple[int, int] | None) -> str:
    """Why the labels of ``board`` may not match another view's ("" when they are absolute).

    ChArUco (``pattern`` None) and a complete chessboard with ``cols + rows``
    odd (its ``(0, 0)`` fixed by colour) are absolute; a complete board with
    ``cols + rows`` even is ``"half turn"`` (``"quarter turns"`` when square);
    a partial board is ``"partial"`` (any turn and offset).

    Examples
    --------
    >>> lab = np.array([(i, j) for j in range(7) for i in range(9)])
    >>> b = Board(np.zeros((63, 2)) + lab, lab, size=(9, 7))
    >>> ambiguity(b, (9, 7)), ambiguity(b, None), ambiguity(Board(b.image_points, lab), (9, 7))
    ('half turn', '', 'partial')
    """
    if pattern is None:
        return ""
    if board.size is None:
        return "partial"
    c, r = pattern
    if (c + r) % 2:
        return ""
    return "quarter turns" if c == r else "half turn"


def relabel(board: Board, k: int, offset) -> Board:
    """``board`` with labels :math:`R_k l + o` (corners in the same order; a partial board stays partial)."""
    lab = board.labels @ LABEL_TURNS[k % 4].T + np.asarray(offset, np.int64)
    return replace(board, labels=lab)


def transform(k: int, offset, square: float) -> tuple[np.ndarray, np.ndarray]:
    """The relabelling in board coordinates: ``(R, t)`` with :math:`X' = R X + t` (3-D, about the normal)."""
    R = np.eye(3)
    R[:2, :2] = LABEL_TURNS[k % 4]
    return R, np.r_[np.asarray(offset, float) * square, 0.0]


def _angle_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    c = (np.trace(Ra.T @ Rb) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def discrete(board: Board, anchor: Board, pattern: tuple[int, int] | None) -> list[tuple[int, tuple]]:
    """The relabellings ``(k, offset)`` of a complete ``board`` that may match a complete ``anchor``:
    the identity only when both are absolute, else every turn that maps the pattern onto itself."""
    if not ambiguity(board, pattern) and not ambiguity(anchor, pattern):
        return [(0, (0, 0))]
    c, r = pattern  # type: ignore[misc]
    ext = np.array([c - 1, r - 1])
    out = []
    for k, Rk in enumerate(LABEL_TURNS):
        if (np.abs(Rk) @ ext).tolist() == ext.tolist():
            corner = Rk @ ext
            out.append((k, tuple(int(v) for v in np.maximum(-corner, 0))))
    return out


def inside(board: Board, pattern: tuple[int, int]) -> list[tuple[int, tuple]]:
    """Every relabelling ``(k, offset)`` of a partial ``board`` that keeps its labels inside the pattern
    (for matching it to a whole board of the same frame)."""
    c, r = pattern
    out = []
    for k, Rk in enumerate(LABEL_TURNS):
        lab = board.labels @ Rk.T
        lo, hi = -lab.min(axis=0), np.array([c - 1, r - 1]) - lab.max(axis=0)
        out += [(k, (int(a), int(b))) for a in range(lo[0], hi[0] + 1) for b in range(lo[1], hi[1] + 1)]
    return out


def consensus(candidates: list[list], distance: float, tol_t: float | None = None):
    """A camera's pose relative to the reference from per-frame candidates.

    Parameters
    ----------
    candidates : list (per frame) of list of ``(R (3, 3), t (3,))``
        Each frame's candidate relative poses (one per relabelling).
    distance : float
        The boards' typical distance from the camera (translation tolerance
        :data:`DIST_TOL` times it).
    tol_t : float, optional
        The translation tolerance instead (tighter where candidates differ by a
        shift of the labels, not by a turn).

    Returns
    -------
    R, t : the consensus, chosen : list of int
        Per frame, the candidate that agrees with the consensus (-1: none).

    Examples
    --------
    >>> R = cv2.Rodrigues(np.array([0.0, 0.1, 0.0]))[0]
    >>> flip = np.diag([-1.0, -1.0, 1.0])
    >>> cands = [[(R, np.r_[-5.0, 0, 0]), (R @ flip, np.r_[-3.0, 2, 0])] for _ in range(4)]
    >>> Rc, tc, chosen = consensus(cands, 20.0)
    >>> np.allclose(Rc, R), tc.tolist(), chosen
    (True, [-5.0, 0.0, 0.0], [0, 0, 0, 0])
    """
    flat = [(f, i, c) for f, cs in enumerate(candidates) for i, c in enumerate(cs)]
    tol_t = DIST_TOL * distance if tol_t is None else tol_t

    def agree(a, b):
        return _angle_deg(a[0], b[0]) <= ROT_TOL and np.linalg.norm(a[1] - b[1]) <= tol_t

    best, best_key = None, None
    for _, _, c in flat:
        frames = {g for g, _, d in flat if agree(c, d)}
        spread = sum(np.linalg.norm(c[1] - d[1]) for _, _, d in flat if agree(c, d))
        key = (len(frames), -spread)
        if best_key is None or key > best_key:
            best, best_key = c, key
    chosen = []
    for cs in candidates:
        good = [i for i, c in enumerate(cs) if agree(best, c)]
        chosen.append(min(good, key=lambda i: np.linalg.norm(cs[i][1] - best[1])) if good else -1)
    Rs = [candidates[f][i][0] for f, i in enumerate(chosen) if i >= 0]
    ts = [candidates[f][i][1] for f, i in enumerate(chosen) if i >= 0]
    u, _, vt = np.linalg.svd(np.sum(Rs, axis=0))  # the chordal mean of the agreeing rotations
    Rm = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    return Rm, np.median(np.array(ts), axis=0), chosen


def _grid_offsets(board: Board, predict, span: int) -> list[tuple[int, tuple]]:
    """Candidate ``(k, offset)`` of a partial observation: per turn, the offset most corners agree
    on when each is given the label of the nearest predicted corner of a wide grid, and its 8
    neighbours."""
    g = np.arange(-span, 2 * span + 1)
    grid = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    px = predict(grid)
    ok = np.all(np.isfinite(px), axis=1)
    if ok.sum() < 4:
        return []
    tree = cKDTree(px[ok])
    _, near = tree.query(board.image_points)
    lab_near = grid[ok][near]
    out = []
    for k, Rk in enumerate(LABEL_TURNS):
        d = lab_near - board.labels @ Rk.T
        vals, counts = np.unique(d, axis=0, return_counts=True)
        o = vals[np.argmax(counts)]
        out += [(k, (int(o[0] + a), int(o[1] + b))) for a in (-1, 0, 1) for b in (-1, 0, 1)]
    return out


def resolve(board: Board, anchor: Board, pattern: tuple[int, int], square: float, K, dist, model: str,
            pose: tuple[np.ndarray, np.ndarray]) -> tuple[Board | None, str]:
    """Relabel ``board`` to match ``anchor``'s labels, from the frame's board pose predicted in this camera.

    ``pose`` ``(R, t)`` maps ``anchor``'s board coordinates into this camera. Each
    candidate relabelling (:func:`discrete` for two complete boards; else every
    turn with the offsets of :func:`_grid_offsets`, inside the pattern when the
    anchor is complete) is projected through ``K, dist, model``; the one of the
    smallest RMS to the observed corners is kept when its RMS is below
    :data:`MAX_CELL` of the predicted cell and :data:`MARGIN` times below the next.

    Returns
    -------
    board : Board or None
        Relabelled (None when no candidate is clearly best).
    why : str
        What was decided, or why the observation goes.
    """
    rvec = cv2.Rodrigues(np.asarray(pose[0], np.float64))[0].ravel()
    tvec = np.asarray(pose[1], np.float64)

    def predict(lab):
        pts = np.c_[np.asarray(lab, float) * square, np.zeros(len(lab))]
        z = (pts @ pose[0].T + tvec)[:, 2]
        px = project(pts, K, dist, model, rvec, tvec)
        px[z <= 0] = np.nan  # behind the camera (a fisheye sees beyond 90 degrees, not behind)
        return px

    why = ambiguity(board, pattern) or ambiguity(anchor, pattern)
    if board.size is not None and anchor.size is not None:
        cands = discrete(board, anchor, pattern)
    else:
        cands = _grid_offsets(board, predict, max(pattern))
        if anchor.size is not None:
            c, r = pattern
            cands = [(k, o) for k, o in cands
                     if _inside(board.labels @ LABEL_TURNS[k].T + np.array(o), c, r)]
    if not cands:
        return None, f"labels ambiguous ({why}): no relabelling of the board lies in front of the camera"
    rms = []
    for k, o in cands:
        lab = board.labels @ LABEL_TURNS[k].T + np.array(o)
        e = board.image_points - predict(lab)
        rms.append(float(np.sqrt(np.mean(np.sum(e ** 2, axis=1)))) if np.isfinite(e).all() else np.inf)
    order = np.argsort(rms)
    k, o = cands[order[0]]
    lab = board.labels @ LABEL_TURNS[k].T + np.array(o)
    cell = float(np.nanmedian(np.hypot(*(predict(lab + [1, 0]) - predict(lab)).T)))
    best = rms[order[0]]
    nxt = rms[order[1]] if len(order) > 1 else np.inf
    if not (best < MAX_CELL * cell and nxt > MARGIN * best):
        return None, (f"labels ambiguous ({why}): no relabelling predicts the corners clearly better than "
                      f"the others (best {best:.3g} px, next {nxt:.3g} px, cell {cell:.3g} px)")
    note = "" if (k, tuple(o)) == (0, (0, 0)) else f"relabelled ({why}: {90 * k} degrees, offset {tuple(o)})"
    return relabel(board, k, o), note


def _inside(lab: np.ndarray, c: int, r: int) -> bool:
    return bool(np.all((lab >= 0) & (lab < [c, r])))
