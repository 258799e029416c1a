"""A calibration's report page: HTML with PNG figures and a verdict in plain words.

The page shows :func:`verdict` (what is wrong with the calibration, if anything,
and what to do about it), where the next views should put the board when that
would help (:func:`~sogdd.calib.guidance.guidance`), the camera, the lens models compared
(``model="auto"``), each view's RMS as a bar chart whose bars link to the views,
the residual vectors magnified and their histogram, where the corners fell in
the frame, the cross-validation difference map, the chosen model's distortion
field, the board poses in 3-D, and every view's detections as a thumbnail (used
corners green, rejected ones red) that links to the same overlay at the image's
size (:data:`OVERLAY_WIDTH` px at most) with each corner's projection.

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

from ..formats.safe_write import write_bytes, write_text
from .detection import THUMB_WIDTH, Thumbnail, ViewRecord, make_thumbnail, view_records
from .figures import pyplot, save_figure
from .guidance import guidance
from .model_selection import ModelSelection
from .report_figures import (
    camera_poses_figure,
    coverage_figure,
    cross_validation_figure,
    distortion_figure,
    residual_figure,
    residual_histogram,
    view_errors_figure,
)
from .result import Calibration
from .verdict import cv_inside, verdict

__all__ = ["LEVEL_COLOURS", "OVERLAY_WIDTH", "PAGE_STYLE", "html_page", "pyplot", "save_figure",
           "selection_table", "write_report"]

#: the widest full-size overlay (px): an image wider than this is drawn at this width
OVERLAY_WIDTH = 1600

# --------------------------------------------------------------------------------------------------
# pictures of the views


def _thumbnail(image, board, used, width: int, size: tuple[int, int],
               residual: np.ndarray | None = None) -> np.ndarray:
    """The view's picture (a :class:`Thumbnail`, an image array or None: grey) ``width`` px wide with its
    detections; with ``residual``, each corner's projection (observed - residual) as a cross too."""
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
                           interpolation=cv2.INTER_AREA if f < 1 else cv2.INTER_LINEAR)
        thumb = Thumbnail(small, thumb.scale * f)
    s = thumb.scale
    vis = cv2.cvtColor(thumb.image, cv2.COLOR_GRAY2BGR)
    if board is not None:
        dot = max(2, min(5, round(2 * width / THUMB_WIDTH)))  # the dots grow with the picture, a little
        u = np.ones(len(board), bool) if used is None else used
        for (x, y), ok in zip((board.image_points + 0.5) * s - 0.5, u):
            cv2.circle(vis, (round(x), round(y)), dot, (0, 180, 0) if ok else (0, 0, 255), -1, cv2.LINE_AA)
        if residual is not None:
            for x, y in (board.image_points - residual + 0.5) * s - 0.5:
                if np.isfinite(x) and np.isfinite(y):
                    cv2.drawMarker(vis, (round(x), round(y)), (255, 0, 255), cv2.MARKER_CROSS, 3 * dot, 1)
        origin = (board.image_points[np.argmin(board.labels.sum(axis=1))] + 0.5) * s - 0.5
        cv2.circle(vis, (round(origin[0]), round(origin[1])), 5 * dot // 2, (255, 0, 0), 1, cv2.LINE_AA)
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
        the pictures; without it the detections are drawn on grey. Files are
        never read here.
    views : sequence of ViewRecord, optional
        Every input's fate (:attr:`sogdd.calib.ImageCalibration.views`): the page
        lists them all, the images that could not be read too; without it, the
        views of ``cal`` (:func:`~sogdd.calib.detection.view_records`).
    title : str
    thumb_width : int
        Thumbnail width in px. Each thumbnail links to the view's overlay at the
        image's width (at most :data:`OVERLAY_WIDTH`), ``report/overlay_NNNN.png``.

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
    >>> "Verdict" in text, pngs[:4]
    (True, ['coverage.png', 'cross_validation.png', 'distortion.png', 'errors_per_view.png'])
    """
    if images is not None and len(images) != len(cal.names):
        raise ValueError(f"{len(images)} images for {len(cal.names)} views")
    out = Path(out_dir)
    figs = out / "report"
    figs.mkdir(parents=True, exist_ok=True)
    residual_figure(cal, figs / "residuals.png")
    residual_histogram(cal, figs / "residual_histogram.png")
    areas = view_errors_figure(cal, figs / "errors_per_view.png")
    coverage_figure(cal, figs / "coverage.png")
    has_cv = cross_validation_figure(cal, figs / "cross_validation.png")
    field = distortion_figure(cal, figs / "distortion.png")
    camera_poses_figure(cal, figs / "poses.png")
    full_width = min(cal.image_size[0], OVERLAY_WIDTH)
    for v in range(len(cal.names)):
        img = images[v] if images is not None else None
        b, u, r = cal.boards[v], cal.corner_used[v], cal.residuals[v]
        _write_png(figs / f"view_{v:04d}.png", _thumbnail(img, b, u, thumb_width, cal.image_size))
        _write_png(figs / f"overlay_{v:04d}.png", _thumbnail(img, b, u, full_width, cal.image_size, r))
    page = out / "report.html"
    body = _html(cal, title, _cards(cal, views), has_cv, _image_map(cal, areas), field.max)
    write_text(page, body)
    return page


def _image_map(cal: Calibration, areas) -> str:
    """The bar chart's image map: each view's column links to its card (``#view-N``)."""
    esc = html.escape
    rows = "".join(f'<area shape="rect" coords="{x0},{y0},{x1},{y1}" href="#view-{v}" '
                   f'alt="{esc(cal.names[v])}" title="{esc(cal.names[v])}">' for v, (x0, y0, x1, y1) in areas)
    return f'<map name="view-errors">{rows}</map>'


def _cards(cal: Calibration, views) -> list[str]:
    """A figure per view (per input with ``views``: one that could not be read has no picture); a view of
    ``cal`` carries the anchor ``view-N`` and its thumbnail links to its full-size overlay."""
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
        v = row.view
        rms = cal.view_rms[v]
        cap = f"{v}: {esc(row.name)}<br>{'' if not np.isfinite(rms) else f'RMS {rms:.3f} px, '}{esc(state)}"
        cards.append(f'<figure id="view-{v}"><a href="report/overlay_{v:04d}.png">'
                     f'<img src="report/view_{v:04d}.png" alt="{esc(row.name)}"></a>'
                     f"<figcaption>{cap}</figcaption></figure>")
    return cards


def _camera_table(cal: Calibration) -> str:
    K = cal.K
    rows = [("fx", K[0, 0]), ("fy", K[1, 1]), ("cx", K[0, 2]), ("cy", K[1, 2])]
    rows += list(cal.coefficients().items())
    cells = "".join(f"<tr><td>{n}</td><td>{v:.6g}</td><td>{cal.std.get(n, float('nan')):.3g}</td></tr>"
                    for n, v in rows)
    return f"<table><tr><th>parameter</th><th>value</th><th>std</th></tr>{cells}</table>"


def _next_views(cal: Calibration) -> str:
    """The "Next views" section: the guidance's advice and its 3 x 3 table of the frame; "" without advice."""
    g = guidance(cal)
    if not g.advice:
        return ""
    items = "".join(f"<li>{html.escape(a)}</li>" for a in g.advice)
    cells = [f"<td>{r.coverage:.0%} of the corners"
             + (f"<br>{r.uncertainty_px:.2g} px" if np.isfinite(r.uncertainty_px) else "") + "</td>"
             for r in g.regions]
    rows = "".join(f"<tr>{''.join(cells[3 * k:3 * k + 3])}</tr>" for k in range(3))
    sigma = (" and a far point's worst projection uncertainty there (1 sigma)"
             if any(np.isfinite(r.uncertainty_px) for r in g.regions) else "")
    return (f"<h2 id='next-views'>Next views</h2><ul>{items}</ul><p>The frame in 3 x 3 regions: the share "
            f"of the used corners in each{sigma}.</p><table style='border:1px solid #ccc'>{rows}</table>")


def _num(v: float, digits: int = 4) -> str:
    """A score to fixed decimals: "failed" for inf, "" for NaN."""
    return f"{v:.{digits}f}" if np.isfinite(v) else ("failed" if v == np.inf else "")


def _pm(value: float, se: float) -> str:
    return _num(value) + (f" &plusmn; {_num(se)}" if np.isfinite(se) else "")


def selection_table(sel: ModelSelection | None) -> str:
    """A model selection's table as HTML (both reports show it): fixed decimals, the chosen model in bold
    and marked "chosen", the others "within noise" or not; "" without a selection.

    Examples
    --------
    >>> from sogdd.calib.model_selection import CandidateScore, ModelSelection
    >>> rows = (CandidateScore("pinhole4", 4, 0.05, 0.0512, 0.001, 0.0, 0.0, True),
    ...         CandidateScore("rational", 8, 0.049, 0.0601, 0.002, 0.0089, 0.001, False))
    >>> t = selection_table(ModelSelection("pinhole4", rows, (), "the fewest coefficients within noise"))
    >>> "<b>pinhole4</b>" in t, "0.0512" in t, "True" in t, "e-" in t
    (True, True, False, False)
    """
    if sel is None:
        return ""
    rows = "".join(
        f"<tr><td>{f'<b>{html.escape(r.model)}</b>' if r.model == sel.chosen else html.escape(r.model)}</td>"
        f"<td>{r.n_coefficients}</td><td>{_num(r.fit_rms)}</td>"
        f"<td>{_pm(r.cv_rms, r.cv_se)}</td><td>{_pm(r.difference, r.difference_se)}</td>"
        f"<td>{'chosen' if r.model == sel.chosen else ('within noise' if r.within_noise else '')}</td>"
        f"<td style='text-align:left'>{html.escape(r.note)}</td></tr>" for r in sel.table)
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in sel.notes)
    return (f"<p>{html.escape(sel.rule[:1].upper() + sel.rule[1:])}.</p>"
            "<table><tr><th>model</th><th>coefficients</th><th>fit RMS (px)</th>"
            "<th>cross-validated RMS &plusmn; SE (px)</th><th>difference to the best &plusmn; SE</th><th></th>"
            f"<th></th></tr>{rows}</table>" + (f"<ul>{notes}</ul>" if notes else ""))


#: the verdict's levels as the pages colour them
LEVEL_COLOURS = {"ok": "#1a7f37", "warn": "#9a6700", "bad": "#cf222e"}
#: the pages' style sheet
PAGE_STYLE = ("body{font-family:sans-serif;max-width:1100px;margin:auto;padding:0 8px}"
              "img{max-width:100%;height:auto}img[usemap]{max-width:none}"
              "figure{display:inline-block;margin:4px;font-size:11px;width:250px;vertical-align:top}"
              "figure:target{outline:3px solid #0969da}figure.none div{width:240px;height:60px;"
              "background:#eee;text-align:center;line-height:60px}td,th{padding:2px 8px;text-align:right}")


def html_page(title: str, summary: str, findings: Sequence[tuple[str, str]], body: str) -> str:
    """A report page: its title, a summary line, the verdict's findings (level, text) coloured by level, then
    ``body`` (HTML). One skeleton for a camera's report and a rig's; the texts are escaped here.

    Examples
    --------
    >>> page = html_page("a < b", "RMS 0.1 px", [("warn", "few views")], "<p>more</p>")
    >>> page.startswith("<!DOCTYPE html>"), "<title>a &lt; b</title>" in page, page.endswith("</html>\\n")
    (True, True, True)
    >>> "<b>warn</b>: few views</li></ul><p>more</p>" in page
    True
    """
    esc = html.escape
    items = "".join(f'<li style="color:{LEVEL_COLOURS[lv]}"><b>{lv}</b>: {esc(t)}</li>' for lv, t in findings)
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(title)}</title>"
            f"<style>{PAGE_STYLE}</style></head><body><h1>{esc(title)}</h1><p>{esc(summary)}</p>"
            f"<h2 id='verdict'>Verdict</h2><ul>{items}</ul>{body}</body></html>\n")


