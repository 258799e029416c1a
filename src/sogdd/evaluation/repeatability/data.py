"""The repeatability images: every image of a folder, as grey uint8."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...image.files import list_images, read_image
from ...image.grey import to_uint8_grey

__all__ = ["load_images"]


def load_images(folder: str | os.PathLike, limit: int | None = None) -> list[tuple[str, np.ndarray]]:
    """``(name, grey uint8 image)`` for the images of ``folder``, sorted by name; the first ``limit``."""
    f = Path(folder)
    if not f.is_dir():
        raise ValueError(f"{f}: no such folder")
    files = list_images(f)
    if not files:
        raise ValueError(f"{f}: holds no image")
    return [(q.name, to_uint8_grey(read_image(q))) for q in (files[:limit] if limit else files)]
