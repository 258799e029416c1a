"""The chessboard search: the stages of :mod:`sogdd.calib.targets.chessboard` run in order.

:func:`find_boards` (and :func:`detect_boards`, :func:`detect_board`,
:func:`view_boards` on top of it) searches the pyramid of
:func:`sogdd.calib.targets.chessboard.xcorners.search_levels`, finest first: at
each level the X-corners (:mod:`.xcorners`) are grown into lattices
(:mod:`.lattice`), strongest seed first, each corner used by one board at most;
each lattice is refined at full resolution (:mod:`.windows`; a corner whose
window stays far less point-symmetric than the board's others is dropped),
checked against the lattice's map (:func:`sogdd.calib.targets.chessboard.mapping.check`,
within :data:`~.mapping.CHECK_TOL` of a cell, twice over), filled at the labels it left
free (:mod:`.fill`), accepted or not (:mod:`.checks`) and labelled
(:mod:`.labels`). The boards of all levels are kept, one board found at several
levels once (with the most corners); the search stops at the first level after
which the frame has no room for a board of the pattern large enough to make the
complete one found a background board (a screen showing the board, three times
smaller, may be the clearest board at the finest level). Where the view's board
it finds (:func:`sogdd.calib.targets.board.view_board`) is not the whole pattern,
OpenCV's detectors propose one
(:mod:`.proposals`), which goes through the same refinement, checks and labels,
and must not be a part of a larger grid (:func:`sogdd.calib.targets.chessboard.checks.extends`).
A grid that cannot be the given pattern (more rows or columns than it has) is not
returned as a board; :func:`find_boards` returns it among the ``others``. Where one
board per image is wanted (:func:`detect_board`, ``view_only``), the levels below the
finest are searched coarsest first, and the first that settles a complete board of
the pattern ends the search: the finer levels, the costlier, are searched only when
the coarser ones settle nothing.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..board import SMALL_CELL, Board, ViewBoards, grid_dims, lattice_cells, median, parse_grid, view_board
from .checks import EDGE_SHARE, MAX_ORPHANS, edge_links, extends, has_block, orphans
from .fill import fill_board
from .labels import orient
from .lattice import Lattice, grow, ray_neighbours, seeds
from .mapping import CHECK_TOL, check
from .proposals import Source, propose
from .windows import refine_board, symmetric
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


def _finish(grey: np.ndarray, xc: XCorners, lat: Lattice, pattern: tuple[int, int] | None,
            min_corners: int, refine: bool, source: Source = "sogdd", others: list[Board] | None = None,
            cells: np.ndarray | None = None) -> Board | None:
    """The lattice refined, checked and labelled (module doc, steps 3-7); None when it is no board.

    A board that passes every check but cannot be ``pattern`` (more rows or
    columns than it has) is appended to ``others``, labelled as one of unknown size.
    """
    checked = _checked(grey, xc, lat, pattern, min_corners, refine, cells)
    if checked is None:
        return None
    xc, idx, xy, labels, quality = checked
    oriented = orient(xc, idx, xy, labels, pattern)
    if oriented is None:
        if others is not None:
            others.append(_labelled(xy, *orient(xc, idx, xy, labels, None), quality, source))  # type: ignore[misc]
        return None
    return _labelled(xy, *oriented, quality, source)


def _checked(grey: np.ndarray, xc: XCorners, lat: Lattice, pattern: tuple[int, int] | None,
             min_corners: int, refine: bool, cells: np.ndarray | None = None) -> tuple | None:
    """Steps 3-6 of the module doc: ``(xc, idx, xy, labels, quality)`` of the corners kept, or None.
    ``cells``: the lattice's :func:`~sogdd.calib.targets.board.lattice_cells`, when known already."""
    idx, labels = lat.index, lat.labels
    xy = xc.xy[idx]
    quality = np.ones(len(xy))
    if refine:
        xy, quality = refine_board(grey, xy, labels, cells)
        keep = symmetric(quality)
        idx, labels, xy, quality = idx[keep], labels[keep], xy[keep], quality[keep]
    for _ in range(2):
        if len(xy) < min_corners:
            return None
        keep = check(xy, labels, tol=CHECK_TOL)
        idx, labels, xy, quality = idx[keep], labels[keep], xy[keep], quality[keep]
    if refine and len(xy) >= min_corners:
        xc, idx, xy, labels, quality = fill_board(grey, xc, idx, xy, labels, quality, pattern)
    if len(xy) < min_corners or min(len(np.unique(labels[:, 0])), len(np.unique(labels[:, 1]))) < 3:
        return None
    if orphans(grey, xc, idx, xy, lattice_cells(xy, labels), grown=lat.index) > MAX_ORPHANS:
        return None
    share, linked = edge_links(grey, xy, labels)
    if share < EDGE_SHARE:
        return None
    idx, labels, xy, quality = idx[linked], labels[linked], xy[linked], quality[linked]
    if len(xy) < min_corners or not has_block(labels):
        return None
    return xc, idx, xy, labels, quality