def _html(cal: Calibration, title: str, cards: list[str], has_cv: bool, image_map: str,
          distortion_max: float) -> str:
    esc = html.escape
    cv = cal.cross_validation
    summary = (f"{cal.model} model, {cal.image_size[0]}x{cal.image_size[1]}, {cal.n_used} of {len(cal.names)} "
               f"views and {cal.n_corners_used} corners used, RMS {cal.rms:.4f} px"
               + (", cross-validation {:.3f} px mean / {:.3f} px max inside the corners' hull"
                  .format(*cv_inside(cv)) if cv is not None else "")
               + ("; on the sensor's pixel grid (EXIF orientations differ)" * (cal.pixel_grid == "sensor")))
    cvfig = ('<h2 id="cross-validation">Cross-validation</h2><p>Two calibrations from the interleaved halves '
             'of the used views; the map shows how far apart they put the same rays (a rotation between them '
             'fitted).</p><img src="report/cross_validation.png" alt="cross-validation difference">'
             ) if has_cv else ""
    selection = ("<h2 id='lens-model'>Lens model</h2>" + selection_table(cal.model_selection)
                 if cal.model_selection is not None else "")
    return html_page(
        title, summary, verdict(cal),
        f"{_next_views(cal)}<h2 id='camera'>Camera</h2>{_camera_table(cal)}{selection}"
            "<h2 id='view-errors'>Error per view</h2><p>Each view's RMS reprojection error; click a bar for "
            "the view.</p><img src='report/errors_per_view.png' usemap='#view-errors' alt='RMS per view'>"
            f"{image_map}"
            "<h2 id='residuals'>Residuals</h2><img src='report/residuals.png' alt='residual vectors'>"
            "<img src='report/residual_histogram.png' alt='residual histogram'>"
            "<h2 id='coverage'>Coverage</h2><img src='report/coverage.png' alt='coverage'>"
            f"{cvfig}<h2 id='distortion'>Distortion</h2><p>Where the {esc(cal.model)} model puts each pixel's "
            f"ray against a pinhole camera of the same K: up to {distortion_max:.2f} px over the frame.</p>"
            "<img src='report/distortion.png' alt='distortion field'>"
            "<h2 id='poses'>Board poses</h2><img src='report/poses.png' alt='camera and board poses'>"
            "<h2 id='views'>Views</h2><p>Green: corners used; red: rejected; blue ring: the board's label "
            "origin. Click a picture for the view at the image's size, each corner's projection a magenta "
            "cross."
            f"</p>{''.join(cards)}")
