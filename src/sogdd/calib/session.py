"""A calibration session: images of a board in, a camera and every view's fate out, and its output folder.

The library's entry point, what ``sogdd calibrate`` runs. :func:`calibrate_images`
finds the board in every image (:mod:`.detection`: in this process, on local worker
processes or on a Dask cluster), checks that the images agree (one size; the board
the specification names, not one of another size), fits the camera (:func:`calibrate`)
and accounts for every input (:class:`ImageCalibration`). An image gives one view, the
board that matches the specification best; other boards in it are reported, ignored
(``boards="all"``: every board is a view, for a scene built with several targets); a much
smaller board (a screen, a reflection or a pattern in the background) is never a view
(:func:`~sogdd.calib.detection.pick_boards`). :func:`write_outputs` writes the output
folder (:func:`check_output_folder` says beforehand whether it may). :func:`calibrate_into` is the two
in one, what ``sogdd calibrate`` runs: every check before any work (the output folder's too), then the
calibration, then its folder.

Bad parameters are refused at the door, before any image is read, each as a one-line
``ValueError``; one that names a parameter is a :class:`ParameterError`, so that the
command line can say the same with its flags.

The output folder is complete or as it was, never a mix: everything is written
into a new hidden folder beside it (``.<name>.new-<random>.sogdd.tmp``), which then
takes its place by two renames (the old folder is renamed aside, the new one in,
the old one deleted). A failure or an interrupt before that leaves the folder as
it was and removes the new one; a signal during the renames (milliseconds) is held
until they are done, and the run completes; what a run killed outright left beside it the
next run removes (:func:`write_folder`). Only a missing folder, an empty one, or a previous
output of ``sogdd calibrate`` (its files alone, one camera's or a rig's) is replaced: a
folder holding anything else is refused, so a run never deletes a file it did not make.
:func:`write_folder` is that contract for any writer of such a folder (the rig's too).
"""

from __future__ import annotations

import functools
import glob
import numbers
import os
import re
import secrets
import shutil
import signal
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

from ..collection import expand_inputs, relative_names
from ..formats.record import check_name
from ..formats.safe_write import TMP_SUFFIX, check_input_files, claimed, folder_holds, remove_stale_beside
from ..image.files import IMAGE_SUFFIXES, list_images
from .detection import (
    BOARD_CHOICES,
    THUMB_WIDTH,
    BoardChoice,
    Thumbnail,
    ViewRecord,
    ViewResult,
    check_read_options,
    detect_files,
    on_sensor_grid,
    pick_boards,
)
from .files import FILES, write_calibration
from .fit import SQUARE_RANGE, calibrate
from .model_selection import ModelChoice, check_model_choice
from .result import Calibration
from .targets.board import Board, grid_dims
from .targets.spec import BoardSpec, parse_board

__all__ = ["OUTPUTS", "ImageCalibration", "ParameterError", "calibrate_images", "calibrate_into",
           "check_detections", "check_inputs", "check_output_folder", "check_run_parameters",
           "common_image_size", "expand_images", "foreign_entry", "foreign_rig_entry", "previous_output",
           "write_folder", "write_outputs"]

#: what :func:`write_outputs` writes: the four files, report.html and the report/ folder of figures
OUTPUTS = (*FILES, "report.html", "report")
_FIGURE = re.compile(r"((view|overlay)_\d{4,}|residuals|residual_histogram|errors_per_view|coverage"
                     r"|cross_validation|distortion|poses)\.png")
#: the figures of a rig's report (:mod:`sogdd.calib.rig.report`), and its cameras' folders
_RIG_FIGURE = re.compile(r"(extrinsics|errors|(uncertainty|rectified)_[A-Za-z0-9_-]+)\.png")
_CAMERA_FOLDER = re.compile(r"[A-Za-z0-9_-]+")


@dataclass(frozen=True)
class ImageCalibration:
    """A calibration from image files, with what became of every input (:func:`calibrate_images`).

    Attributes
    ----------
    calibration : Calibration
        The camera and its diagnostics; its views are the boards found (and the
        images without one), named by their files relative to the inputs' common
        folder (``name#2`` for an image's second board, with ``boards="all"``).
    board : BoardSpec
    views : tuple of ViewRecord
        Every input, in input order, one record per board (an image without a
        board, or that could not be read, is one record too): its status and
        why. A board beside an image's view is a record of status ``ignored``
        named ``name#2``, ... after the image's views, its size in the reason.
    thumbnails : tuple of Thumbnail or None
        Per view of ``calibration``, the small grey image the report draws on.
    """

    calibration: Calibration
    board: BoardSpec
    views: tuple[ViewRecord, ...]
    thumbnails: tuple[Thumbnail | None, ...] = ()

    @property
    def unreadable(self) -> tuple[ViewRecord, ...]:
        """The inputs that could not be read (or whose worker process died)."""
        return tuple(v for v in self.views if v.status == "unreadable")


