"""Boards in image files: detection over many files with --jobs and progress."""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from .targets.board import Board
from .targets.spec import BoardSpec, grid_dims

__all__ = [
    "ViewResult", "check_detector", "detect_files", "detect_view",
]

@dataclass(frozen=True)
class ViewResult:
    """What one image gave: its boards (possibly none), its size, a read error, what else was seen.

    ``seen`` describes what the detector found where no board matched the
    specification (for the error message); ``other_size`` is the (columns,
    rows) of a complete board of another size than the specification's.
    """

    path: str
    boards: tuple[Board, ...] = ()
    size: tuple[int, int] | None = None
    error: str = ""
    seen: str = ""
    other_size: tuple[int, int] | None = None


def _grey(img: np.ndarray) -> np.ndarray:
    if img.ndim == 3:
        img = cv2.cvtColor(img[..., :3], cv2.COLOR_RGB2GRAY)
    return img


def _matches(size, pattern) -> bool:
    return size is None or tuple(size) in (tuple(pattern), tuple(pattern)[::-1])


def detect_view(path: str, spec: BoardSpec) -> ViewResult:
    """Read one image and find its boards by ``spec`` (the unit of work of :func:`detect_files`)."""
    import sogdd

    from .targets import chessboard as detect

    try:
        img = _grey(sogdd.read_image(path))
    except (ValueError, OSError, cv2.error) as exc:
        msg = " ".join(str(exc).split())
        return ViewResult(str(path), error=msg if str(path) in msg else f"{path}: {msg}")
    size = (int(img.shape[1]), int(img.shape[0]))
    if spec.kind == "charuco":
        from .targets.charuco import detect_charuco

        b = detect_charuco(img, spec.charuco_board())
        return ViewResult(str(path), (b,) if b is not None and len(b) else (), size,
                          seen="" if b is not None else "no ChArUco markers/corners")
    boards = [b for b in detect.detect_boards(img, spec.pattern) if len(b)]
    if spec.pattern is not None:
        wrong = [b for b in boards if not _matches(b.size, spec.pattern)]
        boards = [b for b in boards if _matches(b.size, spec.pattern)]
        if wrong and not boards:
            s = wrong[0].size
            return ViewResult(str(path), (), size, seen=f"a board of {s[0]}x{s[1]} inner corners", other_size=s)
        if not boards:
            return _what_else(str(path), img, size, spec.pattern, detect)
    return ViewResult(str(path), tuple(boards), size, seen="" if boards else "no board")


def _what_else(path: str, img: np.ndarray, size, pattern, detect) -> ViewResult:
    """No board of the given size: look for a board of any size, to say what the image shows.

    A complete grid that does not fit in the pattern (in either orientation)
    cannot be part of it: its size contradicts the pattern.
    """
    others = [b for b in detect.detect_boards(img, None) if len(b)]
    for b in others:
        dims = b.size if b.size is not None else grid_dims(b)
        if dims is not None and not _fits(dims, pattern):
            return ViewResult(path, (), size, seen=f"a board of {dims[0]}x{dims[1]} inner corners",
                              other_size=tuple(dims))
    if others:
        return ViewResult(path, (), size, seen=f"a partial board ({max(len(b) for b in others)} corners)")
    return ViewResult(path, (), size, seen="no board")


def _fits(dims, pattern) -> bool:
    (w, h), (c, r) = dims, pattern
    return (w <= c and h <= r) or (w <= r and h <= c)


def check_detector(spec: BoardSpec) -> None:
    """``ValueError`` if the detector that ``spec`` needs cannot be imported (before any work)."""
    import importlib

    name = "charuco" if spec.kind == "charuco" else "chessboard"
    try:
        importlib.import_module(f"sogdd.calib.targets.{name}")
    except ImportError as exc:
        raise ValueError(f"board detection (sogdd.calib.{name}) is not available: {exc}") from None


def detect_files(paths: Sequence[str | os.PathLike], spec: BoardSpec, *, jobs: int = 1,
                 progress: bool = True) -> list[ViewResult]:
    """:func:`detect_view` on every file, ``jobs`` processes at a time, with a progress bar on stderr.

    A file that cannot be read gives a :class:`ViewResult` with ``error`` set;
    the others complete. Results are in input order.
    """
    from tqdm import tqdm

    if int(jobs) < 1:
        raise ValueError(f"--jobs must be >= 1, got {jobs}")
    check_detector(spec)
    names = [str(p) for p in paths]
    bar = tqdm(total=len(names), desc="boards", unit="img", file=sys.stderr, disable=not progress)
    out: list[ViewResult] = []
    try:
        if jobs == 1 or len(names) == 1:
            for n in names:
                out.append(detect_view(n, spec))
                bar.update(1)
        else:
            with ProcessPoolExecutor(max_workers=min(int(jobs), len(names))) as pool:
                for r in pool.map(detect_view, names, [spec] * len(names)):
                    out.append(r)
                    bar.update(1)
    finally:
        bar.close()
    return out
