"""Real calibration photo sets on disk: their boards, images, hand labels and reference cameras.

A **set** is a folder of images (``*.jpg``, ``*.png``, ``*.bmp``, ``*.tif``);
a folder with no images of its own whose sub-folders hold them is a rig, and
each sub-folder (one camera) is a set of its own, named ``rig/camera``.

A folder of images with two or more name prefixes is as many cameras in one
folder (OpenCV's stereo sample: ``left01.jpg .. left14.jpg``,
``right01.jpg .. right14.jpg``): when **every** image's name is
``<prefix><number>.<ext>`` and there are two or more prefixes, each holding at
least 3 images, each prefix is a set of its own, named like a rig's camera,
``folder/prefix`` (the prefix less trailing ``-``, ``_``, ``.``:
``opencv_stereo/left``, ``opencv_stereo/right``); its board and reference are
read from the shared folder. Otherwise the folder is one set (``left-0000.png``,
``left-0003.png``, ...: one prefix, one set).

Board description
-----------------
Read from the set's folder; failing that, for a rig's camera, from the rig's
folder or another camera's (a rig's cameras see one board), and for a set of
its own from a sibling set of the same family (``chessboard_border`` and
``chessboard_hard`` have no file; ``chessboard_sony``'s ``info.txt`` describes
the board of all three, the data's README says). The file is one of:

- ``calibration_target.yaml``, BoofCV's ``ConfigCalibrationTarget``. Its
  ``grid`` (``numRows``, ``numCols``, ``shapeSize``) and ECoCheck
  ``markerShapes`` (``numRows``, ``numCols``, ``squareSize``) count
  **squares**; a chessboard of ``R x C`` squares (``numRows = R``) has
  ``(C - 1) x (R - 1)`` inner corners, given here in OpenCV's ``patternSize``
  order ``(cols, rows)`` = ``(C - 1, R - 1)``. ``type`` missing means a
  chessboard (BoofCV's default). ``numRows`` counts the board's own rows, which
  need not be the image's: the fisheye board (7 x 5 squares) is seen 4 corners
  across and 6 down, the rig's ECoCheck board (14 x 10 squares) turned a quarter,
  13 across and 9 down. Every method compared accepts a board either way round.
- ``info.txt``, ValidationBoof's older form ``chess <left handed> <cols>
  <rows> <square>``, counting the **black squares** along each side of a board
  whose four corner squares are black: ``(2 cols - 1) x (2 rows - 1)`` squares,
  ``(2 cols - 2, 2 rows - 2)`` inner corners (``chess true 4 3 33``: 6 x 4).
  ``square ...`` describes a grid of separate squares.
- an OpenCV FileStorage calibration (any ``*.yml`` / ``*.yaml`` of the folder,
  in name order, that ``cv2.FileStorage`` reads and that holds ``board_width``
  and ``board_height``): OpenCV's calibration samples write the board's
  **inner corners** there, ``patternSize = (board_width, board_height)``, and
  its ``square_size``; the board is taken to be a chessboard (the file does not
  say).

When no file describes the board (the folder's, a rig's or a sibling's), it is
**inferred** from the set's own views (:func:`infer_target`): the chessboard
size that ``sogdd.calib.detect_boards(image, None)`` returns as a complete,
unambiguous grid in the most views, if it is seen in at least 3 views and in
twice as many as every other size together (a clear majority); the views are
read in order and reading stops as soon as that holds. Its ``source`` says
``inferred from N of M views`` and its square is 1 (the unit does not change
the intrinsics). Every method compared, OpenCV's detectors included, is then
given that pattern: OpenCV's comparators are as good as the inferred size.

Hand labels
-----------
``<image>.txt`` beside an image (ValidationBoof): a comment line, then ``x y``
per line. For a chessboard they list the corners square by square of every
other row of black squares, but neither the squares' order nor where each
square's corners start is the same from row to row, so a corner's lattice
label is found from the points' layout instead (:func:`hand_lattice`).

Reference cameras
-----------------
BoofCV's ``intrinsic.xml`` (pinhole ``fx, fy, cx, cy``, two radial terms:
comparable with OpenCV's pinhole; ``leftHanded`` true means its image ``y``
axis points up, so OpenCV's ``cy`` is ``height - 1 - cy``: with it the
calibrations of ``chessboard_sony`` land within 4 px of it, without it
10-14 px away) and ``fisheye.yaml`` (the universal
omnidirectional model of Mei and Rives: a unit sphere projected from a point
``xi`` = ``mirror_offset`` behind its centre). The latter's ``fx`` is not
OpenCV's fisheye ``fx``: near the image centre a ray at angle ``theta`` lands
``fx theta / (1 + xi)`` from the principal point in the omnidirectional model
and ``fx theta`` in OpenCV's fisheye model, so the comparable focal lengths are
``fx / (1 + xi)`` and ``fy / (1 + xi)``; ``cx, cy`` compare directly.

Failing those, a ``*.yml`` / ``*.yaml`` of the folder that ``cv2.FileStorage``
reads: an OpenCV calibration's ``camera_matrix`` (OpenCV's calibration sample),
a ROS ``camera_info`` YAML's ``camera_matrix: data: [...]`` (ROS's
``camera_calibration``, OpenCV's pixel convention; ``distortion_model:
equidistant`` is OpenCV's fisheye model, anything else a pinhole), or a stereo
calibration's ``M1`` / ``M2`` (OpenCV's stereo sample). Each is the source's own
calibration of its camera, a reference, not ground truth: ``fx, fy, cx, cy``
(``K[0, 0], K[1, 1], K[0, 2], K[1, 2]``) compare directly. For one camera of a
folder of several (set discovery above) the camera's own single-camera file,
one whose name starts with the camera's name (``left_intrinsics.yml``), is
preferred, as a fit of that camera alone, like the ones compared with it;
failing that, ``M<k>`` of a stereo file, camera ``k`` being the ``k``-th name
prefix in name order (``left`` before ``right``, ``cam0`` before ``cam1``, as
OpenCV's stereo sample lists each pair's left image first), which the stereo
fit shares with the other camera (OpenCV's sample fixes one focal length for
both). A file named for another of the folder's cameras, or a ``camera_matrix``
file named for none of them, is not used for a camera of such a folder, and a
set of its own does not read ``M1`` / ``M2`` (which camera is it?).
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

__all__ = ["PhotoTarget", "PhotoSet", "parse_target_yaml", "parse_info_txt", "read_target", "photo_sets",
           "hand_lattice", "read_labels", "read_reference", "read_storage", "infer_target", "camera_prefixes",
           "IMAGE_SUFFIXES"]

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff")
TargetKind = Literal["chessboard", "ecocheck", "square_grid", "other"]
CameraModelName = Literal["pinhole", "fisheye"]


@dataclass(frozen=True)
class PhotoTarget:
    """A set's board: its kind, inner corners ``(cols, rows)`` (OpenCV's ``patternSize``), square size.

    ``chessboard_like``: its inner corners are chessboard X-corners (a chessboard,
    or an ECoCheck board, whose codes sit inside the white squares). ``inferred``:
    no file describes it, its size was found in the set's views (:func:`infer_target`),
    and ``source`` says how.
    """

    kind: TargetKind
    pattern: tuple[int, int]
    square: float
    source: str
    inferred: bool = False

    @property
    def chessboard_like(self) -> bool:
        return self.kind in ("chessboard", "ecocheck")

    @property
    def n_corners(self) -> int:
        return self.pattern[0] * self.pattern[1]


_TYPES: dict[str, TargetKind] = {"CHESSBOARD": "chessboard", "ECOCHECK": "ecocheck",
                                 "SQUARE_GRID": "square_grid"}


def _block(lines: list[str], key: str) -> list[str]:
    """The lines indented under the first ``key:`` line (empty when absent)."""
    for k, line in enumerate(lines):
        if line.strip() == f"{key}:":
            indent = len(line) - len(line.lstrip())
            out = []
            for nxt in lines[k + 1:]:
                ind = len(nxt) - len(nxt.lstrip())
                # YAML lets a list's "- " items sit at their key's own indent
                if nxt.strip() and (ind < indent or (ind == indent and not nxt.lstrip().startswith("-"))):
                    break
                out.append(nxt)
            return out
    return []


def _value(block: list[str], key: str) -> str | None:
    for line in block:
        m = re.match(rf"\s*-?\s*{key}:\s*(\S+)", line)
        if m:
            return m.group(1)
    return None


def _squares_to_pattern(rows: str | None, cols: str | None, what: str) -> tuple[int, int]:
    if rows is None or cols is None:
        raise ValueError(f"{what}: numRows or numCols missing")
    r, c = int(rows), int(cols)
    if r < 2 or c < 2:
        raise ValueError(f"{what}: {r} x {c} squares has no inner corners")
    return (c - 1, r - 1)


def parse_target_yaml(text: str, source: str = "calibration_target.yaml") -> PhotoTarget:
    """A board from BoofCV's ``calibration_target.yaml`` (module doc): squares become inner corners.

    Examples
    --------
    >>> yaml = "ConfigCalibrationTarget:\\n  grid:\\n    numRows: 7\\n    shapeSize: 1.0\\n    numCols: 5\\n"
    >>> parse_target_yaml(yaml).pattern  # 7 rows and 5 columns of squares: 4 x 6 inner corners
    (4, 6)
    >>> eco = "c:\\n  ecocheck:\\n    markerShapes:\\n    - numRows: 14\\n      squareSize: 30\\n"
    >>> t = parse_target_yaml(eco + "      numCols: 10\\n  type: ECOCHECK\\n")
    >>> t.kind, t.pattern, t.square
    ('ecocheck', (9, 13), 30.0)
    """
    lines = [ln for ln in text.splitlines() if not ln.lstrip().startswith("#")]
    typ = _value(lines, "type")
    kind = _TYPES.get(typ or "CHESSBOARD", "other")
    if kind == "ecocheck":
        block = _block(_block(lines, "ecocheck"), "markerShapes")
        if sum(1 for ln in block if ln.lstrip().startswith("-")) > 1:
            raise ValueError(f"{source}: several ECoCheck marker shapes; one board per set is read")
        size = _value(block, "squareSize")
    else:
        block = _block(lines, "grid")
        size = _value(block, "shapeSize")
    if not block:
        raise ValueError(f"{source}: no grid or ECoCheck marker shape found")
    pattern = _squares_to_pattern(_value(block, "numRows"), _value(block, "numCols"), source)
    if kind == "square_grid":  # separate squares: 4 corners each, no X-corners
        pattern = (2 * (pattern[0] + 1), 2 * (pattern[1] + 1))
    return PhotoTarget(kind, pattern, float(size) if size else 1.0, source)


def parse_info_txt(text: str, source: str = "info.txt") -> PhotoTarget:
    """A board from ValidationBoof's ``info.txt`` (module doc): black squares per side become inner corners.

    Examples
    --------
    >>> t = parse_info_txt("# (type) (left handed) (num columns) (num rows) (square width)\\nchess true 4 3 33")
    >>> t.kind, t.pattern, t.square
    ('chessboard', (6, 4), 33.0)
    >>> parse_info_txt("square true 4 3 30 30").pattern  # 12 separate squares, 4 corners each
    (8, 6)
    """
    for line in text.splitlines():
        parts = line.split()
        if not parts or line.lstrip().startswith("#"):
            continue
        if len(parts) < 5:
            raise ValueError(f"{source}: expected '<type> <left handed> <cols> <rows> <square>', got {line!r}")
        cols, rows, square = int(parts[2]), int(parts[3]), float(parts[4])
        if parts[0] == "chess":
            return PhotoTarget("chessboard", (2 * cols - 2, 2 * rows - 2), square, source)
        if parts[0] == "square":
            return PhotoTarget("square_grid", (2 * cols, 2 * rows), square, source)
        return PhotoTarget("other", (cols, rows), square, source)
    raise ValueError(f"{source}: no board line")


_STORAGE_SUFFIXES = (".yml", ".yaml")


def _storage_value(node: cv2.FileNode) -> float | str | np.ndarray | None:
    """A FileStorage node as a number, a string or a matrix (``opencv-matrix``, or ROS's ``rows/cols/data``)."""
    if node.isInt() or node.isReal():
        return float(node.real())
    if node.isString():
        return node.string()
    if not node.isMap() or "data" not in node.keys():
        return None
    data = node.getNode("data")
    if not data.isSeq():
        return None
    vals = np.array([data.at(k).real() for k in range(data.size())], dtype=np.float64)
    rows, cols = node.getNode("rows"), node.getNode("cols")
    if rows.isInt() and cols.isInt() and int(rows.real()) * int(cols.real()) == len(vals):
        return vals.reshape(int(rows.real()), int(cols.real()))
    return vals


def read_storage(path: str | Path) -> dict | None:
    """The top-level numbers, strings and matrices of a file ``cv2.FileStorage`` reads; None if it cannot.

    A matrix is an ``!!opencv-matrix`` (OpenCV's calibration samples) or a map
    with ``rows``, ``cols`` and ``data`` (ROS's ``camera_info`` YAML), as an
    array; other entries (lists, nested maps) are left out. A file that is not
    OpenCV's YAML (BoofCV's, a parse error) is None, not an error.

    Examples
    --------
    >>> import tempfile
    >>> f = Path(tempfile.mkdtemp()) / "ost.yaml"
    >>> _ = f.write_text("image_width: 640\\ncamera_matrix:\\n  rows: 3\\n  cols: 3\\n"
    ...                  "  data: [500, 0, 320, 0, 501, 240, 0, 0, 1]\\ndistortion_model: plumb_bob\\n")
    >>> st = read_storage(f)
    >>> st["image_width"], st["camera_matrix"][1].tolist(), st["distortion_model"]
    (640.0, [0.0, 501.0, 240.0], 'plumb_bob')
    """
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # OpenCV's parse errors surface as either
        return None
    try:
        if not fs.isOpened():
            return None
        root = fs.root()
        if not root.isMap():
            return None
        out = {}
        for key in root.keys():
            v = _storage_value(root.getNode(key))
            if v is not None:
                out[key] = v
        return out
    except (cv2.error, SystemError):
        return None
    finally:
        fs.release()


def _storage_files(folder: Path) -> list[Path]:
    """The folder's ``*.yml`` / ``*.yaml`` files in name order (BoofCV's own files are read elsewhere)."""
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in _STORAGE_SUFFIXES
                  and p.name not in ("calibration_target.yaml", "fisheye.yaml"))


