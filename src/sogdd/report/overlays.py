"""Overlay figures in the style of the paper's Figs. 7 and 8: detections against GT.

Markers: matched GT corners as green circles, missed GT corners as red squares,
false detections as blue crosses. Drawn with OpenCV on a dimmed grey copy of
the image so that the markers stand out and the PNGs stay small.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from ..evaluation.points import match_points

__all__ = ["overlay_gt", "montage", "save_png"]

GREEN, RED, BLUE = (0, 170, 0), (0, 0, 230), (230, 90, 0)  # BGR


def _grey_bgr(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.dtype == np.bool_:
        img = img.astype(np.uint8) * 255
    if img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    if img.ndim == 3:
        img = cv2.cvtColor(img[:, :, :3], cv2.COLOR_RGB2GRAY)
    dim = (img.astype(np.float32) * 0.45 + 140).astype(np.uint8)
    return cv2.cvtColor(dim, cv2.COLOR_GRAY2BGR)


def overlay_gt(image: np.ndarray, gt: np.ndarray, det: np.ndarray, delta: float = 2.0,
               scale: float = 1.0, title: str = "") -> np.ndarray:
    """A BGR uint8 picture of detections ``det`` against ground truth ``gt``."""
    canvas = _grey_bgr(image)
    if scale != 1.0:
        canvas = cv2.resize(canvas, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    m = match_points(gt, det, delta)
    gt = np.asarray(gt, dtype=np.float64).reshape(-1, 2)
    det = np.asarray(det, dtype=np.float64).reshape(-1, 2)

    def pt(p):
        return (int(round((p[0] + 0.5) * scale - 0.5)), int(round((p[1] + 0.5) * scale - 0.5)))

    r = max(2, int(round(3 * scale)))
    for i in m.ia:
        cv2.circle(canvas, pt(gt[i]), r, GREEN, 1, cv2.LINE_AA)
    for i in m.unmatched_a:
        c = pt(gt[i])
        cv2.rectangle(canvas, (c[0] - r, c[1] - r), (c[0] + r, c[1] + r), RED, 1)
    for j in m.unmatched_b:
        c = pt(det[j])
        cv2.line(canvas, (c[0] - r, c[1] - r), (c[0] + r, c[1] + r), BLUE, 1, cv2.LINE_AA)
        cv2.line(canvas, (c[0] - r, c[1] + r), (c[0] + r, c[1] - r), BLUE, 1, cv2.LINE_AA)
    if title:
        text = f"{title}: missed {m.n_a - len(m)}, false {m.n_b - len(m)}"
        cv2.rectangle(canvas, (0, 0), (canvas.shape[1], 14), (255, 255, 255), -1)
        cv2.putText(canvas, text, (3, 11), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1,
                    cv2.LINE_AA)
    return canvas


def montage(tiles: list[np.ndarray], columns: int = 3, gap: int = 4) -> np.ndarray:
    """Tiles (same size, BGR) on a white grid."""
    if not tiles:
        raise ValueError("no tiles")
    h, w = tiles[0].shape[:2]
    rows = (len(tiles) + columns - 1) // columns
    out = np.full((rows * (h + gap) - gap, columns * (w + gap) - gap, 3), 255, np.uint8)
    for k, t in enumerate(tiles):
        r, c = divmod(k, columns)
        out[r * (h + gap): r * (h + gap) + h, c * (w + gap): c * (w + gap) + w] = t
    return out


def save_png(path: str | os.PathLike, image: np.ndarray) -> Path:
    """Write a PNG at the highest compression."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(p), image, [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise OSError(f"{p}: could not write")
    return p
