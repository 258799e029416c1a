"""A calibration's views chosen from a video: frames read with OpenCV, the board found, the views picked.

A video of a board waved before a camera holds hundreds of near-identical frames, some
of them smeared by the motion. :func:`choose_frames` reads every ``step``-th frame
(:func:`read_frames`), finds the board in it (:func:`sogdd.calib.targets.view_boards`, its
corners' precision measured) and picks, greedily, at most ``max_views`` frames, each

- **sharp**: its corners' median precision (px, :attr:`Board.precision`) within
  :data:`SHARP_FACTOR` of the video's best (a smeared frame's corners are less precise);
- at a **new pose**: far from every frame already taken (:func:`pose_distance`: the board's
  centre, its size and its tilt, read from the plane's vanishing line, which does not
  depend on how the board's corners were labelled);
- preferring **new coverage**: the frames whose corners fall in the most cells of a
  :data:`GRID` over the frame that no frame taken covers yet.

:func:`calibrate_video` calibrates from the frames chosen, as
:func:`~sogdd.calib.session.calibrate_images` does from images: each frame is a view named
``video.mp4#frame000123``, and its record says why it was chosen
(:attr:`~sogdd.calib.detection.ViewRecord.choice`, the ``reasons`` column of views.csv).
:func:`calibrate_video_into` is the same with its output folder, what ``sogdd calibrate
video.mp4`` runs.

The choice is in two steps that a rig of videos (:mod:`sogdd.calib.rig.video`) shares:
:func:`scan_video` finds the board in the frames read (:class:`VideoScan`), and
:func:`pick_frames` picks from one scan, or from several matched by frame index (a frame of a
rig is sharp, new and covering for a camera when it is for that camera's video).
"""

from __future__ import annotations

import math
import numbers
import os
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .detection import THUMB_WIDTH, Thumbnail, ViewRecord, make_thumbnail, pick_boards
from .fit import calibrate
from .model_selection import ModelChoice, check_model_choice
from .session import (
    ImageCalibration,
    ParameterError,
    check_inputs,
    check_output_folder,
    check_run_parameters,
    write_outputs,
)
from .targets.board import Board
from .targets.precision import measure_precision
from .targets.spec import BoardSpec, parse_board, view_boards

__all__ = ["GRID", "MAX_VIEWS", "SCAN", "SHARP_FACTOR", "VIDEO_SUFFIXES", "ChosenFrame", "FrameBoard",
           "PickedFrame", "VideoScan", "calibrate_video", "calibrate_video_into", "check_video_counts",
           "choose_frames", "default_step", "frame_count", "frame_name", "grid_cells", "is_video",
           "pick_frames", "pose_descriptor", "pose_distance", "read_frames", "scan_video"]

#: the file suffixes read as videos (lower case)
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".webm", ".mpg", ".mpeg", ".wmv")
#: most frames taken from a video (``--max-views``)
MAX_VIEWS = 40
#: most frames scanned when no step is given: every ``ceil(frames / SCAN)``-th frame is read
SCAN = 400
#: a frame is sharp when its corners' median precision is within this factor of the video's best
SHARP_FACTOR = 2.0
#: the cells (across, down) of the frame whose coverage by the boards' corners is counted
GRID = (8, 6)
#: what makes two poses near (:func:`pose_distance` 1): the board's centre moved by this fraction of
#: the frame's half diagonal, its size changed by this log ratio, its tilt vector by this much (~10 degrees)
POSE_SCALES = (0.15, 0.2, 0.15)


def is_video(path: str | os.PathLike) -> bool:
    """Whether ``path`` names a video file by its suffix (:data:`VIDEO_SUFFIXES`).

    Examples
    --------
    >>> is_video("take1.MP4"), is_video("frames/*.png")
    (True, False)
    """
    return Path(os.fspath(path)).suffix.lower() in VIDEO_SUFFIXES


def frame_name(video: str | os.PathLike, index: int) -> str:
    """A video frame's view name: ``video.mp4#frame000123``.

    Examples
    --------
    >>> frame_name("clips/take1.mp4", 123)
    'take1.mp4#frame000123'
    """
    return f"{Path(os.fspath(video)).name}#frame{int(index):06d}"


def _quiet_opencv():
    """OpenCV's log silenced (its video backends warn on stderr about files they cannot open); the old level
    to restore."""
    try:
        old = cv2.utils.logging.getLogLevel()
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
        return old
    except AttributeError:  # a build without the logging module
        return None