def _storage_target(st: dict, source: str) -> PhotoTarget:
    """A chessboard from an OpenCV calibration: ``board_width, board_height`` inner corners, ``square_size``."""
    w, h = st["board_width"], st["board_height"]
    if not all(isinstance(v, float) and v.is_integer() and v >= 2 for v in (w, h)):
        raise ValueError(f"{source}: board_width and board_height must be whole numbers >= 2, got {w!r}, {h!r}")
    square = st.get("square_size")
    square = float(square) if isinstance(square, float) and square > 0 else 1.0
    return PhotoTarget("chessboard", (int(w), int(h)), square, source)


def _target_in(folder: Path) -> PhotoTarget | None:
    y, i = folder / "calibration_target.yaml", folder / "info.txt"
    if y.is_file():
        return parse_target_yaml(y.read_text(), str(y))
    if i.is_file():
        return parse_info_txt(i.read_text(), str(i))
    for f in _storage_files(folder):
        st = read_storage(f)
        if st is not None and "board_width" in st and "board_height" in st:
            return _storage_target(st, str(f))
    return None


def _family(name: str) -> str:
    return name.split("_", 1)[0]


def read_target(folder: Path, *, rig: bool = False) -> PhotoTarget | None:
    """The board of the set in ``folder``: its own file, else a sibling's (module doc); None if none.

    ``rig``: ``folder`` is one camera of a rig, whose folder and other cameras
    are looked in next; otherwise sibling sets of the same family (the name up
    to its first ``_``: ``chessboard_border`` borrows ``chessboard_sony``'s).
    """
    own = _target_in(folder)
    if own is not None:
        return own
    if rig:
        up = _target_in(folder.parent)
        if up is not None:
            return up
    sibs = sorted(p for p in folder.parent.iterdir() if p.is_dir() and p != folder)
    for sib in sibs:
        if rig or _family(sib.name) == _family(folder.name):
            t = _target_in(sib)
            if t is not None:
                return t
    return None