class ParameterError(ValueError):
    """A parameter refused at the door, before any work: one line that names the parameters it is about.

    The message is ``template.format(**words)``: each ``{slot}`` of the template
    is a parameter's name in this library's words (or a value, or a phrase), so
    that a caller with other names for the parameters (a command line's flags)
    can say the same in its own words (:meth:`worded`).

    Attributes
    ----------
    template : str
    words : dict of str to object
        Each slot's word in the message.

    Examples
    --------
    >>> exc = ParameterError("{jobs} must be >= 1, got {value}", jobs="jobs", value=0)
    >>> str(exc)
    'jobs must be >= 1, got 0'
    >>> exc.worded(jobs="--jobs", square="--square")  # a slot the message lacks is ignored
    '--jobs must be >= 1, got 0'
    """

    def __init__(self, template: str, **words: object) -> None:
        self.template = template
        self.words = words
        super().__init__(template.format(**words))

    def worded(self, **words: object) -> str:
        """The message with the slots given worded so (the others as they were)."""
        return self.template.format(**{**self.words, **words})

    def __reduce__(self):
        # rebuilt from its template and words (an exception's default is its message alone, which is not one)
        return functools.partial(type(self), self.template, **self.words), ()


def check_run_parameters(*, square: float, jobs: int, min_views: int) -> None:
    """The numbers every calibration run takes, checked: a one-line :class:`ParameterError` naming the bad one.

    ``square`` must be a positive size in :data:`~sogdd.calib.fit.SQUARE_RANGE`; ``jobs`` and ``min_views``
    integers >= 1.

    Examples
    --------
    >>> check_run_parameters(square=25.0, jobs=1, min_views=0)
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: min_views must be >= 1, got 0
    """
    if not (isinstance(square, numbers.Real) and 0 < square < float("inf")):
        raise ParameterError("{square} must be a positive size, got {value}", square="square", value=square)
    if not SQUARE_RANGE[0] <= square <= SQUARE_RANGE[1]:
        raise ParameterError(f"{{square}} must be from {SQUARE_RANGE[0]:g} to {SQUARE_RANGE[1]:g} (the board's "
                             "square in any unit), got {value}", square="square", value=square)
    for name, v in (("jobs", jobs), ("min_views", min_views)):
        integral = isinstance(v, numbers.Integral) and not isinstance(v, bool)
        if not integral or v < 1:
            why = "must be >= 1, got {value}" if integral else "must be an integer, got {value!r}"
            raise ParameterError(f"{{{name}}} {why}", **{name: name, "value": v})


def _check_parameters(board: str | BoardSpec, square: float, model: str, jobs: int,
                      min_views: int, boards: str) -> BoardSpec:
    """Bad parameters fail before any image is read."""
    spec = parse_board(board) if isinstance(board, str) else board
    if not isinstance(spec, BoardSpec):
        raise TypeError(f"board must be a specification string or a BoardSpec, got {type(board).__name__}")
    check_model_choice(model)
    if boards not in BOARD_CHOICES:
        raise ValueError(f"boards must be one of {', '.join(BOARD_CHOICES)}, got {boards!r}")
    check_run_parameters(square=square, jobs=jobs, min_views=min_views)
    return spec


