"""What a calibration's inputs are, and the calibration each kind gets: one call for them all.

``sogdd calibrate`` and a Python caller alike give :func:`calibrate_inputs_into` one camera's images, its
one video, or a mapping of camera names to each camera's images or one video (a rig; a mapping of one
camera is a rig of one). :func:`input_kind` says which, and the rules that tie the parameters to the kind
are checked at the door, before any file is read, each a one-line
:class:`~sogdd.calib.session.ParameterError` (the command line names its flags instead):

=============  =====================================  =======================================================
kind           inputs                                 the calibration
=============  =====================================  =======================================================
``images``     image files, folders or patterns       :func:`sogdd.calib.session.calibrate_into`
``video``      one video file, alone                  :func:`sogdd.calib.video.calibrate_video_into`
``rig``        ``{name: images}``                     :func:`sogdd.calib.rig.session.calibrate_rig_into`
``rig-video``  ``{name: one video}``                  :func:`sogdd.calib.rig.video.calibrate_rig_video_into`
=============  =====================================  =======================================================

- a video is calibrated alone (no other input beside it), and its frame gives one view (``boards="best"``);
- ``allow_missing`` is for a rig of images, whose frames are matched by the numbers in the files' names
  (a rig of videos matches its frames by index);
- a rig's cameras are all videos, one each, or all images.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Literal

from .detection import BoardChoice
from .model_selection import ModelChoice
from .rig.session import RigImageCalibration, calibrate_rig_into
from .rig.video import calibrate_rig_video_into
from .session import ImageCalibration, ParameterError, calibrate_into
from .targets.spec import BoardSpec
from .video import MAX_VIEWS, calibrate_video_into, is_video

__all__ = ["InputKind", "calibrate_inputs_into", "input_kind"]

#: what a calibration's inputs are (module doc)
InputKind = Literal["images", "video", "rig", "rig-video"]

Inputs = str | os.PathLike | Iterable[str | os.PathLike]


def _items(inputs: Inputs) -> list:
    return [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)


def input_kind(inputs: Inputs | Mapping[str, Inputs]) -> InputKind:
    """The kind of a calibration's inputs (module doc), by their names: videos by their suffixes
    (:func:`sogdd.calib.video.is_video`).

    Raises
    ------
    ParameterError
        A video beside other inputs; a rig whose cameras mix videos and images.

    Examples
    --------
    >>> input_kind(["f1.png", "f2.png"]), input_kind("take1.mp4"), input_kind({"left": "l/*.png"})
    ('images', 'video', 'rig')
    >>> input_kind({"left": "left.mp4", "right": ["right.mp4"]})
    'rig-video'
    >>> input_kind(["take1.mp4", "f1.png"])
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: a video is calibrated alone: give one video file, not 2 inputs
    """
    if isinstance(inputs, Mapping):
        videos = [is_video(p) for given in inputs.values() for p in _items(given)]
        if any(videos) and not all(videos):
            raise ParameterError("a rig's cameras are all videos ({camera} NAME VIDEO, one each) or all "
                                 "images, not a mix", camera="camera")
        return "rig-video" if videos and all(videos) else "rig"
    items = _items(inputs)
    if any(is_video(p) for p in items):
        if len(items) != 1:
            raise ParameterError("a video is calibrated alone: give one video file, not {n} inputs",
                                 n=len(items))
        return "video"
    return "images"


def calibrate_inputs_into(
    inputs: Inputs | Mapping[str, Inputs],
    out: str | os.PathLike,
    board: str | BoardSpec = "chessboard:auto",
    *,
    boards: BoardChoice = "best",
    square: float = 1.0,
    model: ModelChoice | Mapping[str, ModelChoice] = "auto",
    jobs: int = 1,
    scheduler: str | None = None,
    min_views: int = 3,
    reject: bool = True,
    recursive: bool = False,
    allow_missing: bool = False,
    read_options: dict | None = None,
    max_views: int = MAX_VIEWS,
    video_step: int | None = None,
    report: bool = True,
    title: str | None = None,
    progress: bool = False,
) -> tuple[ImageCalibration | RigImageCalibration, dict[str, Path]]:
    """Calibrate from any kind of inputs into an output folder (module doc): what ``sogdd calibrate`` runs.

    Parameters
    ----------
    inputs : path, paths or mapping of str to paths
        One camera's image files, folders or glob patterns; its one video; or, for a rig (one camera or
        more, the first the reference), camera name -> its images or its one video.
    out, board, boards, square, model, jobs, scheduler, min_views, reject, recursive, read_options
        As :func:`sogdd.calib.session.calibrate_into` (a rig: per camera, as
        :func:`sogdd.calib.rig.session.calibrate_rig_into`; ``model`` may then map camera names to models).
        A video reads its frames itself: ``jobs``, ``scheduler``, ``recursive`` and ``read_options`` are
        for images.
    report, title, progress
        As :func:`sogdd.calib.session.calibrate_into`.
    allow_missing : bool
        A rig of images: a frame some cameras have no image of is used by the others.
    max_views, video_step : int
        Videos: the most frames taken as views, and every how many frames one is searched (None: at most
        :data:`~sogdd.calib.video.SCAN` frames read), as :func:`sogdd.calib.video.calibrate_video_into`.

    Returns
    -------
    result : ImageCalibration or RigImageCalibration
        One camera's (images, a video) or a rig's (a mapping).
    files : dict of str to Path
        The files written, as the kind's writer returns them.

    Raises
    ------
    ParameterError
        One line, before any file is read: the rules of the module doc, and the kind's own checks.
    ValueError, OSError
        As the kind's calibration.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> calibrate_inputs_into(d / "take1.mp4", d / "out", "chessboard:9x6", boards="all")
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: boards all is for images; a video's frame gives one view
    >>> calibrate_inputs_into({"left": d / "l.mp4"}, d / "out", "chessboard:9x6", allow_missing=True)
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: allow_missing is for a rig of images; a rig of videos matches its \
frames by index
    >>> (d / "out").exists()
    False
    """
    kind = input_kind(inputs)
    if allow_missing and kind in ("images", "video"):
        raise ParameterError("{allow_missing} is for a rig ({camera} NAME PATTERN... per camera)",
                             allow_missing="allow_missing", camera="camera")
    common = dict(square=square, model=model, min_views=min_views, reject=reject, report=report, title=title,
                  progress=progress)
    if kind == "images":
        return calibrate_into(inputs, out, board, boards=boards, jobs=jobs, scheduler=scheduler,
                              recursive=recursive, read_options=read_options, **common)
    if kind == "rig":
        return calibrate_rig_into(inputs, out, board, boards=boards, jobs=jobs, scheduler=scheduler,
                                  recursive=recursive, allow_missing=allow_missing, read_options=read_options,
                                  **common)
    if boards != "best":
        raise ParameterError("{boards} all is for images; a video's frame gives one view", boards="boards")
    if kind == "video":
        return calibrate_video_into(_items(inputs)[0], out, board, max_views=max_views, step=video_step,
                                    **common)
    if allow_missing:
        raise ParameterError("{allow_missing} is for a rig of images; a rig of videos matches its frames by "
                             "index", allow_missing="allow_missing")
    return calibrate_rig_video_into(inputs, out, board, max_views=max_views, step=video_step, **common)