def _view_size(boards: Sequence) -> tuple[int, int] | None:
    """The ``(cols, rows)`` of a view's largest board when it is one complete, unambiguous grid, else None.

    Unambiguous: every other board of the view with as many corners is a complete
    grid of the same size, either way round (a second copy of the board, on a monitor).
    """
    from sogdd.calib.targets.board import grid_dims

    if not boards:
        return None
    first = max(boards, key=len)
    dims = grid_dims(first)
    if dims is None:
        return None
    for b in boards:
        if b is not first and len(b) >= len(first):
            other = grid_dims(b)
            if other is None or sorted(other) != sorted(dims):
                return None
    return dims


def infer_target(images: Sequence[str | Path | np.ndarray], *, min_views: int = 3) -> PhotoTarget | None:
    """The chessboard size seen in a clear majority of views, when no file describes the board (module doc).

    Each view votes for the ``(cols, rows)`` of the one complete, unambiguous
    grid that ``sogdd.calib.detect_boards(image, None)`` finds there (its largest
    board, whose labels fill a whole rectangle, with no other board as large of
    another size), counted either way round. The views are read in order until
    one size has at least ``min_views`` votes and twice as many as every other
    size together; that size, in the orientation it was seen in most, is the
    board (a chessboard of unit squares). None when no size gets there.

    Parameters
    ----------
    images : sequence of path or ndarray
        The views: image files (read grey; an unreadable file does not vote) or images.
    min_views : int
        Fewest views that must agree (at least 1).

    Returns
    -------
    PhotoTarget or None
        ``inferred`` True; ``source`` says ``inferred from N of M views`` (M: views read).

    Examples
    --------
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200.0 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230.0), (0, 0), 1.0).astype(np.uint8)
    >>> t = infer_target([img, img.T.copy(), img, np.zeros((60, 60), np.uint8), img])  # 7 x 5 inner corners
    >>> t.pattern, t.inferred, t.source.split(" (")[0]
    ((7, 5), True, 'inferred from 3 of 3 views')
    >>> infer_target([img, img]) is None  # 2 views: too few
    True
    """
    from sogdd.calib import detect_boards

    if not isinstance(min_views, int) or isinstance(min_views, bool) or min_views < 1:
        raise ValueError(f"min_views must be an integer >= 1, got {min_views!r}")
    votes: Counter = Counter()
    seen: dict[tuple[int, int], Counter] = {}
    for k, image in enumerate(images, start=1):
        grey = image if isinstance(image, np.ndarray) else cv2.imread(str(image), cv2.IMREAD_GRAYSCALE)
        dims = None if grey is None else _view_size(detect_boards(grey, None))
        if dims is None:
            continue
        key = (max(dims), min(dims))
        votes[key] += 1
        seen.setdefault(key, Counter())[dims] += 1
        (lead, n), = votes.most_common(1)
        others = sum(votes.values()) - n
        if n >= min_views and n >= 2 * others:
            pattern = seen[lead].most_common(1)[0][0]
            rest = f"; {others} view{'s' if others != 1 else ''} with another size" if others else ""
            return PhotoTarget("chessboard", pattern, 1.0,
                               f"inferred from {n} of {k} views (a complete {pattern[0]} x {pattern[1]} grid "
                               f"of sogdd.calib.detect_boards{rest})", inferred=True)
    return None


