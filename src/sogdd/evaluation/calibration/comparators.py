"""The detectors compared on calibration targets, each behind one call: image, pattern -> corners (+ labels).

=================  ======  =====================================================================
name               kind    what runs
=================  ======  =====================================================================
sogdd              board   ``sogdd.calib.detect_board`` (its own refinement), partial boards too
opencv-refine      board   ``cv2.findChessboardCorners`` + ``sogdd.calib.refine_corners`` (the
                           drop-in for ``cv2.cornerSubPix``, its window from the local cell)
hr-grid            board   ``cv2.findChessboardCorners`` orders the grid; each point snapped to
                           the nearest ``hr`` corner (``sogdd.detect_corners(preset="hr")``)
opencv             board   ``cv2.findChessboardCorners`` + ``cv2.cornerSubPix`` 11 x 11
opencv-sb          board   ``cv2.findChessboardCornersSB`` (EXHAUSTIVE | ACCURACY)
calib-targets      board   ``calib_targets.detect_chessboard`` (PyPI ``calib-targets``)
mrgingham          board   the ``mrgingham`` command (Debian package), square boards only
chess-corners      points  ``chess_corners.Detector`` with its Radon preset (PyPI ``chess-corners``)
hr                 points  ``sogdd.detect_corners(preset="hr")``
=================  ======  =====================================================================

A *board* method returns labelled corners (a partial board's labels may be
relative); a *points* method returns points only (scored for position, not for
boards or calibration). A method whose package or command is missing is
skipped with a note (:func:`available`). The comparators are evaluation
dependencies only: ``pip install calib-targets chess-corners`` and
``apt-get install mrgingham``.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from ...calib import detect_board, refine_corners

__all__ = ["Detection", "Method", "METHODS", "available", "method_names", "opencv_classic"]


@dataclass(frozen=True)
class Detection:
    """One method's result on one image: points (N, 2) x, y and labels (N, 2) int or None (points only)."""

    points: np.ndarray
    labels: np.ndarray | None

    @property
    def found(self) -> bool:
        return self.labels is not None and len(self.points) > 0


_NONE = Detection(np.zeros((0, 2)), None)


