"""A calibration's report page: HTML with PNG figures and a verdict in plain words.

The page shows every view's detections as a thumbnail (used corners green,
rejected ones red), the residual vectors magnified, where the corners fell in
the frame, the cross-validation difference map, the lens models compared
(``model="auto"``), and :func:`verdict`: what is
wrong with the calibration, if anything, and what to do about it.

The report never reads an image file: the thumbnails come from :class:`Thumbnail`
objects made where the image was read for detection (:mod:`.detection`), or from
image arrays.
"""

from __future__ import annotations

import html
import os
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from ..formats.safe_write import atomic_write, write_bytes, write_text
from .detection import THUMB_WIDTH, Thumbnail, ViewRecord, make_thumbnail, view_records
from .result import Calibration
from .verdict import coverage, cv_inside, used_points, verdict

__all__ = ["pyplot", "save_figure", "write_report"]

# --------------------------------------------------------------------------------------------------
# figures


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed), imported when a figure is drawn."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> None:
    """Write a figure as a PNG (100 dpi), atomically, and close it."""
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    pyplot().close(fig)


def _residual_figure(cal: Calibration, path: Path) -> None:
    plt = pyplot()
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
    save_figure(fig, path)


def _coverage_figure(cal: Calibration, path: Path) -> None:
    plt = pyplot()
    w, h = cal.image_size
    counts, covered, edge = coverage(cal)
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6))
    ax.imshow(counts > 0, extent=(0, w, h, 0), cmap="Greens", vmin=0, vmax=2, alpha=0.6)
    p = used_points(cal)
    ax.plot(p[:, 0], p[:, 1], ".", ms=1.5, color="k")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_title(f"coverage: {len(p)} used corners; {covered:.0%} of cells, {edge:.0%} of border cells")
    save_figure(fig, path)


def _cross_validation_figure(cal: Calibration, path: Path) -> bool:
    cv = cal.cross_validation
    if cv is None:
        return False
    plt = pyplot()
    d = cv.difference
    w, h = cal.image_size
    fig, ax = plt.subplots(figsize=(8, 8 * h / w + 0.6))
    top = max(2 * cv_inside(cv)[1], 1e-3)  # the colours for the data's region; beyond it saturates
    im = ax.imshow(d.distance, extent=(d.xs[0], d.xs[-1], d.ys[-1], d.ys[0]), cmap="viridis", vmin=0,
                   vmax=min(top, float(np.nanmax(d.distance))))
    fig.colorbar(im, ax=ax, label="px")
    if d.within is not None:  # the corners' hull: the region the data supports
        ax.contour(d.xs, d.ys, d.within.astype(float), levels=[0.5], colors="w", linewidths=1.5)
    mean, mx = cv_inside(cv)
    ax.set_title(f"cross-validation: {mean:.3f} px mean, {mx:.3f} max inside the corners' hull (white);\n"
                 f"whole frame {d.mean:.3f} mean, {d.max:.3g} max", fontsize=9)
    save_figure(fig, path)
    return True


def _thumbnail(image, board, used, width: int, size: tuple[int, int]) -> np.ndarray:
    """The view's thumbnail (a :class:`Thumbnail`, an image array or None: grey) with its detections."""
    if image is None:
        w, h = size
        thumb = Thumbnail(np.full((max(1, round(h * width / w)), width), 200, np.uint8), width / w)
    elif isinstance(image, Thumbnail):
        thumb = image
    else:
        thumb = make_thumbnail(image, width)
    if thumb.image.shape[1] != width:  # made at another width: the picture and the points follow
        f = width / thumb.image.shape[1]
        small = cv2.resize(thumb.image, (width, max(1, round(thumb.image.shape[0] * f))),
                           interpolation=cv2.INTER_AREA)
        thumb = Thumbnail(small, thumb.scale * f)
    s = thumb.scale
    vis = cv2.cvtColor(thumb.image, cv2.COLOR_GRAY2BGR)
    if board is not None:
        u = np.ones(len(board), bool) if used is None else used
        for (x, y), ok in zip((board.image_points + 0.5) * s - 0.5, u):
            cv2.circle(vis, (round(x), round(y)), 2, (0, 180, 0) if ok else (0, 0, 255), -1, cv2.LINE_AA)
        origin = (board.image_points[np.argmin(board.labels.sum(axis=1))] + 0.5) * s - 0.5
        cv2.circle(vis, (round(origin[0]), round(origin[1])), 5, (255, 0, 0), 1, cv2.LINE_AA)
    return vis


def _write_png(path: Path, img: np.ndarray) -> None:
    ok, data = cv2.imencode(".png", img)
    if not ok:
        raise OSError(f"{path}: could not encode the image")
    write_bytes(path, data.tobytes())


# --------------------------------------------------------------------------------------------------
# the page