def _labelled(xy: np.ndarray, lab: np.ndarray, size: tuple[int, int] | None, quality: np.ndarray,
              source: Source) -> Board:
    order = np.lexsort((lab[:, 0], lab[:, 1]))  # row by row, as OpenCV lists a pattern's corners
    return Board(xy[order], lab[order], quality[order], size=size, source=source)


def _boards(grey: np.ndarray, xc: XCorners, pattern: tuple[int, int] | None, min_corners: int, refine: bool,
            max_boards: int, others: list[Board] | None = None, done: Sequence[Board] = (),
            view_only: bool = False) -> list[Board]:
    """The boards of one level's X-corners, largest first. A lattice whose corners all lie on a complete
    board of ``done`` (a level searched before) is that board again, and is not refined a second time.

    Seeds are grown strongest first (:func:`~sogdd.calib.targets.chessboard.lattice.seeds`), each lattice
    refined and checked as it is grown. With ``view_only`` (one board per image, :func:`find_boards`),
    :func:`_view_boards` instead."""
    if len(xc) < 5:
        return []
    nb, dist = ray_neighbours(xc)
    free = np.ones(len(xc), dtype=bool)
    if view_only:
        return _view_boards(grey, xc, nb, dist, free, pattern, min_corners, refine, max_boards, others, done)
    out: list[Board] = []
    for lat in _grown(xc, seeds(xc, nb, dist), nb, free, min_corners, done):
        board = _finish(grey, xc, lat, pattern, min_corners, refine, others=others)
        if board is not None:
            out.append(board)
            if len(out) >= max_boards:
                break
    out.sort(key=lambda b: -len(b))
    return out


def _grown(xc: XCorners, order: np.ndarray, nb: np.ndarray, free: np.ndarray, min_corners: int,
           done: Sequence[Board]) -> Iterator[Lattice]:
    """The lattices grown from the seeds ``order`` whose seed and its neighbours are still free (``free``
    updated as they grow), of ``min_corners`` or more and not already a complete board of ``done``."""
    for s in order:
        if not free[s] or not free[nb[s]].all():
            continue
        lat = grow(xc, int(s), nb, free)  # whole: a part of a larger grid is no board of the pattern
        if len(lat) < min_corners:
            free[lat.index] = True
            free[s] = False  # not a seed again
            continue
        if any(_within(xc.xy[lat.index], b) for b in done if b.size is not None):
            continue
        yield lat


#: with one board per image wanted, a seed or a lattice whose cells are under this share of a complete
#: board's is not grown or refined: :data:`~sogdd.calib.targets.board.SMALL_CELL`, less a margin for a
#: seed's or the grown corners' spacing against the refined board's cells
VIEW_SMALL = 0.8 * float(SMALL_CELL)