def _open(path: str | os.PathLike) -> cv2.VideoCapture:
    """The video opened, or a one-line ``ValueError`` naming it."""
    name = os.fspath(path)
    if not os.path.exists(name):
        raise ValueError(f"{name}: no such file")
    if os.path.isdir(name):
        raise ValueError(f"{name}: is a folder, not a video")
    old = _quiet_opencv()
    try:
        cap = cv2.VideoCapture(name)
    finally:
        if old is not None:
            cv2.utils.logging.setLogLevel(old)
    if not cap.isOpened():
        cap.release()
        raise ValueError(f"{name}: not a video OpenCV can read")
    return cap


def read_frames(path: str | os.PathLike, step: int = 1) -> Iterator[tuple[int, np.ndarray]]:
    """Every ``step``-th frame of a video, ``(index, image)``, in order (the frames between are skipped
    undecoded); a one-line ``ValueError`` when the file cannot be opened as a video or holds no frame.

    Examples
    --------
    >>> import tempfile
    >>> f = tempfile.mkdtemp() + "/v.avi"
    >>> w = cv2.VideoWriter(f, cv2.VideoWriter_fourcc(*"MJPG"), 25, (64, 48), False)
    >>> for k in range(5):
    ...     _ = w.write(np.full((48, 64), 40 * k, np.uint8))
    >>> w.release()
    >>> [(i, img.shape) for i, img in read_frames(f, step=2)]
    [(0, (48, 64, 3)), (2, (48, 64, 3)), (4, (48, 64, 3))]
    """
    for i, frame in _read(path, step):
        if frame is not None:
            yield i, frame


def _read(path: str | os.PathLike, step: int) -> Iterator[tuple[int, np.ndarray | None]]:
    """Every frame of a video, ``(index, image)``, the image None for the frames skipped (grabbed, not
    decoded): its last index + 1 is the frame count as read, which the container's may not be."""
    cap = _open(path)
    try:
        i = 0
        while True:
            if i % step:
                ok, frame = cap.grab(), None
            else:
                ok, frame = cap.read()
            if not ok:
                break
            yield i, frame
            i += 1
        if i == 0:
            raise ValueError(f"{os.fspath(path)}: no frame could be read")
    finally:
        cap.release()


def _container(path: str | os.PathLike) -> tuple[int, float]:
    """The video's frame count (0 when unknown) and frame rate (0 when unknown) as its container says."""
    cap = _open(path)
    try:
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        return max(0, int(cap.get(cv2.CAP_PROP_FRAME_COUNT))), fps if math.isfinite(fps) and fps > 0 else 0.0
    finally:
        cap.release()


def frame_count(path: str | os.PathLike) -> int:
    """The video's frame count as its container says (0 when it does not); a one-line ``ValueError`` when
    the file cannot be opened as a video.

    Examples
    --------
    >>> frame_count("missing.mp4")
    Traceback (most recent call last):
    ...
    ValueError: missing.mp4: no such file
    """
    return _container(path)[0]


@dataclass(frozen=True)
class ChosenFrame:
    """A frame chosen as a view (:func:`choose_frames`).

    Attributes
    ----------
    index : int
        The frame's index in the video (0 first).
    board : Board
        The board found in it, its corners' precision measured.
    size : tuple of int
        The frame's (width, height) in px.
    reasons : tuple of str
        Why it was chosen: ``sharp ...``, ``new pose ...`` and, when its corners cover cells of the
        frame no frame before it did, ``new coverage ...``.
    precision : float
        Its corners' median precision (px).
    pose : ndarray
        The board's pose as the frame shows it, for :func:`pose_distance`: ``(cx, cy, log size, tilt u,
        tilt v)``, the centre in half diagonals from the frame's, the tilt 0 facing the camera.
    thumbnail : Thumbnail or None
        A small grey copy of the frame for the report.
    """

    index: int
    board: Board
    size: tuple[int, int]
    reasons: tuple[str, ...]
    precision: float
    pose: np.ndarray
    thumbnail: Thumbnail | None = None


