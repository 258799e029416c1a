"""A rig calibration's report page: the rig in 3-D, its errors, its uncertainty and a rectified pair.

``report.html`` shows the verdict in plain words (:func:`~sogdd.calib.rig.verdict.rig_verdict`),
the cameras with their standard deviations, the cameras and the board's poses in the first
camera's frame (as MATLAB's extrinsics view), each frame's RMS per camera, each camera's
map of the projection uncertainty of a far point, each pair (the reference and another
camera) rectified with its epipolar lines, the model-selection tables, and a link to each
camera's own report (``NAME/report.html``, :func:`sogdd.calib.report.write_report`). Like
the one-camera report it never reads an image file: it draws on the thumbnails that
detection kept.
"""

from __future__ import annotations

import dataclasses
import html
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import cv2
import numpy as np

from ...formats.safe_write import write_text
from ..cameras import lens
from ..detection import Thumbnail, ViewRecord
from ..figures import COLOURS, PlacedCamera, board_outline, poses_figure, pyplot, save_figure
from ..report import html_page, selection_table, write_report
from .result import RigCalibration, RigCamera, cameras_text
from .stereo import StereoPair, rectify_points, stereo_pair
from .uncertainty import projection_uncertainty
from .verdict import rig_verdict

__all__ = ["RectifiedPair", "rectified_pair", "write_rig_report"]

def _extrinsics_figure(rig: RigCalibration, path: Path) -> None:
    """The cameras and the board's poses in the first camera's frame
    (:func:`~sogdd.calib.figures.poses_figure`)."""
    outlines = []
    for f in np.flatnonzero(rig.frame_used):
        board = next((c.calibration.boards[f] for c in rig.cameras if c.calibration.boards[f] is not None),
                     None)
        q = board_outline(board, rig.rvecs[f], rig.tvecs[f], rig.square)
        if q is not None:
            outlines.append(q)
    cams = [PlacedCamera(c.name, c.K, c.R, c.T, c.image_size) for c in rig.cameras]
    poses_figure(cams, outlines, f"cameras and {int(np.sum(rig.frame_used))} board poses, in "
                 f"{rig.cameras[0].name}'s frame", path)