def _view_boards(grey: np.ndarray, xc: XCorners, nb: np.ndarray, dist: np.ndarray, free: np.ndarray,
                 pattern: tuple[int, int] | None, min_corners: int, refine: bool, max_boards: int,
                 others: list[Board] | None, done: Sequence[Board]) -> list[Board]:
    """:func:`_boards` for one board per image: the seeds spaced at least :data:`VIEW_SMALL` of the widest
    seed's first (strongest first among them), then the others; each group's lattices refined largest
    cells first; once a board of the whole pattern is found (here or in ``done``), no seed or lattice
    under :data:`VIEW_SMALL` of its cells is grown or refined. Such a board can be no view
    (:func:`~sogdd.calib.targets.board.view_board`), and refining it costs as much as the view's own."""
    full = math.inf if pattern is None else pattern[0] * pattern[1]
    settled = max((b.cell for b in done if len(b) == full), default=0.0)
    order = seeds(xc, nb, dist)
    spacing = np.median(dist[order], axis=1)
    wide = spacing >= VIEW_SMALL * max(spacing.max(initial=0.0), settled)
    out: list[Board] = []
    for part in (wide, ~wide):
        group = order[part & (spacing >= VIEW_SMALL * settled)]
        grown = list(_grown(xc, group, nb, free, min_corners, done))
        local = [lattice_cells(xc.xy[lat.index], lat.labels) for lat in grown]  # the refinement's too
        cells = [median(c) for c in local]
        for k in np.argsort(cells, kind="stable")[::-1]:
            if len(out) >= max_boards or cells[k] < VIEW_SMALL * settled:
                break
            board = _finish(grey, xc, grown[k], pattern, min_corners, refine, others=others, cells=local[k])
            if board is not None:
                out.append(board)
                if len(board) == full:
                    settled = max(settled, board.cell)
    out.sort(key=lambda b: -len(b))
    return out


def detect_boards(image: np.ndarray, pattern: tuple[int, int] | None = None, *, min_corners: int = 12,
                  min_strength: float | None = None, scale: float | None = None, refine: bool = True,
                  max_boards: int = 16, mask: np.ndarray | None = None,
                  value_range: tuple[float, float] | None = None, proposals: bool = True) -> list[Board]:
    """Find the chessboards in an image, label their corners and refine them.

    X-corners (saddle points with two edge lines, :func:`sogdd.calib.targets.chessboard.xcorners.find_xcorners`)
    are linked into lattices grown from seeds by local-homography prediction
    (:mod:`sogdd.calib.targets.chessboard.lattice`), refined to their centre of point symmetry
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
        columns and a complete 3 x 3 block are needed too); at most the
        pattern's own, so that a small board (3 x 3 inner corners) is found
        whole.
    min_strength : float or None
        Weakest X-corner considered, in grey levels of contrast (0-255 scale);
        None: a share of the image's range. Each level of the search raises it
        to what noise alone reaches there
        (:func:`sogdd.calib.targets.chessboard.xcorners.threshold`).
    scale : float or None
        Search at this scale only (:func:`sogdd.calib.targets.chessboard.xcorners.find_xcorners`);
        None: over the pyramid of :func:`sogdd.calib.targets.chessboard.xcorners.search_levels`,
        finest first, the boards of every level kept (module doc for when it
        stops). The corners are refined at full resolution.
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
        When ``pattern`` is given and the view's board of the own search
        (:func:`sogdd.calib.targets.board.view_board`) is not complete, also
        take OpenCV's detectors' board as a proposal
        (:mod:`sogdd.calib.targets.chessboard.proposals`): refined, checked and labelled
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
    grey, pat = _validated(image, pattern, min_corners, min_strength, scale, max_boards, mask, value_range)
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
                value_range: tuple[float, float] | None = None, proposals: bool = True,
                view_only: bool = False) -> BoardSearch:
    """:func:`detect_boards`, and the boards of other sizes seen on the way, from one search.

    A view without the board asked for is told what it shows (a board of
    another size) without a second search.

    Parameters
    ----------
    image, pattern, min_corners, min_strength, scale, refine, max_boards, mask, value_range, proposals
        As :func:`detect_boards` (the same keywords and defaults).
    view_only : bool
        Only the view's board is wanted (:func:`sogdd.calib.targets.board.view_board`;
        one board per image): with ``pattern`` given, the pyramid's levels below
        the finest are searched coarsest first, and the first level at which the
        view is a complete board of the pattern ends the search. A board that
        only a finer level would show is smaller than that one (a larger board
        shows at the coarser levels, searched already), so
        it can neither be the view (:func:`~sogdd.calib.targets.board.view_board`
        ranks complete boards by their cells) nor make that board a background
        one; such a board (a screen behind the board, too small for the
        coarser levels) is then not returned. Without a complete board there,
        every level is searched. At every level, the lattices are refined
        largest cells first, and none whose cells are under
        :data:`VIEW_SMALL` of a complete board's.

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
    grey, pat = _validated(image, pattern, min_corners, min_strength, scale, max_boards, mask, value_range)
    return _search(grey, pat, int(min_corners), min_strength, scale, refine, int(max_boards), mask,
                   proposals, bool(view_only))


