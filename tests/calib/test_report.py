"""The calibration report: the page and its figures, and a verdict that follows the data."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.fit import calibrate
from sogdd.calib.report import write_report
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
