"""The calibration report: the page and its figures, and a verdict that follows the data."""

from __future__ import annotations

import dataclasses
import re

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.demo import demo_calibration
from sogdd.calib.fit import calibrate
from sogdd.calib.report import OVERLAY_WIDTH, write_report
from sogdd.calib.report_figures import camera_poses_figure, distortion_field, residual_histogram
from sogdd.calib.targets.board import Board
from sogdd.calib.verdict import coverage, verdict


def _texts(cal):
    return " | ".join(t for _, t in verdict(cal))


def _edge_share(points: np.ndarray, size) -> float:
    """Share of the border cells of an 8 x 6 grid of the frame ([-0.5, w - 0.5] x [-0.5, h - 0.5]) holding a
    point, cell by cell."""
    w, h = size
    hit = set()
    for x, y in points:
        i = min(int((x + 0.5) // (w / 8)), 7)
        j = min(int((y + 0.5) // (h / 6)), 5)
        if i in (0, 7) or j in (0, 5):
            hit.add((i, j))
    return len(hit) / (2 * 8 + 2 * 4)


def test_verdict_follows_the_coverage(synthetic):
    centre = calibrate(synthetic.boards(14, noise=0.05, seed=21, spread=0.2), synthetic.SIZE)
    spread = calibrate(synthetic.boards(14, noise=0.05, seed=21, spread=1.6), synthetic.SIZE)
    for cal in (centre, spread):
        pts = np.concatenate([b.image_points[u] for b, u in zip(cal.boards, cal.corner_used)])
        assert coverage(cal)[2] == pytest.approx(_edge_share(pts, synthetic.SIZE))
    assert coverage(centre)[2] < 0.5 <= coverage(spread)[2]
    assert "cover only the centre" in _texts(centre)
    assert "the model extrapolates there" in _texts(centre)  # the halves part beyond the corners
    assert centre.cross_validation.mean_within < 0.5 < centre.cross_validation.max
    assert "cover only the centre" not in _texts(spread)
    assert verdict(spread)[0][0] == "ok" and "looks sound" in verdict(spread)[0][1]


def test_verdict_few_views_high_rms_and_a_wrong_model(synthetic):
    SIZE, _boards = synthetic.SIZE, synthetic.boards
    few = calibrate(_boards(5, noise=0.05, seed=22, spread=1.6), SIZE)
    assert "few views (5 used)" in _texts(few) and "no cross-validation" in _texts(few)
    noisy = calibrate(_boards(14, noise=0.6, seed=23, spread=1.6), SIZE)
    assert "high RMS" in _texts(noisy)
    d = np.array([-0.4, 0.15, 0.0, 0.0, 0.0])
    no_k = cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST
    wrong = calibrate(_boards(14, noise=0.05, seed=24, dist=d, spread=1.6), SIZE, reject=False, flags=no_k)
    levels = dict((t.split(" (")[0], lv) for lv, t in verdict(wrong))
    assert levels.get("large cross-validation difference") == "bad"


def test_the_page_and_its_figures(tmp_path, synthetic):
    SIZE, _boards = synthetic.SIZE, synthetic.boards
    boards = _boards(8, noise=0.05, seed=25, spread=1.6)
    boards.append(None)
    cal = calibrate(boards, SIZE, names=[f"img{v}.png" for v in range(9)])
    images = [np.full((480, 640), 128, np.uint8) for _ in range(9)]
    images[3] = None
    page = write_report(cal, tmp_path / "out", images=images)
    text = page.read_text()
    figs = page.parent / "report"
    thumbs = [f"view_{v:04d}.png" for v in range(9)]
    for name in ["residuals.png", "coverage.png", "cross_validation.png", *thumbs]:
        assert (figs / name).stat().st_size > 500, name
        assert f"report/{name}" in text
    assert "img8.png" in text and "rejected: no board" in text
    assert "Verdict" in text and "few views (8 used)" in text
    thumb = cv2.imread(str(figs / "view_0000.png"))
    assert thumb.shape[1] == 240 and (thumb[..., 1] > 150).any()  # green corners drawn
    with pytest.raises(ValueError, match="2 images for 9 views"):
        write_report(cal, tmp_path, images=images[:2])


def test_verdict_says_when_the_board_never_tilts(synthetic):
    s = synthetic
    SIZE, _boards, K_TRUE, D_TRUE, COLS, ROWS, OBJ, LABELS = (s.SIZE, s.boards, s.K_TRUE, s.D_TRUE, s.COLS,
                                                               s.ROWS, s.OBJ, s.LABELS)
    rng = np.random.default_rng(30)
    boards = []
    for _ in range(12):
        rvec = rng.normal(0, np.deg2rad(3), 3)
        centre = rng.uniform([180, 140], [460, 340])
        ray = np.linalg.solve(K_TRUE, [*centre, 1.0]) * rng.uniform(12, 16)
        tvec = ray - cv2.Rodrigues(rvec)[0] @ [(COLS - 1) / 2, (ROWS - 1) / 2, 0]
        p = project(OBJ, K_TRUE, D_TRUE, "pinhole", rvec, tvec)
        boards.append(Board(p + rng.normal(0, 0.05, p.shape), LABELS))
    cal = calibrate(boards, SIZE)
    assert "the board faces the camera in every view" in _texts(cal)
    tilted = calibrate(_boards(12, noise=0.05, seed=31), SIZE)
    assert "faces the camera" not in _texts(tilted)


# --------------------------------------------------------------------------------------------------
# the figures a reader of MATLAB's Camera Calibrator or mrcal looks for


def _demo_page(tmp_path, images=None):
    cal = demo_calibration()
    return cal, write_report(cal, tmp_path / "out", images=images)


def test_each_bar_of_the_error_chart_links_its_view(tmp_path):
    """The image map has a column per view over its bar, each linking to an anchor the page holds."""
    cal, page = _demo_page(tmp_path)
    text = page.read_text()
    chart = cv2.imread(str(page.parent / "report" / "errors_per_view.png"))
    assert "usemap='#view-errors'" in text and '<map name="view-errors">' in text
    areas = re.findall(r'<area shape="rect" coords="(\d+),(\d+),(\d+),(\d+)" href="#view-(\d+)"', text)
    assert [int(a[4]) for a in areas] == list(range(len(cal.names)))
    for x0, y0, x1, y1, v in (tuple(map(int, a)) for a in areas):
        assert f'<figure id="view-{v}">' in text and cal.names[v] in text
        assert 0 <= x0 < x1 <= chart.shape[1] and 0 <= y0 < y1 <= chart.shape[0]
        bottom = chart[y1 - 3, (x0 + x1) // 2]  # just above the axis: the bar, blue, where the view was used
        is_bar = bool(np.all(np.abs(bottom.astype(int) - (180, 119, 31)) < 30))  # tab:blue in BGR
        assert is_bar == bool(cal.view_used[v]), v
    assert chart.shape[1] <= 1084  # the page's column: the map's coordinates are the picture's own


def test_thumbnails_link_to_the_views_at_the_image_size(tmp_path):
    images = [np.full((480, 640), 100, np.uint8)] * 9
    cal, page = _demo_page(tmp_path, images)
    text = page.read_text()
    for v in range(len(cal.names)):
        assert f'<a href="report/overlay_{v:04d}.png"><img src="report/view_{v:04d}.png"' in text
        full = cv2.imread(str(page.parent / "report" / f"overlay_{v:04d}.png"))
        assert full.shape[:2] == (480, 640)
    full = cv2.imread(str(page.parent / "report" / "overlay_0000.png"))
    projected = np.all(full == (255, 0, 255), axis=2)  # each corner's projection, a magenta cross
    assert projected.sum() > 54
    big = dataclasses.replace(cal, image_size=(2560, 1920))  # a larger sensor: the overlay is capped
    wide = write_report(big, tmp_path / "wide", images=[np.zeros((1920, 2560), np.uint8)] * 9)
    assert cv2.imread(str(wide.parent / "report" / "overlay_0001.png")).shape[1] == OVERLAY_WIDTH < 2560


def test_the_distortion_map_peaks_at_the_frame_corner_as_the_model_says(tmp_path, drawn_figures):
    """The map's maximum is the model's distortion at a corner of the frame: OpenCV's inverse of the lens
    (cv2.undistortPoints, iterated to convergence) projected by the pinhole of the same K."""
    cal, page = _demo_page(tmp_path)
    assert (page.parent / "report" / "distortion.png").stat().st_size > 5000
    w, h = cal.image_size
    corners = np.array([[0, 0], [w - 1, 0], [0, h - 1], [w - 1, h - 1]], float)
    stop = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14)
    ideal = cv2.undistortPoints(corners[:, None], cal.K, cal.dist, None, cal.K, criteria=stop).reshape(-1, 2)
    expected = np.max(np.hypot(*(corners - ideal).T))
    field = distortion_field(cal)
    assert field.max == pytest.approx(expected, rel=1e-4)
    assert expected > 20  # k1 = -0.2 at 640 x 480: tens of pixels at the corners, none at the centre
    assert field.magnitude[len(field.ys) // 2, len(field.xs) // 2] < 0.5
    assert f"up to {expected:.2f} px over the frame" in page.read_text()
    assert f"max {expected:.2f} px" in drawn_figures.figures["distortion.png"].axes[0].get_title()


def test_the_histogram_counts_every_used_corner_and_the_poses_every_used_view(tmp_path, drawn_figures):
    cal, page = _demo_page(tmp_path)
    text = page.read_text()
    for name in ("residual_histogram.png", "poses.png", "errors_per_view.png", "distortion.png"):
        assert f"report/{name}" in text and (page.parent / "report" / name).stat().st_size > 5000
    assert residual_histogram(cal, tmp_path / "h.png") == 2 * cal.n_corners_used
    assert camera_poses_figure(cal, tmp_path / "p.png") == cal.n_used == 8
    poses = drawn_figures.figures["p.png"].axes[0]
    assert len(poses.lines) == 8 + 1 + 4  # the boards, then the camera's frustum: its far frame, 4 edges
    assert [t.get_text() for t in poses.get_legend().get_texts()] == ["camera"]


def test_no_title_or_label_leaves_its_figure_or_runs_over_a_colour_bar(tmp_path, drawn_figures):
    _demo_page(tmp_path)
    assert len(drawn_figures.figures) >= 7
    for name, fig in drawn_figures.figures.items():
        assert drawn_figures.overlaps(fig) == [], name