def pose_descriptor(board: Board, size: tuple[int, int]) -> np.ndarray | None:
    """The board's pose as the frame shows it: centre (fractions of the half diagonal), log size, and the
    tilt vector (the plane's vanishing line ``a u + b v + c = 0`` as ``(a, b) / c``, in coordinates
    centred on the frame in half diagonals: 0 for a board facing the camera); None without a homography."""
    w, h = size
    d = math.hypot(w, h) / 2
    pts = np.asarray(board.image_points, np.float64)
    lab = np.asarray(board.labels, np.float64)
    if len(pts) < 4:
        return None
    H, _ = cv2.findHomography(lab, pts, 0)
    if H is None or not np.all(np.isfinite(H)):
        return None
    norm = np.array([[1 / d, 0, -w / (2 * d)], [0, 1 / d, -h / (2 * d)], [0, 0, 1.0]])
    try:
        line = np.linalg.inv(norm @ H)[2]
    except np.linalg.LinAlgError:
        return None
    tilt = line[:2] / line[2] if abs(line[2]) > 1e-12 * np.abs(line).max() else np.array([1e3, 1e3])
    centre = (pts.mean(axis=0) - (w / 2, h / 2)) / d
    hull = cv2.convexHull(pts.astype(np.float32))
    area = max(float(cv2.contourArea(hull)), 1.0)
    return np.array([*centre, 0.5 * math.log(area) - math.log(d), *np.clip(tilt, -1e3, 1e3)])


def pose_distance(a: np.ndarray, b: np.ndarray) -> float:
    """How far apart two poses are, in units of :data:`POSE_SCALES` (under 1: near).

    ``a`` and ``b`` are descriptors ``(cx, cy, log size, tilt u, tilt v)`` of boards in a frame.

    Examples
    --------
    >>> a = np.array([0.0, 0, -0.5, 0, 0])
    >>> round(pose_distance(a, a + [0.15, 0, 0, 0, 0]), 3), round(pose_distance(a, a + [0, 0, 0, 0.3, 0]), 3)
    (1.0, 2.0)
    """
    sc, ss, st = POSE_SCALES
    return float(math.sqrt((np.hypot(*(a[:2] - b[:2])) / sc) ** 2 + ((a[2] - b[2]) / ss) ** 2
                           + (np.hypot(*(a[3:] - b[3:])) / st) ** 2))


def grid_cells(board: Board, size: tuple[int, int]) -> frozenset[tuple[int, int]]:
    """The cells ``(across, down)`` of :data:`GRID` over a frame of ``size`` that the board's corners fall in.

    Examples
    --------
    >>> b = Board(np.array([[10.0, 10.0], [630.0, 470.0], [12.0, 15.0]]), np.array([[0, 0], [1, 0], [2, 0]]))
    >>> sorted(grid_cells(b, (640, 480)))
    [(0, 0), (7, 5)]
    """
    gw, gh = GRID
    pts = np.asarray(board.image_points, np.float64)
    i = np.clip((pts[:, 0] / size[0] * gw).astype(int), 0, gw - 1)
    j = np.clip((pts[:, 1] / size[1] * gh).astype(int), 0, gh - 1)
    return frozenset(zip(i.tolist(), j.tolist()))


def _check_count(name: str, value: object, *, none: bool = False) -> None:
    if none and value is None:
        return
    integral = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not integral or value < 1:  # type: ignore[operator]
        why = "must be >= 1, got {value}" if integral else "must be an integer, got {value!r}"
        raise ParameterError(f"{{{name}}} {why}", **{name: name, "value": value})


def check_video_counts(max_views: int, step: int | None, min_views: int) -> None:
    """A video calibration's counts checked at the door: ``max_views`` and ``step`` (None: chosen) integers
    >= 1, ``max_views`` at least ``min_views``; a one-line :class:`~sogdd.calib.session.ParameterError`
    naming the bad one.

    Examples
    --------
    >>> check_video_counts(40, None, 3)
    >>> check_video_counts(2, None, 3)
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: max_views (2) must be at least min_views (3)
    """
    _check_count("max_views", max_views)
    _check_count("video_step", step, none=True)
    if max_views < min_views:
        raise ParameterError("{max_views} ({value}) must be at least {min_views} ({least})",
                             max_views="max_views", min_views="min_views", value=max_views, least=min_views)


def _checked(board: str | BoardSpec, model: object, square: float, min_views: int, max_views: int,
             step: int | None) -> BoardSpec:
    """The video calibration's parameters checked at the door (one line each); the board's specification."""
    spec = parse_board(board) if isinstance(board, str) else board
    if not isinstance(spec, BoardSpec):
        raise TypeError(f"board must be a specification string or a BoardSpec, got {type(board).__name__}")
    check_model_choice(model)
    check_run_parameters(square=square, jobs=1, min_views=min_views)
    check_video_counts(max_views, step, min_views)
    return spec