def write_report(cal: Calibration, out_dir: str | os.PathLike, *, images: Sequence | None = None,
                 views: Sequence[ViewRecord] | None = None, title: str = "Camera calibration",
                 thumb_width: int = THUMB_WIDTH) -> Path:
    """Write ``report.html`` and its figures (``report/*.png``) into ``out_dir``.

    Parameters
    ----------
    cal : Calibration
    out_dir : path
        Created if needed.
    images : sequence, optional
        Per view of ``cal``, a :class:`Thumbnail`, an image array, or None, for
        the thumbnails; without it the detections are drawn on grey. Files are
        never read here.
    views : sequence of ViewRecord, optional
        Every input's fate (:attr:`sogdd.calib.ImageCalibration.views`): the page
        lists them all, the images that could not be read too; without it, the
        views of ``cal`` (:func:`~sogdd.calib.detection.view_records`).
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
    >>> from sogdd.calib.demo import demo_calibration
    >>> with tempfile.TemporaryDirectory() as d:
    ...     page = write_report(demo_calibration(), d)
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
        f = f"view_{v:04d}.png"
        img = images[v] if images is not None else None
        _write_png(figs / f, _thumbnail(img, cal.boards[v], cal.corner_used[v], thumb_width, cal.image_size))
        thumbs.append(f)
    page = out / "report.html"
    write_text(page, _html(cal, title, _cards(cal, thumbs, views), has_cv))
    return page


def _cards(cal: Calibration, thumbs: list[str], views) -> list[str]:
    """A figure per view (per input with ``views``: one that could not be read has no picture)."""
    esc = html.escape
    cards = []
    for row in view_records(cal) if views is None else views:
        # a view the fit had but did not use (no board, or rejected) is "rejected", as the fit says
        word = row.status if row.status in ("unreadable", "ignored") else "rejected"
        state = "used" if row.status == "used" else f"{word}: {row.reason or row.status}"
        if row.view is None:
            cards.append(f'<figure class="none"><div>no picture</div><figcaption>{esc(row.name)}<br>'
                         f"{esc(state)}</figcaption></figure>")
            continue
        rms = cal.view_rms[row.view]
        cap = f"{esc(row.name)}<br>{'' if not np.isfinite(rms) else f'RMS {rms:.3f} px, '}{esc(state)}"
        cards.append(f'<figure><img src="report/{thumbs[row.view]}" alt="{esc(row.name)}">'
                     f"<figcaption>{cap}</figcaption></figure>")
    return cards


def _camera_table(cal: Calibration) -> str:
    K = cal.K
    rows = [("fx", K[0, 0]), ("fy", K[1, 1]), ("cx", K[0, 2]), ("cy", K[1, 2])]
    rows += list(cal.coefficients().items())
    cells = "".join(f"<tr><td>{n}</td><td>{v:.6g}</td><td>{cal.std.get(n, float('nan')):.3g}</td></tr>"
                    for n, v in rows)
    return f"<table><tr><th>parameter</th><th>value</th><th>std</th></tr>{cells}</table>"


def _selection_table(cal: Calibration) -> str:
    """The model selection's table (``model="auto"``), or "" without one."""
    sel = cal.model_selection
    if sel is None:
        return ""

    def num(v: float, d: int = 4) -> str:
        return f"{v:.{d}f}" if np.isfinite(v) else ("failed" if v == np.inf else "")

    rows = "".join(
        f"<tr><td>{html.escape(r.model)}</td><td>{r.n_coefficients}</td><td>{num(r.fit_rms)}</td>"
        f"<td>{num(r.cv_rms)}{' &plusmn; ' + num(r.cv_se) if np.isfinite(r.cv_se) else ''}</td>"
        f"<td>{num(r.difference)}{' &plusmn; ' + num(r.difference_se) if np.isfinite(r.difference_se) else ''}"
        f"</td><td>{'chosen' if r.model == sel.chosen else ('within noise' if r.within_noise else '')}</td>"
        f"<td style='text-align:left'>{html.escape(r.note)}</td></tr>" for r in sel.table)
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in sel.notes)
    return ("<h2>Lens model</h2>"
            f"<p>{html.escape(sel.rule[:1].upper() + sel.rule[1:])}.</p>"
            "<table><tr><th>model</th><th>coefficients</th><th>fit RMS (px)</th>"
            "<th>cross-validated RMS &plusmn; SE (px)</th><th>difference to the best &plusmn; SE</th><th></th>"
            f"<th></th></tr>{rows}</table>" + (f"<ul>{notes}</ul>" if notes else ""))


def _html(cal: Calibration, title: str, cards: list[str], has_cv: bool) -> str:
    esc = html.escape
    colours = {"ok": "#1a7f37", "warn": "#9a6700", "bad": "#cf222e"}
    items = "".join(f'<li style="color:{colours[lv]}"><b>{lv}</b>: {esc(t)}</li>' for lv, t in verdict(cal))
    cv = cal.cross_validation
    summary = (f"{cal.model} model, {cal.image_size[0]}x{cal.image_size[1]}, {cal.n_used} of {len(cal.names)} "
               f"views and {cal.n_corners_used} corners used, RMS {cal.rms:.4f} px"
               + (", cross-validation {:.3f} px mean / {:.3f} px max inside the corners' hull"
                  .format(*cv_inside(cv)) if cv is not None else ""))
    cvfig = ('<h2>Cross-validation</h2><p>Two calibrations from the interleaved halves of the used views; the '
             'map shows how far apart they put the same rays (a rotation between them fitted).</p>'
             '<img src="report/cross_validation.png" alt="cross-validation difference">') if has_cv else ""
    style = ("body{font-family:sans-serif;max-width:1100px;margin:auto}figure{display:inline-block;margin:4px;"
             "font-size:11px;width:250px;vertical-align:top}figure.none div{width:240px;height:60px;"
             "background:#eee;text-align:center;line-height:60px}td,th{padding:2px 8px;text-align:right}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(title)}</title>"
            f"<style>{style}</style></head><body><h1>{esc(title)}</h1><p>{esc(summary)}</p><h2>Verdict</h2><ul>{items}</ul>"
            f"<h2>Camera</h2>{_camera_table(cal)}{_selection_table(cal)}"
            "<h2>Residuals</h2><img src='report/residuals.png' alt='residual vectors'>"
            "<h2>Coverage</h2><img src='report/coverage.png' alt='coverage'>"
            f"{cvfig}<h2>Views</h2><p>Green: corners used; red: rejected; blue ring: the board's label origin."
            f"</p>{''.join(cards)}</body></html>\n")