_NUMBERED = re.compile(r"^(?P<prefix>.*?)(?P<number>\d+)$")
_MIN_PER_CAMERA = 3


def camera_prefixes(names: Sequence[str | Path], *, min_images: int = _MIN_PER_CAMERA) -> dict[str, str] | None:
    """The cameras of one folder of images, ``{camera: name prefix}`` in name order, or None for one camera.

    Several cameras when every name is ``<prefix><number>.<ext>`` and there are
    two or more prefixes, each with at least ``min_images`` images; a camera is
    named by its prefix less trailing ``-``, ``_``, ``.`` and spaces (module doc).

    Examples
    --------
    >>> camera_prefixes([f"{c}{k:02d}.jpg" for c in ("right", "left") for k in (1, 2, 3)])
    {'left': 'left', 'right': 'right'}
    >>> camera_prefixes(["left-0000.png", "left-0003.png", "left-0005.png"]) is None  # one prefix
    True
    >>> camera_prefixes(["l1.png", "l2.png", "l3.png", "r1.png", "r2.png", "notes.png"]) is None
    True
    """
    prefixes: Counter = Counter()
    for name in names:
        m = _NUMBERED.match(Path(name).stem)
        if m is None:
            return None
        prefixes[m.group("prefix")] += 1
    cams = {p.rstrip("-_. "): p for p in prefixes}
    if (len(prefixes) < 2 or min(prefixes.values()) < min_images or len(cams) != len(prefixes)
            or any(not c or "/" in c for c in cams)):
        return None
    return dict(sorted(cams.items()))


