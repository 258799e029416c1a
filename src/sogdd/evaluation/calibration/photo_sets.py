"""Real calibration photo sets on disk: their boards, images, hand labels and reference cameras.

A **set** is a folder of images (``*.jpg``, ``*.png``, ``*.bmp``, ``*.tif``);
a folder with no images of its own whose sub-folders hold them is a rig, and
each sub-folder (one camera) is a set of its own, named ``rig/camera``.

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
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

__all__ = ["PhotoTarget", "PhotoSet", "parse_target_yaml", "parse_info_txt", "read_target", "photo_sets",
           "hand_lattice", "read_labels", "read_reference", "IMAGE_SUFFIXES"]

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff")
TargetKind = Literal["chessboard", "ecocheck", "square_grid", "other"]
CameraModelName = Literal["pinhole", "fisheye"]


@dataclass(frozen=True)
class PhotoTarget:
    """A set's board: its kind, inner corners ``(cols, rows)`` (OpenCV's ``patternSize``), square size.

    ``chessboard_like``: its inner corners are chessboard X-corners (a chessboard,
    or an ECoCheck board, whose codes sit inside the white squares).
    """

    kind: TargetKind
    pattern: tuple[int, int]
    square: float
    source: str

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


def _target_in(folder: Path) -> PhotoTarget | None:
    y, i = folder / "calibration_target.yaml", folder / "info.txt"
    if y.is_file():
        return parse_target_yaml(y.read_text(), str(y))
    if i.is_file():
        return parse_info_txt(i.read_text(), str(i))
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


def read_reference(folder: Path) -> dict | None:
    """The reference camera beside a set (module doc): ``fx, fy, cx, cy`` comparable with OpenCV's, a note.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "fisheye.yaml").write_text("pinhole:\\n  fx: 400\\n  fy: 400\\n  cx: 320\\n  cy: 360\\n"
    ...                                    "model: omnidirectional_universal\\nmirror_offset: 1.0\\n")
    >>> ref = read_reference(d)
    >>> ref["fx"], ref["cx"], ref["model"]
    (200.0, 320.0, 'fisheye')
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
    return None


@dataclass(frozen=True)
class PhotoSet:
    """One camera's photos: name, folder, board, images, hand labels per image (or None), model, reference."""

    name: str
    folder: Path
    target: PhotoTarget | None
    images: tuple[Path, ...]
    labels: tuple[np.ndarray | None, ...]
    model: CameraModelName
    reference: dict | None

    @property
    def n_labelled(self) -> int:
        return sum(lab is not None for lab in self.labels)


def _make_set(name: str, folder: Path) -> PhotoSet:
    images = _images(folder)
    labels = tuple(read_labels(p.with_suffix(".txt")) if p.with_suffix(".txt").is_file() else None
                   for p in images)
    ref = read_reference(folder)
    fisheye = "fisheye" in name.lower() or (ref is not None and ref["model"] == "fisheye")
    return PhotoSet(name, folder, read_target(folder, rig="/" in name), tuple(images), labels,
                    "fisheye" if fisheye else "pinhole", ref)


def _has_images(folder: Path) -> bool:
    return any(p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES for p in folder.iterdir())


def _set_folders(root: Path) -> list[tuple[str, Path]]:
    out = []
    for d in sorted(p for p in root.iterdir() if p.is_dir()):
        if _has_images(d):
            out.append((d.name, d))
            continue
        cams = sorted(p for p in d.iterdir() if p.is_dir())
        out += [(f"{d.name}/{c.name}", c) for c in cams if _has_images(c)]
    return out


def _selects(name: str, wanted: str) -> bool:
    return name == wanted or name.startswith(wanted.rstrip("/") + "/")


def photo_sets(root: str | Path, names: list[str] | None = None) -> list[PhotoSet]:
    """Every set under ``root`` (module doc), or those named (a rig's name selects all its cameras).

    Raises ``ValueError`` for a name that matches no set, or a board file that cannot be read.
    """
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"{root} is not a folder")
    found = _set_folders(root)
    if names is not None:
        bad = [n for n in names if not any(_selects(s, n) for s, _ in found)]
        if bad:
            raise ValueError(f"unknown photo set(s) {', '.join(bad)}; known: {', '.join(s for s, _ in found)}")
        found = [(s, f) for s, f in found if any(_selects(s, n) for n in names)]
    return [_make_set(s, f) for s, f in found]