def calibrate_images(
    images: str | os.PathLike | Iterable[str | os.PathLike],
    board: str | BoardSpec = "chessboard:auto",
    *,
    boards: BoardChoice = "best",
    square: float = 1.0,
    model: ModelChoice = "auto",
    jobs: int = 1,
    scheduler: str | None = None,
    min_views: int = 3,
    reject: bool = True,
    recursive: bool = False,
    read_options: dict | None = None,
    thumbnails: bool = True,
    progress: bool = False,
) -> ImageCalibration:
    """Calibrate a camera from image files of a board.

    Parameters
    ----------
    images : path, pattern, or iterable of them
        Image files, folders (their images; ``recursive``: and their
        sub-folders') and glob patterns (:func:`sogdd.collection.expand_inputs`).
    board : str or BoardSpec
        ``chessboard:COLSxROWS`` (inner corners), ``chessboard:auto``, ``charuco:COLSxROWS:MARKER:DICT``
        or ``aprilgrid:COLSxROWS:SIZE:SPACING`` (:func:`sogdd.calib.parse_board`).
    boards : {"best", "all"}
        Which boards of an image are views. ``"best"``: one, the board that
        matches ``board`` best (complete first, then the most corners, then the
        largest cells); the others are records of status ``ignored``, each with
        its corners and cell size. ``"all"``: every board, for a scene built
        with several targets (``name``, ``name#2``, ...). Either way a board whose
        cells are under a third of those of the image's largest board (a screen,
        a reflection or a pattern in the background) is ignored, never a view
        (:func:`~sogdd.calib.detection.pick_boards`). A ChArUco board is one per
        image.
    square : float
        The side of a board square, in the unit the poses should have; for a board whose specification
        gives its size (``aprilgrid:...:SIZE:...``), a factor on that size's unit (1: poses in it).
    model : {"auto", "pinhole4", "pinhole", "rational", "fisheye", "omnidir"}
        The camera model (:func:`sogdd.calib.calibrate`); ``"auto"``: the one
        cross-validation over the views chooses
        (:func:`~sogdd.calib.model_selection.select_model`, its table in
        ``calibration.model_selection``).
    jobs : int
        Images read and searched at a time, in worker processes (1: in this process).
    scheduler : str, optional
        A Dask distributed scheduler's address to run the detection on
        (``pip install 'sogdd[distributed]'``); ``jobs`` is then unused.
    min_views : int
        Fewest views with a board to calibrate.
    reject : bool
        Reject outlying corners and views (each with its reason).
    recursive : bool
        Folders: include their sub-folders.
    read_options : dict, optional
        Keyword arguments of :func:`sogdd.read_image` (``max_pixels``,
        ``allow_corrupt``, ``ignore_orientation``).
    thumbnails : bool
        Keep a small grey copy of each image for the report.
    progress : bool
        A progress bar on stderr.

    Returns
    -------
    ImageCalibration
        The calibration and every input's fate. An image that cannot be read is
        a view of status ``unreadable`` and the calibration uses the others.

    Raises
    ------
    ValueError
        One line: bad parameters; no input; none of the images readable; no
        board in any of them (saying what was seen instead, and the right
        ``board`` when the images show a board of another size); images of
        different sizes; too few views.
    sogdd.collection.BatchInterrupted
        On Ctrl-C or ``SIGTERM``.

    Examples
    --------
    >>> import tempfile, cv2, numpy as np
    >>> from sogdd.evaluation.calibration import render
    >>> cam = render.Camera(np.array([[560.0, 0, 322], [0, 560, 236], [0, 0, 1]]), (-0.2, 0.06, 0, 0, 0),
    ...                     (640, 480))
    >>> target = render.ChessboardTarget(9, 6, 1.0)
    >>> folder = Path(tempfile.mkdtemp())
    >>> for k, (rv, tv) in enumerate(render.random_sequence(cam, target, 6, seed=3)):
    ...     view = render.render_view(cam, target, rv, tv, blur=0.8, noise=2.0, rng=k)
    ...     _ = cv2.imwrite(str(folder / f"f{k}.png"), view.image)
    >>> (folder / "notes.png").write_bytes(b"not an image")
    12
    >>> result = calibrate_images(folder, "chessboard:9x6", square=25.0)
    >>> cal = result.calibration
    >>> cal.n_used, bool(abs(cal.K[0, 0] - 560) < 5)
    (6, True)
    >>> [(v.name, v.status) for v in result.views][-2:]
    [('f5.png', 'used'), ('notes.png', 'unreadable')]
    """
    spec = _check_parameters(board, square, model, jobs, min_views, boards)
    opts = check_read_options(read_options)
    paths = _expand(images, recursive)
    names = relative_names(paths)  # collisions fail before any work
    run = dict(jobs=jobs, scheduler=scheduler, progress=progress, read_options=opts,
               thumb_width=THUMB_WIDTH if thumbnails else None, view_only=boards != "all")
    results, grid = on_sensor_grid(detect_files(paths, spec, **run), spec, **run)  # turned between shots
    picked = [pick_boards(r.boards, spec, boards) for r in results]
    results = [replace(r, boards=kept) for r, (kept, _) in zip(results, picked)]
    check_detections(results, spec)
    views, vnames, owners = _views(results, names)
    cal = calibrate(views, common_image_size(results), square=float(square) * spec.label_step, model=model,
                    names=vnames, reject=reject, min_views=min_views)
    cal = replace(cal, pixel_grid="sensor", notes=(*cal.notes, grid)) if grid else cal
    records = _records(results, names, cal, spec, [ignored for _, ignored in picked])
    return ImageCalibration(cal, spec, tuple(records), tuple(results[i].thumbnail for i in owners))