@dataclass(frozen=True)
class FrameBoard:
    """The board found in a frame read (:func:`scan_video`): the frame's ``index``, its best ``board``
    (corners' precision measured), its corners' median ``precision`` (px) and a small grey ``thumbnail``
    of the frame (None unless asked for)."""

    index: int
    board: Board
    precision: float
    thumbnail: Thumbnail | None = None


@dataclass(frozen=True)
class VideoScan:
    """What :func:`scan_video` found in a video.

    Attributes
    ----------
    path : str
        The video file.
    size : tuple of int
        Its frames' (width, height) in px.
    frames : int
        Its frames, counted as read (the container's count may differ).
    step : int
        Every ``step``-th frame was searched.
    fps : float
        The frame rate its container gives (0 when none).
    found : tuple of FrameBoard
        The frames searched that show the board, in order.
    """

    path: str
    size: tuple[int, int]
    frames: int
    step: int
    fps: float
    found: tuple[FrameBoard, ...]


def default_step(frames: int) -> int:
    """The step that reads at most :data:`SCAN` of ``frames`` frames (1 when the count is unknown, 0).

    Examples
    --------
    >>> default_step(109), default_step(4000), default_step(0)
    (1, 10, 1)
    """
    return max(1, math.ceil(frames / SCAN))


def scan_video(path: str | os.PathLike, spec: str | BoardSpec, step: int | None = None, *,
               thumbnails: bool = True, progress: bool = False, label: str = "frames") -> VideoScan:
    """The board found in every ``step``-th frame of a video (None: :func:`default_step`), each frame's best
    board (:func:`~sogdd.calib.detection.pick_boards`) with its corners' precision measured.

    ``label`` names the progress bar (on stderr, with ``progress``). A one-line ``ValueError`` when the file
    cannot be read as a video; a video without the board gives ``found == ()``.
    """
    from tqdm import tqdm

    spec = parse_board(spec) if isinstance(spec, str) else spec
    _check_count("video_step", step, none=True)
    total, fps = _container(path)
    step = step or default_step(total)
    found: list[FrameBoard] = []
    size, count = (0, 0), 0
    with tqdm(total=math.ceil(total / step) if total else None, desc=label, unit="frame", file=sys.stderr,
              disable=not progress) as bar:
        for index, frame in _read(path, step):
            count = index + 1
            if frame is None:
                continue
            size = (int(frame.shape[1]), int(frame.shape[0]))
            boards = measure_precision(frame, view_boards(frame, spec, True).boards)
            views, _ = pick_boards(boards, spec, "best")
            bar.update(1)
            if not views or views[0].precision is None or not np.isfinite(np.nanmedian(views[0].precision)):
                continue
            thumb = make_thumbnail(frame, THUMB_WIDTH) if thumbnails else None
            found.append(FrameBoard(index, views[0], float(np.nanmedian(views[0].precision)), thumb))
    return VideoScan(os.fspath(path), size, count, step, fps, tuple(found))


@dataclass(frozen=True)
class PickedFrame:
    """A frame index picked by :func:`pick_frames`: per scan, its view (None where that video shows no
    sharp board there) and, where it shows a board not taken, why (else "")."""

    index: int
    views: tuple[ChosenFrame | None, ...]
    skipped: tuple[str, ...]


def _candidates(scan: VideoScan, sharp: float) -> tuple[dict, dict, float]:
    """A scan's candidate boards (sharp, with a pose) by frame index, as ``(FrameBoard, pose, cells)``; why
    each of its other boards is not one; its best precision (the 10th percentile of its boards')."""
    best = float(np.percentile([f.precision for f in scan.found], 10)) if scan.found else math.nan
    ok, why = {}, {}
    for f in scan.found:
        desc = pose_descriptor(f.board, scan.size)
        if not f.precision <= sharp * best:
            why[f.index] = f"not sharp ({f.precision:.3g} px; {f.precision / best:.2f}x the video's best)"
        elif desc is None:
            why[f.index] = "no pose from its corners"
        else:
            ok[f.index] = (f, desc, grid_cells(f.board, scan.size))
    return ok, why, best


