"""A calibration's report page: HTML with PNG figures and a verdict in plain words.

The page shows every view's detections as a thumbnail (used corners green,
rejected ones red), the residual vectors magnified, where the corners fell in
the frame, the cross-validation difference map, and :func:`verdict`: what is
wrong with the calibration, if anything, and what to do about it.
"""

from __future__ import annotations

import html
import os
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from .calibration import Calibration
from .outputs import _atomic, _write_text

__all__ = ["coverage", "verdict", "write_report"]

# the verdict's limits, each stated where it is used
_FEW_VIEWS = 10            # fewer used views than this is "few"
_RMS_HIGH, _RMS_FAIR = 0.5, 0.2  # px
_CV_LARGE, _CV_FAIR = 2.0, 0.5   # px, mean cross-validation difference
_EDGE_BAND = 0.15          # the frame's outer band, as a fraction of each side
_EDGE_CELLS = 0.5          # share of the band's cells that should hold a corner
_TILT_MIN = 15.0           # degrees: some view should tilt the board at least this much
_GRID = (8, 6)             # coverage cells across and down


def _used_points(cal: Calibration) -> np.ndarray:
    pts = [b.image_points[u] for b, u in zip(cal.boards, cal.corner_used) if b is not None and u is not None]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def coverage(cal: Calibration, grid: tuple[int, int] = _GRID) -> tuple[np.ndarray, float, float]:
    """Where the used corners fell: counts per cell and the shares of cells (all, outer ring) covered.

    The frame is cut into ``grid`` = (columns, rows) equal cells; the outer ring
    is every cell on the border of that grid.

    Returns
    -------
    counts : (rows, columns) int
    covered : float
        Share of cells with at least one used corner.
    edge_covered : float
        Share of the outer ring's cells with at least one used corner.

    Examples
    --------
    >>> from sogdd.calib.calibrate import _demo_calibration
    >>> counts, covered, edge = coverage(_demo_calibration())
    >>> counts.shape, 0 < edge <= covered <= 1
    ((6, 8), True)
    """
    gx, gy = grid
    w, h = cal.image_size
    p = _used_points(cal)
    cx = np.clip((p[:, 0] + 0.5) / w * gx, 0, gx - 1e-9).astype(int)
    cy = np.clip((p[:, 1] + 0.5) / h * gy, 0, gy - 1e-9).astype(int)
    counts = np.zeros((gy, gx), int)
    np.add.at(counts, (cy, cx), 1)
    ring = np.ones((gy, gx), bool)
    ring[1:-1, 1:-1] = False
    return counts, float(np.mean(counts > 0)), float(np.mean(counts[ring] > 0))


def _tilts(cal: Calibration) -> np.ndarray:
    """Angle (degrees) between each used view's board normal and the optical axis: a board
    parallel to the image plane maps to it by an affine map, which says nothing of the focal length."""
    out = []
    for v in np.flatnonzero(cal.view_used):
        R, _ = cv2.Rodrigues(cal.rvecs[v])
        out.append(np.degrees(np.arccos(min(1.0, abs(float(R[2, 2]))))))
    return np.array(out)


def verdict(cal: Calibration) -> list[tuple[str, str]]:
    """Plain-words findings on a calibration, each ``(level, text)`` with level "ok", "warn" or "bad".

    The rules: fewer than 10 used views is few; RMS above 0.5 px is high (0.2
    px: fair); a mean cross-validation difference inside the corners' hull
    above 2 px is large (0.5 px: fair), and outside it a difference above
    both 2 px and 3 times the largest inside is extrapolation; corners in
    fewer than half of the outer ring of an 8 x 6 grid of the frame cover
    "only the centre"; no view tilting the board 15 degrees or
    more leaves the focal length weak; more than a fifth of the views rejected
    is reported. Without any finding the verdict is one "ok".

    Examples
    --------
    >>> from sogdd.calib.calibrate import _demo_calibration
    >>> [level for level, text in verdict(_demo_calibration())][:1]
    ['warn']
    """
    out: list[tuple[str, str]] = []
    n, total = cal.n_used, len(cal.names)
    if n < _FEW_VIEWS:
        out.append(("warn", f"few views ({n} used): calibrate with 10-20 views, the board tilted "
                            "differently and placed over the whole frame"))
    if cal.rms > _RMS_HIGH:
        out.append(("bad", f"high RMS reprojection error ({cal.rms:.2f} px): check blur and focus, motion, "
                           "a board that is not flat, or a lens the model does not fit"))
    elif cal.rms > _RMS_FAIR:
        out.append(("warn", f"fair RMS reprojection error ({cal.rms:.2f} px): sharp, well-lit views do better"))
    out += _coverage_findings(cal)
    out += _cross_validation_findings(cal)
    rejected = total - n - sum(r == "no board" for r in cal.reasons)
    if rejected > 0.2 * total:
        out.append(("warn", f"{rejected} of {total} views rejected (see views.csv): check those images"))
    missing = sum(r == "no board" for r in cal.reasons)
    if missing:
        out.append(("warn" if missing > 0.2 * total else "ok", f"no board found in {missing} of {total} views"))
    if not any(level != "ok" for level, _ in out):
        cv = cal.cross_validation
        out.insert(0, ("ok", f"the calibration looks sound: {n} views, RMS {cal.rms:.3f} px"
                             + (f", halves agree to {_cv_inside(cv)[0]:.2f} px" if cv is not None else "")))
    return out


