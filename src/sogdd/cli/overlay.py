"""Overlay images: detections (red crosses) and optional ground truth (green circles)."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from ..corners import Corners
from ..image.grey import to_gray255
from ..image.validate import validate_image


def check_overlay_path(path: str | Path) -> None:
    """Refuse an overlay path that cannot be written (no image extension, missing or read-only folder)."""
    p = Path(path)
    if not p.suffix or not cv2.haveImageWriter(str(p)):
        raise ValueError(f"--overlay {p}: give an image file name, e.g. {p.with_suffix('.png').name}")
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir() or not os.access(folder, os.W_OK):
        raise ValueError(f"--overlay {p}: folder {folder} does not exist or is not writable")


def save_overlay(image: np.ndarray, corners: Corners, path: str | Path, gt: np.ndarray | None = None) -> None:
    """Draw corners (red crosses) and optional GT (green circles) on the image; write a PNG."""
    grey = np.clip(to_gray255(validate_image(image)), 0, 255).astype(np.uint8)
    vis = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    scale = max(1, int(np.ceil(600 / max(grey.shape))))
    if scale > 1:
        vis = cv2.resize(vis, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)

    def at(x, y):  # pixel centres at integers -> the upscaled canvas
        return (int(round((x + 0.5) * scale - 0.5)), int(round((y + 0.5) * scale - 0.5)))

    if gt is not None:
        for x, y in gt:
            cv2.circle(vis, at(x, y), 2 + scale, (0, 200, 0), 1, cv2.LINE_AA)
    for x, y in corners.xy:
        cv2.drawMarker(vis, at(x, y), (0, 0, 255), cv2.MARKER_CROSS, 3 + 2 * scale, 1, cv2.LINE_AA)
    if not cv2.imwrite(str(path), vis):
        raise ValueError(f"{path}: could not write the overlay image")
