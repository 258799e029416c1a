"""Overlays (sogdd.report.overlays, written by sogdd detect --overlay and sogdd demo): legible at any size."""

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.cli.overlay import save_overlay
from sogdd.corners import Corners
from sogdd.report.overlays import detections_overlay, marker_style, overlay_gt


def _written(tmp_path, image, xy, **kw) -> np.ndarray:
    """The overlay PNG that the command line writes, read back (BGR)."""
    path = tmp_path / "o.png"
    save_overlay(image, Corners(np.asarray(xy, dtype=np.float64)), path, **kw)
    vis = cv2.imread(str(path))
    assert vis is not None
    return vis


def _red(vis: np.ndarray) -> np.ndarray:
    b, g, r = (vis[..., i].astype(int) for i in range(3))
    return (r > 150) & (g < 110) & (b < 110)


def _marker_span(vis: np.ndarray, x: int, y: int, reach: int = 60) -> int:
    """Width (px) of the red marker around (x, y)."""
    cols = np.flatnonzero(_red(vis[y - reach: y + reach + 1, x - reach: x + reach + 1]).any(axis=0))
    return int(cols.max() - cols.min() + 1)


@pytest.mark.parametrize("value", [0, 255])
def test_marker_size_and_width_grow_with_the_image(tmp_path, value):
    # one detection in the middle of a small and of a 3072 x 2048 photo-sized image, dark and bright
    small = np.full((480, 640), value, np.uint8)
    big = np.full((2048, 3072), value, np.uint8)
    span_s = _marker_span(_written(tmp_path, small, [[320, 240]]), 320, 240)
    vis = _written(tmp_path, big, [[1536, 1024]])
    span_b = _marker_span(vis, 1536, 1024)
    arm = _red(vis[1024 - 30: 1024 + 31, 1536 + 6])  # a column crossing the right arm, off the centre
    assert span_s >= 5
    assert span_b >= 4 * span_s  # the old overlay drew 5 px crosses whatever the size
    assert arm.sum() >= 3  # lines 1 px wide before
    # the picture is not enlarged (only small ones are): 3072 x 2048 stays
    assert vis.shape[:2] == (2048, 3072)


def test_markers_have_a_dark_outline_on_bright_areas(tmp_path):
    vis = _written(tmp_path, np.full((480, 640), 255, np.uint8), [[320, 240]])
    style = marker_style(vis.shape)
    beyond = vis[240, 320 + style.radius + 1]  # just past the end of the right arm
    assert beyond.max() < 60  # the outline, not the white background
    assert _red(vis[240:241, 320 - style.radius + 1: 320 + style.radius]).all()  # the arm itself is red


def test_the_legend_gives_the_label_and_the_count(tmp_path):
    grey = np.full((480, 640), 128, np.uint8)
    one = _written(tmp_path, grey, [[600, 400]], label="preset paper")
    many = _written(tmp_path, grey, np.tile([[600.0, 400.0]], (1000, 1)), label="preset paper")
    nolabel = _written(tmp_path, grey, [[600, 400]])

    def box_width(vis):  # the legend darkens the picture behind it, from the top-left corner
        dark = vis[5, :, 1] < 100
        return int(np.argmin(dark)) if not dark.all() else vis.shape[1]

    def text(vis):
        return int((vis[:60, :300, 1] > 200).sum())

    assert text(one) > 50  # white text in the legend (none in the old overlay)
    # "1000" is longer than "1", and the label shows
    assert box_width(many) > box_width(one) > box_width(nolabel) > 0
    assert box_width(one) < 640 // 2


def test_truth_circles_show_around_detections(tmp_path):
    img = np.zeros((480, 640), np.uint8)
    vis = _written(tmp_path, img, [[100, 100]], gt=np.array([[100.0, 100.0], [300.0, 300.0]]))
    g = vis[..., 1].astype(int)
    green = (g > 150) & (vis[..., 2] < 120)
    r = 2 * marker_style(vis.shape).radius
    assert green[300 - r - 1: 300 + r + 2, 300 - r - 1: 300 + r + 2].any()  # the missed one
    assert green[100 - r - 1: 100 + r + 2, 100 - r - 1: 100 + r + 2].any()  # around the detection ...
    assert _red(vis[95:106, 95:106]).any()  # ... which stays visible inside its circle


def test_small_images_are_enlarged_and_markers_stay_on_their_pixel():
    vis = detections_overlay(np.zeros((30, 40), np.uint8), np.array([[20.0, 10.0]]))
    assert vis.shape == (450, 600, 3)  # 15x (the long side reaches 600), pixels repeated
    cy, cx = round((10 + 0.5) * 15 - 0.5), round((20 + 0.5) * 15 - 0.5)
    assert _red(vis[cy - 1: cy + 2, cx - 1: cx + 2]).any()


def test_report_overlay_keeps_its_markers():
    # the report's figures: matched GT green circles, missed red squares, false blue x's, a title band
    img = np.full((60, 80), 100, np.uint8)
    gt = np.array([[20.0, 20.0], [60.0, 40.0]])
    vis = overlay_gt(img, gt, np.array([[20.5, 20.0], [10.0, 50.0]]), title="x")
    assert vis.shape == (60, 80, 3)
    assert vis[30, 40].tolist() == [185, 185, 185]  # the image, dimmed: 100 * 0.45 + 140
    assert vis[37, 60].tolist() == [0, 0, 230]  # the missed corner's square, radius 3, not smoothed
    b, g, r = (int(v) for v in vis[20, 17])  # the matched corner's circle
    assert g > 120 and r < 100 and b < 100
    b, g, r = (int(v) for v in vis[47, 7])  # the false detection's x
    assert b > 150 and r < 120
    assert vis[13, 79].tolist() == [255, 255, 255]  # the title band


def test_demo_overlay_has_red_detections_and_green_truth(tmp_path, capsys):
    out = tmp_path / "demo.png"
    assert main(["demo", "--out", str(out)]) == 0
    assert "recall within 2 px: 0.995" in capsys.readouterr().out
    vis = cv2.imread(str(out))
    assert vis.shape == (480, 640, 3)
    green = (vis[..., 1] > 150) & (vis[..., 2] < 120) & (vis[..., 0] < 120)
    assert _red(vis).sum() > 187 * 5 and green.sum() > 188 * 5