def _coverage_findings(cal: Calibration) -> list[tuple[str, str]]:
    out = []
    _, covered, edge = coverage(cal)
    if edge < _EDGE_CELLS:
        out.append(("bad" if edge < 0.25 else "warn",
                    f"the corners cover only the centre ({edge:.0%} of the frame's border cells, "
                    f"{covered:.0%} of all cells): add views with the board near the edges and corners of "
                    "the frame"))
    tilts = _tilts(cal)
    if len(tilts) and tilts.max() < _TILT_MIN:
        out.append(("warn", f"the board faces the camera in every view (largest tilt {tilts.max():.0f} deg): "
                            "tilt it 20-45 deg in some views to pin down the focal length"))
    return out


def _cross_validation_findings(cal: Calibration) -> list[tuple[str, str]]:
    cv = cal.cross_validation
    if cv is None:
        return [("warn", (cal.notes[0] if cal.notes else "no cross-validation")
                 + ": the calibration's stability is unknown")]
    mean, mx = _cv_inside(cv)
    out = []
    if mean > _CV_LARGE:
        out.append(("bad", f"large cross-validation difference ({mean:.2f} px mean, {mx:.2f} max where the "
                           "corners are): the two halves of the views disagree; the model may not fit the lens "
                           "(try the rational or fisheye model) or more views are needed"))
    elif mean > _CV_FAIR:
        out.append(("warn", f"fair cross-validation difference ({mean:.2f} px mean, {mx:.2f} max where the "
                            "corners are): more views, tilted and near the edges, would pin the camera down"))
    if np.isfinite(cv.max) and cv.max > max(_CV_LARGE, 3 * mx):
        out.append(("warn", f"outside the corners the halves differ by up to {cv.max:.3g} px: the model "
                            "extrapolates there; do not trust it beyond the area the boards covered"))
    return out


def _cv_inside(cv) -> tuple[float, float]:
    """The cross-validation's mean and max inside the corners' hull (whole image without one)."""
    if np.isfinite(cv.mean_within):
        return cv.mean_within, cv.max_within
    return cv.mean, cv.max


# --------------------------------------------------------------------------------------------------
# figures


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    _atomic(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    _plt().close(fig)


def _residual_figure(cal: Calibration, path: Path) -> None:
    plt = _plt()
    w, h = cal.image_size
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6))
    used, bad = [], []
    for b, r, u in zip(cal.boards, cal.residuals, cal.corner_used):
        if b is None or r is None:
            continue
        used.append(np.c_[b.image_points[u], r[u]])
        bad.append(np.c_[b.image_points[~u], r[~u]])
    U = np.concatenate(used) if used else np.zeros((0, 4))
    B = np.concatenate(bad) if bad else np.zeros((0, 4))
    typical = np.percentile(np.hypot(U[:, 2], U[:, 3]), 95) if len(U) else 1.0
    gain = 0.04 * w / max(typical, 1e-9)  # the 95th percentile arrow is 4% of the width
    for arr, colour, lab in ((U, "tab:blue", "used"), (B, "tab:red", "rejected")):
        if len(arr):
            ax.quiver(arr[:, 0], arr[:, 1], arr[:, 2] * gain, arr[:, 3] * gain, color=colour, angles="xy",
                      scale_units="xy", scale=1, width=0.002, label=f"{lab} ({len(arr)})")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal")
    ax.set_title(f"residuals (observed - projected) x{gain:.0f}; RMS {cal.rms:.3f} px")
    ax.legend(loc="upper right", fontsize=8)
    _save(fig, path)