def _expand(images: str | os.PathLike | Iterable[str | os.PathLike], recursive: bool) -> list[Path]:
    """The image files that ``images`` names; a one-line error when there are none."""
    given = [images] if isinstance(images, (str, os.PathLike)) else list(images)
    paths = expand_images(given, recursive=recursive)
    if not paths:
        raise ValueError("no input images")
    return paths


def expand_images(items: Iterable[str | os.PathLike], *, recursive: bool = False) -> list[Path]:
    """The image files a calibration reads: :func:`sogdd.collection.expand_inputs`'s, but a glob pattern's
    broken links and folders named as images (``right99.jpg/``) are inputs too (each reported as unreadable,
    as when named, never dropped in silence), and no file inside a previous output of ``sogdd calibrate``
    (:func:`previous_output`: its report's figures) is one (a re-run of ``-r inp --out inp/calib``)."""
    out: list[Path] = []
    for item in map(os.fspath, items):
        missed = _missed(item)
        try:
            found = expand_inputs([item], recursive=recursive)
        except ValueError:  # a pattern that matches no file: its broken links and folders, if any
            if not missed:
                raise
            found = []
        out += sorted({*found, *missed}) if missed else found
    seen: set[str] = set()
    inside = functools.cache(previous_output)  # each folder asked once
    kept = []
    for p in out:
        key = os.path.realpath(p) if os.path.lexists(p) else str(p)
        if key not in seen and not any(inside(f) for f in Path(os.path.abspath(p)).parents):
            seen.add(key)
            kept.append(p)
    return kept


def _missed(item: str) -> list[Path]:
    """What :func:`sogdd.collection.expand_inputs` leaves out of ``item``: a glob pattern's broken links, and
    a folder named as an image that holds none (a mistake the reader names; a re-expansion keeps it)."""
    def odd(p: str) -> bool:
        return os.path.isdir(p) and Path(p).suffix.lower() in IMAGE_SUFFIXES and not list_images(p)

    if os.path.lexists(item) or not any(ch in item for ch in "*?["):
        return [Path(item)] if odd(item) else []
    return [Path(m) for m in glob.glob(item, recursive=True) if odd(m) or not os.path.exists(m)]


def check_detections(results: Sequence[ViewResult], spec: BoardSpec) -> None:
    """The one-line ``ValueError`` for detections a camera cannot be calibrated from: nothing readable, no
    board, a miscounted board (each camera of a rig is asked too)."""
    failed = [r for r in results if r.error]
    if len(failed) == len(results):
        more = f"; and {len(failed) - 1} more" if len(failed) > 1 else ""
        raise ValueError(f"none of the {len(results)} image(s) could be read: {failed[0].error}{more}")
    if not any(r.boards for r in results):
        _no_board(results, spec)
    _check_smaller(results, spec)


def check_inputs(paths: Iterable[str | os.PathLike]) -> None:
    """The inputs of a run that writes an output folder, checked at the door (one-line ``ValueError``
    naming the file): none a device, a FIFO or a socket (:func:`sogdd.formats.safe_write.check_input_files`),
    every name valid UTF-8, which every output can hold (:func:`sogdd.formats.record.check_name`)."""
    paths = list(paths)
    for p in paths:
        check_name(os.fspath(p))
    check_input_files(paths)


def _views(results: list[ViewResult], names: list[str]) -> tuple[list, list[str], list[int]]:
    """The calibration's views: one per board (an image with several boards gives ``name#2``, ...),
    one for a readable image without a board; with the index of the image each comes from."""
    boards, vnames, owners = [], [], []
    for i, (r, n) in enumerate(zip(results, names)):
        if r.error:
            continue
        for k, b in enumerate(r.boards or (None,)):
            boards.append(b)
            vnames.append(n if k == 0 else f"{n}#{k + 1}")
            owners.append(i)
    return boards, vnames, owners


