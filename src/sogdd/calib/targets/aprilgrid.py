"""AprilGrid boards (Kalibr's target): OpenCV finds the tags, sogdd measures their corners.

The board
---------
Kalibr's AprilGrid (``kalibr_create_target_pdf --type apriltag``) is ``cols x rows``
AprilTags of the 36h11 family with a black border of two bits (a tag is 6 + 2 x 2 =
10 bits across), each ``s`` (the tag size) from outer edge to outer edge, ``g s``
apart (``g`` the spacing ratio), and a black square of side ``g s`` diagonally
off each of the tag's four corners (in the gaps, shared by the four tags of a
crossing). Tag ``t`` lies in column ``c = t % cols`` and row ``r = t // cols``:
in Kalibr's board frame (``x`` right, ``y`` *up* as the target is printed, tag 0
at the bottom left) it covers ``[c P, c P + s] x [r P, r P + s]``, ``P = (1 + g) s``.

Each tag corner is an X-junction: the tag's black border and the black square
meet at it across two white gaps, so the image near it is point symmetric, as a
chessboard's is, up to ``min(2 s / 10, g s)`` from it (the border's width, the
square's side) in the board's directions; beyond, the tag's bits break the
symmetry. :func:`detect_aprilgrid` refines each corner with sogdd's point-symmetry
refinement (:func:`~sogdd.calib.targets.refine.refine_grey`) in a window of
half-width ``h = 0.7 min(0.2, g) L``, ``L`` the shorter of the tag's two edges
at the corner in px (``0.7 < 1 / sqrt 2``: a window turned by 45 degrees stays
inside the symmetric square too), at least 2 px. Measured on rendered views (12
views of 4 x 4 tags of 40-70 px, tilts up to 50 degrees, blur 0.7 and 1.5 px,
noise 2 grey levels), the fraction :data:`WINDOW` 0.4 / 0.55 / 0.7 / 0.85 / 1.0
gave a mean error of 0.021 / 0.017 / 0.014 / 0.013 / 0.014 px, the largest
0.073 / 0.049 / 0.040 / 0.058 / 0.061 px, and 475 / 624 / 628 / 628 / 628
corners (a small window fails more often).

Kalibr's points and sogdd's labels
----------------------------------
Kalibr (``GridCalibrationTargetAprilgrid``) numbers the ``2 cols x 2 rows`` tag
corners on a grid: point ``k`` is grid column ``gc = k % (2 cols)``, grid row
``gr = k // (2 cols)``, at ``x = (gc // 2) P + (gc % 2) s``,
``y = (gr // 2) P + (gr % 2) s``; tag ``t``'s corners are the points
``b, b + 1, b + 2 cols + 1, b + 2 cols`` (its bottom left, bottom right, top
right, top left), ``b = 4 cols (t // cols) + 2 (t % cols)``: not ``4 t ... 4 t + 3``.
:attr:`~sogdd.calib.Board.ids` holds these point numbers.

sogdd's labels are integers on a lattice of step ``u = s / q`` for the spacing
``g = p / q`` in lowest terms (``g = 0.3``: ``u = s / 10``; a spacing is a
fraction of denominator at most :data:`MAX_DENOMINATOR`): a tag spans ``q``
steps and the pitch ``P`` is ``p + q``, so that the object point of a corner is
``label x u``, what :meth:`~sogdd.calib.Board.object_points` gives with
``square = u`` (:attr:`AprilGrid.unit`). A :class:`~sogdd.calib.Board`'s frame
is right-handed with the board's normal pointing away from the camera, ``j``
down the printed target; Kalibr's ``y`` runs up it, so the label of Kalibr's
point ``(x, y)`` is ``(x / u, (Y - y) / u)``, ``Y = (rows - 1) P + s`` the top
edge of the top row: sogdd's origin is the top-left corner of the top-left tag
(tag ``(rows - 1) cols``) and its frame is Kalibr's turned half a turn about
``x`` and moved by ``Y`` (a pose from sogdd, ``X_cam = R X + t``, is Kalibr's with
``R_K = R diag(1, -1, -1)``, ``t_K = t + Y R e_y``). Labels are absolute: a
partial view of the grid keeps them.

Why so: the ``ids`` are Kalibr's own numbers, so that a corner sogdd measured is
the observation Kalibr would index the same way (``4 t ... 4 t + 3`` is only the
order of Kalibr's intermediate list of detected corners, before it puts them in
its grid). The labels keep every other part of sogdd unchanged: the fit, the
report and the rigs take a board as integer labels in the right-handed frame
:class:`~sogdd.calib.Board` defines (the chessboard's and ChArUco's, ``j`` down
the target), and its object points as ``label x square``; a lattice of step
``s / q`` holds both ``s`` and ``(1 + g) s`` exactly, so the object points are
exact with no change there (``--square`` ``s / q``).

The tag's corners in OpenCV's order (top left, top right, bottom right, bottom
left of the marker as ``cv2.aruco.generateImageMarker`` draws it) are, on
Kalibr's target, its bottom right, bottom left, top left and top right: Kalibr
draws tag ``t``'s code bits (bit ``6 i + j`` of its code, black when 0) turned
half a turn (``np.rot90(..., 2)`` in ``kalibr_create_target_pdf``), which is
OpenCV's marker of ID ``t`` turned half a turn (``tests/calib/targets/test_aprilgrid.py``
checks it on Kalibr's first codes).

Checks
------
A tag whose ID is not on the grid is dropped, and both of two tags of one ID (a
tag that is not the target's). A tag is kept when three of its four corners lie
within a quarter of its side of where the homography of its neighbours' corners
(on the grid, 8-neighbours; least median of squares) puts them, or, with no
neighbour seen, where the homography of all the tags (RANSAC) puts them: a tag
read with a wrong ID lies elsewhere than its ID says, and goes; a tag with one
corner of OpenCV's astray stays. After the refinement, a corner more than
``max(1, 0.05 L)`` px (``L`` its tag's side) off the homography of the corners
of its tag and the tags around it (an OpenCV corner a few px astray, refined to
another point) is refined once more from where that homography puts it, and
dropped unless it then stays within that distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import cv2
import numpy as np

from .board import Board, ViewBoards, parse_grid
from .grey import to_grey
from .refine import refine_grey

__all__ = ["BORDER_BITS", "ENLARGE_MAX", "MAX_DENOMINATOR", "OPENCV_CORNERS", "TAGS_36H11", "WINDOW",
           "AprilGrid", "detect_aprilgrid", "detector_parameters", "find_tags", "parse_spec", "spec_text",
           "view_boards"]

#: the black border of Kalibr's tags, in bits (its generator's ``borderBits``; OpenCV's default is 1)
BORDER_BITS = 2
#: the largest denominator of a spacing ratio (labels are integers on a lattice of ``tag size / q``)
MAX_DENOMINATOR = 100
#: where OpenCV's corners 0..3 of a tag lie on Kalibr's target, as (right of the tag's left edge, above its
#: bottom edge), in tag sides: OpenCV's top left is the printed tag's bottom right (module doc)
OPENCV_CORNERS = ((1, 0), (0, 0), (0, 1), (1, 1))
#: the refinement window's half-width over the symmetric square's (module doc)
WINDOW = 0.7
#: an image whose longer side exceeds this (px) is not searched again enlarged (:func:`find_tags`)
ENLARGE_MAX = 4096
#: the number of tags of OpenCV's 36h11 dictionary
TAGS_36H11 = 587


@dataclass(frozen=True)
class AprilGrid:
    """Kalibr's AprilGrid of ``cols x rows`` 36h11 tags of side ``tag_size``, ``spacing`` of a tag apart.

    Examples
    --------
    >>> g = AprilGrid(6, 6, 0.088, 0.3)
    >>> g.steps, round(g.unit, 6)   # tag side and pitch in label steps, a step in the tag size's unit
    ((10, 13), 0.0088)
    >>> g.labels()[[0, 1, 12, 13]].tolist()   # Kalibr's points 0, 1 (bottom row), 12, 13 (next grid row)
    [[0, 75], [10, 75], [0, 65], [10, 65]]
    """

    cols: int
    rows: int
    tag_size: float = 1.0
    spacing: float = 0.3

    @property
    def ratio(self) -> Fraction:
        """The spacing as the exact fraction its decimal text writes (``0.3`` is ``3/10``)."""
        return Fraction(repr(float(self.spacing)))

    @property
    def steps(self) -> tuple[int, int]:
        """``(q, p + q)``: a tag's side and the tags' pitch in label steps, for the spacing ``p / q``."""
        f = self.ratio
        return f.denominator, f.denominator + f.numerator

    @property
    def unit(self) -> float:
        """The length of one label step, ``tag_size / q``: object points are ``label x unit``."""
        return float(self.tag_size) / self.steps[0]

    def labels(self) -> np.ndarray:
        """The labels (4 cols rows, 2) int64 of Kalibr's points, row ``k`` Kalibr's point ``k`` (module doc)."""
        q, pitch = self.steps
        k = np.arange(4 * self.cols * self.rows)
        gc, gr = k % (2 * self.cols), k // (2 * self.cols)
        x = (gc // 2) * pitch + (gc % 2) * q
        y = (gr // 2) * pitch + (gr % 2) * q
        top = (self.rows - 1) * pitch + q
        return np.stack([x, top - y], axis=1).astype(np.int64)

    def tag_points(self, tag: np.ndarray) -> np.ndarray:
        """Kalibr's point numbers (N, 4) of the tags ``tag`` (N,), in OpenCV's corner order (module doc)."""
        t = np.asarray(tag, dtype=np.int64).reshape(-1, 1)
        base = 4 * self.cols * (t // self.cols) + 2 * (t % self.cols)
        dx = np.array([c[0] for c in OPENCV_CORNERS])
        dy = np.array([c[1] for c in OPENCV_CORNERS])
        return base + dx + 2 * self.cols * dy


def detector_parameters(refinement: int | None = None) -> cv2.aruco.DetectorParameters:
    """OpenCV's ArUco parameters for Kalibr's tags: a border of :data:`BORDER_BITS` bits, and OpenCV's
    corner refinement ``refinement`` (``cv2.aruco.CORNER_REFINE_*``; None: none, sogdd refines).

    Examples
    --------
    >>> detector_parameters().markerBorderBits
    2
    """
    p = cv2.aruco.DetectorParameters()
    p.markerBorderBits = BORDER_BITS
    p.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE if refinement is None else int(refinement)
    return p


def _number(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        return float("nan")
    return v


def parse_spec(parts: list[str], spec: str) -> dict | None:
    """The fields of ``aprilgrid:COLSxROWS:SIZE:SPACING`` after its name (a row of
    :data:`sogdd.calib.targets.spec.KINDS`); None when they are not of that form.

    Examples
    --------
    >>> parse_spec(["6x6", "0.088", "0.3"], "aprilgrid:6x6:0.088:0.3")
    {'tags': (6, 6), 'tag_size': 0.088, 'spacing': 0.3}
    >>> parse_spec(["6x6", "0.088", "1/3"], "aprilgrid:6x6:0.088:1/3")
    Traceback (most recent call last):
    ...
    ValueError: board 'aprilgrid:6x6:0.088:1/3': SPACING is the gap between tags over the tag's side, ...
    """
    if len(parts) != 3:
        return None
    size = parse_grid(parts[0])
    if size is None:
        raise ValueError(f"board {spec!r}: {parts[0]!r} is not COLSxROWS (tags)")
    if min(size) < 1 or size[0] * size[1] > TAGS_36H11:
        raise ValueError(f"board {spec!r}: an AprilGrid has from 1 to {TAGS_36H11} tags (36h11)")
    tag = _number(parts[1])
    if not (0 < tag < math.inf):
        raise ValueError(f"board {spec!r}: SIZE is the tag's side (edge to edge, any unit), a positive number")
    spacing = _number(parts[2])
    ok = 0 < spacing <= 1
    if ok:
        f = Fraction(repr(spacing))
        ok = f.denominator <= MAX_DENOMINATOR
    if not ok:
        raise ValueError(f"board {spec!r}: SPACING is the gap between tags over the tag's side, in (0, 1] "
                         f"with at most two decimals (e.g. 0.3)")
    return {"tags": size, "tag_size": tag, "spacing": spacing}


def _short(v: float) -> str:
    """``v`` in the fewest digits that read back exactly."""
    text = f"{v:g}"
    return text if float(text) == v else repr(float(v))


def spec_text(spec) -> str:
    """An AprilGrid :class:`~sogdd.calib.targets.spec.BoardSpec` as its string."""
    return f"aprilgrid:{spec.tags[0]}x{spec.tags[1]}:{_short(spec.tag_size)}:{_short(spec.spacing)}"


def view_boards(image: np.ndarray, spec, view_only: bool = False) -> ViewBoards:
    """The AprilGrid of ``spec`` in an image (:func:`detect_aprilgrid`), in either polarity (where the image
    shows no grid, its negative is searched: a heated grid in a thermal camera), or what was missing; one
    board per image whatever ``view_only`` says (the grid is one board)."""
    grey = to_grey(image)
    b = detect_aprilgrid(grey, spec.aprilgrid(), value_range=(0.0, 255.0))
    if b is None:
        b = detect_aprilgrid(255.0 - grey, spec.aprilgrid(), value_range=(0.0, 255.0))
    seen = "" if b is not None else "no AprilGrid tags (36h11, a border of 2 bits) of the grid"
    return ViewBoards((b,) if b is not None and len(b) else (), seen)


def find_tags(u8: np.ndarray, grid: AprilGrid, params: cv2.aruco.DetectorParameters | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's tags of the grid in a grey uint8 image: corners (N, 4, 2) float64, OpenCV's order, and IDs
    (N,), sorted by ID; unchecked but for an ID off the grid or seen twice (both go). ``params``: OpenCV's
    (None: :func:`detector_parameters`, no corner refinement).

    The image is searched as it is, then at twice its size (bicubic) for the tags not found (unless its
    longer side exceeds :data:`ENLARGE_MAX` px): OpenCV reads a tag's bits on a grid of its own, and a tag
    of a few pixels a bit is read far more often enlarged (on rendered views of tags of 3-5 px a bit, about
    twice as many tags).
    """
    d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    det = cv2.aruco.ArucoDetector(d, detector_parameters() if params is None else params)
    found: dict[int, list[np.ndarray]] = {}
    for scale in (1, 2):
        if scale == 2 and (len(found) >= grid.cols * grid.rows or max(u8.shape) > ENLARGE_MAX):
            break
        img = u8 if scale == 1 else cv2.resize(u8, None, fx=2, fy=2, interpolation=cv2.INTER_CUBIC)
        corners, ids, _ = det.detectMarkers(img)
        if ids is None:
            continue
        seen: dict[int, list[np.ndarray]] = {}
        for q, t in zip(corners, np.asarray(ids).reshape(-1).tolist()):
            # pixel centres at integers: x_1 = (x_2 + 1/2) / 2 - 1/2
            seen.setdefault(int(t), []).append((np.asarray(q, np.float64).reshape(4, 2) + 0.5) / scale - 0.5)
        for t, qs in seen.items():
            found.setdefault(t, qs)
    ids = np.array(sorted(t for t, qs in found.items() if len(qs) == 1 and t < grid.cols * grid.rows),
                   dtype=np.int64)
    quads = np.array([found[t][0] for t in ids.tolist()]).reshape(-1, 4, 2)
    return quads, ids


