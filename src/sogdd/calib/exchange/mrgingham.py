"""A calibration's corners as mrgingham's ``corners.vnl``, what ``mrcal-calibrate-cameras --corners-cache``
reads.

The file is a vnlog: a header ``# filename x y level`` and, for each view with a board, one row
per point of the board's grid of ``W x H`` inner corners in mrgingham's order (row by row,
``index = j W + i`` for sogdd's label ``(i, j)``: mrcal's object point ``(i, j, 0)`` times the
spacing is sogdd's ``(i, j, 0)`` times the square). ``x y`` are the corner's pixel (centres at
integers, as mrcal's and sogdd's); ``level`` is the decimation level mrcal weighs a corner by
(:math:`2^{-level}`): 0 for every corner sogdd measured, ``-`` (all three columns) for a grid
point with no corner (a partial board, or with ``used_only`` a corner the calibration rejected).
A view without a board is one row ``filename - - -``, as mrgingham writes it.

A rig's views are named ``CAMERA/VIEW`` (``mrcal-calibrate-cameras`` then takes one glob per
camera, ``'left/*' 'right/*'``, and matches frames by the numbers in the names). The corners
come from a :class:`~sogdd.calib.Calibration` or :class:`~sogdd.calib.rig.RigCalibration`, or
from sogdd's output folder (its ``corners.csv``; a rig's ``NAME/corners.csv``).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..result import Calibration
from ..rig.result import RigCalibration
from .format import write_files

__all__ = ["CornerView", "corner_views", "corners_vnl_text", "read_corners_vnl", "write_corners_vnl"]

_HEADER = "# filename x y level\n"


@dataclass(frozen=True)
class CornerView:
    """One view's corners: its name, each corner's label ``(i, j)`` and pixel, and whether the fit used it;
    the board's detector (``Board.source``, ``""`` unknown) and its ids where it has them (``Board.ids``: an
    AprilGrid's Kalibr point numbers; a ``corners.csv`` holds none).

    ``labels`` None: the view has no board.
    """

    name: str
    labels: np.ndarray | None
    xy: np.ndarray | None
    used: np.ndarray | None
    source: str = ""
    ids: np.ndarray | None = None


def _of_calibration(cal: Calibration, prefix: str = "") -> list[CornerView]:
    out = []
    for v, name in enumerate(cal.names):
        b = cal.boards[v]
        if b is None:
            out.append(CornerView(prefix + name, None, None, None))
            continue
        used = None if cal.corner_used[v] is None else np.asarray(cal.corner_used[v], bool)
        xy = np.asarray(b.image_points, np.float64)
        out.append(CornerView(prefix + name, np.asarray(b.labels, np.int64), xy, used, b.source, b.ids))
    return out


def _of_csv(path: Path, prefix: str = "") -> list[CornerView]:
    rows: dict[str, list] = {}
    sources: dict[str, str] = {}
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            for r in csv.DictReader(fh):
                rows.setdefault(r["view"], []).append((int(r["i"]), int(r["j"]), float(r["x"]), float(r["y"]),
                                                       r.get("used", "1") == "1"))
                sources.setdefault(r["view"], r.get("source") or "")  # one board a view: one detector
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{path}: not sogdd's corners.csv ({exc})") from None
    out = []
    for name, rs in rows.items():
        a = np.array([r[:4] for r in rs], dtype=np.float64)
        used = np.array([r[4] for r in rs])
        out.append(CornerView(prefix + name, a[:, :2].astype(np.int64), a[:, 2:4], used, sources[name]))
    return out


def corner_views(source: Calibration | RigCalibration | str | os.PathLike) -> list[CornerView]:
    """The views and corners of a calibration, or of sogdd's output folder or ``corners.csv`` (module doc).

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> views = corner_views(demo_calibration())
    >>> views[0].name, views[0].labels.shape
    ('view0.png', (54, 2))
    """
    if isinstance(source, Calibration):
        return _of_calibration(source)
    if isinstance(source, RigCalibration):
        return [v for c in source.cameras for v in _of_calibration(c.calibration, f"{c.name}/")]
    p = Path(source)
    if p.is_file():
        return _of_csv(p)
    if (p / "corners.csv").is_file():
        return _of_csv(p / "corners.csv")
    cams = sorted(q.parent for q in p.glob("*/corners.csv")) if p.is_dir() else []
    if not cams:
        raise ValueError(f"{p}: no corners.csv (sogdd calibrate's output folder, or a rig's NAME/corners.csv)")
    return [v for c in cams for v in _of_csv(c / "corners.csv", f"{c.name}/")]


def _pattern(views: Sequence[CornerView], pattern: tuple[int, int] | None) -> tuple[int, int]:
    seen = [v.labels for v in views if v.labels is not None and len(v.labels)]
    if not seen:
        raise ValueError("no view has corners")
    lab = np.concatenate(seen)
    if pattern is None:
        if lab.min() < 0:
            raise ValueError("the boards' labels are relative (a board of unknown size): give the pattern "
                             "(W, H)")
        pattern = (int(lab[:, 0].max()) + 1, int(lab[:, 1].max()) + 1)
    W, H = (int(v) for v in pattern)
    if lab.min() < 0 or lab[:, 0].max() >= W or lab[:, 1].max() >= H:
        raise ValueError(f"a corner's label lies outside the {W} x {H} grid: mrgingham's grid holds labels "
                         f"0..{W - 1} x 0..{H - 1}")
    return W, H


def corners_vnl_text(views: Sequence[CornerView], pattern: tuple[int, int] | None = None, *,
                     used_only: bool = False) -> str:
    """The views as ``corners.vnl`` text (module doc); ``pattern`` ``(W, H)`` inner corners (default: from
    the labels).

    Examples
    --------
    >>> v = CornerView("a.png", np.array([[0, 0], [1, 1]]), np.array([[10.5, 20.25], [30.0, 40.0]]), None)
    >>> print(corners_vnl_text([v, CornerView("b.png", None, None, None)], (2, 2)), end="")
    # filename x y level
    a.png 10.5 20.25 0
    a.png - - -
    a.png - - -
    a.png 30.0 40.0 0
    b.png - - -
    """
    W, H = _pattern(views, pattern)
    lines = [_HEADER]
    for v in views:
        if any(c.isspace() for c in v.name) or not v.name:
            raise ValueError(f"view {v.name!r}: a vnlog's file name holds no white space")
        if v.labels is None:
            lines.append(f"{v.name} - - -\n")
            continue
        grid: list[str | None] = [None] * (W * H)
        keep = np.ones(len(v.labels), bool) if not used_only or v.used is None else v.used
        for (i, j), (x, y), k in zip(v.labels, v.xy, keep):
            if k:
                grid[int(j) * W + int(i)] = f"{float(x)!r} {float(y)!r} 0"
        lines += [f"{v.name} {g if g is not None else '- - -'}\n" for g in grid]
    return "".join(lines)


def write_corners_vnl(source: Calibration | RigCalibration | str | os.PathLike, path: str | os.PathLike, *,
                      pattern: tuple[int, int] | None = None, used_only: bool = False,
                      inputs: Iterable[str | os.PathLike] = ()) -> Path:
    """Write the corners of ``source`` (:func:`corner_views`) as ``corners.vnl`` at ``path`` (a file name
    with a suffix, or ``path/corners.vnl`` for a folder or a name without one); the file written.
    ``used_only``: the corners the calibration used (the others ``-``). Neither ``inputs`` nor the
    ``corners.csv`` read is ever overwritten.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.demo import demo_calibration
    >>> p = write_corners_vnl(demo_calibration(), Path(tempfile.mkdtemp()) / "corners.vnl")
    >>> grid = read_corners_vnl(p, (9, 6))
    >>> len(grid), grid["view0.png"].shape
    (8, (54, 3))
    """
    p = Path(path)
    target = p / "corners.vnl" if p.is_dir() or not p.suffix else p
    text = corners_vnl_text(corner_views(source), pattern, used_only=used_only)
    inputs = list(inputs)
    if isinstance(source, (str, os.PathLike)):  # never over the corners read
        src = Path(source)
        inputs += [src] if src.is_file() else [*src.glob("corners.csv"), *src.glob("*/corners.csv")]
    return write_files({target: text}, inputs)[0]


def read_corners_vnl(path: str | os.PathLike, pattern: tuple[int, int]) -> dict[str, np.ndarray]:
    """A ``corners.vnl``: view name -> ``(W H, 3)`` rows ``x, y, level`` in mrgingham's order (NaN for ``-``);
    a view without a board is absent."""
    W, H = (int(v) for v in pattern)
    rows: dict[str, list] = {}
    for n, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        f = line.split()
        if len(f) not in (3, 4):
            raise ValueError(f"{path}:{n}: a row is 'filename x y [level]'")
        rows.setdefault(f[0], []).append([np.nan if t == "-" else float(t) for t in (f[1:] + ["0"])[:3]])
    out = {}
    for name, r in rows.items():
        if len(r) == 1 and np.isnan(r[0][0]):
            continue
        if len(r) != W * H:
            raise ValueError(f"{path}: view {name} has {len(r)} rows; a {W} x {H} grid has {W * H}")
        out[name] = np.array(r, dtype=np.float64)
    return out