def _records(results: list[ViewResult], names: list[str], cal: Calibration, spec: BoardSpec,
             ignored: list[tuple[tuple[Board, str], ...]]) -> list[ViewRecord]:
    """Every input's fate, in input order (the views in the calibration's order, which is the same), an
    image's ignored boards after its views."""
    out: list[ViewRecord] = []
    v = 0
    for r, n, beside in zip(results, names, ignored):
        if r.error:
            out.append(ViewRecord(n, r.path, "unreadable", r.error))
            continue
        if not r.boards:
            if r.other_size is not None:
                out.append(ViewRecord(n, r.path, "ignored", f"{r.seen}, not {spec}", v))
            else:
                out.append(ViewRecord(n, r.path, "no board", r.seen or "no board", v))
            v += 1
            continue
        for _ in r.boards:
            used = bool(cal.view_used[v])
            out.append(ViewRecord(cal.names[v], r.path, "used" if used else "rejected",
                                  "" if used else cal.reasons[v], v))
            v += 1
        # numbered on from the image's views: every record has its own name (camera.json keys them by it)
        out += [ViewRecord(f"{n}#{k}", r.path, "ignored", why, None, len(b))
                for k, (b, why) in enumerate(beside, start=len(r.boards) + 1)]
    return out


def common_image_size(results: Sequence[ViewResult]) -> tuple[int, int]:
    """The one size of every readable image (a calibration is for one camera at one resolution); a one-line
    ``ValueError`` naming two images of different sizes."""
    sizes: dict = {}
    for r in results:
        if r.size is not None:
            sizes.setdefault(r.size, r.path)
    if len(sizes) > 1:
        (s1, p1), (s2, p2) = list(sizes.items())[:2]
        raise ValueError(f"images of different sizes: {p1} is {s1[0]}x{s1[1]} but {p2} is {s2[0]}x{s2[1]}; "
                         "a calibration is for one camera at one resolution")
    return next(iter(sizes))


def _no_board(results: list[ViewResult], spec: BoardSpec) -> None:
    """Raise the one-line error for a run where no image shows a usable board."""
    good = [r for r in results if not r.error]
    others = [r for r in good if r.other_size is not None]
    if spec.pattern is not None and others:
        s = others[0].other_size
        raise ValueError(f"board {spec} contradicts the images: {len(others)} of {len(good)} show a board of "
                         f"{s[0]}x{s[1]} inner corners (e.g. {others[0].path}); give chessboard:{s[0]}x{s[1]} "
                         "(inner corners, not squares)")
    seen = "; ".join(f"{r.path}: {r.seen or 'no board'}" for r in good[:3])
    more = f"; and {len(good) - 3} more" if len(good) > 3 else ""
    raise ValueError(f"no board ({spec}) in any of the {len(good)} image(s): {seen}{more}")


def _check_smaller(results: list[ViewResult], spec: BoardSpec) -> None:
    """Every board a whole grid of one same size, smaller than the specification's: the size was miscounted
    (partial views of a larger board would not all show the same whole rectangle)."""
    boards = [b for r in results for b in r.boards]
    if spec.pattern is None or len(boards) < 3 or any(b.size is not None for b in boards):
        return
    dims = {grid_dims(b) for b in boards}
    if len(dims) == 1 and None not in dims:
        w, h = dims.pop()
        raise ValueError(f"board {spec} contradicts the images: all {len(boards)} boards show exactly "
                         f"{w}x{h} inner corners; give chessboard:{w}x{h} (inner corners, not squares)")


# --------------------------------------------------------------------------------------------------
# the output folder


def foreign_entry(folder: Path) -> str | None:
    """None if ``folder`` holds only what :func:`write_outputs` writes, else the first entry it did not
    (the rig's writer asks it of each camera's folder)."""
    for p in sorted(folder.iterdir()):
        if p.name.endswith(TMP_SUFFIX):
            continue
        if p.name == "report" and p.is_dir() and not p.is_symlink():
            odd = next((q for q in sorted(p.iterdir()) if not _FIGURE.fullmatch(q.name)
                        and not q.name.endswith(TMP_SUFFIX)), None)
            if odd is not None:
                return f"report/{odd.name}"
        elif p.name not in OUTPUTS or not p.is_file():
            return p.name
    return None


