"""The command line's overlay files: the path check before any work, and the write.

The drawing itself is :func:`sogdd.report.overlays.detections_overlay`, the one
home of every overlay (markers sized from the picture, outlined, with a legend).
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from ..corners import Corners
from ..formats.safe_write import write_bytes
from ..image.grey import to_gray255
from ..image.validate import validate_image
from ..report.overlays import detections_overlay


def check_overlay_path(path: str | Path, option: str = "--overlay") -> None:
    """Refuse an overlay path that cannot be written (no image extension, missing or read-only folder),
    naming the command's ``option``."""
    p = Path(path)
    if not p.suffix or not cv2.haveImageWriter(str(p)):
        raise ValueError(f"{option} {p}: give an image file name, e.g. {p.with_suffix('.png').name}")
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir() or not os.access(folder, os.W_OK):
        raise ValueError(f"{option} {p}: folder {folder} does not exist or is not writable")


def save_overlay(image: np.ndarray, corners: Corners, path: str | Path, gt: np.ndarray | None = None,
                 label: str = "") -> None:
    """Write ``image`` with the corners (red crosses), optional GT (green circles) and a legend.

    Any image :func:`sogdd.detect_corners` takes (its grey levels on the 0-255
    scale are drawn); ``label`` names the detections in the legend (e.g. the preset).
    """
    grey = np.clip(to_gray255(validate_image(image)), 0, 255).astype(np.uint8)
    vis = detections_overlay(grey, corners.xy, gt, label=label)
    ok, data = cv2.imencode(Path(path).suffix, vis)
    if not ok:
        raise ValueError(f"{path}: could not encode the overlay image")
    write_bytes(path, data.tobytes())  # whole or not at all