def _errors_figure(rig: RigCalibration, path: Path) -> None:
    plt = pyplot()
    F = len(rig.frames)
    n = len(rig.cameras)
    fig, ax = plt.subplots(figsize=(min(10.5, max(6, 0.3 * F * n / 2 + 2)), 3.5))  # within the page
    width = 0.8 / n
    for k, cam in enumerate(rig.cameras):
        rms = np.asarray(cam.calibration.view_rms, float)
        used = np.asarray(cam.calibration.view_used, bool)
        x = np.arange(F) + (k - (n - 1) / 2) * width
        ax.bar(x[used], np.nan_to_num(rms[used]), width, color=COLOURS[k % len(COLOURS)],
               label=f"{cam.name} (RMS {cam.calibration.rms:.3f} px)")
        bad = ~used & np.isfinite(rms)
        if bad.any():
            ax.bar(x[bad], rms[bad], width, color="none", edgecolor="tab:red", hatch="//")
    ax.set_xticks(np.arange(F))
    ax.set_xticklabels(rig.frames, rotation=90, fontsize=7)
    ax.set_ylabel("RMS (px)")
    ax.set_title("each frame's RMS per camera (hatched red: rejected)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)


def _uncertainty_figure(rig: RigCalibration, cam: RigCamera, path: Path) -> bool:
    try:
        pixels, sigma = projection_uncertainty(rig, cam.name, grid=(32, 24))
    except ValueError:
        return False
    sigma = np.asarray(sigma, float)
    if not np.isfinite(sigma).any():
        return False
    plt = pyplot()
    w, h = cam.image_size
    xs, ys = np.unique(pixels[:, 0]), np.unique(pixels[:, 1])
    grid = np.full((len(ys), len(xs)), np.nan)
    grid[np.searchsorted(ys, pixels[:, 1]), np.searchsorted(xs, pixels[:, 0])] = sigma
    fig, ax = plt.subplots(figsize=(6.5, 6 * h / w + 0.9), layout="constrained")
    from matplotlib.colors import LogNorm

    im = ax.imshow(grid, extent=(xs[0], xs[-1], ys[-1], ys[0]), cmap="magma",
                   norm=LogNorm() if np.nanmin(grid) > 0 else None)
    fig.colorbar(im, ax=ax, label="1 sigma (px)", shrink=0.9)
    used = [b.image_points[u] for b, u in zip(cam.calibration.boards, cam.calibration.corner_used)
            if b is not None and u is not None]
    if used:
        p = np.concatenate(used)
        ax.plot(p[:, 0], p[:, 1], ".", ms=1, color="c")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_title(f"{cam.name}: projection uncertainty of a far point\n(cyan: the corners used)", fontsize=9,
                 loc="left")
    save_figure(fig, path)
    return True


def _thumb_matrix(scale: float) -> np.ndarray:
    """Full-image pixels to thumbnail pixels: ``(p + 0.5) scale - 0.5``."""
    off = 0.5 * scale - 0.5
    return np.array([[scale, 0, off], [0, scale, off], [0, 0, 1.0]])


def _rectified(cam: RigCamera, Rr: np.ndarray, P: np.ndarray, thumb: Thumbnail | None,
               size: tuple[int, int], scale: float) -> np.ndarray:
    """The thumbnail rectified (grey on a blank canvas without one), at ``scale`` of the full image."""
    A = _thumb_matrix(scale)
    if thumb is None:
        return np.full((size[1], size[0]), 200, np.uint8)
    At = _thumb_matrix(thumb.scale)
    K = At @ cam.K
    if lens(cam.model).start == "fisheye.calibrate":
        m1, m2 = cv2.fisheye.initUndistortRectifyMap(K, cam.dist[:4], Rr, A @ P[:, :3], size, cv2.CV_32FC1)
    else:
        m1, m2 = cv2.initUndistortRectifyMap(K, cam.dist, Rr, A @ P[:, :3], size, cv2.CV_32FC1)
    return cv2.remap(thumb.image, m1, m2, cv2.INTER_LINEAR, borderValue=255)


@dataclasses.dataclass(frozen=True)
class RectifiedPair:
    """Two cameras, the reference and another, rectified in the frame they share most corners of.

    What :func:`rectified_pair` returns.

    Attributes
    ----------
    pair : StereoPair
        The two cameras' rectification (:func:`~sogdd.calib.rig.stereo.stereo_pair`).
    frame : int
        The frame's index in ``rig.frames``.
    points : (dict, dict)
        Per camera (the reference, then the other), each corner's label ``(i, j)``
        -> its rectified pixel ``(x, y)`` (:func:`~sogdd.calib.rig.stereo.rectify_points`).
    """

    pair: StereoPair
    frame: int
    points: tuple[dict, dict]

    @property
    def shared(self) -> list[tuple[int, int]]:
        """The labels both cameras saw, sorted."""
        return sorted(set(self.points[0]) & set(self.points[1]))

    @property
    def disparity(self) -> float:
        """The RMS vertical disparity of the shared corners (px): :math:`\\sqrt{\\overline{(y_1 - y_2)^2}}`,
        0 for a perfect rectification (a point's two images on one row); NaN without a shared corner."""
        dy = np.array([self.points[0][s][1] - self.points[1][s][1] for s in self.shared])
        return float(np.sqrt(np.mean(dy ** 2))) if len(dy) else float("nan")


def rectified_pair(rig: RigCalibration, name: str) -> RectifiedPair | None:
    """The reference camera and camera ``name`` rectified, in the used frame where they share most corners.

    What the report draws for each pair, and what ``rig.json`` holds of it
    (:func:`~sogdd.calib.rig.files.rig_dict`): the corners of both views mapped
    into the rectified images, whose vertical disparity measures the
    calibration (a point's two images share one row when it is right).

    Returns
    -------
    RectifiedPair or None
        None when the two cameras share no corner in any used frame.

    Examples
    --------
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> check = rectified_pair(demo_rig(), "right")
    >>> len(check.shared), bool(check.disparity < 0.2)  # px: the demo's corners carry noise
    (54, True)
    """
    first, other = rig.cameras[0], rig.camera(name)
    best, count = None, 0
    for f in np.flatnonzero(rig.frame_used):
        a, b = first.calibration.boards[f], other.calibration.boards[f]
        if a is None or b is None:
            continue
        n = len({tuple(t) for t in a.labels} & {tuple(t) for t in b.labels})
        if n > count:
            best, count = int(f), n
    if best is None:
        return None
    pair = stereo_pair(rig, first.name, other.name)
    points = []
    for which, cam in enumerate((first, other)):
        board = cam.calibration.boards[best]
        q = rectify_points(pair, cam.K, cam.dist, cam.model, board.image_points, which + 1)
        points.append(dict(zip(map(tuple, board.labels), q)))
    return RectifiedPair(pair, best, (points[0], points[1]))


def _pair_figure(rig: RigCalibration, check: RectifiedPair, thumbnails, path: Path) -> None:
    """The reference and the other camera of ``check`` rectified side by side, their corners marked."""
    first, other = rig.cameras[0], rig.camera(check.pair.names[1])
    pair, best = check.pair, check.frame
    w, h = first.image_size
    scale = 480.0 / max(w, h)
    size = (int(round(w * scale)), int(round(h * scale)))
    A = _thumb_matrix(scale)
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 10 * size[1] / size[0] / 2 + 0.8))
    for ax, cam, Rr, P, which in ((axes[0], first, pair.R1, pair.P1, 0), (axes[1], other, pair.R2, pair.P2, 1)):
        thumb = thumbnails.get(cam.name, [None] * len(rig.frames))[best] if thumbnails else None
        ax.imshow(_rectified(cam, Rr, P, thumb, size, scale), cmap="gray", vmin=0, vmax=255)
        q = np.array(list(check.points[which].values()))
        qt = np.c_[q, np.ones(len(q))] @ A.T
        inside = np.all((qt[:, :2] >= -0.5) & (qt[:, :2] <= np.array(size) - 0.5), axis=1)
        ax.plot(qt[inside, 0], qt[inside, 1], "+", ms=4, color=COLOURS[which])
        ax.set_xlim(-0.5, size[0] - 0.5)
        ax.set_ylim(size[1] - 0.5, -0.5)
        for y in np.linspace(0, size[1], 12)[1:-1]:
            ax.axhline(y, color="y", lw=0.6)
        ax.set_title(f"{cam.name}, frame {rig.frames[best]}", fontsize=9)
        ax.set_axis_off()
    fig.suptitle(f"rectified pair {first.name} / {other.name}: the same corner lies on the same row; "
                 f"vertical disparity {check.disparity:.3f} px RMS over {len(check.shared)} shared corners",
                 fontsize=9)
    save_figure(fig, path)


