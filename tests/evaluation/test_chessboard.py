"""The dense-checkerboard benchmark: rendered truth, metrics, the CLI and the real check."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.chessboard import BoardScene, evaluate, render_board, scene_grid
from sogdd.evaluation.chessboard import scenes as S
from sogdd.evaluation.chessboard.metrics import pool, score_image
from sogdd.evaluation.chessboard.rows import gftt_subpix, make_rows

_CRIT = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-4)


def _refine(img, start):
    p = np.asarray(start, np.float32).reshape(-1, 1, 2)
    return cv2.cornerSubPix(img, p.copy(), (5, 5), (-1, -1), _CRIT).reshape(-1, 2)


@pytest.mark.parametrize("angle", [0.0, 10.0, 30.0])
def test_rendered_corners_are_where_cornersubpix_converges(angle):
    # 16-px cells, PSF 1.5: the 11x11 window sees one X-corner, whose symmetry makes
    # cornerSubPix unbiased; started 0.6 px off it must land on the rendered truth.
    rng = np.random.default_rng(3)
    for _ in range(2):
        rb = render_board(BoardScene(16, 7, 6, angle, tuple(rng.uniform(0, 1, 2)), psf=1.5))
        got = _refine(rb.image, rb.corners + [0.6, -0.4])
        assert np.max(np.hypot(*(got - rb.corners).T)) < 0.05


def test_exact_render_pixel_coverage():
    # angle 0, no PSF: a pixel cut by a vertical cell edge is the area-weighted mix
    s = BoardScene(8, 6, 5, 0.0, (0.25, 0.0))
    rb = render_board(s)
    x0, y0 = S.board_to_image(s, rb.image.shape, np.array([[0.0, 0.0]]))[0]
    xe = x0 + 8  # edge between cell (0, 0) (dark) and cell (1, 0) (light)
    j, i = int(np.floor(xe + 0.5)), int(round(y0 + 4))
    frac_dark = xe - (j - 0.5)
    expect = s.dark * frac_dark + s.light * (1 - frac_dark)
    assert abs(float(rb.image[i, j]) - expect) <= 0.5 + 1e-9
    assert rb.image[i, j - 1] == s.dark and rb.image[i, j + 1] == s.light


def test_two_render_paths_agree():
    # exact separable integration (angle 0) against point supersampling: each edge through a
    # pixel is placed to within half a sample, so a pixel is off by at most (light - dark) / ss
    s = BoardScene(5, 8, 7, 0.0, (0.37, 0.81))
    shape = S._image_shape(s)
    exact = S._render_exact(s, shape)
    for ss in (8, 16):
        diff = np.abs(exact - S._render_sampled(s, shape, supersample=ss))
        assert diff.max() <= (s.light - s.dark) / ss and diff.mean() < 0.5


def test_phase_moves_corners_and_image_exactly():
    a = render_board(BoardScene(6, 8, 7, 0.0, (0.0, 0.0), psf=0.7))
    b = render_board(BoardScene(6, 8, 7, 0.0, (1.0, 2.0), psf=0.7))
    assert np.allclose(b.corners - a.corners, [1.0, 2.0])
    assert np.array_equal(a.image[:-2, :-1], b.image[2:, 1:])  # integer phase: a pure shift


def test_board_is_point_symmetric():
    # phase 0, odd x odd cells: rotating the image by 180 degrees gives the same board
    rb = render_board(BoardScene(8, 7, 5, 0.0, (0.0, 0.0), psf=0.7))
    assert np.array_equal(rb.image, rb.image[::-1, ::-1])
    h, w = rb.image.shape
    flipped = np.array([w - 1, h - 1]) - rb.corners
    assert np.allclose(np.sort(flipped, axis=0), np.sort(rb.corners, axis=0))


def test_scene_grid_phases_distinct_and_seeded():
    g = scene_grid([4], quick=False, seed=1)
    assert len(g) == S.FULL_GRID.size() and len({sc.phase for sc in g}) == len(g)
    assert [sc.phase for sc in scene_grid([4], seed=1)] == [sc.phase for sc in g]
    with pytest.raises(ValueError):
        scene_grid([1.0])


def test_metrics_on_hand_made_detections():
    rb = render_board(BoardScene(6, 6, 5, 0.0, (0.2, 0.3)))
    c, n = rb.corners, len(rb.corners)
    centre = c.mean(0)
    det = np.vstack([c + [0.3, 0.0],  # every corner 0.3 px off
                     c[:1] + [0.0, 0.5],  # a duplicate of corner 0, within 1 px but farther
                     [centre + [3.0, 3.0]],  # a cell centre: inside the region, false
                     [[1.0, 1.0]]])  # the image border: outside the region, not counted
    s = score_image(c, rb.region, det, cell=6)
    assert (s.hits, s.false, s.duplicates) == (n, 1, 1)
    assert np.allclose(s.located, 0.3)
    r = pool([s, score_image(c, rb.region, np.zeros((0, 2)), cell=6)])
    assert r["recall"] == pytest.approx(0.5) and r["false"] == pytest.approx(1 / (2 * n))
    assert r["mean_error"] == pytest.approx(0.3) and r["p95_error"] == pytest.approx(0.3)
    assert r["located"] == pytest.approx(0.5)


def _truth_stub(cells, shift=(0.0, 0.0)):
    """A detector that returns each quick-grid board's true corners (plus ``shift``)."""
    table = {}
    for sc in scene_grid(cells, quick=True):
        rb = render_board(sc)
        table[rb.image.tobytes()] = rb.corners + shift
    return lambda img: table[np.ascontiguousarray(img).tobytes()]