def _coverage_figure(cal: Calibration, path: Path) -> None:
    plt = _plt()
    w, h = cal.image_size
    counts, covered, edge = coverage(cal)
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6))
    ax.imshow(counts > 0, extent=(0, w, h, 0), cmap="Greens", vmin=0, vmax=2, alpha=0.6)
    p = _used_points(cal)
    ax.plot(p[:, 0], p[:, 1], ".", ms=1.5, color="k")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_title(f"coverage: {len(p)} used corners; {covered:.0%} of cells, {edge:.0%} of border cells")
    _save(fig, path)


def _cross_validation_figure(cal: Calibration, path: Path) -> bool:
    cv = cal.cross_validation
    if cv is None:
        return False
    plt = _plt()
    d = cv.difference
    w, h = cal.image_size
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6))
    top = max(2 * _cv_inside(cv)[1], 1e-3)  # the colours for the data's region; beyond it saturates
    im = ax.imshow(d.distance, extent=(d.xs[0], d.xs[-1], d.ys[-1], d.ys[0]), cmap="viridis", vmin=0,
                   vmax=min(top, float(np.nanmax(d.distance))))
    fig.colorbar(im, ax=ax, label="px")
    if d.within is not None:  # the corners' hull: the region the data supports
        ax.contour(d.xs, d.ys, d.within.astype(float), levels=[0.5], colors="w", linewidths=1.5)
    mean, mx = _cv_inside(cv)
    ax.set_title(f"cross-validation: {mean:.3f} px mean, {mx:.3f} max inside the corners' hull (white);\n"
                 f"whole frame {d.mean:.3f} mean, {d.max:.3g} max", fontsize=9)
    _save(fig, path)
    return True


def _thumbnail(image, board, used, width: int, size: tuple[int, int]) -> np.ndarray:
    w, h = size
    if image is None:
        grey = np.full((h, w), 200, np.uint8)
    else:
        grey = np.asarray(image)
        if grey.ndim == 3:
            grey = cv2.cvtColor(grey[..., :3].astype(np.float32), cv2.COLOR_RGB2GRAY)
        if grey.dtype != np.uint8:  # 16-bit or float: stretch its range to 8 bits for the picture
            grey = np.clip(grey * (255.0 / max(1e-9, float(np.max(grey)))), 0, 255).astype(np.uint8)
    s = width / grey.shape[1]
    small = cv2.resize(grey, (width, max(1, round(grey.shape[0] * s))), interpolation=cv2.INTER_AREA)
    vis = cv2.cvtColor(small, cv2.COLOR_GRAY2BGR)
    if board is not None:
        u = np.ones(len(board), bool) if used is None else used
        for (x, y), ok in zip(board.image_points * s, u):
            cv2.circle(vis, (round(x), round(y)), 2, (0, 180, 0) if ok else (0, 0, 255), -1, cv2.LINE_AA)
        origin = board.image_points[np.argmin(board.labels.sum(axis=1))] * s
        cv2.circle(vis, (round(origin[0]), round(origin[1])), 5, (255, 0, 0), 1, cv2.LINE_AA)
    return vis


def _load(image):
    if image is None or isinstance(image, np.ndarray):
        return image
    import sogdd

    try:
        return sogdd.read_image(image)
    except ValueError:
        return None


def _write_png(path: Path, img: np.ndarray) -> None:
    def write(tmp: Path) -> None:
        if not cv2.imwrite(str(tmp), img):
            raise OSError(f"{path}: could not write the image")

    _atomic(path, write)


# --------------------------------------------------------------------------------------------------
# the page


