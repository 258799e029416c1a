"""A rig calibration session: each camera's images of a board in, the rig and every image's fate out.

The library's entry point for rigs, what ``sogdd calibrate --camera NAME PATTERN ...`` runs.
:func:`calibrate_rig_images` matches the cameras' images into frames
(:func:`~sogdd.calib.rig.frames.match_frames`), finds the board in every image of every
camera in one pass (:func:`sogdd.calib.detection.detect_files`: one pool of workers for
all of them), keeps each image's best board (:func:`~sogdd.calib.detection.pick_boards`),
checks that each camera's images agree (one size each), chooses each camera's model, and
fits the rig (:func:`~sogdd.calib.rig.fit.calibrate_rig`). :func:`write_rig_outputs`
writes the output folder: rig.yaml, rig.json, report.html with its figures, and each
camera's own files in ``NAME/`` (:mod:`sogdd.calib.rig.files`), under the one-camera
session's contract (:func:`sogdd.calib.session.write_folder`): the folder ends complete
or as it was, and only a missing or empty folder or a previous output is replaced.
:func:`calibrate_rig_into` is the two in one, what ``sogdd calibrate --camera ...`` runs.

A rig's own rules are checked at the door, before any image is read, each a one-line
:class:`~sogdd.calib.session.ParameterError` naming the parameters (the command line
names its flags instead): one or more cameras with valid names, a board of known size
(``chessboard:auto`` cannot be a rig's: the cameras' corner labels must agree), and
one board per image (``boards="best"``: a frame is one pose of one board).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

from ...collection import relative_names
from ..detection import (
    BOARD_CHOICES,
    THUMB_WIDTH,
    Thumbnail,
    ViewRecord,
    ViewResult,
    check_read_options,
    detect_files,
    on_sensor_grid,
    pick_boards,
)
from ..model_selection import ModelChoice, check_model_choice, select_model
from ..session import (
    ParameterError,
    check_detections,
    check_inputs,
    check_output_folder,
    check_run_parameters,
    common_image_size,
    expand_images,
    foreign_rig_entry,
    write_folder,
)
from ..targets.spec import BoardSpec, parse_board
from .files import check_camera_names, write_rig
from .fit import calibrate_rig
from .frames import match_frames
from .result import RigCalibration, cameras_text

__all__ = ["RigImageCalibration", "calibrate_rig_images", "calibrate_rig_into", "check_rig_output_folder",
           "check_rig_parameters", "fit_rig_boards", "foreign_rig_entry", "write_rig_outputs"]

Inputs = str | os.PathLike | Iterable[str | os.PathLike]


@dataclass(frozen=True)
class RigImageCalibration:
    """A rig calibration from image files, with what became of every input (:func:`calibrate_rig_images`).

    Attributes
    ----------
    rig : RigCalibration
        The rig; each camera's views are its images of the frames, named by their
        files relative to that camera's inputs' common folder.
    board : BoardSpec
    views : dict of str to tuple of ViewRecord
        Per camera, every input in frame order, one record per image (``view``
        is the frame's index; None for an image that could not be read), and an
        ignored board beside an image's view as a record ``name#2`` after it.
    frames : tuple of str
        The frames' names (their number, or their rank in sorted order).
    thumbnails : dict of str to tuple of Thumbnail or None
        Per camera, per frame, the small grey image the report draws on.
    """

    rig: RigCalibration
    board: BoardSpec
    views: dict[str, tuple[ViewRecord, ...]]
    frames: tuple[str, ...]
    thumbnails: dict[str, tuple[Thumbnail | None, ...]] = field(default_factory=dict)

    @property
    def unreadable(self) -> tuple[ViewRecord, ...]:
        """The inputs of every camera that could not be read (or whose worker process died)."""
        return tuple(v for views in self.views.values() for v in views if v.status == "unreadable")


def _check_spec(board: str | BoardSpec, boards: str) -> BoardSpec:
    """The rig's board: of known size, one per image."""
    spec = parse_board(board) if isinstance(board, str) else board
    if not isinstance(spec, BoardSpec):
        raise TypeError(f"board must be a specification string or a BoardSpec, got {type(board).__name__}")
    if spec.kind == "chessboard" and spec.pattern is None:
        # a chessboard's labels are relative to what each image shows: only its size makes them agree
        raise ParameterError("{board} chessboard:auto cannot calibrate a rig: the cameras' corner labels must "
                             "agree, which needs the board's size; give {board} chessboard:COLSxROWS (inner "
                             "corners)", board="board")
    if boards not in BOARD_CHOICES:
        raise ValueError(f"boards must be one of {', '.join(BOARD_CHOICES)}, got {boards!r}")
    if boards != "best":
        raise ParameterError("{boards} {value} cannot be used with {cameras}: a rig's frame is one pose of one "
                             "board", boards="boards", value=boards, cameras="a rig")
    return spec


def _check_models(model: str | Mapping[str, str], names: tuple[str, ...]) -> dict[str, str]:
    """Each camera's model (``"auto"`` or one of :data:`~sogdd.calib.MODELS`), one for all or by name."""
    given = dict(model) if isinstance(model, Mapping) else {n: model for n in names}
    if set(given) != set(names):
        odd = sorted(set(given) ^ set(names))
        raise ValueError(f"model: give one model, or one per camera ({', '.join(names)}); {odd[0]!r} is not "
                         "both a camera and a key")
    for m in given.values():
        check_model_choice(m)
    return {n: given[n] for n in names}


def check_rig_parameters(cameras: Mapping[str, Inputs], board: str | BoardSpec,
                         model: ModelChoice | Mapping[str, ModelChoice], boards: str, square: float,
                         jobs: int, min_views: int) -> tuple[tuple[str, ...], BoardSpec, dict[str, str]]:
    """A rig's parameters checked before any input is read (a one-line
    :class:`~sogdd.calib.session.ParameterError` or ``ValueError``): one or more cameras with valid names,
    the board (of known size, one per image), the numbers, each camera's model. Returns the cameras' names,
    the board's specification and each camera's model."""
    try:
        names = check_camera_names(cameras)
    except ValueError as exc:
        raise ParameterError("{cameras}: {why}", cameras="cameras", why=str(exc)) from None
    if not names:
        raise ParameterError("{cameras}: no camera given", cameras="cameras")
    spec = _check_spec(board, boards)
    check_run_parameters(square=square, jobs=jobs, min_views=min_views)
    return names, spec, _check_models(model, names)


def _expand(cameras: Mapping[str, Inputs], recursive: bool) -> dict[str, list[Path]]:
    """Each camera's image files; a file given to two cameras is refused (a frame is one moment per camera)."""
    out: dict[str, list[Path]] = {}
    owner: dict[str, str] = {}
    for name, inputs in cameras.items():
        given = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
        paths = expand_images(given, recursive=recursive)
        if not paths:
            raise ParameterError("{camera} {name}: no input images", camera="camera", name=name)
        for p in paths:
            key = os.path.realpath(p)
            if owner.setdefault(key, name) != name:
                raise ValueError(f"{p} is an image of both camera {owner[key]} and camera {name}; give each "
                                 "camera its own images")
        out[name] = paths
    return out


def calibrate_rig_images(
    cameras: Mapping[str, Inputs],
    board: str | BoardSpec = "chessboard:auto",
    *,
    square: float = 1.0,
    model: ModelChoice | Mapping[str, ModelChoice] = "auto",
    boards: Literal["best"] = "best",
    jobs: int = 1,
    scheduler: str | None = None,
    min_views: int = 3,
    reject: bool = True,
    recursive: bool = False,
    allow_missing: bool = False,
    read_options: dict | None = None,
    thumbnails: bool = True,
    progress: bool = False,
) -> RigImageCalibration:
    """Calibrate a rig from each camera's image files of a board.

    A rig of one camera is that camera fitted by the rig's joint solver (the same
    numbers as :func:`sogdd.calib.calibrate` up to the fit's tolerance) and written
    as a rig (``rig.yaml`` with its one camera, ``NAME/``): scripts that calibrate
    any number of cameras get one layout.

    The board's pose in frame :math:`f` and each camera's pose
    :math:`x_{cam} = R\\,x_{first} + T` are fitted jointly with every camera's
    intrinsics (:func:`~sogdd.calib.rig.fit.calibrate_rig`): a corner with board
    point :math:`X` seen by camera :math:`c` in frame :math:`f` is predicted at
    :math:`\\pi_c(R_c (R_f X + t_f) + T_c)`.

    Parameters
    ----------
    cameras : mapping of str to inputs
        Camera name (letters, digits, ``_``, ``-``; the first is the reference)
        -> its image files, folders or glob patterns
        (:func:`sogdd.collection.expand_inputs`). Images are matched into frames by
        the number in their file names, else by sorted order
        (:func:`~sogdd.calib.rig.frames.match_frames`).
    board : str or BoardSpec
        ``chessboard:COLSxROWS`` (inner corners) or ``charuco:COLSxROWS:MARKER:DICT``;
        ``chessboard:auto`` is refused: the cameras' labels must agree, which
        needs the board's size.
    square : float
        The side of a board square, in the unit the translations should have.
    model : str or mapping of str to str
        ``"auto"`` (each camera's model chosen by its data, by the one-camera
        fit) or a model of :data:`sogdd.calib.MODELS`; one for every camera, or
        one per camera name.
    boards : {"best"}
        An image's view is its best board (:func:`~sogdd.calib.detection.pick_boards`);
        the others are records of status ``ignored``. ``"all"`` is refused: a
        frame is one pose of one board.
    jobs, scheduler, min_views, reject, recursive, read_options, thumbnails, progress
        As :func:`sogdd.calib.calibrate_images` (``min_views``: per camera).
    allow_missing : bool
        A frame some cameras have no image of is used by the others (its view
        in those cameras absent); by default it is an error, naming the frames.

    Returns
    -------
    RigImageCalibration
        An image that cannot be read is a record of status ``unreadable``; its
        camera's view of that frame is absent and the rig uses the others.

    Raises
    ------
    ParameterError
        One line naming the parameter (:class:`sogdd.calib.session.ParameterError`):
        no camera, a bad camera name, ``chessboard:auto``,
        ``boards="all"``, a camera without input, ``square``, ``jobs`` or
        ``min_views`` out of range.
    ValueError
        One line: another bad parameter; frames that do not match; a camera
        none of whose images can be read, or that sees no board; a camera's
        images of different sizes; too few views.
    sogdd.collection.BatchInterrupted
        On Ctrl-C or ``SIGTERM``.

    Examples
    --------
    >>> from sogdd.calib.rig.session import calibrate_rig_images
    >>> calibrate_rig_images({"left": "l/*.png", "right": "r/*.png"})
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: board chessboard:auto cannot calibrate a rig: the cameras' corner \
labels must agree, which needs the board's size; give board chessboard:COLSxROWS (inner corners)
    >>> calibrate_rig_images({"left": "l/*.png", "right": "r/*.png"}, "chessboard:9x6", boards="all")
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: boards all cannot be used with a rig: a rig's frame is one pose of \
one board
    """
    names, spec, models = check_rig_parameters(cameras, board, model, boards, square, jobs, min_views)
    opts = check_read_options(read_options)
    frames, per = match_frames(_expand(cameras, recursive), allow_missing=allow_missing)
    files = [p for n in names for p in per[n] if p is not None]
    run = dict(jobs=jobs, scheduler=scheduler, progress=progress, read_options=opts,
               thumb_width=THUMB_WIDTH if thumbnails else None, view_only=True)  # a frame: one board
    by_file = dict(zip(files, detect_files(files, spec, **run)))
    results, ignored, labels, grids = {}, {}, {}, {}
    for n in names:  # a camera turned between shots is calibrated on its sensor's grid
        mine, grids[n] = on_sensor_grid([by_file[p] for p in per[n] if p is not None], spec, **run)
        picked = [pick_boards(r.boards, spec, "best") for r in mine]
        mine = [replace(r, boards=kept) for r, (kept, _) in zip(mine, picked)]
        _camera_says(n, check_detections, mine, spec)
        it, beside = iter(mine), iter(b for _, b in picked)
        results[n] = [None if p is None else next(it) for p in per[n]]
        ignored[n] = [() if p is None else next(beside) for p in per[n]]
        rel = iter(relative_names([p for p in per[n] if p is not None]))
        labels[n] = [f"(frame {f}: no image)" if p is None else next(rel) for f, p in zip(frames, per[n])]
    sizes = {n: _camera_says(n, common_image_size, [r for r in results[n] if r is not None]) for n in names}
    views = {n: [r.boards[0] if r is not None and r.boards else None for r in results[n]] for n in names}
    rig = fit_rig_boards(views, sizes, spec, square=square, models=models, frames=frames, view_names=labels,
                         reject=reject, min_views=min_views)
    rig = _unreadable(_sensor_grids(rig, grids), results)
    records = {n: _records(n, results[n], labels[n], ignored[n], rig, spec) for n in names}
    thumbs = {n: tuple(None if r is None else r.thumbnail for r in results[n]) for n in names}
    return RigImageCalibration(rig, spec, records, tuple(frames), thumbs if thumbnails else {})


def fit_rig_boards(views: Mapping[str, Sequence], sizes: Mapping[str, tuple[int, int]], spec: BoardSpec, *,
                   square: float, models: Mapping[str, str], frames: Sequence[str],
                   view_names: Mapping[str, Sequence[str]], reject: bool, min_views: int) -> RigCalibration:
    """The rig fitted on each camera's board per frame (None: no view): each camera's model as given in
    ``models`` or, ``"auto"``, chosen by its views (:func:`sogdd.calib.model_selection.select_model`), then
    :func:`~sogdd.calib.rig.fit.calibrate_rig`, in the unit of ``square`` (the side of a square of ``spec``).
    What :func:`calibrate_rig_images` and :func:`sogdd.calib.rig.video.calibrate_rig_video` share."""
    unit = float(square) * spec.label_step  # the board length of one label step
    chosen, selection = _choose_models(dict(models), dict(views), dict(sizes), unit, reject, min_views)
    rig = calibrate_rig(views, sizes, square=unit, models=chosen, frames=frames, view_names=view_names,
                        pattern=spec.pattern, reject=reject, min_views=min_views)
    return replace(rig, model_selection=selection) if selection else rig


def _unreadable(rig: RigCalibration, results: Mapping[str, list[ViewResult | None]]) -> RigCalibration:
    """The rig, each camera's view of a frame whose image could not be read said so in its calibration's
    reasons (``unreadable: why``), not "no board" as the fit, which saw no board there, says."""
    def said(cam):
        reasons = tuple(f"unreadable: {r.error}" if r is not None and r.error else why
                        for r, why in zip(results[cam.name], cam.calibration.reasons))
        return replace(cam, calibration=replace(cam.calibration, reasons=reasons))
    return replace(rig, cameras=tuple(said(c) for c in rig.cameras))


def _sensor_grids(rig: RigCalibration, grids: dict[str, str]) -> RigCalibration:
    """The rig, each camera on its sensor's grid saying so (``grids[name]``: its note, "" for none)."""
    def said(c):
        cal = c.calibration
        return replace(c, calibration=replace(cal, pixel_grid="sensor", notes=(*cal.notes, grids[c.name])))

    return replace(rig, notes=(*rig.notes, *(f"camera {n}: {g}" for n, g in grids.items() if g)),
                   cameras=tuple(said(c) if grids.get(c.name) else c for c in rig.cameras))


def _camera_says(name: str, check, *args):
    """``check(*args)``, its one-line error naming the camera."""
    try:
        return check(*args)
    except ValueError as exc:
        raise ValueError(f"camera {name}: {exc}") from None


def _choose_models(models: dict[str, str], views: dict, sizes: dict, square: float, reject: bool,
                   min_views: int) -> tuple[dict[str, str], dict[str, object]]:
    """Each camera's model: as given, or (``"auto"``) the one cross-validation over its views chooses
    (:func:`sogdd.calib.model_selection.select_model`, as the one-camera ``model="auto"``); with the
    selection of each camera that chose."""
    chosen, selection = {}, {}
    for n, m in models.items():
        if m == "auto":
            selection[n] = _camera_says(n, _select, views[n], sizes[n], square, reject, min_views)
            m = selection[n].chosen
        chosen[n] = m
    return chosen, selection


def _select(boards, size, square: float, reject: bool, min_views: int):
    return select_model(boards, size, square=square, reject=reject, min_views=min_views)


def _records(name: str, results: list[ViewResult | None], labels: list[str],
             ignored: list[tuple], rig: RigCalibration, spec: BoardSpec) -> tuple[ViewRecord, ...]:
    """A camera's every input, in frame order (``view`` the frame's index), an image's ignored boards after
    its view; a frame it has no image of gives no record (it is no input)."""
    cal = rig.camera(name).calibration
    out: list[ViewRecord] = []
    for f, (r, n, beside) in enumerate(zip(results, labels, ignored)):
        if r is None:
            continue
        if r.error:
            out.append(ViewRecord(n, r.path, "unreadable", r.error))
        elif not r.boards:
            status, why = ("ignored", f"{r.seen}, not {spec}") if r.other_size is not None else \
                ("no board", r.seen or "no board")
            out.append(ViewRecord(n, r.path, status, why, f))
        else:
            used = bool(cal.view_used[f])
            out.append(ViewRecord(n, r.path, "used" if used else "rejected", "" if used else cal.reasons[f], f))
        out += [ViewRecord(f"{n}#{k}", r.path, "ignored", why, None, len(b))
                for k, (b, why) in enumerate(beside, start=2)]
    return tuple(out)


# --------------------------------------------------------------------------------------------------
# the output folder


def check_rig_output_folder(out: str | os.PathLike, inputs: Iterable[str | os.PathLike] = ()) -> Path:
    """Whether :func:`write_rig_outputs` may write ``out``: a one-line ``ValueError`` if not, else its path.

    As :func:`sogdd.calib.check_output_folder`, a previous output being a rig's:
    rig.yaml, rig.json, report.html, its figures in report/, and per camera a
    folder of its own files (:data:`sogdd.calib.session.OUTPUTS`) and nothing else
    (:func:`sogdd.calib.session.foreign_rig_entry`); a one-camera run's output is
    replaced too.
    """
    return check_output_folder(out, inputs, previous=foreign_rig_entry)


def write_rig_outputs(result: RigImageCalibration, out: str | os.PathLike, *, report: bool = True,
                      inputs: Sequence[str | os.PathLike] = (), title: str | None = None) -> dict[str, Path]:
    """Write a rig's output folder: rig.yaml, rig.json, ``NAME/`` (camera.yaml, camera.json, views.csv,
    corners.csv) per camera and, with ``report``, report.html with its figures (each camera's too).

    The folder ends complete, or as it was (:func:`sogdd.calib.session.write_folder`);
    ``inputs`` and the images of ``result`` are never written over and may not
    lie in ``out`` (:func:`check_rig_output_folder`).

    Returns
    -------
    dict
        Name relative to ``out`` (``rig.yaml``, ``left/camera.yaml``, ``report.html``,
        ``report``) -> its final path.

    Raises
    ------
    ValueError
        ``out`` may not be written.
    OSError
        A write failed: one line saying that ``out`` was left as it was.
    """
    inputs = [*inputs, *(v.file for views in result.views.values() for v in views)]

    def fill(new: Path) -> dict[str, Path]:
        files = write_rig(result.rig, new, inputs=inputs, views=result.views)
        if report:
            from .report import write_rig_report

            rig = result.rig
            n = int(rig.frame_used.sum())
            files["report.html"] = write_rig_report(
                rig, new, thumbnails=result.thumbnails or None, views=result.views,
                title=title or f"Rig calibration: {cameras_text(len(rig.cameras))}, {n} frames, {result.board}")
            files["report"] = new / "report"
        return files

    return write_folder(out, fill, inputs=inputs, previous=foreign_rig_entry)


def calibrate_rig_into(
    cameras: Mapping[str, Inputs],
    out: str | os.PathLike,
    board: str | BoardSpec = "chessboard:auto",
    *,
    square: float = 1.0,
    model: ModelChoice | Mapping[str, ModelChoice] = "auto",
    boards: Literal["best"] = "best",
    jobs: int = 1,
    scheduler: str | None = None,
    min_views: int = 3,
    reject: bool = True,
    recursive: bool = False,
    allow_missing: bool = False,
    read_options: dict | None = None,
    report: bool = True,
    title: str | None = None,
    progress: bool = False,
) -> tuple[RigImageCalibration, dict[str, Path]]:
    """Calibrate a rig from each camera's image files into an output folder: what ``sogdd calibrate --camera``
    runs.

    Every check comes before any work: the parameters and the rig's rules
    (:func:`calibrate_rig_images`), each camera's inputs (at least one, none of
    them a device or a FIFO, every name valid UTF-8: :func:`sogdd.calib.session.check_inputs`) and
    ``out`` (:func:`check_rig_output_folder`). Then :func:`calibrate_rig_images`
    and :func:`write_rig_outputs`: the folder ends complete, or as it was.

    Parameters
    ----------
    cameras, board, square, model, boards, jobs, scheduler, min_views, reject, recursive, allow_missing
        As :func:`calibrate_rig_images`.
    read_options, progress
        As :func:`calibrate_rig_images`.
    out : path
        The output folder: missing (made), empty, or a previous rig output (replaced whole).
    report : bool
        Write report.html and its figures (each camera's too); the images'
        thumbnails are kept for it only then.
    title : str, optional
        The report's title (default: the cameras, the frames and the board).

    Returns
    -------
    result : RigImageCalibration
    files : dict of str to Path
        Name relative to ``out`` -> its final path, as :func:`write_rig_outputs`.

    Raises
    ------
    ParameterError, ValueError
        One line, as :func:`calibrate_rig_images`; also an input that is a device,
        a FIFO or a socket, or whose name is not valid UTF-8, and an ``out`` that may not be written.
    OSError
        A write failed; ``out`` was left as it was.
    sogdd.collection.BatchInterrupted
        On Ctrl-C or ``SIGTERM``; ``out`` was left as it was.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> calibrate_rig_into({"left": d, "right": d}, d / "rig", "chessboard:9x6", jobs=0)
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: jobs must be >= 1, got 0
    >>> (d / "left").mkdir(); (d / "right").mkdir()  # two folders without images
    >>> calibrate_rig_into({"left": d / "left", "right": d / "right"}, d / "rig", "chessboard:9x6")
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: camera left: no input images
    >>> (d / "rig").exists()
    False
    """
    _, spec, _ = check_rig_parameters(cameras, board, model, boards, square, jobs, min_views)
    check_read_options(read_options)
    paths = _expand(cameras, recursive)
    every = [p for ps in paths.values() for p in ps]
    check_inputs(every)  # a device or a FIFO would be read for ever; a name no output can hold
    check_rig_output_folder(out, every)
    result = calibrate_rig_images(paths, spec, square=square, model=model, boards=boards, jobs=jobs,
                                  scheduler=scheduler, min_views=min_views, reject=reject,
                                  allow_missing=allow_missing, read_options=read_options, thumbnails=report,
                                  progress=progress)
    return result, write_rig_outputs(result, out, report=report, inputs=every, title=title)