def _fmt(v: float, digits: int = 4) -> str:
    return "nan" if not np.isfinite(v) else f"{v:.{digits}g}"


def _camera_rows(rig: RigCalibration) -> str:
    rows = []
    for cam in rig.cameras:
        K, s = cam.K, cam.std
        cells = [html.escape(cam.name), cam.model, f"{cam.image_size[0]}x{cam.image_size[1]}"]
        cells += [f"{_fmt(K[i, j], 6)} ± {_fmt(s.get(n, np.nan), 2)}"
                  for n, (i, j) in (("fx", (0, 0)), ("fy", (1, 1)), ("cx", (0, 2)), ("cy", (1, 2)))]
        cells += [f"{_fmt(cam.baseline)} ± {_fmt(s.get('baseline', np.nan), 2)}",
                  f"{cam.rotation_deg:.3f} ± {_fmt(s.get('rotation_deg', np.nan), 2)}",
                  f"{cam.calibration.rms:.4f}", f"{cam.calibration.n_used} of {len(rig.frames)}",
                  f'<a href="{html.escape(cam.name)}/report.html">report</a>']
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    head = ("camera", "model", "size", "fx", "fy", "cx", "cy", "baseline", "rotation (deg)", "RMS (px)",
            "frames used", "")
    return "<table><tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr>" + "".join(rows) + "</table>"


def _selection_tables(rig: RigCalibration) -> str:
    """Each camera's model-selection table (``model="auto"``), as the one-camera report shows it
    (:func:`~sogdd.calib.report.selection_table`)."""
    if not rig.model_selection:
        return ""
    out = ["<h2>Lens model chosen by the data</h2>"]
    for name, sel in rig.model_selection.items():
        out.append(f"<h3>{html.escape(name)}: {html.escape(sel.chosen)}</h3>{selection_table(sel)}")
    return "".join(out)


