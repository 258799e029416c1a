"""Chessboard detection: X-corners, the lattice, refinement, the checks, the labels.

The steps (:func:`detect_boards`):

1. X-corner candidates with their edge lines (:func:`sogdd.calib.targets.xcorners.find_xcorners`;
   on a reduced scale for images above 2 MP, and again at full scale when that
   finds no board);
2. boards grown from seeds by prediction (:mod:`sogdd.calib.targets.lattice`), strongest
   seed first, each corner used by one board at most;
3. every corner refined at full resolution with a window of 0.65 of its local cell
   (:func:`sogdd.calib.refine_corners`), the window cut to where the squares
   around it are point-symmetric for the corners on the border and for those
   far less point-symmetric than the board's others (a code in the white
   squares), and those still far less symmetric measured again with the
   shading taken out (a shadow over a square;
   :func:`sogdd.calib.targets.windows._refine_board`); a corner whose
   refinement fails, or whose window stays far less point-symmetric
   (:data:`sogdd.calib.targets.windows.ASYMMETRY`; an occluder, the frame's
   edge), is dropped;
4. the check: each corner must be predicted by a homography of its neighbours
   within :data:`CHECK_TOL` of a cell (:func:`sogdd.calib.targets.lattice.check`); a corner
   that is not is dropped, twice over;
5. the labels the lattice left free next to the board (inside it, or within
   the pattern when it is given) measured where the board's curved map puts
   them, and kept when their squares, symmetry and neighbours say they are
   the board's corners (:func:`sogdd.calib.targets.fill._fill`: junctions that
   are no saddle, corners beyond the growth's reach at a fisheye's rim);
6. a board is kept with at least ``min_corners`` corners, three rows and three
   columns of them, a complete 3 x 3 block, and 80 % of its links running along
   an edge between a dark and a light square (:func:`_edges`; a corner without
   such a link is dropped), and few strong X-corners inside its outline left out
   (:func:`_orphans`: a lattice of wrong steps leaves most of them out);
7. the labels (below).

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

A grid that cannot be the given pattern (more rows or columns than it has) is not
returned.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial import cKDTree

from .board import LABEL_TURNS, Board, ViewBoards, grid_dims, parse_grid
from .fill import _filled
from .lattice import Lattice, check, grow, predict_labels, ray_neighbours, seeds
from .proposals import Source, propose
from .refine import half_widths, refine_grey
from .windows import ASYMMETRY, MIN_ASYMMETRY, _bilinear, _local_cells, _refine_board, _symmetric
from .xcorners import (
    SIGMA2,
    XCorners,
    check_search,
    edge_geometry,
    hessian_at,
    junction_strength,
    search,
    search_levels,
    to_grey,
)

__all__ = ["BoardSearch", "detect_board", "detect_boards", "find_boards", "parse_spec", "spec_text",
           "view_boards"]

#: leave-one-out prediction error allowed for a refined corner, in cells
CHECK_TOL = 0.12
#: a link's contrast across it, relative to the board's median (:func:`_edges`)
EDGE_CONTRAST = 0.3
#: the share of a board's links that must run along edges
EDGE_SHARE = 0.8
#: strong X-corners inside a board's outline that are not its corners, per board corner (:func:`_orphans`)
MAX_ORPHANS = 0.25


def _check_pattern(pattern: object) -> tuple[int, int] | None:
    if pattern is None:
        return None
    try:
        c, r = pattern  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"pattern must be (cols, rows) of inner corners or None, got {pattern!r}") from None
    ok = all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 2 for v in (c, r))
    if not ok:
        raise ValueError(f"pattern must be two integers >= 2 (inner corners), got {pattern!r}")
    return int(c), int(r)


def _edges(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray) -> tuple[float, np.ndarray]:
    """The share of lattice links that run along an edge, and the corners with at least one such link.

    A link between label neighbours ``p, q`` of a true board runs along an edge
    between a dark and a light square: at ``t = 1/4, 1/2, 3/4`` of the way the
    image differs across the link, ``I(m + d n) - I(m - d n)`` (``n`` the link's
    normal, ``d = max(0.1 |q - p|, 1)`` px), with one sign and at least
    :data:`EDGE_CONTRAST` of the board's median difference. A grid that links
    corners across squares (a lattice of wrong steps, e.g. a knight's move of a
    board blurred beyond recognition) fails it at ``t = 1/4`` or ``3/4``.
    """
    pos = {tuple(q): k for k, q in enumerate(labels.tolist())}
    pairs = np.array([(k, pos[(i + di, j + dj)]) for k, (i, j) in enumerate(labels.tolist())
                      for di, dj in ((1, 0), (0, 1)) if (i + di, j + dj) in pos], dtype=np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        return 0.0, np.zeros(len(xy), dtype=bool)
    p, q = xy[pairs[:, 0]], xy[pairs[:, 1]]
    v = q - p
    length = np.hypot(v[:, 0], v[:, 1])
    n = np.stack([-v[:, 1], v[:, 0]], axis=1) / np.maximum(length, 1e-9)[:, None]
    d = np.maximum(0.1 * length, 1.0)[:, None] * n
    diff = np.stack([_bilinear(grey, p + t * v + d) - _bilinear(grey, p + t * v - d)
                     for t in (0.25, 0.5, 0.75)])
    scale = float(np.median(np.abs(diff[1])))
    ok = (np.abs(diff) >= EDGE_CONTRAST * scale).all(axis=0) & (np.sign(diff) == np.sign(diff[1])).all(axis=0)
    ok &= scale > 0
    has = np.zeros(len(xy), dtype=bool)
    has[pairs[ok].ravel()] = True
    return float(np.mean(ok)), has


def _ring_contrast(grey: np.ndarray, xy: np.ndarray, light: np.ndarray, cell: float) -> np.ndarray:
    """How much the light wedges of X-corners stay lighter than the dark ones out to a third of a cell.

    With ``u`` the light axis and ``v`` perpendicular to it (the dark wedges'
    bisector), at radii ``r = (0.15, 0.3) cell``:
    ``c = min_r [min(I(p +- r u)) - max(I(p +- r v))]``. A board's corner keeps
    its full contrast at both radii (its wedges are squares a cell wide); a
    saddle between the dots or bits of a code inside a white square is light all
    round a few pixels out, so its ``c`` is small or negative.
    """
    u = np.stack([np.cos(light), np.sin(light)], axis=1)
    v = np.stack([-u[:, 1], u[:, 0]], axis=1)
    out = np.full(len(xy), np.inf)
    for r in (0.15 * cell, 0.3 * cell):
        lo = np.minimum(_bilinear(grey, xy + r * u), _bilinear(grey, xy - r * u))
        hi = np.maximum(_bilinear(grey, xy + r * v), _bilinear(grey, xy - r * v))
        out = np.minimum(out, lo - hi)
    return out


def _orphans(grey: np.ndarray, xc: XCorners, idx: np.ndarray, xy: np.ndarray, cells: np.ndarray,
             grown: np.ndarray | None = None) -> float:
    """Strong X-corners inside the board's outline that are none of its corners, per board corner.

    A true board uses every inner corner in its outline; a lattice of wrong steps
    (a knight's move, a diagonal) leaves most of them out. Only X-corners with
    the wedges of a board corner count (:func:`_ring_contrast` at least half the
    board's median): the saddles between the dots of a code inside a white
    square (ECoCheck, ChArUco's markers) are strong but light all round. The
    X-corners ``grown`` (indices into ``xc``: the lattice as grown, before the
    refinement and the check dropped some of it) are not left out by the
    lattice and do not count: a corner dropped for its asymmetry (an occluder,
    a code in its squares) says nothing about the lattice's steps.
    """
    hull = cv2.convexHull(xy.astype(np.float32)).reshape(-1, 2)
    strong = xc.strength >= 0.5 * float(np.median(xc.strength[idx]))
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    cand = np.flatnonzero(strong & np.all((xc.xy >= lo) & (xc.xy <= hi), axis=1))
    if grown is not None:
        cand = np.setdiff1d(cand, grown)
    cell = float(np.median(cells[np.isfinite(cells)])) if np.isfinite(cells).any() else 1.0
    d, _ = cKDTree(xy).query(xc.xy[cand])
    cand = cand[d > 0.3 * cell]
    if len(cand):
        own = float(np.median(_ring_contrast(grey, xy, xc.light[idx], cell)))
        cand = cand[_ring_contrast(grey, xc.xy[cand], xc.light[cand], cell) >= 0.5 * max(own, 1e-9)]
    inside = [cv2.pointPolygonTest(hull, (float(x), float(y)), True) > 0.3 * cell for x, y in xc.xy[cand]]
    return float(np.count_nonzero(inside)) / max(len(xy), 1)


def _axes(xy: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Mean image displacement per label step along ``i`` and ``j``: rows ``a_i``, ``a_j``."""
    pos = {tuple(q): k for k, q in enumerate(labels.tolist())}
    out = np.zeros((2, 2))
    for ax, (di, dj) in enumerate(((1, 0), (0, 1))):
        d = [xy[pos[(i + di, j + dj)]] - xy[k] for k, (i, j) in enumerate(labels.tolist())
             if (i + di, j + dj) in pos]
        if d:
            out[ax] = np.mean(d, axis=0)
    return out


def _has_block(labels: np.ndarray) -> bool:
    s = {tuple(q) for q in labels.tolist()}
    return any(all((i + a, j + b) in s for a in (-1, 0, 1) for b in (-1, 0, 1)) for i, j in s)


def _outer_square_dark(xc: XCorners, idx: np.ndarray, labels: np.ndarray, axes: np.ndarray) -> bool:
    """Majority vote: is the square beyond label (0, 0) in ``-i, -j`` dark (module doc)?"""
    diag = [np.arctan2(*(axes[0] + axes[1])[::-1]), np.arctan2(*(axes[0] - axes[1])[::-1])]
    light = xc.light[idx]
    on_pp = np.abs(np.cos(light - diag[0])) > np.abs(np.cos(light - diag[1]))  # (+i, +j) wedge light
    parity = (labels.sum(axis=1) % 2).astype(bool)
    # the (-i, -j) wedge has the (+i, +j) wedge's colour; it turns with each label step
    light_at_origin = on_pp ^ parity
    return bool(np.count_nonzero(light_at_origin) * 2 < len(light_at_origin))


def _orient(xc: XCorners, idx: np.ndarray, xy: np.ndarray, labels: np.ndarray,
            pattern: tuple[int, int] | None) -> tuple[np.ndarray, tuple[int, int] | None] | None:
    """Final labels and size (module doc), or None when the grid cannot be ``pattern``."""
    axes = _axes(xy, labels)
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
        new_axes = _axes(xy, lab)
        if not _outer_square_dark(xc, idx, lab, new_axes):
            lab = np.array([c - 1, r - 1]) - lab  # the half turn
    return lab, (c, r)


def _finish(grey: np.ndarray, xc: XCorners, lat: Lattice, pattern: tuple[int, int] | None,
            min_corners: int, refine: bool, source: Source = "sogdd", others: list[Board] | None = None
            ) -> Board | None:
    """The lattice refined, checked and labelled (module doc, steps 3-7); None when it is no board.

    A board that passes every check but cannot be ``pattern`` (more rows or
    columns than it has) is appended to ``others``, labelled as one of unknown size.
    """
    checked = _checked(grey, xc, lat, pattern, min_corners, refine)
    if checked is None:
        return None
    xc, idx, xy, labels, quality = checked
    oriented = _orient(xc, idx, xy, labels, pattern)
    if oriented is None:
        if others is not None:
            others.append(_labelled(xy, *_orient(xc, idx, xy, labels, None), quality, source))  # type: ignore[misc]
        return None
    return _labelled(xy, *oriented, quality, source)


def _checked(grey: np.ndarray, xc: XCorners, lat: Lattice, pattern: tuple[int, int] | None,
             min_corners: int, refine: bool) -> tuple | None:
    """Steps 3-6 of the module doc: ``(xc, idx, xy, labels, quality)`` of the corners kept, or None."""
    idx, labels = lat.index, lat.labels
    xy = xc.xy[idx]
    quality = np.ones(len(xy))
    if refine:
        xy, quality = _refine_board(grey, xy, labels)
        keep = _symmetric(quality)
        idx, labels, xy, quality = idx[keep], labels[keep], xy[keep], quality[keep]
    for _ in range(2):
        if len(xy) < min_corners:
            return None
        keep = check(xy, labels, tol=CHECK_TOL)
        idx, labels, xy, quality = idx[keep], labels[keep], xy[keep], quality[keep]
    if refine and len(xy) >= min_corners:
        xc, idx, xy, labels, quality = _filled(grey, xc, idx, xy, labels, quality, pattern)
    if len(xy) < min_corners or min(len(np.unique(labels[:, 0])), len(np.unique(labels[:, 1]))) < 3:
        return None
    if _orphans(grey, xc, idx, xy, _local_cells(xy, labels), grown=lat.index) > MAX_ORPHANS:
        return None
    share, linked = _edges(grey, xy, labels)
    if share < EDGE_SHARE:
        return None
    idx, labels, xy, quality = idx[linked], labels[linked], xy[linked], quality[linked]
    if len(xy) < min_corners or not _has_block(labels):
        return None
    return xc, idx, xy, labels, quality


def _labelled(xy: np.ndarray, lab: np.ndarray, size: tuple[int, int] | None, quality: np.ndarray,
              source: Source) -> Board:
    order = np.lexsort((lab[:, 0], lab[:, 1]))  # row by row, as OpenCV lists a pattern's corners
    return Board(xy[order], lab[order], quality[order], size=size, source=source)


def _boards(grey: np.ndarray, xc: XCorners, pattern: tuple[int, int] | None, min_corners: int, refine: bool,
            max_boards: int, others: list[Board] | None = None) -> list[Board]:
    if len(xc) < 5:
        return []
    tree = cKDTree(xc.xy)
    nb, dist = ray_neighbours(xc, tree)
    free = np.ones(len(xc), dtype=bool)
    out: list[Board] = []
    for s in seeds(xc, nb, dist):
        if len(out) >= max_boards:
            break
        if not free[s] or not free[nb[s]].all():
            continue
        lat = grow(xc, int(s), nb, free, tree)  # whole: a part of a larger grid is no board of the pattern
        if len(lat) < min_corners:
            free[lat.index] = True
            free[s] = False  # not a seed again
            continue
        board = _finish(grey, xc, lat, pattern, min_corners, refine, others=others)
        if board is not None:
            out.append(board)
    out.sort(key=lambda b: -len(b))
    return out


def detect_boards(image: np.ndarray, pattern: tuple[int, int] | None = None, *, min_corners: int = 12,
                  min_strength: float | None = None, scale: float | None = None, refine: bool = True,
                  max_boards: int = 16, mask: np.ndarray | None = None,
                  value_range: tuple[float, float] | None = None, proposals: bool = True) -> list[Board]:
    """Find the chessboards in an image, label their corners and refine them.

    X-corners (saddle points with two edge lines, :func:`sogdd.calib.targets.xcorners.find_xcorners`)
    are linked into lattices grown from seeds by local-homography prediction
    (:mod:`sogdd.calib.targets.lattice`), refined to their centre of point symmetry
    (:func:`sogdd.calib.refine_corners`), and kept only where every corner agrees
    with a homography of its neighbours within 0.12 of a cell. Labels are
    right-handed (module doc for which corner is ``(0, 0)``).

    Parameters
    ----------
    image : ndarray
        Grey or colour image (RGB), any dtype the corner detector takes, on its
        scale (:func:`sogdd.image.to_gray255`): uint8, uint16, float on [0, 1];
        another range (a float image of grey levels 0-255, as OpenCV's) needs
        ``value_range``.
    pattern : (cols, rows) or None
        Inner corners of the board (OpenCV's ``patternSize``), or None for an
        unknown size. A grid that cannot be this pattern is not returned; one
        smaller than it (partial, occluded) is, with relative labels and
        ``size=None``.
    min_corners : int
        Fewest corners a board may have (at least 9; three rows and three
        columns and a complete 3 x 3 block are needed too).
    min_strength : float or None
        Weakest X-corner considered, in grey levels of contrast (0-255 scale);
        None: a share of the image's range. Each level of the search raises it
        to what noise alone reaches there
        (:func:`sogdd.calib.targets.xcorners.threshold`).
    scale : float or None
        Search at this scale only (:func:`sogdd.calib.targets.xcorners.find_xcorners`);
        None: over the pyramid of :func:`sogdd.calib.targets.xcorners.search_levels`,
        finest first, until a level gives the whole ``pattern``, else the level
        whose largest board is largest. The corners are refined at full
        resolution.
    refine : bool
        Refine the corners (else the saddle points, coarse at a reduced scale).
    max_boards : int
        Most boards returned.
    mask : ndarray of bool or None
        Where corners may lie.
    value_range : (lo, hi) or None
        The image's range, mapped to 0-255 (``(0, 255)`` for a float image of
        grey levels); None: the dtype's, and a float image outside [0, 1] is a
        one-line ``ValueError``.
    proposals : bool
        When ``pattern`` is given and the own search finds no complete board,
        also take OpenCV's detectors' board as a proposal
        (:mod:`sogdd.calib.targets.proposals`): refined, checked and labelled
        as any other, ``Board.source`` naming its source.

    Returns
    -------
    list of Board
        Largest first; empty when there is no board.

    Examples
    --------
    >>> import cv2
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200.0 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230.0), (0, 0), 1.0)  # 7 x 5 inner corners
    >>> b = detect_boards(img, (7, 5), value_range=(0, 255))[0]
    >>> b.size, len(b), b.labels[:2].tolist()
    ((7, 5), 35, [[0, 0], [1, 0]])
    >>> np.round(b.image_points[0], 2).tolist()  # the first inner corner, between pixels 49 and 50
    [49.5, 49.5]
    >>> detect_boards(np.full((100, 100), 128, np.uint8))
    []
    >>> detect_boards(img)  # a float image is on [0, 1] unless its range is given
    Traceback (most recent call last):
    ...
    ValueError: float images must be on [0, 1] (got [30, 230]); give their range: value_range=(lo, hi) ...
    """
    grey = to_grey(image, value_range)
    pat = _check_pattern(pattern)
    _check_counts(min_corners, max_boards)
    check_search(grey, min_strength, scale, mask)
    return _search(grey, pat, int(min_corners), min_strength, scale, refine, int(max_boards), mask,
                   proposals).boards


@dataclass(frozen=True)
class BoardSearch:
    """What one search of an image found: ``boards`` (:func:`detect_boards`' result) and ``others``,
    boards that passed every check but cannot be the pattern asked for (more rows or columns than it has),
    labelled as boards of unknown size: what the image shows instead."""

    boards: list[Board]
    others: list[Board]


def find_boards(image: np.ndarray, pattern: tuple[int, int] | None = None, *, min_corners: int = 12,
                min_strength: float | None = None, scale: float | None = None, refine: bool = True,
                max_boards: int = 16, mask: np.ndarray | None = None,
                value_range: tuple[float, float] | None = None, proposals: bool = True) -> BoardSearch:
    """:func:`detect_boards`, and the boards of other sizes seen on the way, from one search.

    A view without the board asked for is told what it shows (a board of
    another size) without a second search.

    Parameters
    ----------
    image, pattern, min_corners, min_strength, scale, refine, max_boards, mask, value_range, proposals
        As :func:`detect_boards` (the same keywords and defaults).

    Returns
    -------
    BoardSearch

    Examples
    --------
    >>> import cv2
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200.0 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230.0), (0, 0), 1.0)  # 7 x 5 inner corners
    >>> found = find_boards(img, (5, 4), value_range=(0, 255))
    >>> found.boards, grid_dims(found.others[0])
    ([], (7, 5))
    """
    grey = to_grey(image, value_range)
    pat = _check_pattern(pattern)
    _check_counts(min_corners, max_boards)
    check_search(grey, min_strength, scale, mask)
    return _search(grey, pat, int(min_corners), min_strength, scale, refine, int(max_boards), mask,
                   proposals)


def _check_counts(min_corners: object, max_boards: object) -> None:
    if not isinstance(min_corners, (int, np.integer)) or isinstance(min_corners, bool) or min_corners < 9:
        raise ValueError(f"min_corners must be an integer >= 9, got {min_corners!r}")
    if not isinstance(max_boards, (int, np.integer)) or isinstance(max_boards, bool) or max_boards < 1:
        raise ValueError(f"max_boards must be a positive integer, got {max_boards!r}")


def _search(grey: np.ndarray, pat: tuple[int, int] | None, min_corners: int, min_strength: float | None,
            scale: float | None, refine: bool, max_boards: int, mask: np.ndarray | None,
            proposals: bool) -> BoardSearch:
    """The search of :func:`find_boards` on a validated grey image."""
    best: list[Board] = []
    others: list[Board] = []
    for level in (scale,) if scale is not None else search_levels(grey.shape):
        xc = search(grey, min_strength, level, mask)
        out = _boards(grey, xc, pat, min_corners, refine, max_boards, others)
        if _rank(out, pat) > _rank(best, pat):
            best = out
        if pat is not None and _rank(best, pat)[0]:
            break  # the whole board: no coarser level can do better
    if pat is not None and not _rank(best, pat)[0] and proposals:
        for prop in propose(grey, pat):
            board = _finish(grey, _proposed(grey, prop.xy), Lattice(np.arange(len(prop.xy)), prop.labels), pat,
                            min_corners, refine, prop.source)
            if board is not None and _extends(grey, board):
                others.append(board)  # a part of a larger grid, which OpenCV may propose as the pattern
            elif board is not None and _rank([board], pat) > _rank(best, pat):
                best = [board, *(b for b in best if not _overlaps(b, board))]
    return BoardSearch(best, others)


def _extends(grey: np.ndarray, board: Board) -> bool:
    """Whether the grid goes on beyond a side of the board: a part of a larger board.

    The labels one step beyond each side are put where the board's map puts
    them (:func:`sogdd.calib.targets.lattice.predict_labels`) and refined there; a side
    continues when at least half of them are X-junctions like the board's own:
    saddle strength (:func:`sogdd.calib.targets.xcorners.junction_strength`) at least
    half the board's median, and point-symmetric within the board's limit
    (:func:`sogdd.calib.targets.windows._symmetric`'s rule). Beyond a board's last corners
    lie the edges of its outer squares and the paper: no X-junction.
    """
    xy, labels = board.image_points, board.labels
    lo, hi = labels.min(axis=0), labels.max(axis=0)
    cols, rows = range(lo[0], hi[0] + 1), range(lo[1], hi[1] + 1)
    sides = [[(lo[0] - 1, j) for j in rows], [(hi[0] + 1, j) for j in rows],
             [(i, lo[1] - 1) for i in cols], [(i, hi[1] + 1) for i in cols]]
    cells = _local_cells(xy, labels)
    cell = float(np.median(cells[np.isfinite(cells)])) if np.isfinite(cells).any() else 0.0
    own_half = half_widths(xy, None, np.where(np.isfinite(cells), cells, cell))
    _, q_own = refine_grey(grey, xy, own_half, own_half.astype(np.float64), iterations=1)
    limit = max(ASYMMETRY * float(np.median(1.0 - q_own)), MIN_ASYMMETRY)
    strong = 0.5 * float(np.median(junction_strength(hessian_at(grey, xy, np.sqrt(SIGMA2)))))
    H, W = grey.shape
    for side in sides:
        P = predict_labels(xy, labels, np.array(side))[:, 0]
        room = np.min(np.c_[P, W - 1 - P[:, 0], H - 1 - P[:, 1]], axis=1)
        P = P[np.isfinite(room) & (room > 0.5 * cell)]
        if len(P) < max(2, len(side) // 2):
            continue
        half = half_widths(P, None, np.full(len(P), cell))
        r, q = refine_grey(grey, P, half, 0.5 * half.astype(np.float64))
        s_side = junction_strength(hessian_at(grey, r, np.sqrt(SIGMA2)))
        like = (q > 0) & (1.0 - q <= limit) & (s_side >= strong)
        if np.count_nonzero(like) >= max(2, len(side) / 2):
            return True
    return False


def _proposed(grey: np.ndarray, xy: np.ndarray) -> XCorners:
    """X-corners at a proposal's points: their edge lines and strength measured there (:mod:`.xcorners`)."""
    hess = hessian_at(grey, xy, np.sqrt(SIGMA2))
    light, phi, _ = edge_geometry(hess)
    return XCorners(xy.copy(), junction_strength(hess), light, phi)


def _overlaps(a: Board, b: Board) -> bool:
    """Whether two boards share corners (within a quarter of ``b``'s smallest spacing)."""
    d, _ = cKDTree(b.image_points).query(a.image_points)
    step = float(np.min(cKDTree(b.image_points).query(b.image_points, k=2)[0][:, 1]))
    return bool(np.any(d < 0.25 * step))


def _rank(boards: list[Board], pattern: tuple[int, int] | None) -> tuple[bool, int]:
    """How good one level's boards are: a complete board of ``pattern`` first, then the largest board."""
    whole = pattern is not None and any(len(b) == pattern[0] * pattern[1] for b in boards)
    return whole, max((len(b) for b in boards), default=0)


def detect_board(image: np.ndarray, pattern: tuple[int, int] | None = None, *, min_corners: int = 12,
                 min_strength: float | None = None, scale: float | None = None, refine: bool = True,
                 max_boards: int = 16, mask: np.ndarray | None = None,
                 value_range: tuple[float, float] | None = None, proposals: bool = True) -> Board | None:
    """The largest board of :func:`detect_boards` (a complete one first when ``pattern`` is given), or None.

    Of the boards ``B`` found, the one that maximises ``(B.size is not None, len(B))``.

    Parameters
    ----------
    image, pattern, min_corners, min_strength, scale, refine, max_boards, mask, value_range, proposals
        As :func:`detect_boards` (the same keywords and defaults).

    Returns
    -------
    Board or None

    Examples
    --------
    >>> detect_board(np.zeros((64, 64))) is None
    True
    """
    boards = detect_boards(image, pattern, min_corners=min_corners, min_strength=min_strength, scale=scale,
                           refine=refine, max_boards=max_boards, mask=mask, value_range=value_range,
                           proposals=proposals)
    if not boards:
        return None
    return max(boards, key=lambda b: (b.size is not None, len(b)))


def parse_spec(parts: list[str], spec: str) -> dict | None:
    """The fields of ``chessboard:COLSxROWS`` or ``chessboard:auto`` after its name (a row of
    :data:`sogdd.calib.targets.spec.KINDS`); None when they are not of that form.

    Examples
    --------
    >>> parse_spec(["9x6"], "chessboard:9x6"), parse_spec(["AUTO"], "chessboard:AUTO")
    ({'pattern': (9, 6)}, {})
    """
    if len(parts) != 1:
        return None
    if parts[0].lower() == "auto":
        return {}
    size = parse_grid(parts[0])
    if size is None:
        raise ValueError(f"board {spec!r}: {parts[0]!r} is not COLSxROWS")
    if min(size) < 2:
        raise ValueError(f"board {spec!r}: a chessboard needs at least 2x2 inner corners")
    return {"pattern": size}


def spec_text(spec) -> str:
    """A chessboard :class:`~sogdd.calib.targets.spec.BoardSpec` as its string."""
    return "chessboard:auto" if spec.pattern is None else f"chessboard:{spec.pattern[0]}x{spec.pattern[1]}"


def view_boards(image: np.ndarray, spec) -> ViewBoards:
    """The chessboards of ``spec`` in an image and, where there is none, what the same search saw instead.

    A board of unknown size (``spec.pattern`` None) is any board. Otherwise the
    boards that can be the pattern (complete, or partial with relative labels);
    failing them, a complete grid that does not fit in the pattern (either way
    round) contradicts it: "a board of WxH inner corners" (:func:`find_boards`'
    ``others``, no second search).

    Examples
    --------
    >>> from sogdd.calib.targets.spec import parse_board
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230).astype(np.uint8), (0, 0), 1.0)
    >>> v = view_boards(img, parse_board("chessboard:5x4"))
    >>> v.boards, v.seen, v.other_size
    ((), 'a board of 7x5 inner corners', (7, 5))
    """
    pattern = spec.pattern
    found = find_boards(image, pattern)
    boards = [b for b in found.boards if len(b)]
    if pattern is None:
        return ViewBoards(tuple(boards), "" if boards else "no board")
    fit = [b for b in boards if b.size is None or tuple(b.size) in (tuple(pattern), tuple(pattern)[::-1])]
    if fit:
        return ViewBoards(tuple(fit))
    for b in [b for b in boards if b not in fit] + found.others:
        dims = b.size if b.size is not None else grid_dims(b)
        if dims is not None and not _fits(dims, pattern):
            return ViewBoards((), f"a board of {dims[0]}x{dims[1]} inner corners", tuple(dims))
    if found.others:
        return ViewBoards((), f"a partial board ({max(len(b) for b in found.others)} corners)")
    return ViewBoards((), "no board")


def _fits(dims: tuple[int, int], pattern: tuple[int, int]) -> bool:
    (w, h), (c, r) = dims, pattern
    return (w <= c and h <= r) or (w <= r and h <= c)