def _consistent(quads: np.ndarray, ids: np.ndarray, grid: AprilGrid) -> np.ndarray:
    """Which tags agree with their neighbours on the grid, or with all the tags (module doc), (N,) bool."""
    n = len(ids)
    if n < 2:
        return np.ones(n, bool)
    board = grid.labels().astype(np.float64)[grid.tag_points(ids)]  # (N, 4, 2)
    side = np.array([min(np.hypot(*(q[1] - q[0])), np.hypot(*(q[3] - q[0]))) for q in quads])
    col, row = ids % grid.cols, ids // grid.cols

    def agree(H: np.ndarray | None, a: int) -> bool:
        if H is None:
            return False
        pred = cv2.perspectiveTransform(board[a].reshape(-1, 1, 2), H).reshape(4, 2)
        return int(np.sum(np.hypot(*(pred - quads[a]).T) < 0.25 * side[a])) >= 3

    keep = np.zeros(n, bool)
    alone = np.zeros(n, bool)
    for a in range(n):
        near = np.flatnonzero((np.abs(col - col[a]) <= 1) & (np.abs(row - row[a]) <= 1) & (np.arange(n) != a))
        if not len(near):
            alone[a] = True
            continue
        src, dst = board[near].reshape(-1, 2), quads[near].reshape(-1, 2)
        H, _ = cv2.findHomography(src, dst, cv2.LMEDS if len(near) > 1 else 0)
        keep[a] = agree(H, a)
    if np.any(alone):
        src, dst = board.reshape(-1, 2), quads.reshape(-1, 2)
        H, _ = cv2.findHomography(src, dst, cv2.RANSAC, float(0.5 * np.median(side)))
        for a in np.flatnonzero(alone):
            keep[a] = agree(H, a)
    return keep