def pick_frames(scans: Sequence[VideoScan], max_views: int = MAX_VIEWS, *, sharp: float = SHARP_FACTOR,
                whole: bool = False) -> list[PickedFrame]:
    """The frames to calibrate from, picked greedily from one scan or from several matched by frame index
    (a rig's cameras), in frame order (module doc).

    A scan's board is a candidate when it is **sharp** (its precision within ``sharp`` of that video's best,
    the 10th percentile of its boards); a frame index is a candidate when some scan has a candidate there
    (with ``whole``, a board whole, its labels absolute: :attr:`Board.size` set; the other scans' boards in
    that frame may be partial).
    Each pick is a frame **new** for some scan that sees it (its pose farther than 1 from every pose that
    scan has taken, :func:`pose_distance`), the best by: seen by two or more scans (it ties them
    together), then the most new coverage (cells of :data:`GRID` no frame taken covers, summed over the
    scans), then the newest pose (capped at 4), then the sharpest (precision over its video's best, the
    mean over the scans). With one scan, the rules of :func:`choose_frames`. Every scan seeing a picked
    frame takes it: its pose and cells count as taken for that scan.

    Returns
    -------
    list of PickedFrame
        At most ``max_views``; each view's ``reasons``: ``sharp ...``, ``new pose ...`` (or, for a scan
        the frame is not new for, ``pose near one taken ...``), and ``new coverage ...`` where it covers
        new cells.
    """
    _check_count("max_views", max_views)
    n = len(scans)
    # per scan: frame index -> (FrameBoard, pose, cells) of its candidates; -> why its other boards are not
    ok, why, best = zip(*(_candidates(s, sharp) for s in scans)) if scans else ((), (), ())
    pool = sorted(set().union(*ok))
    if whole:  # a partial chessboard's labels are fixed by a whole board of its frame
        pool = [k for k in pool if any(k in mine and mine[k][0].board.size is not None for mine in ok)]
    taken: list[list[np.ndarray]] = [[] for _ in scans]
    covered: list[set[tuple[int, int]]] = [set() for _ in scans]
    picked: list[PickedFrame] = []
    while pool and len(picked) < max_views:
        scores = []
        for k in pool:
            seen = [c for c in range(n) if k in ok[c]]
            near = {c: min((pose_distance(ok[c][k][1], t) for t in taken[c]), default=math.inf) for c in seen}
            new = {c: len(ok[c][k][2] - covered[c]) for c in seen}
            q = float(np.mean([ok[c][k][0].precision / best[c] for c in seen]))
            scores.append((seen, near, new, (min(len(seen), 2), sum(new.values()),
                                             min(max(near.values()), 4.0), -q)))
        fresh = [j for j, (_, near, _, _) in enumerate(scores) if max(near.values()) > 1.0]
        if not fresh:
            break
        j = max(fresh, key=lambda j: scores[j][3])
        k = pool.pop(j)
        seen, near, new, _ = scores[j]
        views: list[ChosenFrame | None] = [None] * n
        for c in seen:
            f, desc, cells = ok[c][k]
            pose = ("new pose (the first)" if not taken[c] else
                    f"new pose ({near[c]:.1f} from the nearest taken)" if near[c] > 1.0 else
                    f"pose near one taken ({near[c]:.1f}), new for another camera")
            reasons = [f"sharp ({f.precision:.3g} px; {f.precision / best[c]:.2f}x the video's best)", pose]
            if new[c]:
                reasons.append(f"new coverage ({new[c]} of {GRID[0]}x{GRID[1]} cells)")
            views[c] = ChosenFrame(k, f.board, scans[c].size, tuple(reasons), f.precision, desc, f.thumbnail)
            taken[c].append(desc)
            covered[c] |= cells
        picked.append(PickedFrame(k, tuple(views), tuple(why[c].get(k, "") for c in range(n))))
    return sorted(picked, key=lambda p: p.index)