def write_report(cal: Calibration, out_dir: str | os.PathLike, *, images: Sequence | None = None,
                 title: str = "Camera calibration", thumb_width: int = 240) -> Path:
    """Write ``report.html`` and its figures (``report/*.png``) into ``out_dir``.

    Parameters
    ----------
    cal : Calibration
    out_dir : path
        Created if needed.
    images : sequence, optional
        Per view, an image (array), an image file, or None, for the
        thumbnails (read one at a time); without it the detections are drawn
        on grey.
    title : str
    thumb_width : int
        Thumbnail width in px.

    Returns
    -------
    Path
        The HTML file.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.calibrate import _demo_calibration
    >>> with tempfile.TemporaryDirectory() as d:
    ...     page = write_report(_demo_calibration(), d)
    ...     text = page.read_text()
    ...     pngs = sorted(p.name for p in (page.parent / "report").glob("*.png"))
    >>> "Verdict" in text, pngs[:3]
    (True, ['coverage.png', 'cross_validation.png', 'residuals.png'])
    """
    if images is not None and len(images) != len(cal.names):
        raise ValueError(f"{len(images)} images for {len(cal.names)} views")
    out = Path(out_dir)
    figs = out / "report"
    figs.mkdir(parents=True, exist_ok=True)
    _residual_figure(cal, figs / "residuals.png")
    _coverage_figure(cal, figs / "coverage.png")
    has_cv = _cross_validation_figure(cal, figs / "cross_validation.png")
    thumbs = []
    for v in range(len(cal.names)):
        img = _load(images[v]) if images is not None else None
        f = f"view_{v:04d}.png"
        _write_png(figs / f, _thumbnail(img, cal.boards[v], cal.corner_used[v], thumb_width, cal.image_size))
        thumbs.append(f)
    page = out / "report.html"
    _write_text(page, _html(cal, title, thumbs, has_cv))
    return page


def _camera_table(cal: Calibration) -> str:
    K = cal.K
    rows = [("fx", K[0, 0]), ("fy", K[1, 1]), ("cx", K[0, 2]), ("cy", K[1, 2])]
    rows += list(cal.coefficients().items())
    cells = "".join(f"<tr><td>{n}</td><td>{v:.6g}</td><td>{cal.std.get(n, float('nan')):.3g}</td></tr>"
                    for n, v in rows)
    return f"<table><tr><th>parameter</th><th>value</th><th>std</th></tr>{cells}</table>"


def _html(cal: Calibration, title: str, thumbs: list[str], has_cv: bool) -> str:
    esc = html.escape
    colours = {"ok": "#1a7f37", "warn": "#9a6700", "bad": "#cf222e"}
    items = "".join(f'<li style="color:{colours[lv]}"><b>{lv}</b>: {esc(t)}</li>' for lv, t in verdict(cal))
    cv = cal.cross_validation
    summary = (f"{cal.model} model, {cal.image_size[0]}x{cal.image_size[1]}, {cal.n_used} of {len(cal.names)} "
               f"views and {cal.n_corners_used} corners used, RMS {cal.rms:.4f} px"
               + (", cross-validation {:.3f} px mean / {:.3f} px max inside the corners' hull"
                  .format(*_cv_inside(cv)) if cv is not None else ""))
    cards = []
    for v, (name, f) in enumerate(zip(cal.names, thumbs)):
        rms = cal.view_rms[v]
        state = "used" if cal.view_used[v] else f"rejected: {cal.reasons[v]}"
        cap = f"{esc(name)}<br>{'' if not np.isfinite(rms) else f'RMS {rms:.3f} px, '}{esc(state)}"
        cards.append(f'<figure><img src="report/{f}" alt="{esc(name)}"><figcaption>{cap}</figcaption></figure>')
    cvfig = ('<h2>Cross-validation</h2><p>Two calibrations from the interleaved halves of the used views; the '
             'map shows how far apart they put the same rays (a rotation between them fitted).</p>'
             '<img src="report/cross_validation.png" alt="cross-validation difference">') if has_cv else ""
    style = ("body{font-family:sans-serif;max-width:1100px;margin:auto}figure{display:inline-block;margin:4px;"
             "font-size:11px;width:250px;vertical-align:top}td,th{padding:2px 8px;text-align:right}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(title)}</title>"
            f"<style>{style}</style></head><body><h1>{esc(title)}</h1><p>{esc(summary)}</p><h2>Verdict</h2><ul>{items}</ul>"
            f"<h2>Camera</h2>{_camera_table(cal)}"
            "<h2>Residuals</h2><img src='report/residuals.png' alt='residual vectors'>"
            "<h2>Coverage</h2><img src='report/coverage.png' alt='coverage'>"
            f"{cvfig}<h2>Views</h2><p>Green: corners used; red: rejected; blue ring: the board's label origin."
            f"</p>{''.join(cards)}</body></html>\n")
