"""A rig calibrated from videos, one per camera, their frames matched by index.

Frame ``k`` of every camera's video is one moment of the rig (the cameras recorded together, from
the first frame on: triggered, or their videos cut to a common start). :func:`calibrate_rig_video`
finds the board in every ``step``-th frame of each video (:func:`sogdd.calib.video.scan_video`) and
picks the rig's frames with the rules of one camera's video (:func:`sogdd.calib.video.pick_frames`),
applied to the rig:

- a frame index is a candidate when at least one camera sees a **sharp** board in it (its corners'
  precision within :data:`~sogdd.calib.video.SHARP_FACTOR` of that camera's best), for a chessboard
  a whole one (the other cameras' boards of that frame may be partial);
- it is taken only when it is **new** for some camera that sees it (a pose far from every frame that
  camera has taken), and taken by every camera that sees it;
- frames seen by **two or more cameras** come first (they tie the cameras together), then the most
  new coverage of the cameras' frames, then the newest pose, the sharpest last;
- at most ``max_views`` frames, every ``step``-th frame searched.

Videos of different lengths are matched over their **common prefix** (the shortest video's frames):
the frames of the longer ones past it are not used, and the rig's notes say so. Then the rig's fit
(:func:`~sogdd.calib.rig.session.fit_rig_boards`, as from images): each camera's views are its
boards of the frames taken, named ``left.mp4#frame000123`` (:func:`sogdd.calib.video.frame_name`),
and each record's ``choice`` says why the frame was taken (the ``reasons`` column of the camera's
views.csv). :func:`calibrate_rig_video_into` writes the output folder as a rig of images does
(:func:`~sogdd.calib.rig.session.write_rig_outputs`), what ``sogdd calibrate --camera left left.mp4
--camera right right.mp4`` runs.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

from ..detection import ViewRecord
from ..model_selection import ModelChoice
from ..session import check_inputs
from ..targets.spec import BoardSpec
from ..video import (
    MAX_VIEWS,
    PickedFrame,
    VideoScan,
    check_video_counts,
    default_step,
    frame_count,
    frame_name,
    is_video,
    pick_frames,
    scan_video,
)
from .result import RigCalibration, cameras_text
from .session import (
    RigImageCalibration,
    check_rig_output_folder,
    check_rig_parameters,
    fit_rig_boards,
    write_rig_outputs,
)

__all__ = ["calibrate_rig_video", "calibrate_rig_video_into", "check_rig_videos"]

Video = str | os.PathLike


def check_rig_videos(cameras: Mapping[str, Video | Sequence[Video]]) -> dict[str, Path]:
    """Each camera's one video file, checked before any frame is read: a one-line ``ValueError`` naming the
    camera for a camera given no file or several, a file not named as a video
    (:func:`sogdd.calib.video.is_video`), missing, a folder, a device or a FIFO, a name that is not valid
    UTF-8, or a video given to two cameras.

    Examples
    --------
    >>> check_rig_videos({"left": "left.mp4", "right": ["r1.mp4", "r2.mp4"]})
    Traceback (most recent call last):
    ...
    ValueError: camera right: give one video file, not 2
    >>> check_rig_videos({"left": "left.mp4", "right": "right/*.png"})
    Traceback (most recent call last):
    ...
    ValueError: camera right: right/*.png is not a video (.mp4, .avi, .mov, ...); a rig's cameras are all \
videos, one each, or all images
    >>> check_rig_videos({"left": "left.mp4", "right": "right.mp4"})
    Traceback (most recent call last):
    ...
    ValueError: camera left: left.mp4: no such file
    """
    given: dict[str, Path] = {}
    for name, inputs in cameras.items():  # what was given first, then the files
        files = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
        if len(files) != 1:
            raise ValueError(f"camera {name}: give one video file, not {len(files)}")
        if not is_video(files[0]):
            raise ValueError(f"camera {name}: {os.fspath(files[0])} is not a video (.mp4, .avi, .mov, ...); a "
                             "rig's cameras are all videos, one each, or all images")
        given[name] = Path(os.fspath(files[0]))
    owner: dict[str, str] = {}
    for name, path in given.items():
        if not path.exists():
            raise ValueError(f"camera {name}: {path}: no such file")
        if path.is_dir():
            raise ValueError(f"camera {name}: {path}: is a folder, not a video")
        try:
            check_inputs([path])  # a device or a FIFO would be read for ever; a name no output can hold
        except ValueError as exc:
            raise ValueError(f"camera {name}: {exc}") from None
        key = os.path.realpath(path)
        if owner.setdefault(key, name) != name:
            raise ValueError(f"{path} is the video of both camera {owner[key]} and camera {name}; give each "
                             "camera its own video")
    return given


def _says(name: str, fn, *args, **kwargs):
    """``fn(*args, **kwargs)``, its one-line ``ValueError`` naming the camera."""
    try:
        return fn(*args, **kwargs)
    except ValueError as exc:
        raise ValueError(f"camera {name}: {exc}") from None


def _length_notes(scans: dict[str, VideoScan]) -> list[str]:
    """What the rig's notes say of videos that differ in length or frame rate."""
    notes = []
    counts = {n: s.frames for n, s in scans.items()}
    common = min(counts.values())
    if len(set(counts.values())) > 1:
        notes.append(f"videos of unequal length ({', '.join(f'{n} {k}' for n, k in counts.items())} frames): "
                     f"frames matched by index over the first {common}, the longer videos' later frames unused")
    rates = {n: s.fps for n, s in scans.items() if s.fps > 0}
    if len(rates) > 1 and max(rates.values()) - min(rates.values()) > 1e-3 * max(rates.values()):
        # frames matched by index are one moment only if the cameras ran at one rate
        notes.append(f"videos at different frame rates ({', '.join(f'{n} {r:.3g}' for n, r in rates.items())} "
                     "fps): frames matched by index are not one moment unless the cameras were triggered "
                     "together")
    return notes


def _choice(pick: PickedFrame, c: int, names: Sequence[str]) -> str:
    """Why camera ``c``'s view of a picked frame was taken: its reasons, and which cameras saw the board."""
    seen = [n for n, v in zip(names, pick.views) if v is not None]
    tie = f"seen by {seen[0]} only" if len(seen) == 1 else f"seen by {', '.join(seen)}"
    return "; ".join([*pick.views[c].reasons, tie])


def _records(c: int, name: str, video: Path, picks: list[PickedFrame], names: Sequence[str],
             rig: RigCalibration) -> tuple[ViewRecord, ...]:
    """Camera ``c``'s record of every frame taken (``view`` the frame's index in the rig): its view used or
    rejected and why it was taken; a smeared board ignored; no board."""
    cal = rig.camera(name).calibration
    out = []
    for f, p in enumerate(picks):
        label = frame_name(video, p.index)
        if p.views[c] is not None:
            used = bool(cal.view_used[f])
            out.append(ViewRecord(label, os.fspath(video), "used" if used else "rejected",
                                  "" if used else cal.reasons[f], f, choice=_choice(p, c, names)))
        elif p.skipped[c]:
            out.append(ViewRecord(label, os.fspath(video), "ignored", p.skipped[c], f))
        else:
            out.append(ViewRecord(label, os.fspath(video), "no board", "no board", f))
    return tuple(out)


def calibrate_rig_video(
    cameras: Mapping[str, Video | Sequence[Video]],
    board: str | BoardSpec = "chessboard:auto",
    *,
    square: float = 1.0,
    model: ModelChoice | Mapping[str, ModelChoice] = "auto",
    min_views: int = 3,
    reject: bool = True,
    max_views: int = MAX_VIEWS,
    step: int | None = None,
    thumbnails: bool = True,
    progress: bool = False,
) -> RigImageCalibration:
    """Calibrate a rig (one or more cameras) from one video per camera, frame ``k`` of every video one
    moment of the rig (module doc).

    Parameters
    ----------
    cameras : mapping of str to path
        Camera name (the first is the reference) -> its video file (or a one-item list of it).
    board, square, model, min_views, reject
        As :func:`sogdd.calib.rig.calibrate_rig_images` (``min_views``: per camera).
    max_views : int
        Most frames taken (each gives every camera that sees the board a view).
    step : int, optional
        Search every ``step``-th frame (None: at most :data:`~sogdd.calib.video.SCAN` frames of the
        shortest video, by the containers' counts).
    thumbnails : bool
        Keep a small grey copy of each view's frame for the report.
    progress : bool
        A progress bar per camera on stderr, over the frames searched.

    Returns
    -------
    RigImageCalibration
        ``frames``: the frame indices taken (as text); ``views``: per camera, one record per frame taken
        (``used`` or ``rejected`` with ``choice`` saying why it was taken, ``ignored`` for a smeared board,
        ``no board``); the rig's notes say when the videos differ in length (the common prefix used) or in
        frame rate.

    Raises
    ------
    ParameterError
        One line naming the parameter (:class:`sogdd.calib.session.ParameterError`): fewer than two
        cameras, a bad camera name, ``chessboard:auto``, ``square``, ``min_views``, ``max_views`` or
        ``step`` out of range.
    ValueError
        One line: a camera without exactly one video file, a file that is not a video or cannot be read
        as one; a camera whose video shows no board; too few frames for a camera.

    Examples
    --------
    >>> calibrate_rig_video({"left": "left.mp4", "right": "right.mp4"}, "chessboard:9x6", max_views=0)
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: max_views must be >= 1, got 0
    """
    names, spec, models = check_rig_parameters(cameras, board, model, "best", square, 1, min_views)
    check_video_counts(max_views, step, min_views)
    videos = check_rig_videos(cameras)
    counts = [_says(n, frame_count, videos[n]) for n in names]
    step = step or default_step(min((k for k in counts if k > 0), default=0))
    scans = {n: _says(n, scan_video, videos[n], spec, step, thumbnails=thumbnails, progress=progress,
                      label=f"camera {n}") for n in names}
    common = min(s.frames for s in scans.values())
    # frames matched by index: past the shortest video's end no frame is a moment of every camera
    matched = [replace(scans[n], found=tuple(f for f in scans[n].found if f.index < common)) for n in names]
    for n, s in zip(names, matched):
        if not s.found:
            part = f" (its first {common} frames, the shortest video's)" if common < s.frames else ""
            raise ValueError(f"camera {n}: no board ({spec}) in any frame read of {videos[n].name}{part}; "
                             "check --board (chessboard: inner corners, not squares)")
    # a chessboard's partial view is labelled against a whole one of its frame (the cameras' labels agree)
    picks = pick_frames(matched, max_views, whole=spec.kind == "chessboard")
    for c, n in enumerate(names):
        got = sum(p.views[c] is not None for p in picks)
        if got < min_views:
            raise ValueError(f"camera {n}: only {got} frame(s) with a sharp board at distinct poses, under the "
                             f"{min_views} views needed; move the board more slowly, to more places")
    frames = tuple(str(p.index) for p in picks)
    views = {n: [None if p.views[c] is None else p.views[c].board for p in picks] for c, n in enumerate(names)}
    labels = {n: [frame_name(videos[n], p.index) for p in picks] for n in names}
    sizes = {n: s.size for n, s in zip(names, matched)}
    rig = fit_rig_boards(views, sizes, spec, square=square, models=models, frames=frames, view_names=labels,
                         reject=reject, min_views=min_views)
    notes = _length_notes(scans)
    if notes:
        rig = replace(rig, notes=(*rig.notes, *notes))
    records = {n: _records(c, n, videos[n], picks, names, rig) for c, n in enumerate(names)}
    thumbs = {n: tuple(None if p.views[c] is None else p.views[c].thumbnail for p in picks)
              for c, n in enumerate(names)}
    return RigImageCalibration(rig, spec, records, frames, thumbs if thumbnails else {})


def calibrate_rig_video_into(
    cameras: Mapping[str, Video | Sequence[Video]],
    out: str | os.PathLike,
    board: str | BoardSpec = "chessboard:auto",
    *,
    square: float = 1.0,
    model: ModelChoice | Mapping[str, ModelChoice] = "auto",
    min_views: int = 3,
    reject: bool = True,
    max_views: int = MAX_VIEWS,
    step: int | None = None,
    report: bool = True,
    title: str | None = None,
    progress: bool = False,
) -> tuple[RigImageCalibration, dict[str, Path]]:
    """:func:`calibrate_rig_video` into an output folder, what ``sogdd calibrate --camera left left.mp4
    --camera right right.mp4`` runs: every check first (the parameters, the videos' names, ``out``:
    :func:`~sogdd.calib.rig.session.check_rig_output_folder`), then the calibration, then the folder
    (:func:`~sogdd.calib.rig.session.write_rig_outputs`: rig.yaml, rig.json, ``NAME/`` per camera,
    report.html), complete or as it was.

    Parameters
    ----------
    cameras, board, square, model, min_views, reject, max_views, step, progress
        As :func:`calibrate_rig_video`.
    out : path
        The output folder: missing (made), empty, or a previous rig output (replaced whole).
    report : bool
        Write report.html and its figures; the frames' thumbnails are kept for it only then.
    title : str, optional
        The report's title (default: the cameras, the frames, the videos and the board).

    Returns
    -------
    result : RigImageCalibration
    files : dict of str to Path
        Name relative to ``out`` -> its final path.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> calibrate_rig_video_into({"left": d / "l.mp4", "right": d / "r.mp4"}, d / "rig", "chessboard:9x6")
    Traceback (most recent call last):
    ...
    ValueError: camera left: ...l.mp4: no such file
    >>> (d / "rig").exists()
    False
    """
    names, spec, _ = check_rig_parameters(cameras, board, model, "best", square, 1, min_views)
    check_video_counts(max_views, step, min_views)
    videos = check_rig_videos(cameras)
    check_rig_output_folder(out, list(videos.values()))
    result = calibrate_rig_video(videos, spec, square=square, model=model, min_views=min_views, reject=reject,
                                 max_views=max_views, step=step, thumbnails=report, progress=progress)
    n = len(result.frames)
    files = ", ".join(v.name for v in videos.values())
    return result, write_rig_outputs(
        result, out, report=report, inputs=list(videos.values()),
        title=title or f"Rig calibration: {cameras_text(len(names))}, {n} frames of {files}, {spec}")