def _grid_labels(n: int, cols: int) -> np.ndarray:
    k = np.arange(n)
    return np.stack([k % cols, k // cols], axis=1).astype(np.int64)


def _board(points, pattern) -> Detection:
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return Detection(pts, _grid_labels(len(pts), pattern[0]))


def opencv_classic(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    """OpenCV's classic detector (adaptive threshold, normalised image) and ``cornerSubPix`` 11 x 11."""
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    ok, pts = cv2.findChessboardCorners(image, pattern, flags=flags)
    if not ok:
        return _NONE
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    pts = cv2.cornerSubPix(image, pts, (5, 5), (-1, -1), crit)  # an 11 x 11 window
    return _board(pts, pattern)


def _opencv_refine(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    ok, pts = cv2.findChessboardCorners(image, pattern,
                                        flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not ok:
        return _NONE
    # float64 in, float64 out: OpenCV's float32 corners would come back rounded to float32
    return _board(refine_corners(image, pts.reshape(-1, 2).astype(np.float64)), pattern)


def _opencv_sb(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    ok, pts = cv2.findChessboardCornersSB(image, pattern, flags=cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY)
    return _board(pts, pattern) if ok else _NONE


def _hr_points(image: np.ndarray) -> np.ndarray:
    import sogdd

    return np.asarray(sogdd.detect_corners(image, preset="hr").xy, dtype=np.float64).reshape(-1, 2)


def _hr(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    return Detection(_hr_points(image), None)


def _hr_grid(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    """OpenCV's grid, each corner replaced by the nearest hr corner within 0.3 of the local spacing."""
    from scipy.spatial import cKDTree

    ok, grid = cv2.findChessboardCorners(image, pattern,
                                         flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not ok:
        return _NONE
    grid = grid.reshape(-1, 2).astype(np.float64)
    hr = _hr_points(image)
    if len(hr) == 0:
        return _NONE
    labels = _grid_labels(len(grid), pattern[0])
    spacing = np.median(np.linalg.norm(np.diff(grid.reshape(pattern[1], pattern[0], 2), axis=1), axis=2))
    dist, idx = cKDTree(hr).query(grid)
    keep = dist < 0.3 * spacing
    return Detection(hr[idx[keep]], labels[keep])


def _calib_targets(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    import calib_targets

    res = calib_targets.detect_chessboard(np.ascontiguousarray(image))
    if res is None or not res.corners:
        return _NONE
    pts = np.array([c.position for c in res.corners], dtype=np.float64).reshape(-1, 2)
    lab = np.array([[c.grid.u, c.grid.v] for c in res.corners], dtype=np.int64).reshape(-1, 2)
    return Detection(pts, lab)


_CHESS = None


def _chess_corners(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    global _CHESS
    import chess_corners

    if _CHESS is None:
        _CHESS = chess_corners.Detector(chess_corners.DetectorConfig.radon())
    det = _CHESS.detect(np.ascontiguousarray(image))
    return Detection(np.asarray(det.xy, dtype=np.float64).reshape(-1, 2), None)


def _mrgingham(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    if pattern[0] != pattern[1]:
        return _NONE
    with tempfile.TemporaryDirectory(prefix="sogdd-mrg-") as tmp:
        path = os.path.join(tmp, "view.png")
        if not cv2.imwrite(path, image):
            raise OSError(f"could not write {path}")
        out = subprocess.run(["mrgingham", "--gridn", str(pattern[0]), path], capture_output=True, text=True,
                             timeout=600, check=False)
    rows = [ln.split() for ln in out.stdout.splitlines() if ln and not ln.startswith("#")]
    pts = [(float(r[1]), float(r[2])) for r in rows if len(r) >= 3 and r[1] != "-"]
    if len(pts) != pattern[0] * pattern[1]:
        return _NONE
    return _board(pts, pattern)


def _sogdd(image: np.ndarray, pattern: tuple[int, int]) -> Detection:
    board = detect_board(image, pattern)
    if board is None:
        return _NONE
    return Detection(np.asarray(board.image_points, dtype=np.float64), np.asarray(board.labels, dtype=np.int64))


@dataclass(frozen=True)
class Method:
    """A compared method: its name, kind ("board" or "points"), what it needs, and its call."""

    name: str
    kind: str
    detect: Callable[[np.ndarray, tuple[int, int]], Detection]
    needs: str = ""
    square_only: bool = False


def _has_module(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


METHODS: dict[str, Method] = {m.name: m for m in (
    Method("sogdd", "board", _sogdd, "sogdd.calib.detect_board"),
    Method("opencv-refine", "board", _opencv_refine, "sogdd.calib.refine_corners"),
    Method("hr-grid", "board", _hr_grid),
    Method("opencv", "board", opencv_classic),
    Method("opencv-sb", "board", _opencv_sb),
    Method("calib-targets", "board", _calib_targets, "pip install calib-targets"),
    Method("mrgingham", "board", _mrgingham, "apt-get install mrgingham", square_only=True),
    Method("chess-corners", "points", _chess_corners, "pip install chess-corners"),
    Method("hr", "points", _hr),
)}

_PROBES: dict[str, Callable[[], bool]] = {
    "calib-targets": lambda: _has_module("calib_targets"),
    "chess-corners": lambda: _has_module("chess_corners"),
    "mrgingham": lambda: shutil.which("mrgingham") is not None,
}


def available(name: str) -> tuple[bool, str]:
    """Whether method ``name`` can run here, and a note saying why not ("" when it can).

    Examples
    --------
    >>> available("opencv")
    (True, '')
    """
    m = METHODS[name]
    probe = _PROBES.get(name)
    if probe is None or probe():
        return True, ""
    return False, f"{name} skipped: not installed ({m.needs})"


def method_names(spec: str | None = None) -> list[str]:
    """Method names from a comma-separated ``spec`` (None or "all": every method).

    Examples
    --------
    >>> method_names("opencv, hr")
    ['opencv', 'hr']
    """
    if spec is None or spec.strip() == "all":
        return list(METHODS)
    names = [n.strip() for n in spec.split(",") if n.strip()]
    bad = [n for n in names if n not in METHODS]
    if bad or not names:
        raise ValueError(f"unknown method(s) {', '.join(bad) or '(none)'}; known: {', '.join(METHODS)}")
    return names