def foreign_rig_entry(folder: Path) -> str | None:
    """None if ``folder`` holds only what a rig's writer writes (rig.yaml, rig.json, report.html, its figures
    in report/, a folder per camera as :func:`foreign_entry` says), else the first entry it did not."""
    from .rig.files import RIG_FILES

    for p in sorted(folder.iterdir()):
        if p.name.endswith(TMP_SUFFIX):
            continue
        if p.name in (*RIG_FILES, "report.html") and p.is_file():
            continue
        if not p.is_dir() or p.is_symlink():
            return p.name
        if p.name == "report":
            odd = next((q for q in sorted(p.iterdir()) if not _RIG_FIGURE.fullmatch(q.name)
                        and not q.name.endswith(TMP_SUFFIX)), None)
            if odd is not None:
                return f"report/{odd.name}"
            continue
        # a camera's folder: its files (as a one-camera output), camera.yaml always among them
        odd = foreign_entry(p) if _CAMERA_FOLDER.fullmatch(p.name) and (p / "camera.yaml").is_file() else ""
        if odd is not None:
            return f"{p.name}/{odd}" if odd else p.name
    return None


def previous_output(folder: str | os.PathLike) -> bool:
    """Whether ``folder`` is a previous output of ``sogdd calibrate``, one camera's or a rig's (its files and
    nothing else): a run may replace it, and its files are never a run's inputs."""
    path = Path(folder)
    try:
        return path.is_dir() and not path.is_symlink() and any(
            (path / marker).is_file() and foreign(path) is None
            for marker, foreign in (("camera.yaml", foreign_entry), ("rig.yaml", foreign_rig_entry)))
    except OSError:  # a folder that cannot be listed is no output of ours
        return False


def _foreign(folder: Path, own: Callable[[Path], str | None]) -> str | None:
    """None if a run may replace ``folder`` (``own`` says it is its kind's previous output, or it is the other
    kind's: a one-camera run replaces a rig's output and the reverse), else the first entry no run wrote."""
    odd = own(folder)
    if odd is None or previous_output(folder):
        return None
    for marker, foreign in (("rig.yaml", foreign_rig_entry), ("camera.yaml", foreign_entry)):
        if (folder / marker).is_file():  # the files say which kind of output it was: that kind's entry
            return foreign(folder)
    return odd


def check_output_folder(out: str | os.PathLike, inputs: Iterable[str | os.PathLike] = (), *,
                        previous: Callable[[Path], str | None] | None = None) -> Path:
    """Whether :func:`write_outputs` may write ``out``: a one-line ``ValueError`` if not, else its full path.

    ``out`` may be missing (it is created, with its parents), empty, or a
    previous output (:data:`OUTPUTS` and nothing else, or a rig's: :func:`previous_output`),
    which is replaced. It is refused when it is a file, its name is not valid UTF-8, it holds
    an input (however the inputs were named: :func:`sogdd.formats.safe_write.folder_holds`),
    holds files this function did not write, or is (or holds) the current folder. ``previous``
    says what a previous output holds for another writer of such a folder (the
    rig's): given the folder, None if it is one, else the first entry it did
    not write.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp()); _ = (d / "a.png").write_bytes(b"x")
    >>> check_output_folder(d / "calib", [d / "a.png"]) == d / "calib"
    True
    >>> check_output_folder(d, [d / "*.png"])
    Traceback (most recent call last):
    ...
    ValueError: output folder /...: holds the input /.../*.png; choose another folder for the outputs
    """
    given = os.fspath(out)
    path = Path(os.path.abspath(given))
    try:
        check_name(str(path))
    except ValueError:  # OpenCV's writers cannot take such a name (they crash)
        shown = os.fsencode(path).decode("utf-8", "backslashreplace")
        raise ValueError(f"output folder {shown}: the name is not valid UTF-8; give a UTF-8 name") from None
    if os.path.lexists(path) and not path.is_dir():
        raise ValueError(f"output folder {given}: exists and is not a folder")
    held = folder_holds(path, inputs)  # a glob pattern too: it lies where its matches would
    if held is not None:
        raise ValueError(f"output folder {given}: holds the input {held}; choose another folder for the "
                         "outputs")
    real, here = os.path.realpath(path), os.path.realpath(os.getcwd())
    if os.path.commonpath([real, here]) == real:
        raise ValueError(f"output folder {given}: is (or holds) the current folder, which a run replaces; "
                         "choose another folder")
    if path.is_dir():
        odd = _foreign(path, previous or foreign_entry)
        if odd is not None:
            raise ValueError(f"output folder {given}: holds {odd}, which sogdd calibrate did not write; give a "
                             "new or empty folder, or a previous output to replace")
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not os.access(folder, os.W_OK):
        raise ValueError(f"output folder {given}: folder {folder} is not writable")
    return path


