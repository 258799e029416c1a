"""The real check: calibration-target photos with hand-labelled corners.

Data: ``$SOGDD_DATA/calibration`` (BoofCV's ValidationBoof, Sony DSC-HX5V video
frames, 640 x 480): ``chessboard_sony`` (13 frames, the 24 inner corners of a
7 x 5 board, cells of about 40-60 px) and ``square_grid_sony`` (14 frames, the
4 corners of each of 12 squares: L-corners). ``frameNN.txt`` lists ``x y``.

Label convention
----------------
The labels' pixel convention is undocumented. ``cv2.cornerSubPix`` started
on them lands about (-0.45, -0.66) px away. We estimate **one global offset per
data set, the same for every detector**: the median of
``cornerSubPix(label) - label`` (``winSize (5, 5)``, an 11 x 11 window that
sees only the corner's own edges at these cell sizes) over the set's
*development* frames (odd numbers). The offset is added to every label of the
set; the *confirmation* frames (even numbers) took no part in estimating it.

Why per data set: the two sets' medians differ, (-0.45, -0.68) and
(-0.38, -0.27) px, and after removing the chessboard's offset from both,
sogdd, GFTT + cornerSubPix and Harris all see the square-grid corners
(+0.07, +0.41) px from the labels (within 0.05 px of one another), so the
difference is in the labels, not in cornerSubPix. (A bias of cornerSubPix
towards the inside of L-corners would not survive the median either: each
square's four corners pull in four directions.)

Each row's own median residual after the shift is reported as
``residual_offset``: a row far from (0, 0) sees the corners elsewhere than
cornerSubPix does, and its errors include that systematic part.

Scores (per detector, per data set, per split) are those of :mod:`.metrics`
with two changes for real labels: the scored region is the labels' convex
hull grown by 3 px (the board beyond the outermost labelled corners, the paper
and the background are not scored), and the capture radius is 5 px
(cells are 40-60 px here).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..points import match_points
from .metrics import ImageScore, pool
from .rows import make_rows

__all__ = ["CalibrationFrame", "load_calibration", "estimate_offset", "evaluate_calibration",
           "DATASETS"]

#: data set folder -> inner-corner pattern size (None: not a chessboard)
DATASETS: dict[str, tuple[int, int] | None] = {"chessboard_sony": (6, 4), "square_grid_sony": None}
_CAPTURE = 5.0
_GROW = 3.0


@dataclass(frozen=True)
class CalibrationFrame:
    dataset: str
    name: str
    image: np.ndarray  # uint8 grey
    labels: np.ndarray  # (N, 2) x, y as published
    pattern_size: tuple[int, int] | None

    @property
    def dev(self) -> bool:
        """Development half: odd frame numbers."""
        m = re.search(r"(\d+)", self.name)
        return bool(m) and int(m.group(1)) % 2 == 1


def calibration_root(path: str | os.PathLike | None = None) -> Path | None:
    """``path``, else ``$SOGDD_DATA/calibration``, else ``../shared/data/calibration``; None if absent."""
    if path is not None:
        p = Path(path)
        if not p.is_dir():
            raise ValueError(f"calibration data folder not found: {p}")
        return p
    env = os.environ.get("SOGDD_DATA")
    for root in ([Path(env)] if env else []) + [Path("..") / "shared" / "data"]:
        if (root / "calibration").is_dir():
            return root / "calibration"
    return None


def load_calibration(root: str | os.PathLike) -> list[CalibrationFrame]:
    """Every labelled frame of the known data sets under ``root``."""
    root = Path(root)
    out = []
    for ds, pattern in DATASETS.items():
        folder = root / ds
        if not folder.is_dir():
            continue
        for txt in sorted(folder.glob("frame*.txt")):
            img_path = txt.with_suffix(".jpg")
            if not img_path.is_file():
                continue
            labels = np.loadtxt(txt, comments="#", dtype=np.float64).reshape(-1, 2)
            img = cv2.imread(str(img_path), cv2.IMREAD_GRAYSCALE)
            if img is None:
                raise ValueError(f"cannot read {img_path}")
            out.append(CalibrationFrame(ds, txt.stem, img, labels, pattern))
    if not out:
        raise ValueError(f"no labelled frames under {root} (expected {', '.join(DATASETS)})")
    return out


def estimate_offset(frames: list[CalibrationFrame], win: int = 5) -> np.ndarray:
    """Median ``cornerSubPix(label) - label`` (x, y) over ``frames``.

    Examples
    --------
    >>> img = np.full((60, 60), 200, np.uint8); img[20:40, 20:40] = 40
    >>> lab = np.array([[19.5, 19.5], [39.5, 19.5], [39.5, 39.5], [19.5, 39.5]]) + [0.4, 0.6]
    >>> estimate_offset([CalibrationFrame("t", "frame01", img, lab, None)]).round(2).tolist()
    [-0.4, -0.6]
    """
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 0.001)
    d = []
    for f in frames:
        p = f.labels.astype(np.float32).reshape(-1, 1, 2)
        r = cv2.cornerSubPix(f.image, p.copy(), (win, win), (-1, -1), crit).reshape(-1, 2)
        d.append(r - f.labels)
    return np.median(np.concatenate(d), axis=0)


def _grown_hull(labels: np.ndarray):
    hull = cv2.convexHull(labels.astype(np.float32).reshape(-1, 1, 2))

    def inside(pts: np.ndarray) -> np.ndarray:
        return np.array([cv2.pointPolygonTest(hull, (float(x), float(y)), True) >= -_GROW
                         for x, y in pts], dtype=bool)
    return inside


def score_frame(truth: np.ndarray, det: np.ndarray, radius: float = 1.0) -> tuple[ImageScore, np.ndarray]:
    """Score detections on one frame; also return the located residuals (det - truth)."""
    det = np.asarray(det, dtype=np.float64).reshape(-1, 2)
    hits = len(match_points(truth, det, radius))
    inside = _grown_hull(truth)(det) if len(det) else np.zeros(0, bool)
    if len(det):
        d = np.min(np.hypot(det[:, None, 0] - truth[None, :, 0], det[:, None, 1] - truth[None, :, 1]), 1)
        false, near = int(np.sum(inside & (d > radius))), int(np.sum(d <= radius))
    else:
        false = near = 0
    loc = match_points(truth, det, _CAPTURE)
    resid = det[loc.ib] - truth[loc.ia]
    return ImageScore(len(truth), hits, false, np.asarray(loc.dist, dtype=np.float64), near - hits), resid


def evaluate_calibration(detectors=None, root: str | os.PathLike | None = None) -> dict:
    """Score rows on the real calibration frames (module doc).

    Returns ``{"offset": {dataset: [dx, dy]}, "offset_method": ..., "datasets": {dataset:
    {detector: {"dev": row, "confirm": row, "all": row, "residual_offset": [dx, dy]}}}}``
    with rows as :meth:`.metrics.CellScore.as_dict`.
    """
    base = calibration_root(root)
    if base is None:
        raise ValueError("no calibration data: pass a folder or set SOGDD_DATA")
    frames = load_calibration(base)
    rows = make_rows(detectors)
    out: dict = {"offset_method": "per data set: median cornerSubPix(label, winSize (5,5)) - label on its "
                                  "odd (development) frames, added to every label of the set",
                 "offset": {}, "datasets": {}}
    for ds in DATASETS:
        fr = [f for f in frames if f.dataset == ds]
        if not fr:
            continue
        off = estimate_offset([f for f in fr if f.dev] or fr)
        out["offset"][ds] = [float(v) for v in off]
        res: dict = {}
        for row in rows:
            if row.needs_pattern and fr[0].pattern_size is None:
                continue
            split: dict[str, list] = {"dev": [], "confirm": []}
            resid = []
            for f in fr:
                xy = _run(row, f)
                sc, r = score_frame(f.labels + off, xy)
                split["dev" if f.dev else "confirm"].append(sc)
                resid.append(r)
            rr = np.concatenate(resid) if resid else np.zeros((0, 2))
            res[row.label] = {"dev": pool(split["dev"]), "confirm": pool(split["confirm"]),
                              "all": pool(split["dev"] + split["confirm"]),
                              "residual_offset": [float(v) for v in np.median(rr, 0)] if len(rr)
                              else None}
        out["datasets"][ds] = res
    return out


def _run(row, f: CalibrationFrame) -> np.ndarray:
    if not row.needs_pattern:
        return row.run(f.image, f.pattern_size)
    xy = row.run(f.image, f.pattern_size)
    if len(xy) == 0 and f.pattern_size is not None:  # the board may lie with its long side vertical
        xy = row.run(f.image, f.pattern_size[::-1])
    return xy
