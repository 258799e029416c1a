"""What to do next after a calibration: the regions the boards missed and the tilts the views lack, on boards
projected through the known camera of the demo (exact poses, Gaussian corner noise)."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.demo import DEMO_DIST, DEMO_K, DEMO_PATTERN, DEMO_SIZE
from sogdd.calib.files import calibration_dict
from sogdd.calib.fit import calibrate
from sogdd.calib.guidance import REGIONS, board_tilts, guidance
from sogdd.calib.report import write_report
from sogdd.calib.targets.board import Board
from sogdd.calib.uncertainty import UNCERTAIN_PX

COLS, ROWS = DEMO_PATTERN
OBJ = np.array([(i, j, 0.0) for j in range(ROWS) for i in range(COLS)])
W, H = DEMO_SIZE
#: the axes the views turn the board about, in turn: the vertical, the horizontal, the diagonal
AXES = (np.array([0.0, 1, 0]), np.array([1.0, 0, 0]), np.array([1.0, 1, 0]) / np.sqrt(2))


def _calibration(n: int, seed: int, *, x: tuple[float, float], tilt: tuple[float, float], z=(14.0, 20.0),
                 noise: float = 0.05):
    """``n`` views of the 9 x 6 board, its centre on the ray of a pixel with ``x`` (a range, as a share of
    the width) and any height, turned ``tilt`` degrees (a range) about the vertical axis, the horizontal
    one, or both in turn, each corner inside the frame and left of ``x[1]`` of the width; 0.05 px noise."""
    rng = np.random.default_rng(seed)
    boards = []
    while len(boards) < n:
        axis = AXES[len(boards) % 3]
        rvec = axis * np.deg2rad(rng.uniform(*tilt)) * rng.choice([-1, 1])
        centre = np.array([rng.uniform(*x) * W, rng.uniform(0.1, 0.9) * H])
        ray = np.linalg.solve(DEMO_K, [centre[0], centre[1], 1.0])
        R, _ = cv2.Rodrigues(rvec)
        tvec = ray * rng.uniform(*z) - R @ np.array([(COLS - 1) / 2, (ROWS - 1) / 2, 0.0])
        p = project(OBJ, DEMO_K, DEMO_DIST, "pinhole", rvec, tvec)
        if np.all((p > 3) & (p < [x[1] * W - 4, H - 4])):
            boards.append(Board(p + rng.normal(0, noise, p.shape), OBJ[:, :2].astype(int)))
    return calibrate(boards, DEMO_SIZE, reject=False, cross_validate=False)


@pytest.fixture(scope="module")
def left_half():
    """Boards in the left half of the frame only, well tilted."""
    return _calibration(16, 1, x=(0.1, 0.5), tilt=(30, 45), z=(18.0, 24.0), noise=0.08)


@pytest.fixture(scope="module")
def spread():
    """Boards over the whole frame, well tilted about both axes."""
    return _calibration(21, 2, x=(0.05, 1.0), tilt=(32, 45), z=(11.0, 16.0))


def test_boards_in_the_left_half_ask_for_the_right_side(left_half):
    g = guidance(left_half)
    regions = {r.name: r for r in g.regions}
    right = ("top right", "right", "bottom right")
    assert sum(regions[n].coverage for n in right) == 0
    place = [a for a in g.advice if a.startswith("put the board")]
    assert place and place[0] == g.advice[0], g.advice  # the region is what is missing, the tilts are fine
    where = {"top right": "the top-right corner", "right": "the right edge",
             "bottom right": "the bottom-right corner"}
    named = [n for n in right if where[n] in place[0]]
    assert len(named) == 1, place[0]
    named = named[0]
    covered = max(regions[n].uncertainty_px for n in ("top left", "left", "bottom left", "centre"))
    assert regions[named].uncertainty_px > max(UNCERTAIN_PX, covered), g.regions
    # twice as loose everywhere (the covariance four times): even the best region is beyond 1 px, so more
    # views over the whole frame come first, then the same right side
    loose = guidance(dataclasses.replace(left_half, covariance=4 * left_half.covariance))
    assert loose.advice[0].startswith("add sharp views over the whole frame"), loose.advice
    assert loose.advice[1] == place[0].replace(f"({regions[named].uncertainty_px:.2g} px",
                                               f"({2 * regions[named].uncertainty_px:.2g} px")
    # without a covariance the corners' counts decide: still the right side, now by its empty share
    bare = guidance(dataclasses.replace(left_half, covariance=np.zeros((0, 0))))
    assert all(np.isnan(r.uncertainty_px) for r in bare.regions)
    assert bare.advice and all("right" in a and "0% of the corners" in a for a in bare.advice), bare.advice


def test_fronto_parallel_views_ask_for_tilts():
    cal = _calibration(12, 3, x=(0.05, 1.0), tilt=(0, 5), z=(11.0, 16.0))
    assert np.all(board_tilts(cal) < 6)
    tilts = [a for a in guidance(cal).advice if a.startswith("tilt")]
    assert [t.split(" (")[0] for t in tilts] == ["tilt the board 30-45 deg about the vertical axis",
                                                 "tilt the board 30-45 deg about the horizontal axis"]
    assert "(0 of 12 views tilted so)" in tilts[0]


def test_a_spread_tilted_set_needs_nothing(spread):
    g = guidance(spread)
    assert max(r.uncertainty_px for r in g.regions) <= UNCERTAIN_PX, g.regions
    assert min(g.tilted()) >= 5
    assert g.advice == ()


def test_camera_json_and_the_report_carry_it(left_half, spread, tmp_path):
    d = calibration_dict(left_half)["guidance"]
    assert [r["name"] for r in d["regions"]] == list(REGIONS)
    assert d["advice"] == list(guidance(left_half).advice) and d["advice"]
    assert d["tilts"]["views"] == left_half.n_used
    page = write_report(left_half, tmp_path / "a").read_text()
    assert "Next views" in page and d["advice"][0] in page
    assert "Next views" not in write_report(spread, tmp_path / "b").read_text()