def write_rig_report(rig: RigCalibration, out_dir: str | os.PathLike, *,
                     thumbnails: Mapping[str, Sequence[Thumbnail | None]] | None = None,
                     views: Mapping[str, Sequence[ViewRecord]] | None = None,
                     title: str = "Rig calibration") -> Path:
    """Write ``report.html`` and its figures (``report/*.png``) into ``out_dir``, and each camera's own report.

    Parameters
    ----------
    rig : RigCalibration
    out_dir : path
        Created if needed; each camera's report goes into ``out_dir/NAME/``.
    thumbnails : mapping of camera name to a sequence of Thumbnail or None, optional
        Per camera, per frame, the small grey images the pictures are drawn on
        (without them: on grey).
    views : mapping of camera name to a sequence of ViewRecord, optional
        Per camera, every input's fate, for its own report.
    title : str

    Returns
    -------
    Path
        The HTML file.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> with tempfile.TemporaryDirectory() as d:
    ...     page = write_rig_report(demo_rig(), d)
    ...     names = sorted(p.name for p in (page.parent / "report").glob("*.png"))
    ...     own = (page.parent / "right" / "report.html").is_file()
    >>> names[:2], own
    (['errors.png', 'extrinsics.png'], True)
    """
    out = Path(out_dir)
    figs = out / "report"
    figs.mkdir(parents=True, exist_ok=True)
    _extrinsics_figure(rig, figs / "extrinsics.png")
    _errors_figure(rig, figs / "errors.png")
    maps, pairs = [], []
    for cam in rig.cameras:
        if _uncertainty_figure(rig, cam, figs / f"uncertainty_{cam.name}.png"):
            maps.append(cam.name)
        thumbs = thumbnails.get(cam.name) if thumbnails else None
        write_report(cam.calibration, out / cam.name, images=thumbs,
                     views=views.get(cam.name) if views else None, title=f"{title}: camera {cam.name}")
    for cam in rig.cameras[1:]:
        check = rectified_pair(rig, cam.name)
        if check is not None:
            _pair_figure(rig, check, thumbnails, figs / f"rectified_{cam.name}.png")
            pairs.append((cam.name, check.disparity))
    page = out / "report.html"
    write_text(page, _html(rig, title, maps, pairs))
    return page


def _html(rig: RigCalibration, title: str, maps: list[str], pairs: list[tuple[str, float]]) -> str:
    esc = html.escape
    first = rig.cameras[0].name
    summary = (f"{cameras_text(len(rig.cameras))}, {int(np.sum(rig.frame_used))} of {len(rig.frames)} frames "
               f"used, RMS {rig.rms:.4f} px over every camera's corners, corner noise {rig.sigma:.4f} px; "
               f"poses in {first}'s frame (x_cam = R x_{first} + T), translations in the square's unit")
    notes = "".join(f"<li>{esc(n)}</li>" for n in rig.notes)
    unc = "".join(f"<img src='report/uncertainty_{esc(n)}.png' alt='uncertainty of {esc(n)}'>" for n in maps)
    rect = "".join(f"<p>{esc(first)} / {esc(n)}: {d:.3f} px RMS vertical disparity</p>"
                   f"<img src='report/rectified_{esc(n)}.png' alt='rectified {esc(n)}'>" for n, d in pairs)
    return html_page(
        title, summary, rig_verdict(rig),
        (f"<h2>Notes</h2><ul>{notes}</ul>" if notes else "")
        + f"<h2>Cameras</h2>{_camera_rows(rig)}"
        "<h2>The rig</h2><img src='report/extrinsics.png' alt='cameras and board poses'>"
        "<h2>Errors</h2><img src='report/errors.png' alt='RMS per frame and camera'>"
        "<h2>Projection uncertainty</h2><p>1 sigma of where a far point projects (the worst direction), "
        f"from the fit's covariance; the other cameras' include their pose's.</p>{unc}"
        + (f"<h2>Rectified pairs</h2>{rect}" if len(rig.cameras) > 1 else "") + _selection_tables(rig))
