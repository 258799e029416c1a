"""Overlays: points drawn on an image, the one home of every overlay the package draws.

``sogdd detect --overlay`` and ``sogdd demo`` draw :func:`detections_overlay`
(detections as red crosses, the demo's true corners as green circles); the
report's figures in the style of the paper's Figs. 7 and 8 draw
:func:`overlay_gt` (matched GT corners as green circles, missed ones as red
squares, false detections as blue crosses) and put them side by side with
:func:`montage`.

Markers are sized from the picture they are drawn on (:func:`marker_style`):
a 5 px cross, 1 px wide, is a speck on a 3072 x 2048 photo seen at screen size, so
the size and the line width grow with the picture's long side. Each marker is
drawn over a dark outline, so it stands out on bright and on dark areas alike,
and a legend says what the markers are and how many there are.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from ..evaluation.points import match_points

__all__ = ["MarkerStyle", "detections_overlay", "draw_legend", "draw_markers", "grey_canvas", "marker_style",
           "montage", "overlay_gt", "save_png"]

GREEN, RED, BLUE = (0, 170, 0), (0, 0, 230), (230, 90, 0)  # BGR
#: the detections and truth of :func:`detections_overlay` (BGR): bright, so that the dark outline frames them
DETECTION, TRUTH = (40, 40, 255), (60, 230, 60)
OUTLINE = (0, 0, 0)
#: the long side (pixels) at which markers have their smallest size; they grow in proportion above it
BASE_SIDE = 640


@dataclass(frozen=True)
class MarkerStyle:
    """How big markers and legend text are on one picture.

    ``radius`` is the half-size of a marker (a cross's arm, a circle's radius), ``thickness``
    its line width, ``outline`` the dark border on each side of a line (0: none),
    ``font_scale`` and ``font_thickness`` the legend's text (OpenCV units).
    """

    radius: int
    thickness: int
    outline: int
    font_scale: float
    font_thickness: int


def marker_style(shape: tuple[int, ...], *, outline: bool = True) -> MarkerStyle:
    """The marker style for a picture of ``shape`` (H, W[, C]): sizes in proportion to its long side.

    At :data:`BASE_SIDE` (640 px) and below, markers keep their smallest legible size
    (radius 3, 1 px lines); above, the size and the width grow linearly, so a
    marker covers the same fraction of the picture whatever its resolution.

    Examples
    --------
    >>> marker_style((480, 640))
    MarkerStyle(radius=3, thickness=1, outline=1, font_scale=0.45, font_thickness=1)
    >>> s = marker_style((2048, 3072))
    >>> s.radius, s.thickness
    (14, 4)
    """
    f = max(1.0, max(shape[:2]) / BASE_SIDE)
    thickness = max(1, int(round(f * 0.8)))
    return MarkerStyle(radius=max(3, int(round(3 * f))), thickness=thickness,
                       outline=max(1, int(round(thickness / 2))) if outline else 0,
                       font_scale=round(0.45 * f, 2), font_thickness=max(1, int(round(f * 0.8))))


def grey_canvas(image: np.ndarray, scale: float = 1.0, *, dim: bool = False) -> np.ndarray:
    """A BGR uint8 grey copy of ``image`` to draw on, resized by ``scale``.

    ``image``: grey or RGB, uint8 or values on the 0-255 scale, or bool. ``dim``
    maps the grey levels to 140-255 (the report's figures: markers without outline
    stand out on it). A scale above 1 repeats pixels (nearest), below 1 averages them.
    """
    img = np.asarray(image)
    if img.dtype == np.bool_:
        img = img.astype(np.uint8) * 255
    if img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    if img.ndim == 3:
        img = cv2.cvtColor(np.ascontiguousarray(img[:, :, :3]), cv2.COLOR_RGB2GRAY)
    if dim:
        img = (img.astype(np.float32) * 0.45 + 140).astype(np.uint8)
    canvas = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if scale != 1.0:
        interp = cv2.INTER_NEAREST if scale > 1 else cv2.INTER_AREA
        canvas = cv2.resize(canvas, None, fx=scale, fy=scale, interpolation=interp)
    return canvas


def _centres(xy: np.ndarray, scale: float) -> np.ndarray:
    """Canvas pixels of points whose pixel centres are at integers (OpenCV's convention)."""
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return np.round((p + 0.5) * scale - 0.5).astype(np.int64)


def _shape(canvas: np.ndarray, c, kind: str, colour, r: int, t: int, aa: int) -> None:
    x, y = int(c[0]), int(c[1])
    if kind == "circle":
        cv2.circle(canvas, (x, y), r, colour, t, aa)
    elif kind == "square":
        cv2.rectangle(canvas, (x - r, y - r), (x + r, y + r), colour, t)
    elif kind == "cross":
        cv2.line(canvas, (x - r, y), (x + r, y), colour, t, aa)
        cv2.line(canvas, (x, y - r), (x, y + r), colour, t, aa)
    elif kind == "x":
        cv2.line(canvas, (x - r, y - r), (x + r, y + r), colour, t, aa)
        cv2.line(canvas, (x - r, y + r), (x + r, y - r), colour, t, aa)
    else:
        raise ValueError(f"unknown marker {kind!r}: use circle, square, cross or x")


def draw_markers(canvas: np.ndarray, xy: np.ndarray, kind: str, colour: tuple[int, int, int],
                 style: MarkerStyle, scale: float = 1.0) -> np.ndarray:
    """Draw one marker per point of ``xy`` (N, 2; x, y in image pixels) on ``canvas``, in place.

    ``kind``: ``"circle"``, ``"square"``, ``"cross"`` (+) or ``"x"``; ``scale`` maps
    image pixels to canvas pixels. Every outline is drawn before any marker, so no
    outline covers a neighbouring marker.

    Examples
    --------
    >>> canvas = np.full((40, 40, 3), 255, np.uint8)
    >>> _ = draw_markers(canvas, np.array([[20.0, 20.0]]), "cross", (0, 0, 255), marker_style((40, 40)))
    >>> (canvas[20, 20] > 128).tolist(), (canvas[20, 24] > 128).tolist()  # red centre, dark outline
    ([False, False, True], [False, False, False])
    """
    centres = _centres(xy, scale)
    r, t, o = style.radius, style.thickness, style.outline
    aa = cv2.LINE_AA if t == 1 else cv2.LINE_8
    if o:
        for c in centres:
            _shape(canvas, c, kind, OUTLINE, r + o if kind != "circle" else r, t + 2 * o, cv2.LINE_8)
    for c in centres:
        _shape(canvas, c, kind, colour, r, t, aa)
    return canvas


def draw_legend(canvas: np.ndarray, entries: list[tuple[str, tuple[int, int, int], str]],
                style: MarkerStyle, avoid: np.ndarray | None = None) -> tuple[int, int, int, int]:
    """A legend in a corner of ``canvas``: one line per ``(marker kind, colour, text)``, in place.

    White text on a darkened box, each line led by its marker, sized by ``style``.
    The box goes into the corner (top-left, top-right, bottom-left, bottom-right,
    in that order of preference) that covers the fewest of the canvas points
    ``avoid`` (N, 2; x, y). Returns the box, ``(x0, y0, x1, y1)`` (empty without entries).
    """
    if not entries:
        return 0, 0, 0, 0
    font = cv2.FONT_HERSHEY_SIMPLEX
    fs, ft = style.font_scale, style.font_thickness
    sizes = [cv2.getTextSize(text, font, fs, ft) for _, _, text in entries]
    line = max(h + b for (_, h), b in sizes) + 2 * style.thickness + 4
    pad = max(4, line // 3)
    mark = max(line // 2, 2 * style.radius + 2)
    width = min(pad * 3 + mark + max(w for (w, _), _ in sizes), canvas.shape[1])
    height = min(pad * 2 + line * len(entries), canvas.shape[0])
    x0, y0 = _legend_corner(canvas.shape, width, height, avoid)
    box = canvas[y0:y0 + height, x0:x0 + width]
    box[:] = (box.astype(np.float32) * 0.25).astype(np.uint8)  # darkened, the picture still shows through
    for i, ((kind, colour, text), ((_, h), _)) in enumerate(zip(entries, sizes)):
        cy = y0 + pad + i * line + line // 2
        ms = MarkerStyle(min(style.radius, line // 2 - 1), style.thickness, 0, fs, ft)
        draw_markers(canvas, np.array([[x0 + pad + mark / 2, cy]]), kind, colour, ms)
        cv2.putText(canvas, text, (x0 + 2 * pad + mark, cy + h // 2), font, fs, (255, 255, 255), ft,
                    cv2.LINE_AA)
    return x0, y0, x0 + width, y0 + height


def _legend_corner(shape, width: int, height: int, avoid: np.ndarray | None) -> tuple[int, int]:
    """The top-left pixel of the corner box of ``width`` x ``height`` covering the fewest ``avoid`` points."""
    h, w = shape[:2]
    corners = [(0, 0), (w - width, 0), (0, h - height), (w - width, h - height)]
    if avoid is None or len(avoid) == 0:
        return corners[0]
    p = np.asarray(avoid, dtype=np.float64).reshape(-1, 2)

    def covered(c):
        x0, y0 = c
        return int(np.sum((p[:, 0] >= x0) & (p[:, 0] < x0 + width) & (p[:, 1] >= y0) & (p[:, 1] < y0 + height)))

    return min(corners, key=covered)  # the first of equals: top-left where nothing is covered


def detections_overlay(image: np.ndarray, xy: np.ndarray, gt: np.ndarray | None = None, *,
                       label: str = "", min_side: int = 600) -> np.ndarray:
    """Detections (red crosses) and optional ground truth (green circles) on ``image``, with a legend.

    ``image``: grey or RGB on the 0-255 scale (:func:`grey_canvas`); ``xy`` and
    ``gt``: (N, 2) points, x = column, y = row. A picture smaller than ``min_side``
    is enlarged by a whole factor (pixels repeated) so that the markers fit between
    its pixels. ``label`` names the detections in the legend (for example the preset).

    Examples
    --------
    >>> img = np.zeros((48, 64), np.uint8)
    >>> vis = detections_overlay(img, np.array([[10.0, 20.0]]), gt=np.array([[10.0, 20.0]]), label="paper")
    >>> vis.shape  # enlarged 10x: 640 >= 600
    (480, 640, 3)
    """
    shape = np.shape(image)
    scale = max(1, int(np.ceil(min_side / max(shape[:2]))))
    canvas = grey_canvas(image, scale)
    style = marker_style(canvas.shape)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    name = f"detections ({label})" if label else "detections"
    entries = [("cross", DETECTION, f"{name}: {len(xy)}")]
    if gt is not None:
        gt = np.asarray(gt, dtype=np.float64).reshape(-1, 2)
        # around the crosses, not under them: a detection on a true corner shows both
        draw_markers(canvas, gt, "circle", TRUTH, replace(style, radius=2 * style.radius), scale)
        entries.append(("circle", TRUTH, f"true corners: {len(gt)}"))
    draw_markers(canvas, xy, "cross", DETECTION, style, scale)
    points = [xy] if gt is None else [xy, gt]
    x0, y0, x1, y1 = draw_legend(canvas, entries, style, avoid=_centres(np.concatenate(points), scale))
    # points the legend still covers (every corner is full) are drawn again, over it: none is hidden
    for pts, kind, colour, st in ([(gt, "circle", TRUTH, replace(style, radius=2 * style.radius))]
                                  if gt is not None else []) + [(xy, "cross", DETECTION, style)]:
        c = _centres(pts, scale)
        under = (c[:, 0] >= x0) & (c[:, 0] < x1) & (c[:, 1] >= y0) & (c[:, 1] < y1)
        if under.any():
            draw_markers(canvas, pts[under], kind, colour, st, scale)
    return canvas


def overlay_gt(image: np.ndarray, gt: np.ndarray, det: np.ndarray, delta: float = 2.0,
               scale: float = 1.0, title: str = "") -> np.ndarray:
    """A BGR uint8 picture of detections ``det`` against ground truth ``gt`` (the report's figures).

    On a dimmed grey copy (:func:`grey_canvas`), without outlines: matched GT
    corners as green circles, missed ones as red squares, false detections as blue
    x's; ``title`` heads a white band with the counts of missed and false points.
    """
    canvas = grey_canvas(image, dim=True)
    if scale != 1.0:
        canvas = cv2.resize(canvas, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    m = match_points(gt, det, delta)
    gt = np.asarray(gt, dtype=np.float64).reshape(-1, 2)
    det = np.asarray(det, dtype=np.float64).reshape(-1, 2)
    style = MarkerStyle(max(2, int(round(3 * scale))), 1, 0, 0.38, 1)
    draw_markers(canvas, gt[m.ia], "circle", GREEN, style, scale)
    draw_markers(canvas, gt[m.unmatched_a], "square", RED, style, scale)
    draw_markers(canvas, det[m.unmatched_b], "x", BLUE, style, scale)
    if title:
        text = f"{title}: missed {m.n_a - len(m)}, false {m.n_b - len(m)}"
        cv2.rectangle(canvas, (0, 0), (canvas.shape[1], 14), (255, 255, 255), -1)
        cv2.putText(canvas, text, (3, 11), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1, cv2.LINE_AA)
    return canvas


def montage(tiles: list[np.ndarray], columns: int = 3, gap: int = 4) -> np.ndarray:
    """Tiles (same size, BGR) on a white grid."""
    if not tiles:
        raise ValueError("no tiles")
    h, w = tiles[0].shape[:2]
    rows = (len(tiles) + columns - 1) // columns
    out = np.full((rows * (h + gap) - gap, columns * (w + gap) - gap, 3), 255, np.uint8)
    for k, t in enumerate(tiles):
        r, c = divmod(k, columns)
        out[r * (h + gap): r * (h + gap) + h, c * (w + gap): c * (w + gap) + w] = t
    return out


def save_png(path: str | os.PathLike, image: np.ndarray) -> Path:
    """Write a PNG at the highest compression."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(p), image, [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise OSError(f"{p}: could not write")
    return p