def _validated(image, pattern, min_corners, min_strength, scale, max_boards, mask, value_range):
    """The search's arguments checked at the door (one-line ``ValueError``): the grey image and the pattern."""
    grey = to_grey(image, value_range)
    pat = _check_pattern(pattern)
    if not isinstance(min_corners, (int, np.integer)) or isinstance(min_corners, bool) or min_corners < 9:
        raise ValueError(f"min_corners must be an integer >= 9, got {min_corners!r}")
    if not isinstance(max_boards, (int, np.integer)) or isinstance(max_boards, bool) or max_boards < 1:
        raise ValueError(f"max_boards must be a positive integer, got {max_boards!r}")
    check_search(grey, min_strength, scale, mask)
    return grey, pat


def _search(grey: np.ndarray, pat: tuple[int, int] | None, min_corners: int, min_strength: float | None,
            scale: float | None, refine: bool, max_boards: int, mask: np.ndarray | None,
            proposals: bool, view_only: bool = False) -> BoardSearch:
    """The search of :func:`find_boards` on a validated grey image."""
    if pat is not None:  # a whole board of the pattern is always a board
        min_corners = max(9, min(min_corners, pat[0] * pat[1]))
    g32 = grey.astype(np.float32)  # the X-corner search's maps are float32
    levels = (scale,) if scale is not None else search_levels(grey.shape)
    if view_only and pat is not None and len(levels) > 1:
        # the coarser levels, coarsest first: a complete board settles the view (module doc)
        coarse = sorted(v for v in levels if v < levels[0])  # not the full scale a large frame ends with
        best, others = _levels(grey, g32, coarse, pat, min_corners, min_strength, refine, max_boards, mask,
                               view_only=True, settle=True)
        if _settled(best, pat):
            return BoardSearch(best, others)
    best, others = _levels(grey, g32, levels, pat, min_corners, min_strength, refine, max_boards, mask,
                           view_only and pat is not None)
    view = view_board(best)
    if pat is not None and proposals and (view is None or len(view) < pat[0] * pat[1]):
        for prop in propose(grey, pat):
            board = _finish(grey, _proposed(grey, prop.xy), Lattice(np.arange(len(prop.xy)), prop.labels), pat,
                            min_corners, refine, prop.source)
            if board is not None and extends(grey, board):
                others.append(board)  # a part of a larger grid, which OpenCV may propose as the pattern
            elif board is not None and (view is None or len(board) > len(view)):
                best = [board, *(b for b in best if not _overlaps(b, board))]
    return BoardSearch(best, others)


def _levels(grey: np.ndarray, g32: np.ndarray, levels: Sequence[float], pat: tuple[int, int] | None,
            min_corners: int, min_strength: float | None, refine: bool, max_boards: int,
            mask: np.ndarray | None, view_only: bool = False, settle: bool = False
            ) -> tuple[list[Board], list[Board]]:
    """The boards of the pyramid's ``levels``, in that order, and the ``others``: the loop of :func:`_search`,
    stopped where :func:`_room_for_larger` says no larger board can follow, or with ``settle`` (levels
    coarse to fine) at the first that settles the view (``view_only``: :func:`_boards`')."""
    best: list[Board] = []
    others: list[Board] = []
    cap, finest = math.inf, math.inf  # the noise of the finest level searched so far, and its scale
    for level in levels:
        xc = search(g32, min_strength, level, mask, cap if level < finest else math.inf)
        if level < finest:
            cap, finest = xc.noise, level
        best = _merged(best, _boards(grey, xc, pat, min_corners, refine, max_boards, others, best, view_only))
        if pat is not None and (_settled(best, pat) if settle else not _room_for_larger(best, pat, grey.shape)):
            break
    return best, others


def _settled(boards: list[Board], pattern: tuple[int, int]) -> bool:
    """Whether the view's board (:func:`~sogdd.calib.targets.board.view_board`) is the whole pattern."""
    view = view_board(boards)
    return view is not None and len(view) == pattern[0] * pattern[1]


