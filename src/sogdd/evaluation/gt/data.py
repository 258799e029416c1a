"""Ground-truth corner sets: the on-disk format and its loader.

Format of one GT set (the format of ``shared/data/corners_gt/*``)
------------------------------------------------------------------
A folder holding exactly one ``image.<ext>`` (any format OpenCV reads: png,
gif, jpg, bmp, ...) and ``corners.csv``::

    # comment lines start with '#'
    x,y
    167,61
    70.25,63.5

``x`` is the column and ``y`` the row, 0-based, with the centre of the top-left
pixel at (0, 0) (OpenCV's convention; sub-pixel values allowed). The set's name
is the folder's name. A folder whose sub-folders are GT sets is a collection.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...image.files import read_image

__all__ = ["GTSet", "find_gt_sets", "load_gt_set", "read_corners_csv", "write_corners_csv"]


@dataclass(frozen=True)
class GTSet:
    """One image with its ground-truth corners (``corners`` is (N, 2) ``x, y``)."""

    name: str
    image: np.ndarray
    corners: np.ndarray
    path: Path


def read_corners_csv(path: str | os.PathLike) -> np.ndarray:
    """Read a ``corners.csv`` (``x,y`` header, ``#`` comments) as an (N, 2) float array."""
    p = Path(path)
    lines = [ln.strip() for ln in p.read_text().splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("#")]
    if not lines:
        return np.zeros((0, 2))
    header = [h.strip().lower() for h in lines[0].split(",")]
    if "x" not in header or "y" not in header:
        raise ValueError(f"{p}: the first non-comment line must be a header with 'x' and 'y'")
    ix, iy = header.index("x"), header.index("y")
    try:
        rows = [[float(v) for v in ln.split(",")] for ln in lines[1:]]
    except ValueError as exc:
        raise ValueError(f"{p}: not numeric: {exc}") from None
    if not rows:
        return np.zeros((0, 2))
    arr = np.asarray(rows, dtype=np.float64)
    return np.stack([arr[:, ix], arr[:, iy]], axis=1)


def write_corners_csv(path: str | os.PathLike, xy: np.ndarray, comment: str = "") -> None:
    """Write corners in the GT format (used by tests and by users converting their sets)."""
    buf = io.StringIO()
    for line in comment.splitlines():
        buf.write(f"# {line}\n")
    buf.write("x,y\n")
    for x, y in np.asarray(xy, dtype=np.float64).reshape(-1, 2):
        buf.write(f"{x:.6g},{y:.6g}\n")
    Path(path).write_text(buf.getvalue())


def _image_file(folder: Path) -> Path | None:
    cands = sorted(
        q for q in folder.iterdir() if q.is_file() and q.stem == "image" and q.suffix.lower() != ".csv"
    )
    return cands[0] if cands else None


def _is_gt_set(folder: Path) -> bool:
    return (folder / "corners.csv").is_file() and _image_file(folder) is not None


def load_gt_set(folder: str | os.PathLike) -> GTSet:
    """Load one GT folder (``image.<ext>`` + ``corners.csv``)."""
    f = Path(folder)
    if not f.is_dir():
        raise ValueError(f"{f}: no such folder")
    img = _image_file(f)
    if img is None or not (f / "corners.csv").is_file():
        raise ValueError(f"{f}: a GT set needs image.<ext> and corners.csv")
    return GTSet(f.name, read_image(img), read_corners_csv(f / "corners.csv"), f)


def find_gt_sets(root: str | os.PathLike) -> list[GTSet]:
    """``root`` itself if it is a GT set, else its GT sub-folders (sorted by name)."""
    r = Path(root)
    if not r.is_dir():
        raise ValueError(f"{r}: no such folder")
    if _is_gt_set(r):
        return [load_gt_set(r)]
    sets = [load_gt_set(d) for d in sorted(r.iterdir()) if d.is_dir() and _is_gt_set(d)]
    if not sets:
        raise ValueError(f"{r}: holds no GT set (image.<ext> + corners.csv)")
    return sets
