"""Boards in image files: each image read once, made grey once, its boards found; over many files.

:func:`detect_view` is the unit of work: it reads one file (:func:`sogdd.read_image`),
finds its boards by the specification (the detector makes the image grey, once, by the
core's conversion, :func:`sogdd.image.to_gray255`), says what it saw where no board
matched, and keeps a small grey thumbnail for the report (the image shrunk, then made
grey), so no file is read twice. :func:`detect_files` runs
it over many files through :func:`sogdd.collection.run_tasks`: in this process, on local
worker processes (a worker that dies costs only its image) or on a Dask cluster.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Literal

import cv2
import numpy as np

from ..collection import run_tasks
from ..image.files import max_pixels_limit, opencv_message, read_image_and_orientation
from ..image.grey import to_gray255
from ..image.validate import validate_image
from .result import Calibration
from .targets.board import SMALL_CELL, Board, cell_size
from .targets.precision import measure_precision
from .targets.spec import BoardSpec, view_boards

__all__ = ["BOARD_CHOICES", "READ_OPTIONS", "SMALL_CELL", "THUMB_WIDTH", "BoardChoice", "Thumbnail",
           "ViewRecord", "ViewResult", "ViewStatus", "cell_size", "check_read_options", "detect_files",
           "detect_view", "make_thumbnail", "on_sensor_grid", "pick_boards", "view_records"]

#: the keyword arguments of :func:`sogdd.read_image` that ``read_options`` may hold
READ_OPTIONS = ("max_pixels", "allow_corrupt", "ignore_orientation")


# a forkserver imports this module once for all its workers
_PRELOAD = ("sogdd.calib.detection",)


#: what became of an input: its board used or rejected by the fit; a board of another kind or size, or a
#: board beside the image's view (:func:`pick_boards`), seen and ignored; no board; a file that could not be
#: read (or whose worker died)
ViewStatus = Literal["used", "rejected", "ignored", "no board", "unreadable"]

#: which boards of an image are views: the one that matches the specification best, or every one
#: (a scene built with several targets); :func:`pick_boards`
BoardChoice = Literal["best", "all"]
BOARD_CHOICES: tuple[BoardChoice, ...] = ("best", "all")



@dataclass(frozen=True)
class ViewRecord:
    """The fate of one view: an image's board (``name``, ``name#2`` for its second board), or an image
    that gave the calibration nothing.

    ``file`` is the input file; ``status`` a :data:`ViewStatus`; ``reason`` says
    why it was not used (the read error, what was seen instead of the board,
    the fit's rejection, why a board beside the view was ignored), "" for a used
    view; ``view`` is its index in the calibration's views (``Calibration.names``),
    None for an image that could not be read and for an ignored board beside
    its image's view (:func:`pick_boards`), whose corners found ``corners``
    counts (the calibration counts those of its views); ``choice`` says why a
    video's frame was chosen as a view (:mod:`sogdd.calib.video`), "" for an image.
    """

    name: str
    file: str
    status: ViewStatus
    reason: str = ""
    view: int | None = None
    corners: int | None = None
    choice: str = ""


def view_records(cal: Calibration) -> list[ViewRecord]:
    """A :class:`ViewRecord` per view of a calibration alone (no files: ``file`` is the view's name).

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> r = view_records(demo_calibration())
    >>> r[0].status, r[8].status, r[8].reason
    ('used', 'no board', 'no board')
    """
    def status(v: int) -> ViewStatus:
        return "used" if cal.view_used[v] else "no board" if cal.boards[v] is None else "rejected"

    return [ViewRecord(n, n, status(v), cal.reasons[v], v) for v, n in enumerate(cal.names)]


#: the thumbnails' width in px
THUMB_WIDTH = 240


@dataclass(frozen=True)
class Thumbnail:
    """A small grey copy of an image for the report: ``image`` (uint8, H x W) and ``scale``, its
    pixels per pixel of the full image (a point ``p`` of the image lies at ``(p + 0.5) scale - 0.5``)."""

    image: np.ndarray
    scale: float


def make_thumbnail(image: np.ndarray, width: int = THUMB_WIDTH) -> Thumbnail:
    """A :class:`Thumbnail` ``width`` px wide (never wider than the image) of a grey float image on
    0-255 (what :func:`sogdd.image.to_gray255` returns) or of any image :func:`sogdd.image.validate_image`
    takes (converted by the core's conversion).

    Examples
    --------
    >>> t = make_thumbnail(np.full((480, 640), 100, np.uint8))
    >>> t.image.shape, t.image.dtype.name, t.scale, int(t.image[0, 0])
    ((180, 240), 'uint8', 0.375, 100)
    """
    img = np.asarray(image)
    w = max(1, min(int(width), img.shape[1]))
    s = w / img.shape[1]
    size = (w, max(1, round(img.shape[0] * s)))
    if img.ndim == 2 and img.dtype == np.float64:
        small = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    elif img.dtype in (np.uint8, np.uint16, np.float32):
        # shrunk, then made grey: the whole frame is made grey once, by the detector
        small = to_gray255(validate_image(cv2.resize(img, size, interpolation=cv2.INTER_AREA)))
    else:
        small = cv2.resize(to_gray255(validate_image(img)), size, interpolation=cv2.INTER_AREA)
    return Thumbnail(np.clip(np.rint(small), 0, 255).astype(np.uint8), s)


@dataclass(frozen=True)
class ViewResult:
    """What one image gave: its boards (possibly none), its size, a read error, what else was seen.

    ``seen`` describes what the detector found where no board matched the
    specification; ``other_size`` is the (columns, rows) of a complete board of
    another size than the specification's (a board that was seen and ignored);
    ``thumbnail`` is the small grey picture the report draws the detections on
    (None when not asked for or when the image could not be read);
    ``orientation`` the file's EXIF orientation (1-8, 1 when none), applied
    unless ``read_options`` said ``ignore_orientation``.
    """

    path: str
    boards: tuple[Board, ...] = ()
    size: tuple[int, int] | None = None
    error: str = ""
    seen: str = ""
    other_size: tuple[int, int] | None = None
    thumbnail: Thumbnail | None = None
    orientation: int = 1


def check_read_options(read_options: Mapping | None) -> dict:
    """``read_options`` as a dict, checked before any work (``ValueError`` for an unknown key or a bad limit).

    Examples
    --------
    >>> check_read_options({"allow_corrupt": True})
    {'allow_corrupt': True}
    >>> check_read_options({"max_pixel": 10})
    Traceback (most recent call last):
    ...
    ValueError: read_options: unknown option 'max_pixel' (known: max_pixels, allow_corrupt, ignore_orientation)
    """
    opts = dict(read_options or {})
    for k in opts:
        if k not in READ_OPTIONS:
            raise ValueError(f"read_options: unknown option {k!r} (known: {', '.join(READ_OPTIONS)})")
    max_pixels_limit(opts.get("max_pixels"))
    return opts


def _describe(board: Board, cell: float) -> str:
    return f"{len(board)} corners, cells of {cell:.1f} px"


def pick_boards(boards: Sequence[Board], spec: BoardSpec, choice: BoardChoice = "best"
                ) -> tuple[tuple[Board, ...], tuple[tuple[Board, str], ...]]:
    """Which of an image's boards are views: ``(views, ignored)``, ``ignored`` holding ``(board, reason)``.

    A board whose median cell (:func:`cell_size`) is under :data:`SMALL_CELL`
    of that of the image's largest board is a screen, a reflection or a
    pattern in the background: never a view. Of the others, ``"best"`` keeps
    the one that matches ``spec`` best (complete first, then the most corners,
    then the largest cells), ``"all"`` keeps every one (a scene built with
    several targets). Views and ignored boards are both in that order, best
    first; every reason gives the board's corners and cell size.

    Examples
    --------
    >>> from sogdd.calib import parse_board
    >>> grid = np.array([(i, j) for j in range(4) for i in range(6)])
    >>> near, far, screen = Board(grid * 40.0, grid), Board(grid * 30.0, grid), Board(grid * 4.0, grid)
    >>> views, ignored = pick_boards([screen, far, near], parse_board("chessboard:6x4"))
    >>> [b is near for b in views]
    [True]
    >>> import textwrap
    >>> for _, reason in ignored:
    ...     print(textwrap.fill(reason, 100))
    another board in the image (24 corners, cells of 30.0 px); one board per image, the best match (24
    corners, cells of 40.0 px), unless all boards are asked for
    a small board (24 corners, cells of 4.0 px), under 1/3 of the cells of the largest board in the
    image (40.0 px): a screen, a reflection or a pattern in the background, never a view
    >>> views, ignored = pick_boards([screen, far, near], parse_board("chessboard:6x4"), "all")
    >>> [b is near for b in views], [b is far for b in views], [b is screen for b, _ in ignored]
    ([True, False], [False, True], [True])
    """
    if choice not in BOARD_CHOICES:
        raise ValueError(f"boards must be one of {', '.join(BOARD_CHOICES)}, got {choice!r}")
    full = None if spec.pattern is None else spec.pattern[0] * spec.pattern[1]
    cells = [cell_size(b) for b in boards]

    def rank(k: int) -> tuple:
        b = boards[k]
        whole = len(b) == full if full is not None else b.size is not None and len(b) == b.size[0] * b.size[1]
        return (whole, len(b), np.nan_to_num(cells[k], nan=0.0))

    order = sorted(range(len(boards)), key=rank, reverse=True)
    largest = max((c for c in cells if np.isfinite(c)), default=float("nan"))
    small = [k for k in order if cells[k] < SMALL_CELL * largest]
    views = [k for k in order if k not in small]
    views, more = (views[:1], views[1:]) if choice == "best" else (views, [])
    best = _describe(boards[views[0]], cells[views[0]]) if views else ""
    ignored = [(k, f"another board in the image ({_describe(boards[k], cells[k])}); one board per image, the "
                   f"best match ({best}), unless all boards are asked for") for k in more]
    ignored += [(k, f"a small board ({_describe(boards[k], cells[k])}), under {SMALL_CELL} of the cells of "
                    f"the largest board in the image ({largest:.1f} px): a screen, a reflection or a pattern "
                    "in the background, never a view") for k in small]
    return tuple(boards[k] for k in views), tuple((boards[k], why) for k, why in ignored)


def _read(path: str, read_options: Mapping | None) -> tuple[np.ndarray, int]:
    """The image file as read (:func:`sogdd.read_image`), checked by the core's rules, and its EXIF
    orientation; the detectors make it grey, once, by the core's conversion."""
    image, turn = read_image_and_orientation(path, **(read_options or {}))
    return validate_image(image), turn


def detect_view(path: str | os.PathLike, spec: BoardSpec, read_options: Mapping | None = None,
                thumb_width: int | None = THUMB_WIDTH, view_only: bool = False) -> ViewResult:
    """Read one image and find its boards by ``spec`` (the unit of work of :func:`detect_files`).

    A file that cannot be read gives a :class:`ViewResult` with ``error`` set
    (one line, naming the file). ``read_options`` go to :func:`sogdd.read_image`;
    ``thumb_width`` is the width of the thumbnail kept for the report (None: none).
    ``view_only``: one board per image is wanted (the search stops once the
    view's board is settled: :func:`sogdd.calib.targets.chessboard.find_boards`), and
    a screen behind it that only a finer level shows is not reported. Every
    board returned carries its corners' measured precision
    (:func:`~sogdd.calib.targets.precision.measure_precision`).

    Examples
    --------
    >>> import tempfile, cv2
    >>> from sogdd.calib import parse_board
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230).astype(np.uint8), (0, 0), 1.0)
    >>> f = tempfile.mkdtemp() + "/board.png"; _ = cv2.imwrite(f, img)
    >>> r = detect_view(f, parse_board("chessboard:7x5"))
    >>> len(r.boards[0]), r.size, r.thumbnail.image.shape
    (35, (220, 180), (180, 220))
    >>> detect_view(f, parse_board("chessboard:5x4")).seen  # a board that cannot be part of a 5 x 4 one
    'a board of 7x5 inner corners'
    >>> print(detect_view(f + ".missing", parse_board("chessboard:7x5")).error)
    /...board.png.missing: no such file
    """
    path = str(path)
    try:
        image, turn = _read(path, read_options)
    except (ValueError, OSError, cv2.error) as exc:
        msg = opencv_message(exc) if isinstance(exc, cv2.error) else " ".join(str(exc).split())
        return ViewResult(path, error=msg if path in msg else f"{path}: {msg}")
    except MemoryError:
        return ViewResult(path, error=f"{path}: out of memory")
    size = (int(image.shape[1]), int(image.shape[0]))
    thumb = make_thumbnail(image, thumb_width) if thumb_width else None
    try:
        found = view_boards(image, spec, view_only)
    except ValueError as exc:  # an image the search cannot take (too small): this view's error, not the batch's
        return ViewResult(path, error=f"{path}: {exc}")
    return ViewResult(path, measure_precision(image, found.boards), size, seen=found.seen,
                      other_size=found.other_size, thumbnail=thumb, orientation=turn)


def _died(a: tuple, message: str) -> ViewResult:
    return ViewResult(str(a[0]), error=f"{a[0]}: {message}")


def detect_files(paths: Sequence[str | os.PathLike], spec: BoardSpec, *, jobs: int = 1,
                 scheduler: str | None = None, progress: bool = False, read_options: Mapping | None = None,
                 thumb_width: int | None = THUMB_WIDTH, view_only: bool = False) -> list[ViewResult]:
    """:func:`detect_view` on every file, ``jobs`` processes at a time or on the Dask cluster at ``scheduler``.

    A file that cannot be read, or whose worker process dies, gives a
    :class:`ViewResult` with ``error`` set; the others complete. Results are in
    input order. ``progress`` shows a bar on stderr, opened once the work starts.
    Raises :class:`sogdd.collection.BatchInterrupted` on Ctrl-C or ``SIGTERM``.
    """
    from tqdm import tqdm

    if int(jobs) < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    opts = check_read_options(read_options)
    names = [str(p) for p in paths]
    args = [(n, spec, opts, thumb_width, view_only) for n in names]
    results: dict[str, ViewResult] = {}
    bars: list = []

    def started() -> None:
        bars.append(tqdm(total=len(names), desc="boards", unit="img", file=sys.stderr, disable=not progress))

    def done(r: ViewResult) -> None:
        results[r.path] = r
        bars[0].update(1)

    try:
        run_tasks(detect_view, args, done, jobs=min(int(jobs), max(1, len(names))), scheduler=scheduler,
                  started=started, died=_died, preload=_PRELOAD)
    finally:
        for bar in bars:
            bar.close()
    return [results[n] for n in names]


def on_sensor_grid(results: Sequence[ViewResult], spec: BoardSpec, *, jobs: int = 1,
                   scheduler: str | None = None, progress: bool = False, read_options: Mapping | None = None,
                   thumb_width: int | None = THUMB_WIDTH, view_only: bool = False
                   ) -> tuple[list[ViewResult], str]:
    """The views of one camera on one pixel grid: ``(results, note)``.

    A camera's intrinsics live on its sensor's pixel grid. When every readable
    image has the same EXIF orientation, the results are returned as they are (the
    orientation applied, as :func:`sogdd.read_image` does) and ``note`` is "".
    When they differ (a phone or tablet turned between shots), the images whose
    orientation was applied are read and searched again without it
    (:func:`detect_files`, ``ignore_orientation``), so that every view is on the
    sensor's grid, and ``note`` says so, naming the orientations seen
    (``ignore_orientation`` given: the results as they are, on that grid already).
    """
    opts = check_read_options(read_options)
    turns = tuple(sorted({r.orientation for r in results if not r.error}))
    if len(turns) < 2 or opts.get("ignore_orientation"):
        return list(results), ""
    again = [i for i, r in enumerate(results) if not r.error and r.orientation != 1]
    redone = detect_files([results[i].path for i in again], spec, jobs=jobs, scheduler=scheduler,
                          progress=progress, read_options={**opts, "ignore_orientation": True},
                          thumb_width=thumb_width, view_only=view_only)
    out = list(results)
    for i, r in zip(again, redone):
        out[i] = replace(r, path=results[i].path)
    return out, ("calibrated on the sensor's pixel grid: the images' EXIF orientations differ "
                 f"({', '.join(map(str, turns))}), so none was applied; the camera matrix is the sensor's, "
                 "for the images as stored (cv2.IMREAD_IGNORE_ORIENTATION)")
