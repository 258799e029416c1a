"""The detectors (rows) of the chessboard benchmark.

A row is anything that turns a grey image into corner positions:

* a registry spec ``NAME[:key=value...]`` (:mod:`sogdd.evaluation.specs`; its
  ``remove_border`` and ``top_k`` keys apply),
  run **at its defaults**, as a user would run it: thresholds are not tuned
  per board. The default-threshold run is what a calibration user meets; a
  detector that over-detects pays in ``false``, one that under-detects in
  ``recall``. (``sogdd``'s paper threshold ``T_h = 1e9`` is an absolute
  level; at this benchmark's contrast, 170 grey levels, it passes the
  X-corners' responses.) Override a threshold in the spec to study another
  operating point, e.g. ``sogdd:threshold=1e8``.
* ``gftt+subpix``: the practitioner's pipeline, OpenCV's
  ``goodFeaturesToTrack`` (Shi-Tomasi, ``qualityLevel`` 0.01, ``minDistance``
  2 px so that 3-px cells stay separable, ``blockSize`` 3, no count limit)
  followed by ``cornerSubPix`` with ``winSize (5, 5)`` (an 11 x 11 window),
  no dead zone, and OpenCV tutorial's criteria (100 iterations or a step
  below 0.001 px).
* ``chessboard-sb``: ``cv2.findChessboardCornersSB`` with the board's true
  pattern size (inner corners per row and column) and default flags. It
  returns every inner corner or nothing, so its recall per image is 0 or
  (nearly) 1. It needs the pattern size, so it runs only where the scene
  knows it (rendered boards, the real chessboard photos).
* any callable ``f(image) -> (N, 2) xy`` (or :class:`~sogdd.corners.Corners`)
  and any object with ``detect_corners(image)``: custom configurations.

Every row gets the image as ``uint8`` (H, W).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from ..specs import DetectorSpec, build_detector, detect, parse_spec, registry_names

__all__ = ["Row", "make_row", "make_rows", "SPECIAL_ROWS", "DEFAULT_ROWS", "gftt_subpix",
           "chessboard_sb"]

_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 0.001)


def _xy(out: Any) -> np.ndarray:
    xy = getattr(out, "xy", out)
    return np.asarray(xy, dtype=np.float64).reshape(-1, 2)


def gftt_subpix(image: np.ndarray, win: int = 5, min_distance: float = 2.0,
                quality: float = 0.01) -> np.ndarray:
    """GFTT corners refined by ``cv2.cornerSubPix(winSize=(win, win))`` (module doc).

    Examples
    --------
    >>> img = np.zeros((40, 40), np.uint8); img[10:30, 10:30] = 200
    >>> xy = gftt_subpix(img)
    >>> bool(np.min(np.hypot(*(xy - [9.5, 9.5]).T)) < 0.3)
    True
    """
    img = np.ascontiguousarray(image)
    if img.dtype != np.uint8:
        img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    pts = cv2.goodFeaturesToTrack(img, maxCorners=0, qualityLevel=quality,
                                  minDistance=min_distance, blockSize=3)
    if pts is None or len(pts) == 0:
        return np.zeros((0, 2))
    pts = cv2.cornerSubPix(img, pts.astype(np.float32), (win, win), (-1, -1), _CRITERIA)
    return pts.reshape(-1, 2).astype(np.float64)


def chessboard_sb(image: np.ndarray, pattern_size: tuple[int, int], flags: int = 0) -> np.ndarray:
    """``cv2.findChessboardCornersSB``: all ``cols x rows`` inner corners, or none."""
    img = np.ascontiguousarray(image)
    if img.dtype != np.uint8:
        img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    ok, pts = cv2.findChessboardCornersSB(img, tuple(int(v) for v in pattern_size), flags=flags)
    if not ok or pts is None:
        return np.zeros((0, 2))
    return pts.reshape(-1, 2).astype(np.float64)


@dataclass(frozen=True)
class Row:
    """A benchmark row: ``label`` and ``run(image, pattern_size) -> (N, 2) xy``.

    ``pattern_size`` is ``(cols, rows)`` of inner corners, or ``None`` where
    unknown; ``needs_pattern`` rows are skipped there.
    """

    label: str
    run: Callable[[np.ndarray, tuple[int, int] | None], np.ndarray]
    needs_pattern: bool = False


#: special row names -> their labels
SPECIAL_ROWS: dict[str, str] = {
    "gftt+subpix": "GFTT + cornerSubPix (5,5)",
    "chessboard-sb": "findChessboardCornersSB",
}

#: the rows measured by default: both SOGDD presets, the corner baselines, the pipelines
DEFAULT_ROWS: tuple[str, ...] = ("sogdd", "sogdd-authors", "harris", "shi-tomasi", "fast",
                                 "gftt+subpix", "chessboard-sb")


def make_row(item: Any) -> Row:
    """A :class:`Row` from a spec string, a ``DetectorSpec``, a detector object or a callable.

    Raises
    ------
    ValueError
        Unknown detector name or malformed spec.

    Examples
    --------
    >>> make_row("gftt+subpix").label
    'GFTT + cornerSubPix (5,5)'
    >>> make_row(lambda im: np.zeros((0, 2))).label
    '<lambda>'
    """
    if isinstance(item, Row):
        return item
    if isinstance(item, str):
        key = item.strip()
        if key == "gftt+subpix":
            return Row(SPECIAL_ROWS[key], lambda im, ps: gftt_subpix(im))
        if key == "chessboard-sb":
            return Row(SPECIAL_ROWS[key], lambda im, ps: chessboard_sb(im, ps), needs_pattern=True)
        item = parse_spec(key)
        if item.name not in registry_names():
            raise ValueError(f"unknown detector {item.name!r}; available: "
                             f"{', '.join(list(registry_names()) + list(SPECIAL_ROWS))}")
    if isinstance(item, DetectorSpec):
        det = build_detector(item)
        return Row(item.label, lambda im, ps, _s=item, _d=det: detect(_s, im, _d).xy)
    if hasattr(item, "detect_corners"):
        label = getattr(item, "name", None) or type(item).__name__
        return Row(str(label), lambda im, ps, _d=item: _xy(_d.detect_corners(im)))
    if callable(item):
        label = getattr(item, "__name__", None) or type(item).__name__
        return Row(str(label), lambda im, ps, _f=item: _xy(_f(im)))
    raise ValueError(f"not a detector: {item!r} (a spec string, a DetectorSpec, an object with "
                     "detect_corners, or a callable image -> (N, 2) xy)")


def make_rows(items: Any) -> list[Row]:
    """Rows from one item, a comma-separated spec string, or a list of items; ``all`` adds the registry."""
    if items is None:
        items = list(DEFAULT_ROWS)
    elif isinstance(items, str):
        items = [t.strip() for t in items.split(",") if t.strip()]
    elif not isinstance(items, (list, tuple)):
        items = [items]
    expanded: list[Any] = []
    for it in items:
        if it == "all":
            expanded += [n for n in registry_names() if n not in expanded]
            expanded += [n for n in SPECIAL_ROWS if n not in expanded]
        else:
            expanded.append(it)
    if not expanded:
        raise ValueError("no detectors given")
    rows = [make_row(it) for it in expanded]
    seen: dict[str, int] = {}
    out = []
    for r in rows:  # distinct labels: the JSON is keyed by them
        k = seen.get(r.label, 0)
        seen[r.label] = k + 1
        out.append(r if k == 0 else Row(f"{r.label}#{k + 1}", r.run, r.needs_pattern))
    return out