def _beside(path: Path, tag: str) -> Path:
    """A new name beside ``path`` for a folder of this run (hidden, with the temporary suffix)."""
    return path.parent / f".{path.name}.{tag}-{secrets.token_hex(4)}{TMP_SUFFIX}"


def _make_parents(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; return those made, deepest first (to undo)."""
    made = []
    p = folder
    while not p.exists():
        made.append(p)
        p = p.parent
    for q in reversed(made):
        q.mkdir()
    return made


@contextmanager
def _signals_held():
    """``SIGINT`` and ``SIGTERM`` wait while the folders are swapped (main thread only): the renames take
    milliseconds, and an interrupt between them would leave no folder under the name."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.signal(s, lambda *_: None) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _swap(new: Path, out: Path) -> None:
    """Put ``new`` in the place of ``out`` (missing, or replaced), the old one deleted."""
    with _signals_held():
        if not out.exists():
            os.rename(new, out)
            return
        aside = _beside(out, "old")
        os.rename(out, aside)
        try:
            os.rename(new, out)
        except BaseException:
            os.rename(aside, out)
            raise
        shutil.rmtree(aside, ignore_errors=True)


def write_outputs(result: ImageCalibration, out: str | os.PathLike, *, report: bool = True,
                  inputs: Sequence[str | os.PathLike] = (), title: str | None = None) -> dict[str, Path]:
    """Write the output folder of a calibration: camera.yaml, camera.json, views.csv, corners.csv and, with
    ``report``, report.html with its figures (report/).

    The folder ends complete, or as it was (module doc); files get the user's
    umask (:func:`sogdd.formats.safe_write.user_mode`), a replaced folder keeps
    its permissions. ``inputs`` (the image files) are never written over and
    may not lie in ``out`` (:func:`check_output_folder`).

    Returns
    -------
    dict
        File name (``report.html`` and ``report`` too) -> its final path.

    Raises
    ------
    ValueError
        ``out`` may not be written (:func:`check_output_folder`).
    OSError
        A write failed (full disk, permissions): one line saying that ``out``
        was left as it was.
    """
    def fill(new: Path) -> dict[str, Path]:
        files = write_calibration(result.calibration, new, inputs=inputs, views=result.views)
        if report:
            from .report import write_report

            n = sum(v.view is not None for v in result.views)
            files["report.html"] = write_report(
                result.calibration, new, images=result.thumbnails or None, views=result.views,
                title=title or f"Camera calibration: {n} views, {result.board}")
            files["report"] = new / "report"
        return files

    return write_folder(out, fill, inputs=inputs)


def calibrate_into(
    images: str | os.PathLike | Iterable[str | os.PathLike],
    out: str | os.PathLike,
    board: str | BoardSpec = "chessboard:auto",
    *,
    boards: BoardChoice = "best",
    square: float = 1.0,
    model: ModelChoice = "auto",
    jobs: int = 1,
    scheduler: str | None = None,
    min_views: int = 3,
    reject: bool = True,
    recursive: bool = False,
    read_options: dict | None = None,
    report: bool = True,
    title: str | None = None,
    progress: bool = False,
) -> tuple[ImageCalibration, dict[str, Path]]:
    """Calibrate a camera from image files of a board into an output folder: what ``sogdd calibrate`` runs.

    Every check comes before any work: the parameters, the inputs (none of them a
    device or a FIFO, every name valid UTF-8: :func:`check_inputs`) and ``out``
    (:func:`check_output_folder`). Then :func:`calibrate_images` and
    :func:`write_outputs`: the folder ends complete, or as it was.

    Parameters
    ----------
    images, board, boards, square, model, jobs, scheduler, min_views, reject, recursive, read_options, progress
        As :func:`calibrate_images`.
    out : path
        The output folder: missing (made), empty, or a previous output (replaced whole).
    report : bool
        Write report.html and its figures; the images' thumbnails are kept for it only then.
    title : str, optional
        The report's title (default: the number of views and the board).

    Returns
    -------
    result : ImageCalibration
    files : dict of str to Path
        File name (``report.html`` and ``report`` too) -> its final path, as :func:`write_outputs`.

    Raises
    ------
    ParameterError
        ``square``, ``jobs`` or ``min_views`` out of range (one line naming it).
    ValueError
        One line: the other errors of :func:`calibrate_images`; an input that is a
        device, a FIFO or a socket, or whose name is not valid UTF-8; an ``out`` that may not be written.
    OSError
        A write failed; ``out`` was left as it was.
    sogdd.collection.BatchInterrupted
        On Ctrl-C or ``SIGTERM``; ``out`` was left as it was.

    Examples
    --------
    >>> import tempfile, cv2, numpy as np
    >>> from sogdd.evaluation.calibration import render
    >>> cam = render.Camera(np.array([[560.0, 0, 322], [0, 560, 236], [0, 0, 1]]), (-0.2, 0.06, 0, 0, 0),
    ...                     (640, 480))
    >>> target = render.ChessboardTarget(9, 6, 1.0)
    >>> folder = Path(tempfile.mkdtemp())
    >>> for k, (rv, tv) in enumerate(render.random_sequence(cam, target, 5, seed=3)):
    ...     view = render.render_view(cam, target, rv, tv, blur=0.8, noise=2.0, rng=k)
    ...     _ = cv2.imwrite(str(folder / f"f{k}.png"), view.image)
    >>> calibrate_into(folder / "*.png", folder / "calib", "chessboard:9x6", jobs=0)
    Traceback (most recent call last):
    ...
    sogdd.calib.session.ParameterError: jobs must be >= 1, got 0
    >>> result, files = calibrate_into(folder / "*.png", folder / "calib", "chessboard:9x6", model="pinhole",
    ...                                report=False)
    >>> result.calibration.n_used, sorted(files)
    (5, ['camera.json', 'camera.yaml', 'corners.csv', 'views.csv'])
    """
    spec = _check_parameters(board, square, model, jobs, min_views, boards)
    check_read_options(read_options)
    paths = _expand(images, recursive)
    check_inputs(paths)
    check_output_folder(out, paths)
    result = calibrate_images(paths, spec, boards=boards, square=square, model=model, jobs=jobs,
                              scheduler=scheduler, min_views=min_views, reject=reject,
                              read_options=read_options, thumbnails=report, progress=progress)
    return result, write_outputs(result, out, report=report, inputs=paths, title=title)


def write_folder(out: str | os.PathLike, fill: Callable[[Path], Mapping[str, object]], *,
                 inputs: Sequence[str | os.PathLike] = (),
                 previous: Callable[[Path], str | None] | None = None) -> dict[str, Path]:
    """Write an output folder whole or not at all (module doc): ``fill(new)`` writes the files into a new
    hidden folder beside ``out``, which then takes its place.

    :func:`write_outputs` and the rig's writer share it. ``out`` is checked
    first (:func:`check_output_folder`, with ``previous``); ``fill`` returns the
    names it wrote (relative to the folder it was given); the result maps each
    to its final path. A failure or an interrupt leaves ``out`` as it was (an
    ``OSError`` is one line saying so). The new folder is held while it is written
    (:func:`~sogdd.formats.safe_write.claimed`); what a run killed outright (``SIGKILL``) left beside
    ``out``, its new folder and (killed during the renames) the old one, is removed first.
    """
    path = check_output_folder(out, inputs, previous=previous)
    given = os.fspath(out)
    kept = f"{given} left as it was" if path.exists() else f"{given} not created"
    remove_stale_beside(path)  # what a run killed outright left (a running one's is held, and kept)
    made = _make_parents(path.parent)
    new = None
    try:
        new = _beside(path, "new")
        new.mkdir()  # the user's umask, as any folder they make
        with claimed(new):
            if path.exists():
                os.chmod(new, path.stat().st_mode & 0o7777)
            files = fill(new)
            _swap(new, path)
    except OSError as exc:
        _undo(new, made)
        why = exc.strerror or (str(exc).replace(str(new), given) if new is not None else str(exc))
        raise OSError(exc.errno, f"{given}: cannot write the outputs ({why}); {kept}") from None
    except BaseException:
        _undo(new, made)
        raise
    return {name: path / name for name in files}


def _undo(new: Path | None, made: list[Path]) -> None:
    """Remove this run's new folder and the parents it made."""
    if new is not None:
        shutil.rmtree(new, ignore_errors=True)
    for p in made:
        try:
            p.rmdir()
        except OSError:
            break