def _prefix_of(path: Path) -> str | None:
    m = _NUMBERED.match(path.stem)
    return None if m is None else m.group("prefix")


def _images(folder: Path) -> list[Path]:
    """Image files in natural order (``2.jpg`` before ``10.jpg``): frame N is the N-th of each camera."""
    files = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES]

    def key(p: Path):
        return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.stem)]

    return sorted(files, key=key)


def read_labels(path: Path) -> np.ndarray:
    """Hand-labelled points ``(N, 2)`` from a ValidationBoof ``<image>.txt`` (comment lines: ``#``)."""
    lines = path.read_text().splitlines()
    rows = [ln.split() for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    return np.array([[float(r[0]), float(r[1])] for r in rows], dtype=np.float64).reshape(-1, 2)


def _max_quad(hull: np.ndarray) -> np.ndarray:
    """The 4 hull vertices (in hull order) that span the largest quadrilateral: a grid's 4 outer corners."""
    best, quad = -1.0, hull[:4]
    for idx in combinations(range(len(hull)), 4):
        q = hull[list(idx)]
        area = abs(cv2.contourArea(q.astype(np.float32)))
        if area > best:
            best, quad = area, q
    return quad


def _labels_from(points: np.ndarray, quad: np.ndarray, grid: np.ndarray, pattern) -> tuple[float, np.ndarray]:
    H = cv2.getPerspectiveTransform(quad.astype(np.float32), grid.astype(np.float32))
    for _ in range(2):  # refit on every point once the outer corners have placed them
        uv = cv2.perspectiveTransform(points.reshape(-1, 1, 2), H).reshape(-1, 2)
        lab = np.rint(uv).astype(np.int64)
        H, _mask = cv2.findHomography(points, lab.astype(np.float64))
        if H is None:
            return np.inf, lab
    uv = cv2.perspectiveTransform(points.reshape(-1, 1, 2), H).reshape(-1, 2)
    lab = np.rint(uv).astype(np.int64)
    inside = np.all((lab >= 0) & (lab < np.array(pattern)), axis=1).all()
    unique = len(np.unique(lab, axis=0)) == len(lab)
    return (float(np.abs(uv - lab).max()) if inside and unique else np.inf), lab


def hand_lattice(points: np.ndarray, pattern: tuple[int, int]) -> np.ndarray | None:
    """Lattice labels of a complete board's hand-labelled corners, from their layout alone (module doc).

    The 4 outer corners (the largest quadrilateral on the points' convex hull)
    give a homography to the ``pattern`` grid, refitted on every point; the
    labels are its rounded values. None when the points are not one complete
    ``pattern`` grid (a label off its lattice place by 0.3 of a cell or more).

    Examples
    --------
    >>> g = np.array([(i, j) for j in range(4) for i in range(6)], dtype=float)
    >>> pts = g * [40.0, 38.0] + [100, 80] + 0.3 * g[:, ::-1] ** 2  # a little distortion
    >>> rng = np.random.default_rng(0)
    >>> order = rng.permutation(24)  # the file's order does not matter
    >>> lab = hand_lattice(pts[order], (6, 4))
    >>> bool(np.all(lab == g[order])), hand_lattice(pts[:20], (6, 4)) is None
    (True, True)
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    cols, rows = pattern
    if len(pts) != cols * rows or min(pattern) < 2:
        return None
    hull = cv2.convexHull(pts.astype(np.float32)).reshape(-1, 2).astype(np.float64)
    if len(hull) < 4:
        return None
    quad = _max_quad(hull)
    best = (np.inf, None)
    for shift in range(4):
        for c, r in {(cols, rows), (rows, cols)}:
            grid = np.array([(0, 0), (c - 1, 0), (c - 1, r - 1), (0, r - 1)], dtype=np.float64)
            err, lab = _labels_from(pts, np.roll(quad, shift, axis=0), grid, (c, r))
            if err < best[0]:
                best = (err, lab)
    return best[1] if best[0] < 0.3 else None


def _xml_double(text: str, name: str) -> float | None:
    m = re.search(rf'property="{name}">\s*<double>([-0-9.eE]+)</double>', text)
    return float(m.group(1)) if m else None


def _yaml_number(text: str, name: str) -> float | None:
    m = re.search(rf"^\s*{name}:\s*([-0-9.eE]+)\s*$", text, re.MULTILINE)
    return float(m.group(1)) if m else None


def _pinhole_reference(K: object, path: Path, what: str, model: CameraModelName, st: dict) -> dict | None:
    """``fx, fy, cx, cy`` of a 3 x 3 camera matrix read from ``path``, with its note; None if it is not one."""
    K = np.asarray(K, dtype=np.float64) if isinstance(K, np.ndarray) else None
    if K is None or K.size != 9:
        return None
    K = K.reshape(3, 3)
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        return None
    ref = {"fx": round(float(K[0, 0]), 4), "fy": round(float(K[1, 1]), 4), "cx": round(float(K[0, 2]), 4),
           "cy": round(float(K[1, 2]), 4), "model": model, "source": str(path),
           "note": f"{what} ({path.parent.name}/{path.name}), the source's own calibration: a reference, "
                   "not ground truth; fx, fy, cx, cy compare directly"}
    w, h = st.get("image_width"), st.get("image_height")
    if isinstance(w, float) and isinstance(h, float):
        ref["size"] = [int(w), int(h)]
    return ref


def _matrix_reference(path: Path, st: dict) -> dict | None:
    """The ``camera_matrix`` of an OpenCV calibration or a ROS ``camera_info`` file (module doc)."""
    dist = st.get("distortion_model")
    if isinstance(dist, str):  # ROS camera_info: its distortion model names the lens model
        model: CameraModelName = "fisheye" if dist == "equidistant" else "pinhole"
        return _pinhole_reference(st.get("camera_matrix"), path, f"ROS camera_info, distortion_model {dist}",
                                  model, st)
    return _pinhole_reference(st.get("camera_matrix"), path, "OpenCV calibration, camera_matrix", "pinhole", st)


def _owner(path: Path, cameras: Sequence[str]) -> str | None:
    """The camera a file is named for (the longest camera name its name starts with), or None."""
    named = [c for c in cameras if path.name.lower().startswith(c.lower())]
    return max(named, key=len) if named else None


def _storage_reference(folder: Path, camera: str | None, cameras: Sequence[str]) -> dict | None:
    """A FileStorage / ROS reference of the set, or of one ``camera`` of a folder of ``cameras``: module doc."""
    files = [(f, read_storage(f)) for f in _storage_files(folder)]
    files = [(f, st) for f, st in files if st is not None]
    if camera is None:
        return next((r for f, st in files if (r := _matrix_reference(f, st)) is not None), None)
    own = next((r for f, st in files if _owner(f, cameras) == camera
                and (r := _matrix_reference(f, st)) is not None), None)
    if own is not None:
        return own
    k = list(cameras).index(camera) + 1
    for f, st in files:
        if _owner(f, cameras) is None:
            what = f"OpenCV stereo calibration, M{k}: camera {k} of {len(cameras)} in name order, {camera}"
            ref = _pinhole_reference(st.get(f"M{k}"), f, what, "pinhole", st)
            if ref is not None:
                return ref
    return None


def read_reference(folder: Path, camera: str | None = None, cameras: Sequence[str] = ()) -> dict | None:
    """The reference camera beside a set (module doc): ``fx, fy, cx, cy`` comparable with OpenCV's, a note.

    Parameters
    ----------
    folder : Path
        The set's folder.
    camera : str or None
        For one camera of a folder of several: its name (one of ``cameras``).
    cameras : sequence of str
        Every camera of that folder, in name order (:func:`camera_prefixes`).

    Returns
    -------
    dict or None
        ``fx, fy, cx, cy, model, source, note`` (and ``size``, ``mirror_offset`` where known).

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "fisheye.yaml").write_text("pinhole:\\n  fx: 400\\n  fy: 400\\n  cx: 320\\n  cy: 360\\n"
    ...                                    "model: omnidirectional_universal\\nmirror_offset: 1.0\\n")
    >>> ref = read_reference(d)
    >>> ref["fx"], ref["cx"], ref["model"]
    (200.0, 320.0, 'fisheye')
    >>> d = Path(tempfile.mkdtemp())
    >>> m = "!!opencv-matrix\\n rows: 3\\n cols: 3\\n dt: d\\n data: [%s, 0, 320, 0, %s, 240, 0, 0, 1.]\\n"
    >>> _ = (d / "stereo.yml").write_text("%YAML:1.0\\nM1: " + m % (500, 500) + "M2: " + m % (510, 510))
    >>> read_reference(d, "right", ["left", "right"])["fx"]  # M2: the second camera in name order
    510.0
    >>> read_reference(d) is None  # a set of its own does not read M1 / M2
    True
    """
    xml, fish = folder / "intrinsic.xml", folder / "fisheye.yaml"
    if xml.is_file():
        t = xml.read_text()
        vals = {k: _xml_double(t, k) for k in ("fx", "fy", "cx", "cy")}
        note = "BoofCV pinhole with two radial terms (intrinsic.xml): fx, fy, cx compare directly"
        h = re.search(r'property="height">\s*<int>(\d+)</int>', t)
        if re.search(r'property="leftHanded">\s*<boolean>true', t) and h and vals["cy"] is not None:
            vals["cy"] = round(int(h.group(1)) - 1 - vals["cy"], 4)
            note += "; leftHanded (its y axis points up): cy given as height - 1 - cy"
        else:
            note += ", and cy"
        return {**vals, "model": "pinhole", "source": str(xml), "note": note}
    if fish.is_file():
        t = fish.read_text()
        xi = _yaml_number(t, "mirror_offset") or 0.0
        vals = {k: _yaml_number(t, k) for k in ("fx", "fy", "cx", "cy")}
        for k in ("fx", "fy"):
            vals[k] = None if vals[k] is None else round(vals[k] / (1.0 + xi), 4)
        return {**vals, "model": "fisheye", "source": str(fish), "mirror_offset": xi,
                "note": "BoofCV universal omnidirectional model: fx, fy are its fx/(1 + mirror_offset) "
                        "(the focal length at the image centre, OpenCV fisheye's fx); cx, cy compare "
                        "directly; the distortion terms do not compare"}
    return _storage_reference(folder, camera, cameras)


@dataclass(frozen=True)
class PhotoSet:
    """One camera's photos: name, folder, board, images, hand labels per image (or None), model, reference.

    ``prefix``: for one camera of a folder of several (module doc), the name
    prefix of its images in ``folder``; None for a folder of one camera.
    """

    name: str
    folder: Path
    target: PhotoTarget | None
    images: tuple[Path, ...]
    labels: tuple[np.ndarray | None, ...]
    model: CameraModelName
    reference: dict | None
    prefix: str | None = None

    @property
    def n_labelled(self) -> int:
        return sum(lab is not None for lab in self.labels)


@dataclass(frozen=True)
class _Place:
    """Where a set is: name, folder; for one camera of a folder of several, its name, prefix, and all names."""

    name: str
    folder: Path
    rig: bool = False
    camera: str | None = None
    prefix: str | None = None
    cameras: tuple[str, ...] = ()


def _make_set(place: _Place) -> PhotoSet:
    images = _images(place.folder)
    if place.prefix is not None:
        images = [p for p in images if _prefix_of(p) == place.prefix]
    labels = tuple(read_labels(p.with_suffix(".txt")) if p.with_suffix(".txt").is_file() else None
                   for p in images)
    ref = read_reference(place.folder, place.camera, place.cameras)
    fisheye = "fisheye" in place.name.lower() or (ref is not None and ref["model"] == "fisheye")
    target = read_target(place.folder, rig=place.rig)
    if target is None and images:
        target = infer_target(images)
    return PhotoSet(place.name, place.folder, target, tuple(images), labels,
                    "fisheye" if fisheye else "pinhole", ref, place.prefix)


def _has_images(folder: Path) -> bool:
    return any(p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES for p in folder.iterdir())


def _set_folders(root: Path) -> list[_Place]:
    out = []
    for d in sorted(p for p in root.iterdir() if p.is_dir()):
        if _has_images(d):
            cams = camera_prefixes([p.name for p in _images(d)])
            if cams is None:
                out.append(_Place(d.name, d))
            else:
                out += [_Place(f"{d.name}/{c}", d, camera=c, prefix=pre, cameras=tuple(cams))
                        for c, pre in cams.items()]
            continue
        cams = sorted(p for p in d.iterdir() if p.is_dir())
        out += [_Place(f"{d.name}/{c.name}", c, rig=True) for c in cams if _has_images(c)]
    return out


def _selects(name: str, wanted: str) -> bool:
    return name == wanted or name.startswith(wanted.rstrip("/") + "/")


def photo_sets(root: str | Path, names: list[str] | None = None) -> list[PhotoSet]:
    """Every set under ``root`` (module doc), or those named (a rig's name selects all its cameras).

    A set with no board file has its board inferred from its views here
    (:func:`infer_target`: a few seconds); a name selects its sets before that.
    Raises ``ValueError`` for a name that matches no set, or a board file that cannot be read.
    """
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"{root} is not a folder")
    found = _set_folders(root)
    if names is not None:
        bad = [n for n in names if not any(_selects(f.name, n) for f in found)]
        if bad:
            known = ", ".join(f.name for f in found)
            raise ValueError(f"unknown photo set(s) {', '.join(bad)}; known: {known}")
        found = [f for f in found if any(_selects(f.name, n) for n in names)]
    return [_make_set(f) for f in found]