def test_truth_stub_scores_perfectly():
    r = evaluate(_truth_stub([5, 8]), cells=[5, 8], quick=True)
    for cell in ("5", "8"):
        assert r[cell]["recall"] == 1.0 and r[cell]["false"] == 0.0 and r[cell]["duplicates"] == 0.0
        assert r[cell]["mean_error"] == pytest.approx(0.0, abs=1e-9)


def test_shifted_stub_errors_are_the_shift():
    r = evaluate(_truth_stub([5], (1.5, 0.0)), cells=[5], quick=True)["5"]
    # 1.5 px: outside the 1 px recall radius, inside the 2.5 px capture radius, inside the region
    assert r["recall"] == 0.0 and r["located"] == 1.0 and r["false"] == 1.0
    assert r["mean_error"] == pytest.approx(1.5) and r["p95_error"] == pytest.approx(1.5)


def test_practitioner_pipeline_on_large_cells():
    rb = render_board(BoardScene(16, 7, 6, 0.0, (0.4, 0.7), psf=1.5, noise=2.0, seed=4))
    s = score_image(rb.corners, rb.region, gftt_subpix(rb.image), cell=16)
    assert s.hits == len(rb.corners) and np.mean(s.located) < 0.05


def test_rows_accept_specs_callables_and_reject_unknown():
    rows = make_rows(["sogdd:sigma2=2.0", "gftt+subpix", "chessboard-sb", lambda im: np.zeros((0, 2))])
    assert [r.label for r in rows][:3] == ["sogdd:sigma2=2.0", "GFTT + cornerSubPix (5,5)",
                                            "findChessboardCornersSB"]
    assert rows[2].needs_pattern
    with pytest.raises(ValueError, match="unknown detector"):
        make_rows("no-such-detector")


def test_cli_quick_json_shape(capsys):
    rc = main(["eval", "chessboard", "--quick", "--json", "--no-real", "--no-progress",
               "--cells", "8,16", "--detectors", "gftt+subpix,chessboard-sb,shi-tomasi"])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["cells"] == [8.0, 16.0] and obj["real"] is None
    dets = obj["detectors"]
    assert list(dets) == ["GFTT + cornerSubPix (5,5)", "findChessboardCornersSB", "shi-tomasi"]
    for per_cell in dets.values():
        assert list(per_cell) == ["8", "16"]
        for row in per_cell.values():
            assert {"mean_error", "p95_error", "recall", "false"} <= set(row)
            assert row["recall"] * row["n_corners"] == pytest.approx(round(row["recall"] * row["n_corners"]))
    assert dets["findChessboardCornersSB"]["16"]["recall"] == 1.0
    # the figures of these rows on the quick boards (2 images per cell, 260 and 60 inner corners):
    # gradient refinement finds every corner within 0.05 px; integer Shi-Tomasi peaks sit ~0.7 px off
    for row in dets["GFTT + cornerSubPix (5,5)"].values():
        assert row["recall"] == 1.0 and row["false"] == 0.0 and row["mean_error"] < 0.05
    for row in dets["shi-tomasi"].values():
        assert 0.4 < row["recall"] < 0.8 and 0.5 < row["mean_error"] < 1.0 and row["located"] == 1.0
    assert dets["findChessboardCornersSB"]["8"]["recall"] == 0.5  # the finder gives up on one 8 px board


def test_cli_out_writes_json_and_plot(tmp_path):
    rc = main(["eval", "chessboard", "--quick", "--no-real", "--no-progress", "--cells", "12",
               "--detectors", "shi-tomasi", "--out", str(tmp_path)])
    assert rc == 0
    js = json.loads((tmp_path / "chessboard.json").read_text())
    assert "12" in js["detectors"]["shi-tomasi"]
    assert (tmp_path / "chessboard.png").stat().st_size > 1000


@pytest.mark.parametrize("argv", [["--cells", "3,x"], ["--cells", "1"], ["--detectors", "nope"],
                                  ["--data", "/no/such/folder"]])
def test_cli_bad_input(argv, capsys):
    rc = main(["eval", "chessboard", "--quick", "--no-progress", *argv])
    assert rc == 2
    err = capsys.readouterr().err
    assert err.startswith("sogdd: error:") and "Traceback" not in err


def test_real_calibration_check(data_dir):
    from sogdd.evaluation.chessboard.calibration import evaluate_calibration

    if not (data_dir / "calibration").is_dir():
        pytest.skip("no calibration data")
    r = evaluate_calibration(["chessboard-sb"], data_dir / "calibration")
    # the README's cornerSubPix offset on frames 01, 05, 09: (-0.45, -0.66)
    assert np.allclose(r["offset"]["chessboard_sony"], [-0.45, -0.66], atol=0.1)
    row = r["datasets"]["chessboard_sony"]["findChessboardCornersSB"]
    assert row["confirm"]["recall"] > 0.9 and row["confirm"]["mean_error"] < 0.5
    assert "findChessboardCornersSB" not in r["datasets"]["square_grid_sony"]
