"""A calibration's corners as Kalibr's target observations: one CSV per camera, one row per corner.

Kalibr reads its images from rosbags and detects the target itself; it has no input for
corners found elsewhere. This file gives sogdd's corners as Kalibr's observations -- for
each corner Kalibr's point number, its pixel and its point on the target in Kalibr's target
frame -- to a script that builds Kalibr's ``GridCalibrationTargetObservation`` (its
``setImagePoints`` / ``updateImagePoint(id, xy)`` take exactly these ids and pixels), or to any
other solver, with Kalibr's numbering. It is a sibling of :mod:`.mrgingham` (the corners
for mrcal) and takes the corners from the same places (:func:`~.mrgingham.corner_views`): a
:class:`~sogdd.calib.Calibration` or :class:`~sogdd.calib.rig.RigCalibration`, or sogdd's
output folder (its ``corners.csv``; a rig's ``NAME/corners.csv``).

The file
--------
A header and one row per corner, the corners of a view sorted by their id::

    timestamp_ns,view,corner_id,x,y,target_x,target_y,used
    0,view0.png,0,149.3558799554368,118.10468546038985,0.0,0.0,1
    0,view0.png,1,188.91246769260619,118.080323673245,0.0,25.0,1

``timestamp_ns``
    Kalibr's observation time (integer ns), here a key that orders the views and matches a
    rig's cameras, not a clock: the view's frame number (:func:`~sogdd.calib.rig.frames.frame_number`,
    the last run of digits in the name's stem; a video's ``clip.mp4#frame000123`` is 123) when
    every view of the camera has one and no two share it, else the view's index (its place
    in the calibration, or in ``corners.csv``, which lists only the views with corners).
``view``
    The view's name (a rig's without its ``NAME/``).
``corner_id``
    Kalibr's point number (below).
``x``, ``y``
    The corner's pixel, ``x`` the column, pixel centres at integers: sogdd's convention, and
    Kalibr's (its corners come from OpenCV's ``findChessboardCorners`` and ``cornerSubPix``, or
    the AprilTag detector's corners refined by ``cornerSubPix``, all with integer centres).
``target_x``, ``target_y``
    The corner's point on the target in Kalibr's target frame (``GridCalibrationTarget.point(id)``),
    in the unit of the calibration's square (a chessboard) or of the AprilGrid's tag size, times
    ``scale``.
``used``
    1 if the calibration used the corner, else 0 (``used_only``: only the used ones are written).

A view without a board has no row (Kalibr has no observation of it). Floats are written as
their shortest repr, so that they read back bit for bit (:func:`read_kalibr_corners`).

Kalibr's numbers
----------------
A chessboard of ``W x H`` inner corners is Kalibr's ``GridCalibrationTargetCheckerboard`` with
``targetCols = W``, ``targetRows = H``: its point ``id = r W + c`` for grid row ``r`` and column
``c``, the order of OpenCV's ``findChessboardCorners`` with ``patternSize = (W, H)``, so sogdd's
label ``(i, j)`` (column, row, as in :mod:`.mrgingham`) is ``id = j W + i``. Kalibr's
``createGridPoints`` puts that point at ``(rowSpacing r, colSpacing c, 0)``: ``target_x = j square``,
``target_y = i square`` (x along the rows, as Kalibr's code has it, whatever its comment says).
``W`` is ``pattern[0]``, or by default the largest label ``i`` plus one over all the views.
A ChArUco board's corners are numbered the same way (Kalibr has no ChArUco target).

An AprilGrid of ``cols x rows`` tags of side ``s``, ``g s`` apart (Kalibr's
``GridCalibrationTargetAprilgrid``, :mod:`sogdd.calib.targets.aprilgrid`) numbers the corners of
a grid of ``2 cols x 2 rows``: point ``k`` is grid column ``gc = k % (2 cols)``, row
``gr = k // (2 cols)``, at ``x = (gc // 2) (1 + g) s + (gc % 2) s``, ``y = (gr // 2) (1 + g) s + (gr % 2) s``
(Kalibr's expression, evaluated in its order). A detected :class:`~sogdd.calib.Board` holds
these numbers in ``ids``; ``corners.csv`` has no id column, only the labels, which the grid maps
to the ids (:meth:`~sogdd.calib.targets.aprilgrid.AprilGrid.labels`). Either way the grid's
geometry is needed (``grid``; ``--board aprilgrid:COLSxROWS:SIZE:SPACING``), and the ids a board
holds must be the ones its labels have on that grid.

Files
-----
One camera: ``path`` itself when it has a suffix (``obs.csv``), else ``path/observations.csv``.
A rig: ``path/NAME.csv`` for each camera, nothing else. Every file is written atomically
(:func:`~.format.write_files`), and never over the ``corners.csv`` read.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..result import Calibration
from ..rig.frames import frame_number
from ..rig.result import RigCalibration
from ..targets.aprilgrid import AprilGrid
from .conversion import read_calibration
from .format import write_files
from .mrgingham import CornerView, corner_views
from .stored import check_scale

__all__ = ["COLUMNS", "KalibrCamera", "KalibrObservation", "kalibr_cameras",
           "kalibr_corners_text", "kalibr_observations", "read_kalibr_corners", "write_kalibr_corners"]

#: the file's columns (module doc)
COLUMNS = ("timestamp_ns", "view", "corner_id", "x", "y", "target_x", "target_y", "used")


@dataclass(frozen=True)
class KalibrCamera:
    """One camera's views; ``name`` ``""`` for a lone camera, ``square`` its board's square (None: unknown)."""

    name: str
    views: tuple[CornerView, ...]
    square: float | None


@dataclass(frozen=True)
class KalibrObservation:
    """One view's rows (module doc): the corners' ``ids`` (N,), pixels ``xy`` (N, 2), ``target`` points
    (N, 2) and ``used`` (N,), sorted by id."""

    view: str
    timestamp_ns: int
    ids: np.ndarray
    xy: np.ndarray
    target: np.ndarray
    used: np.ndarray

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, KalibrObservation):
            return NotImplemented
        return (self.view == other.view and self.timestamp_ns == other.timestamp_ns
                and all(np.array_equal(a, b) for a, b in zip(self._arrays(), other._arrays())))

    def _arrays(self) -> tuple[np.ndarray, ...]:
        return self.ids, self.xy, self.target, self.used


def _of_csv(path: Path, name: str = "") -> KalibrCamera:
    """A camera's ``corners.csv`` (a malformed file: its one-line ``ValueError``), with the square of the
    ``camera.json`` beside it (None without one)."""
    meta = path.parent / "camera.json"
    square = read_calibration(meta).square if meta.is_file() else None
    return KalibrCamera(name, tuple(corner_views(path)), square)


def kalibr_cameras(source: Calibration | RigCalibration | str | os.PathLike) -> list[KalibrCamera]:
    """The cameras and their views of a calibration, a rig, or sogdd's output folder or ``corners.csv``
    (a rig's folder: one camera per ``NAME/corners.csv``, with the square of its ``camera.json``).

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> cam, = kalibr_cameras(demo_calibration())
    >>> cam.name, cam.square, cam.views[0].name, cam.views[0].source
    ('', 1.0, 'view0.png', 'sogdd')
    """
    if isinstance(source, Calibration):
        return [KalibrCamera("", tuple(corner_views(source)), float(source.square))]
    if isinstance(source, RigCalibration):
        return [KalibrCamera(c.name, tuple(corner_views(c.calibration)), float(c.calibration.square))
                for c in source.cameras]
    p = Path(source)
    if p.is_file():
        return [_of_csv(p)]
    if (p / "corners.csv").is_file():
        return [_of_csv(p / "corners.csv")]
    cams = sorted(q.parent for q in p.glob("*/corners.csv")) if p.is_dir() else []
    if not cams:
        corner_views(p)  # its one-line ValueError: no corners.csv
    return [_of_csv(c / "corners.csv", c.name) for c in cams]


def _timestamps(views: Sequence[CornerView]) -> list[int]:
    numbers = [frame_number(v.name.rsplit("#", 1)[-1]) for v in views]
    if all(n is not None for n in numbers) and len(set(numbers)) == len(numbers):
        return [int(n) for n in numbers]  # type: ignore[arg-type]
    return list(range(len(views)))


def _grid_of(grid: AprilGrid | str | None) -> AprilGrid | None:
    if grid is None or isinstance(grid, AprilGrid):
        return grid
    from ..targets.spec import parse_board

    spec = parse_board(grid)
    if spec.kind != "aprilgrid":
        raise ValueError(f"board {grid!r}: Kalibr's ids need an AprilGrid's geometry here "
                         "(aprilgrid:COLSxROWS:SIZE:SPACING); a chessboard's size is the pattern")
    return spec.aprilgrid()


def _width(cameras: Sequence[KalibrCamera], pattern: tuple[int, int] | None) -> int:
    seen = [v.labels for c in cameras for v in c.views
            if v.labels is not None and len(v.labels) and v.source != "aprilgrid"]
    if not seen:
        return 0
    lab = np.concatenate(seen)
    if lab.min() < 0:
        raise ValueError("the boards' labels are relative (a board of unknown size): Kalibr's ids need the "
                         "pattern (W, H)")
    if pattern is None:
        return int(lab[:, 0].max()) + 1
    W, H = (int(v) for v in pattern)
    if lab[:, 0].max() >= W or lab[:, 1].max() >= H:
        raise ValueError(f"a corner's label lies outside the {W} x {H} grid of inner corners: Kalibr's "
                         f"checkerboard holds labels 0..{W - 1} x 0..{H - 1}")
    return W


def _aprilgrid(v: CornerView, grid: AprilGrid | None) -> tuple[np.ndarray, np.ndarray]:
    if grid is None:
        raise ValueError(f"view {v.name}: an AprilGrid's corners: Kalibr's ids and points need its geometry "
                         "(grid; --board aprilgrid:COLSxROWS:SIZE:SPACING)")
    table = grid.labels()
    if v.ids is not None:
        ids = np.asarray(v.ids, np.int64)
        if ids.min() < 0 or ids.max() >= len(table) or not np.array_equal(table[ids], v.labels):
            raise ValueError(f"view {v.name}: the board's ids are not its labels' on the "
                             f"{grid.cols} x {grid.rows} AprilGrid given")
    else:
        index = {(int(i), int(j)): k for k, (i, j) in enumerate(table)}
        try:
            ids = np.array([index[(int(i), int(j))] for i, j in v.labels], np.int64)
        except KeyError as exc:
            raise ValueError(f"view {v.name}: label {exc.args[0]} is no corner of the {grid.cols} x "
                             f"{grid.rows} AprilGrid given") from None
    cols2 = 2 * grid.cols
    gc, gr = (ids % cols2).astype(np.float64), (ids // cols2).astype(np.float64)
    s, g = float(grid.tag_size), float(grid.spacing)
    x = np.floor(gc / 2) * (1 + g) * s + (gc % 2) * s  # Kalibr's createGridPoints, term for term
    y = np.floor(gr / 2) * (1 + g) * s + (gr % 2) * s
    return ids, np.stack([x, y], axis=1)


def kalibr_observations(camera: KalibrCamera, *, width: int | None = None, grid: AprilGrid | str | None = None,
                        used_only: bool = False, scale: float = 1.0,
                        square: float | None = None) -> list[KalibrObservation]:
    """A camera's views as Kalibr's observations (module doc), the views without a corner left out.

    Parameters
    ----------
    camera : KalibrCamera
        From :func:`kalibr_cameras`.
    width : int, optional
        A chessboard's ``W`` (inner corners along a row); default: the largest label ``i`` plus one.
    grid : AprilGrid or str, optional
        The AprilGrid (or its specification ``aprilgrid:COLSxROWS:SIZE:SPACING``); needed for an
        AprilGrid's corners.
    used_only : bool
        Only the corners the calibration used.
    scale : float
        Multiplies the target points (0.001: a square in mm to Kalibr's metres).
    square : float, optional
        A chessboard's square (default: the camera's).

    Examples
    --------
    >>> v = CornerView("f7.png", np.array([[1, 0], [0, 1]]), np.array([[10.5, 20.25], [30.0, 40.0]]), None)
    >>> o, = kalibr_observations(KalibrCamera("", (v,), 25.0), width=3)
    >>> o.timestamp_ns, o.ids.tolist(), o.target.tolist()  # (i, j) = (1, 0): id 1, Kalibr's (0, 25)
    (7, [1, 3], [[0.0, 25.0], [25.0, 0.0]])
    """
    scale = check_scale(scale)
    g = _grid_of(grid)
    W = _width([camera], None) if width is None else int(width)
    sq = camera.square if square is None else float(square)
    out = []
    for v, stamp in zip(camera.views, _timestamps(camera.views)):
        if v.labels is None or not len(v.labels):
            continue
        used = np.ones(len(v.labels), bool) if v.used is None else np.asarray(v.used, bool)
        if v.source == "aprilgrid":
            ids, target = _aprilgrid(v, g)
        else:
            if sq is None:
                raise ValueError(f"camera {camera.name or 'camera'}: the square is unknown (no camera.json "
                                 "beside its corners.csv): give it")
            lab = np.asarray(v.labels, np.int64)
            ids = lab[:, 1] * W + lab[:, 0]
            target = np.stack([lab[:, 1] * sq, lab[:, 0] * sq], axis=1).astype(np.float64)
        if scale != 1.0:
            target = target * float(scale)
        if len(np.unique(ids)) != len(ids):
            raise ValueError(f"view {v.name}: two corners have one Kalibr id")
        keep = used if used_only else np.ones(len(ids), bool)
        order = np.argsort(ids, kind="stable")
        order = order[keep[order]]
        if not len(order):
            continue
        out.append(KalibrObservation(v.name, int(stamp), ids[order], np.asarray(v.xy, np.float64)[order],
                                     target[order], used[order]))
    return out


def kalibr_corners_text(observations: Iterable[KalibrObservation]) -> str:
    """The observations as the file's text (module doc).

    Examples
    --------
    >>> o = KalibrObservation("a.png", 3, np.array([4]), np.array([[1.5, 2.0]]), np.array([[0.1, 0.0]]),
    ...                       np.array([True]))
    >>> print(kalibr_corners_text([o]), end="")
    timestamp_ns,view,corner_id,x,y,target_x,target_y,used
    3,a.png,4,1.5,2.0,0.1,0.0,1
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for o in observations:
        for k, (x, y), (tx, ty), u in zip(o.ids, o.xy, o.target, o.used):
            w.writerow([int(o.timestamp_ns), o.view, int(k), repr(float(x)), repr(float(y)), repr(float(tx)),
                        repr(float(ty)), int(bool(u))])
    return buf.getvalue()


def write_kalibr_corners(source: Calibration | RigCalibration | str | os.PathLike, path: str | os.PathLike, *,
                         pattern: tuple[int, int] | None = None, grid: AprilGrid | str | None = None,
                         used_only: bool = False, scale: float = 1.0,
                         inputs: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """Write the corners of ``source`` (:func:`kalibr_cameras`) as Kalibr's observations (module doc): one
    camera to ``path`` (a file name with a suffix) or ``path/observations.csv``, a rig to ``path/NAME.csv``
    for each camera; the files written. ``pattern`` ``(W, H)``: a chessboard's inner corners (default:
    from the labels); ``grid``: an AprilGrid's geometry; ``used_only``: only the corners the calibration
    used; ``scale`` multiplies the target points. Neither ``inputs`` nor the ``corners.csv`` read is ever
    overwritten; nothing is written unless every file can be.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.demo import demo_calibration
    >>> p, = write_kalibr_corners(demo_calibration(), Path(tempfile.mkdtemp()) / "obs.csv", pattern=(9, 6))
    >>> obs = read_kalibr_corners(p)
    >>> len(obs), obs[0].view, obs[0].ids[:3].tolist(), obs[0].target[1].tolist()
    (8, 'view0.png', [0, 1, 2], [0.0, 1.0])
    """
    check_scale(scale)  # before any file is read
    cameras = kalibr_cameras(source)
    W = _width(cameras, pattern)
    p = Path(path)
    if len(cameras) > 1:
        if p.suffix and not p.is_dir():
            raise ValueError(f"{p}: a rig's observations are one file per camera: OUT is a folder")
        targets = [p / f"{c.name}.csv" for c in cameras]
    else:
        targets = [p / "observations.csv" if p.is_dir() or not p.suffix else p]
    files = {t: kalibr_corners_text(kalibr_observations(c, width=W, grid=grid, used_only=used_only,
                                                        scale=scale)) for t, c in zip(targets, cameras)}
    inputs = list(inputs)
    if isinstance(source, (str, os.PathLike)):  # never over the corners read
        src = Path(source)
        inputs += [src] if src.is_file() else [*src.glob("corners.csv"), *src.glob("*/corners.csv")]
    return write_files(files, inputs)


def read_kalibr_corners(path: str | os.PathLike) -> list[KalibrObservation]:
    """A file :func:`write_kalibr_corners` wrote: its views' observations, in the file's order; a one-line
    ``ValueError`` for a file that is not one.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "obs.csv"
    >>> _ = p.write_text(",".join(COLUMNS) + "\\n5,a.png,2,1.5,2.0,0.0,0.5,0\\n")
    >>> o, = read_kalibr_corners(p)
    >>> o.view, o.timestamp_ns, o.ids.tolist(), o.xy.tolist(), o.target.tolist(), o.used.tolist()
    ('a.png', 5, [2], [[1.5, 2.0]], [[0.0, 0.5]], [False])
    """
    p = Path(path)
    rows: dict[str, list] = {}
    stamps: dict[str, int] = {}
    try:
        with open(p, newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            head = next(reader, None)
            if head is None or tuple(head) != COLUMNS:
                raise ValueError(f"{p}: not Kalibr-style observations (its first line is not "
                                 f"'{','.join(COLUMNS)}')")
            for n, r in enumerate(reader, 2):
                if not r:
                    continue
                try:
                    if len(r) != len(COLUMNS) or r[7] not in ("0", "1"):
                        raise ValueError
                    t, view = int(r[0]), r[1]
                    rows.setdefault(view, []).append((int(r[2]), float(r[3]), float(r[4]), float(r[5]),
                                                      float(r[6]), r[7] == "1"))
                except ValueError:
                    raise ValueError(f"{p}:{n}: a row is '{','.join(COLUMNS)}' (integers, numbers, used 0 "
                                     "or 1)") from None
                if stamps.setdefault(view, t) != t:
                    raise ValueError(f"{p}:{n}: view {view} has two timestamps")
    except UnicodeDecodeError:
        raise ValueError(f"{p}: not a text file") from None
    except OSError as exc:
        raise ValueError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    out = []
    for view, rs in rows.items():
        a = np.array([r[1:5] for r in rs], dtype=np.float64)
        out.append(KalibrObservation(view, stamps[view], np.array([r[0] for r in rs], np.int64), a[:, :2],
                                     a[:, 2:], np.array([r[5] for r in rs], bool)))
    return out