def choose_frames(path: str | os.PathLike, spec: str | BoardSpec, max_views: int = MAX_VIEWS, *,
                  step: int | None = None, sharp: float = SHARP_FACTOR, thumbnails: bool = True,
                  progress: bool = False) -> list[ChosenFrame]:
    """The frames of a video to calibrate from (module doc), in the video's order: :func:`scan_video`, then
    :func:`pick_frames`.

    Parameters
    ----------
    path : path
        The video file (anything OpenCV's ``VideoCapture`` reads).
    spec : str or BoardSpec
        The board (:func:`sogdd.calib.parse_board`).
    max_views : int
        Most frames chosen.
    step : int, optional
        Read every ``step``-th frame (None: enough to read at most :data:`SCAN` frames).
    sharp : float
        A frame is sharp when its corners' median precision is within this factor of the video's best
        (the 10th percentile of the frames with a board).
    thumbnails : bool
        Keep a small grey copy of each chosen frame (for the report).
    progress : bool
        A progress bar on stderr, over the frames read.

    Returns
    -------
    list of ChosenFrame
        At most ``max_views``; empty when no frame shows the board.

    Raises
    ------
    ValueError
        One line: the file cannot be read as a video; bad parameters
        (:class:`~sogdd.calib.session.ParameterError`).
    """
    _check_count("max_views", max_views)
    _check_count("video_step", step, none=True)
    scan = scan_video(path, spec, step, thumbnails=thumbnails, progress=progress)
    return [p.views[0] for p in pick_frames([scan], max_views, sharp=sharp)]


def calibrate_video(
    video: str | os.PathLike,
    board: str | BoardSpec = "chessboard:auto",
    *,
    square: float = 1.0,
    model: ModelChoice = "auto",
    min_views: int = 3,
    reject: bool = True,
    max_views: int = MAX_VIEWS,
    step: int | None = None,
    thumbnails: bool = True,
    progress: bool = False,
) -> ImageCalibration:
    """Calibrate a camera from a video of a board: its frames chosen (:func:`choose_frames`), then the fit.

    Parameters
    ----------
    video : path
        The video file.
    board, square, model, min_views, reject, thumbnails, progress
        As :func:`sogdd.calib.calibrate_images`.
    max_views : int
        Most frames taken as views.
    step : int, optional
        Read every ``step``-th frame (None: at most :data:`SCAN` frames read).

    Returns
    -------
    ImageCalibration
        Each view a chosen frame, named ``video.mp4#frame000123`` (:func:`frame_name`); its record's
        ``choice`` says why it was chosen.

    Raises
    ------
    ValueError
        One line: bad parameters (a :class:`~sogdd.calib.session.ParameterError` naming it); the file cannot
        be read as a video; no frame shows the board; too few frames chosen.
    """
    spec = _checked(board, model, square, min_views, max_views, step)
    name = os.fspath(video)
    chosen = choose_frames(video, spec, max_views, step=step, thumbnails=thumbnails, progress=progress)
    if not chosen:
        raise ValueError(f"{name}: no board ({spec}) in any frame read; check --board (chessboard: inner "
                         "corners, not squares)")
    if len(chosen) < min_views:
        raise ValueError(f"{name}: only {len(chosen)} frame(s) sharp and at distinct poses, under the "
                         f"{min_views} views needed; move the board more slowly, to more places")
    names = [frame_name(video, c.index) for c in chosen]
    cal = calibrate([c.board for c in chosen], chosen[0].size, square=float(square) * spec.label_step,
                    model=model, names=names, reject=reject, min_views=min_views)
    records = tuple(
        ViewRecord(n, name, "used" if cal.view_used[v] else "rejected",
                   "" if cal.view_used[v] else cal.reasons[v], v, choice="; ".join(c.reasons))
        for v, (n, c) in enumerate(zip(names, chosen)))
    return ImageCalibration(cal, spec, records, tuple(c.thumbnail for c in chosen) if thumbnails else ())


def calibrate_video_into(
    video: str | os.PathLike,
    out: str | os.PathLike,
    board: str | BoardSpec = "chessboard:auto",
    *,
    square: float = 1.0,
    model: ModelChoice = "auto",
    min_views: int = 3,
    reject: bool = True,
    max_views: int = MAX_VIEWS,
    step: int | None = None,
    report: bool = True,
    title: str | None = None,
    progress: bool = False,
) -> tuple[ImageCalibration, dict[str, Path]]:
    """:func:`calibrate_video` into an output folder (as :func:`sogdd.calib.session.calibrate_into`): every
    check first (the parameters, the video's name, ``out``), then the calibration, then its folder, complete
    or as it was. What ``sogdd calibrate video.mp4`` runs."""
    spec = _checked(board, model, square, min_views, max_views, step)
    check_inputs([video])
    check_output_folder(out, [video])
    result = calibrate_video(video, spec, square=square, model=model, min_views=min_views, reject=reject,
                             max_views=max_views, step=step, thumbnails=report, progress=progress)
    n = len(result.calibration.names)
    return result, write_outputs(result, out, report=report, inputs=[video],
                                 title=title or f"Camera calibration: {n} frames of {Path(video).name}, {spec}")