def _merged(found: list[Board], new: list[Board]) -> list[Board]:
    """The boards of the levels so far and of the next one: one board found at two levels kept once, with
    the more corners (the finer level's on a tie), largest first."""
    out = list(found)
    for b in new:
        same = [k for k, a in enumerate(out) if _overlaps(a, b) or _overlaps(b, a)]
        if not same:
            out.append(b)
        elif len(b) > max(len(out[k]) for k in same):
            out = [a for k, a in enumerate(out) if k not in same] + [b]
    out.sort(key=lambda b: -len(b))
    return out


def _room_for_larger(boards: list[Board], pattern: tuple[int, int], shape: tuple[int, int]) -> bool:
    """Whether the frame could hold a board of ``pattern`` that would make the complete one found so far a
    background board (:func:`sogdd.calib.targets.board.view_board`): cells ``1 / SMALL_CELL`` times as
    large, its shorter side (``min(pattern) + 1`` cells) within the frame's longer side. Until a complete
    board is found, or while such a board fits, the coarser levels are searched too (a screen showing
    the board may be the clearest board at the finest level)."""
    cells = [b.cell for b in boards if len(b) == pattern[0] * pattern[1]]
    if not cells:
        return True
    return max(cells) / SMALL_CELL * (min(pattern) + 1) <= max(shape)


def _proposed(grey: np.ndarray, xy: np.ndarray) -> XCorners:
    """X-corners at a proposal's points: their edge lines and strength measured there (:mod:`.xcorners`)."""
    hess = hessian_at(grey, xy, np.sqrt(SIGMA2))
    light, phi, _ = edge_geometry(hess)
    return XCorners(xy.copy(), junction_strength(hess), light, phi)


def _within(xy: np.ndarray, board: Board) -> bool:
    """Whether every point lies within a quarter of the board's cell (:attr:`Board.cell`) of one of its
    corners."""
    d, _ = cKDTree(board.image_points).query(xy)
    return bool(np.all(d < 0.25 * board.cell))


def _overlaps(a: Board, b: Board) -> bool:
    """Whether two boards share corners (within a quarter of ``b``'s smallest spacing)."""
    tree = cKDTree(b.image_points)
    d, _ = tree.query(a.image_points)
    step = float(np.min(tree.query(b.image_points, k=2)[0][:, 1]))
    return bool(np.any(d < 0.25 * step))


def detect_board(image: np.ndarray, pattern: tuple[int, int] | None = None, *, min_corners: int = 12,
                 min_strength: float | None = None, scale: float | None = None, refine: bool = True,
                 max_boards: int = 16, mask: np.ndarray | None = None,
                 value_range: tuple[float, float] | None = None, proposals: bool = True) -> Board | None:
    """The view's board of :func:`detect_boards` (a complete one first when ``pattern`` is given), or None.

    Of the boards ``B`` found, leaving out those whose cells are under a third of
    the largest board's (a screen or a reflection: :func:`sogdd.calib.targets.board.view_board`),
    the one that maximises ``(B.size is not None, len(B), cell_size(B))``. The search is
    :func:`find_boards`' with ``view_only``: it stops once a complete board of
    ``pattern`` settles the view.

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
    found = find_boards(image, pattern, min_corners=min_corners, min_strength=min_strength, scale=scale,
                        refine=refine, max_boards=max_boards, mask=mask, value_range=value_range,
                        proposals=proposals, view_only=True)
    return view_board(found.boards)


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


def view_boards(image: np.ndarray, spec, view_only: bool = False) -> ViewBoards:
    """The chessboards of ``spec`` in an image and, where there is none, what the same search saw instead.

    A board of unknown size (``spec.pattern`` None) is any board. Otherwise the
    boards that can be the pattern (complete, or partial with relative labels);
    failing them, a complete grid that does not fit in the pattern (either way
    round) contradicts it: "a board of WxH inner corners" (:func:`find_boards`'
    ``others``, no second search). ``view_only``: as :func:`find_boards`' (one
    board per image is wanted).

    Examples
    --------
    >>> import cv2
    >>> from sogdd.calib.targets.spec import parse_board
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230).astype(np.uint8), (0, 0), 1.0)
    >>> v = view_boards(img, parse_board("chessboard:5x4"))
    >>> v.boards, v.seen, v.other_size
    ((), 'a board of 7x5 inner corners', (7, 5))
    """
    pattern = spec.pattern
    found = find_boards(image, pattern, view_only=view_only)
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