def _off_grid(xy: np.ndarray, labels: np.ndarray, tag: np.ndarray, side: np.ndarray, grid: AprilGrid,
              valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which refined corners lie off their neighbourhood's homography (module doc), (N,) bool, and where the
    homography puts each corner, (N, 2) (NaN where it cannot).

    For each corner, the homography of the labels to the image points of the ``valid`` corners of its tag
    and of the tags next to it (8-neighbours), itself left out, fitted by least median of squares; the
    corner is off when it lies more than ``max(1, 0.05 L)`` px from the homography's prediction (``L`` its
    tag's side in px), far beyond a lens's bending over three tags and far within the reach of a corner
    taken for another. A corner with fewer than 6 valid others around it is kept as it is.
    """
    col, row = tag % grid.cols, tag // grid.cols
    lab = labels.astype(np.float64)
    off = np.zeros(len(xy), bool)
    pred = np.full((len(xy), 2), np.nan)
    for i in range(len(xy)):
        near = np.flatnonzero((np.abs(col - col[i]) <= 1) & (np.abs(row - row[i]) <= 1) & valid)
        near = near[near != i]
        if len(near) < 6:
            continue
        H, _ = cv2.findHomography(lab[near], xy[near], cv2.LMEDS)
        if H is None:
            continue
        pred[i] = cv2.perspectiveTransform(lab[i].reshape(1, 1, 2), H).reshape(2)
        off[i] = not np.hypot(*(pred[i] - xy[i])) <= max(1.0, 0.05 * side[i])
    return off, pred


def detect_aprilgrid(image: np.ndarray, grid: AprilGrid, *, refine: bool = True, min_corners: int = 4,
                     value_range: tuple[float, float] | None = None) -> Board | None:
    """Detect an AprilGrid: OpenCV's tags and IDs, each tag's corners labelled as Kalibr numbers them and
    re-measured by sogdd (module doc).

    Parameters
    ----------
    image : ndarray
        Grey or colour image (RGB), any dtype the corner detector takes, on its
        scale (:func:`sogdd.image.to_gray255`); another range needs ``value_range``.
    grid : AprilGrid
        The target (:meth:`sogdd.calib.targets.spec.BoardSpec.aprilgrid`).
    refine : bool
        Re-measure the corners by point symmetry (window of ``0.7 min(0.2, g)``
        of the tag's side, module doc); else OpenCV's positions. A corner whose
        re-measurement fails is dropped.
    min_corners : int
        Fewer corners than this give None.
    value_range : (lo, hi) or None
        The image's range, mapped to 0-255; None: the dtype's.

    Returns
    -------
    Board or None
        ``labels`` on the lattice of :attr:`AprilGrid.unit` (object points
        ``label x unit``), ``ids`` Kalibr's point numbers, sorted by them;
        ``size`` Kalibr's grid ``(2 cols, 2 rows)`` when every corner was found
        (else None); ``source`` ``"aprilgrid"``.

    Examples
    --------
    >>> d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    >>> img = np.full((140, 140), 255, np.uint8)   # one tag, 10 px a bit, as Kalibr prints it
    >>> img[20:120, 20:120] = np.kron(np.rot90(cv2.aruco.generateImageMarker(d, 0, 10, borderBits=2), 2),
    ...                               np.ones((10, 10), np.uint8))
    >>> for y, x in ((0, 0), (0, 120), (120, 0), (120, 120)):  # the four squares at its corners
    ...     img[y:y + 20, x:x + 20] = 0
    >>> b = detect_aprilgrid(cv2.GaussianBlur(img, (0, 0), 1.0), AprilGrid(1, 1, 1.0, 0.2))
    >>> b.ids.tolist(), b.labels.tolist(), b.size
    ([0, 1, 2, 3], [[0, 5], [5, 5], [0, 0], [5, 0]], (2, 2))
    >>> np.round(b.image_points, 2).tolist()  # the tag's edges at pixel edges 19.5 and 119.5
    [[19.5, 119.5], [119.5, 119.5], [19.5, 19.5], [119.5, 19.5]]
    """
    if not isinstance(grid, AprilGrid):
        raise TypeError(f"grid must be an AprilGrid, got {type(grid).__name__}")
    if not isinstance(min_corners, (int, np.integer)) or isinstance(min_corners, bool) or min_corners < 1:
        raise ValueError(f"min_corners must be a positive integer, got {min_corners!r}")
    grey = to_grey(image, value_range)
    u8 = np.clip(np.rint(grey), 0, 255).astype(np.uint8)
    quads, ids = find_tags(u8, grid)
    keep = _consistent(quads, ids, grid)
    quads, ids = quads[keep], ids[keep]
    if 4 * len(ids) < min_corners:
        return None
    points = grid.tag_points(ids).reshape(-1)
    xy = quads.reshape(-1, 2).copy()
    quality = np.ones(len(xy))
    if refine and len(xy):
        # the shorter of the tag's two edges at each corner (corner m's edges go to m - 1 and m + 1)
        edge = np.hypot(*(quads - np.roll(quads, 1, axis=1)).transpose(2, 0, 1))  # edge m: m-1 -> m
        side = np.minimum(edge, np.roll(edge, -1, axis=1)).reshape(-1)
        reach = min(2.0 / (6 + 2 * BORDER_BITS), float(grid.spacing))
        half = np.maximum(2, np.rint(WINDOW * reach * side)).astype(np.int64)
        xy, quality = refine_grey(grey, xy, half, half.astype(np.float64))
        lab, tag = grid.labels()[points], np.repeat(ids, 4)
        off, pred = _off_grid(xy, lab, tag, side, grid, quality > 0)
        ok = (quality > 0) & ~off
        # a corner that failed or went astray from OpenCV's start, once more from where the others put it
        again = np.flatnonzero(~ok & np.isfinite(pred[:, 0]))
        if len(again):
            xy2, q2 = refine_grey(grey, pred[again], half[again], half[again].astype(np.float64))
            tol = np.maximum(1.0, 0.05 * side[again])
            good = (q2 > 0) & (np.hypot(*(xy2 - pred[again]).T) <= tol)
            xy[again[good]], quality[again[good]], ok[again[good]] = xy2[good], q2[good], True
        xy, points, quality = xy[ok], points[ok], quality[ok]
        if len(points) < min_corners:
            return None
    order = np.argsort(points, kind="stable")
    n_all = 4 * grid.cols * grid.rows
    size = (2 * grid.cols, 2 * grid.rows) if len(points) == n_all else None
    return Board(xy[order], grid.labels()[points[order]], quality[order], size=size, ids=points[order],
                 source="aprilgrid")
