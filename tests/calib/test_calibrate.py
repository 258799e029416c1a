"""calibrate() on boards projected through known cameras: recovery, rejection, cross-validation, errors."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import MODELS, distort, project, projection_difference, undistort
from sogdd.calib.demo import DEMO_DIST, DEMO_K, DEMO_PATTERN, DEMO_SIZE, demo_boards, demo_poses
from sogdd.calib.fit import calibrate
from sogdd.calib.solvers import jacobian_std
from sogdd.calib.targets.board import Board

SIZE, K_TRUE, D_TRUE = DEMO_SIZE, DEMO_K, DEMO_DIST
COLS, ROWS = DEMO_PATTERN
OBJ = np.array([(i, j, 0.0) for j in range(ROWS) for i in range(COLS)])
LABELS = OBJ[:, :2].astype(int)
_poses, _boards = demo_poses, demo_boards


def test_distort_and_project_match_opencv():
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(-0.5, 0.5, (50, 2)), np.ones(50)] * rng.uniform(1, 3, (50, 1))
    rv, tv = np.array([0.1, -0.2, 0.05]), np.array([0.1, 0.2, 0.5])
    for model, d in (("pinhole", D_TRUE), ("rational", np.r_[D_TRUE, 0.01, -0.02, 0.003])):
        ref, _ = cv2.projectPoints(pts, rv, tv, K_TRUE, d)
        np.testing.assert_allclose(project(pts, K_TRUE, d, model, rv, tv), ref.reshape(-1, 2), atol=1e-9)
    fd = np.array([0.05, -0.01, 0.002, -0.0004])
    ref, _ = cv2.fisheye.projectPoints(pts.reshape(-1, 1, 3), rv, tv, K_TRUE, fd)
    np.testing.assert_allclose(project(pts, K_TRUE, fd, "fisheye", rv, tv), ref.reshape(-1, 2), atol=1e-9)


@pytest.mark.parametrize("model,dist", [("pinhole", D_TRUE), ("fisheye", np.array([0.05, -0.01, 0.002, 0.0]))])
def test_undistort_inverts_the_model(model, dist):
    gx, gy = np.meshgrid(np.linspace(0, 639, 20), np.linspace(0, 479, 15))
    px = np.c_[gx.ravel(), gy.ravel()]
    xy, ok = undistort(px, K_TRUE, dist, model)
    assert ok.all()
    np.testing.assert_allclose(project(np.c_[xy, np.ones(len(xy))], K_TRUE, dist, model), px, atol=1e-6)
    assert distort(xy, dist, model).shape == xy.shape


def test_projection_difference_of_known_shifts():
    same = projection_difference((K_TRUE, D_TRUE), (K_TRUE, D_TRUE), SIZE)
    assert same.mean < 1e-6 and same.valid_fraction == 1.0
    K2 = K_TRUE.copy()
    K2[0, 2] += 0.5
    K2[1, 2] -= 1.2
    d = projection_difference((K_TRUE, D_TRUE), (K2, D_TRUE), SIZE)
    assert d.mean == pytest.approx(1.3, abs=1e-6) and d.max == pytest.approx(1.3, abs=1e-6)
    # a focal error grows with the distance from the principal point
    K3 = K_TRUE.copy()
    K3[0, 0] *= 1.01
    K3[1, 1] *= 1.01
    d3 = projection_difference((K_TRUE, np.zeros(5)), (K3, np.zeros(5)), SIZE)
    assert d3.max > 3.5 > d3.mean > 1.0
    assert np.nanargmin(d3.distance) != 0
    with pytest.raises(ValueError, match="not a camera"):
        projection_difference("cam", (K_TRUE, D_TRUE), SIZE)


def test_recovers_the_known_camera():
    boards = _boards(14, noise=0.05)
    cal = calibrate(boards, SIZE, square=1.0)
    assert cal.n_used == 14 and all(r == "" for r in cal.reasons)
    assert abs(cal.K[0, 0] - 600.0) < 1.0 and abs(cal.K[1, 1] - 598.0) < 1.0
    np.testing.assert_allclose(cal.K[:2, 2], [322.0, 236.0], atol=1.5)
    assert abs(cal.dist[0] - D_TRUE[0]) < 0.01
    assert 0.05 < cal.rms < 0.1  # 0.05 px per axis: sqrt(2) * 0.05
    # a principal point ~0.3 px off, traded against the poses' rotation: small once that rotation is fitted
    assert projection_difference(cal, (K_TRUE, D_TRUE), SIZE).mean < 0.5
    assert projection_difference(cal, (K_TRUE, D_TRUE), SIZE, fit_rotation=True).mean < 0.2
    # the standard deviations are OpenCV's, and of the right size for 0.05 px noise
    assert 0 < cal.std["fx"] < 1.0 and 0 < cal.std["k1"] < 0.01
    assert len(cal.residuals) == 14 and cal.residuals[0].shape == (COLS * ROWS, 2)
    assert np.all(np.isfinite(cal.rvecs)) and cal.tvecs[:, 2].min() > 10
    assert np.allclose(cal.view_rms, cal.view_rms.mean(), rtol=0.5)
    # almost no good corner is rejected
    assert cal.n_corners_used >= 14 * COLS * ROWS - 2
    cv = cal.cross_validation
    assert cv is not None and cv.mean < 1.0 and len(cv.views_a) == len(cv.views_b) == 7


def test_rejects_planted_outlier_corners():
    boards = _boards(12, noise=0.05, seed=3)
    planted = {(2, 5): (3.0, -2.0), (7, 20): (-4.0, 0.0), (9, 40): (0.0, 2.5)}
    for (v, c), shift in planted.items():
        pts = boards[v].image_points.copy()
        pts[c] += shift
        boards[v] = Board(pts, LABELS)
    cal = calibrate(boards, SIZE)
    for v, c in planted:
        assert not cal.corner_used[v][c], (v, c)
        assert "residual" in cal.corner_reasons[v][c]
        assert np.hypot(*cal.residuals[v][c]) > 2.0
    assert cal.n_used == 12
    assert cal.n_corners_used >= 12 * COLS * ROWS - 3 - 3
    assert abs(cal.K[0, 0] - 600.0) < 1.5
    # without rejection, the planted corners are used and inflate the RMS
    raw = calibrate(boards, SIZE, reject=False)
    assert raw.n_corners_used == 12 * COLS * ROWS and raw.rms > 2 * cal.rms


def test_rejects_an_outlier_view_with_its_reason():
    boards = _boards(12, noise=0.05, seed=4)
    rng = np.random.default_rng(9)
    bad = boards[5].image_points + rng.normal(0, 1.5, (COLS * ROWS, 2))
    boards[5] = Board(bad, LABELS)
    cal = calibrate(boards, SIZE, names=[f"f{i}.png" for i in range(12)])
    assert not cal.view_used[5] and cal.reasons[5]
    assert ("most corners" in cal.reasons[5]) or ("RMS" in cal.reasons[5])
    assert cal.view_used.sum() == 11
    assert not cal.corner_used[5].any()
    assert cal.residuals[5] is not None and cal.view_rms[5] > 1.0  # its pose from solvePnP
    assert abs(cal.K[0, 0] - 600.0) < 1.5


def test_views_without_board_or_with_too_few_corners_are_reported():
    boards = _boards(8, seed=5)
    boards[1] = None
    boards[3] = Board(boards[3].image_points[:4], LABELS[:4])
    boards[6] = Board(boards[6].image_points[:9], LABELS[:9])  # one row of the board
    cal = calibrate(boards, SIZE)
    assert cal.reasons[1] == "no board" and cal.residuals[1] is None and cal.corner_used[1] is None
    assert cal.reasons[3].startswith("too few corners")
    assert "one line" in cal.reasons[6]
    assert cal.n_used == 5


def test_cross_validation_exposes_a_wrong_model():
    """Heavy distortion fitted without distortion terms: the halves disagree far more."""
    d = np.array([-0.4, 0.15, 0.0, 0.0, 0.0])
    boards = _boards(16, noise=0.05, seed=6, dist=d, spread=1.6)
    right = calibrate(boards, SIZE)
    wrong = calibrate(boards, SIZE, reject=False, flags=cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2
                      | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST)
    assert right.cross_validation.mean < 1.0
    assert wrong.cross_validation.mean > 20 * right.cross_validation.mean
    assert wrong.rms > 10 * right.rms


def test_rational_and_fisheye_models():
    boards = _boards(12, noise=0.03, seed=7)
    rat = calibrate(boards, SIZE, model="rational")
    assert len(rat.dist) == 8 and rat.model == "rational"
    assert projection_difference(rat, (K_TRUE, D_TRUE), SIZE, margin=40, fit_rotation=True).mean < 0.3
    fd = np.array([0.08, -0.02, 0.01, 0.0])
    fb = _boards(12, noise=0.03, seed=8, dist=fd, model="fisheye")
    fish = calibrate(fb, SIZE, model="fisheye")
    assert len(fish.dist) == 4 and abs(fish.K[0, 0] - 600.0) < 2.0
    assert projection_difference(fish, (K_TRUE, fd, "fisheye"), SIZE, fit_rotation=True).mean < 0.1
    # OpenCV's fisheye calibration gives no standard deviations: they come from the residuals' Jacobian
    assert all(np.isfinite(v) and v > 0 for v in fish.std.values()) and fish.std_note == ""
    assert 0 < fish.std["fx"] < 1.0


def test_partial_boards_with_relative_labels():
    """Labels of a partial board start anywhere: only their consistency within a view matters."""
    boards = _boards(10, noise=0.03, seed=10)
    keep = (LABELS[:, 0] >= 2) & (LABELS[:, 1] >= 1)
    boards = [Board(b.image_points[keep], LABELS[keep] - [2, 1] + [v, -v]) for v, b in enumerate(boards)]
    cal = calibrate(boards, SIZE)
    assert cal.n_used == 10 and abs(cal.K[0, 0] - 600.0) < 2.0


@pytest.mark.parametrize("call,match", [
    (lambda b: calibrate(b[:2], SIZE), r"too few views: 2 usable view\(s\), calibration needs 3 \(1 more\)"),
    (lambda b: calibrate([None, None], SIZE), "no corners"),
    (lambda b: calibrate(b, (480, 640)), "outside the 480x640 image"),
    (lambda b: calibrate(b, SIZE, names=["a"]), "boards but 1 view names"),
    (lambda b: calibrate(b, SIZE, model="kb8"), "unknown camera model"),
    (lambda b: calibrate(b, SIZE, square=0), "square must be"),
    (lambda b: calibrate(b, SIZE, square=1e9), r"square must be from 1e-06 to 1e\+06"),
    (lambda b: calibrate(b, SIZE, square=1e-30), r"square must be from 1e-06 to 1e\+06"),
    (lambda b: calibrate(b, "640x480"), "image_size"),
    (lambda b: calibrate([*b, "x"], SIZE), "expected a Board"),
])
def test_errors_are_one_line(call, match):
    boards = _boards(5, seed=11)
    with pytest.raises(ValueError, match=match) as exc:
        call(boards)
    assert "\n" not in str(exc.value)


def test_too_few_views_says_why_the_others_were_left_out():
    boards = _boards(3, seed=12)
    boards[2] = Board(boards[2].image_points[:5], LABELS[:5])
    with pytest.raises(ValueError, match=r"1 more\); rejected: too few corners: 1"):
        calibrate(boards + [None], SIZE)


def test_rejection_never_leaves_a_view_with_too_few_corners():
    """At the fewest views, a small view's outliers stay rather than leave it under min_corners."""
    boards = _boards(3, noise=0.03, seed=13)
    keep = (LABELS[:, 0] < 4) & (LABELS[:, 1] < 2)  # 8 corners
    pts = boards[2].image_points[keep].copy()
    pts[[0, 3, 5]] += [[3.0, 0.0], [0.0, -3.0], [2.5, 2.5]]
    boards[2] = Board(pts, LABELS[keep])
    cal = calibrate(boards, SIZE, min_views=3)
    assert cal.view_used.all() and cal.corner_used[2].sum() >= 6
    more = _boards(5, noise=0.03, seed=14)
    cal = calibrate(boards + more, SIZE, min_views=3)
    assert not cal.view_used[2] and cal.reasons[2]  # with views to spare, the view goes as a whole


def test_projection_difference_within_a_polygon():
    """Cameras that differ in k3 agree near the centre and part far from it."""
    d3 = D_TRUE + [0, 0, 0, 0, 0.5]
    poly = np.array([[200, 150], [440, 150], [440, 330], [200, 330]], float)
    d = projection_difference((K_TRUE, D_TRUE), (K_TRUE, d3), SIZE, within=poly)
    assert 0.1 < d.within.mean() < 0.3
    assert d.mean_within < 0.1 * d.mean and d.max_within < 0.1 * d.max
    assert np.all(d.distance[d.within] <= d.max_within)
    with pytest.raises(ValueError, match="polygon of at least 3 points"):
        projection_difference((K_TRUE, D_TRUE), (K_TRUE, d3), SIZE, within=poly[:2])


def test_a_sub_pixel_outlier_is_rejected_above_the_floor():
    """At 0.01 px noise the robust limit is far below 0.1 px: the floor decides, and 0.7 px is an outlier."""
    boards = _boards(10, noise=0.01, seed=40)
    pts = boards[4].image_points.copy()
    pts[23] += [0.5, -0.5]
    boards[4] = Board(pts, LABELS)
    cal = calibrate(boards, SIZE)
    r = np.hypot(*cal.residuals[4][23])
    assert 0.3 < r < 1.0  # between the floor and a floor ten times too high
    assert not cal.corner_used[4][23] and "residual" in cal.corner_reasons[4][23]
    assert cal.thresholds["corner"] == pytest.approx(0.1)
    assert cal.n_corners_used == 10 * COLS * ROWS - 1


@pytest.mark.parametrize("model,dist,n", [("fisheye", np.array([0.3, -0.1, 0.05, 0.0]), 4),
                                          ("rational", D_TRUE, 8)])
def test_the_halves_are_fitted_with_the_model(model, dist, n):
    """A fisheye's halves fitted as pinholes would disagree by hundreds of px."""
    boards = _boards(12, noise=0.03, seed=41, dist=dist, model="pinhole" if model == "rational" else model,
                     spread=1.4)
    cv = calibrate(boards, SIZE, model=model).cross_validation
    assert len(cv.dist_a) == len(cv.dist_b) == n
    assert cv.mean_within < 0.3 and cv.rms_a < 0.1 and cv.rms_b < 0.1


def test_the_halves_are_disjoint_and_each_is_its_own_fit():
    boards = _boards(12, noise=0.1, seed=42)
    boards[3] = None
    cal = calibrate(boards, SIZE)
    cv = cal.cross_validation
    a, b = set(cv.views_a), set(cv.views_b)
    assert not a & b and a | b == set(np.flatnonzero(cal.view_used).tolist())
    assert abs(len(a) - len(b)) <= 1
    # each half's camera is the calibration of its own views (fitted here by OpenCV directly)
    for views, K in ((cv.views_a, cv.K_a), (cv.views_b, cv.K_b)):
        obj = [cal.boards[v].object_points(1.0)[cal.corner_used[v]].astype(np.float32) for v in views]
        img = [cal.boards[v].image_points[cal.corner_used[v]].astype(np.float32) for v in views]
        _, K_ref, *_ = cv2.calibrateCamera(obj, img, SIZE, None, None)
        np.testing.assert_allclose(K, K_ref, atol=0.05)
    # on noisy data two disjoint halves differ by far more than rounding
    assert abs(cv.K_a[0, 0] - cv.K_b[0, 0]) > 1e-3 and cv.mean > 0.01


def test_one_view_has_no_standard_deviations_and_says_why():
    cal = calibrate(_boards(1, seed=2), SIZE, min_views=1)
    assert all(np.isnan(v) for v in cal.std.values())
    assert cal.std_note.startswith("one view") and any(n.endswith(cal.std_note) for n in cal.notes)
    assert calibrate(_boards(3, seed=2), SIZE).std_note == ""


def test_standard_deviations_match_the_spread_over_noise_draws():
    """Each parameter's reported deviation against its spread over 50 fresh noise draws on one scene."""
    rng = np.random.default_rng(43)
    scene = [p for _, _, p in _poses(8, rng)]
    values, stds = [], []
    for _ in range(50):
        boards = [Board(p + rng.normal(0, 0.1, p.shape), LABELS) for p in scene]
        cal = calibrate(boards, SIZE, reject=False, cross_validate=False)
        values.append([cal.K[0, 0], cal.K[1, 1], cal.K[0, 2], cal.K[1, 2], *cal.dist])
        stds.append(list(cal.std.values()))
    assert list(cal.std) == ["fx", "fy", "cx", "cy", *MODELS["pinhole"]]
    spread = np.std(values, axis=0, ddof=1)
    reported = np.median(stds, axis=0)
    # the linearised estimate is exact to first order; the spread of 50 draws is good to about 10 %
    for name, s, r in zip(cal.std, spread, reported):
        assert s / 1.35 < r < s * 1.35, (name, r, s)


@pytest.mark.parametrize("model", ["pinhole", "rational"])
def test_the_jacobian_standard_deviations_are_opencvs(model):
    """jacobian_std (what the fisheye model gets) is the estimate OpenCV makes for the others."""
    boards = _boards(8, noise=0.1, seed=45)
    obj = [b.object_points(1.0).reshape(-1, 1, 3) for b in boards]
    img = [b.image_points.reshape(-1, 1, 2) for b in boards]
    flags = cv2.CALIB_RATIONAL_MODEL if model == "rational" else 0
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    _, K, D, rv, tv, std, _, _ = cv2.calibrateCameraExtended(obj, img, SIZE, None, None, flags=flags,
                                                             criteria=crit)
    n = 4 + len(MODELS[model])
    mine = jacobian_std([o.reshape(-1, 3) for o in obj], [i.reshape(-1, 2) for i in img], K, D.ravel()[:n - 4],
                        np.array(rv).reshape(-1, 3), np.array(tv).reshape(-1, 3), model)
    np.testing.assert_allclose(mine, std.ravel()[:n], rtol=1e-3)
    # and calibrate names OpenCV's vector in that order
    cal = calibrate(boards, SIZE, model=model, reject=False, cross_validate=False)
    names = ("fx", "fy", "cx", "cy", *MODELS[model])
    np.testing.assert_allclose([cal.std[k] for k in names], std.ravel()[:n], rtol=1e-3)


@pytest.fixture(scope="module")
def rendered_boards(rendered_frames):
    """The boards detected in the eight rendered frames, and their image size."""
    from sogdd.calib import calibrate_images
    cal = calibrate_images(rendered_frames, "chessboard:9x6").calibration
    return list(cal.boards), cal.image_size


@pytest.mark.parametrize("model", ["pinhole", "auto"])
def test_the_square_does_not_change_the_fit(rendered_boards, model):
    """The unit of the board is the poses' alone: from 1e-6 to 1e6 the same camera, the same residuals,
    and translations that scale with the square."""
    boards, size = rendered_boards
    ref = calibrate(boards, size, square=1.0, model=model)
    for s in (1e-6, 1e-3, 25.0, 1e3, 1e6):
        cal = calibrate(boards, size, square=s, model=model)
        assert cal.model == ref.model and cal.square == s
        np.testing.assert_allclose(cal.K, ref.K, rtol=1e-9, atol=0)
        np.testing.assert_allclose(cal.dist, ref.dist, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(cal.rms, ref.rms, rtol=1e-9)
        np.testing.assert_allclose(cal.rvecs, ref.rvecs, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(cal.tvecs / s, ref.tvecs, rtol=1e-9)
        assert [cal.std[n] for n in ref.std] == pytest.approx([ref.std[n] for n in ref.std], rel=1e-9)
        assert cal.cross_validation.mean == pytest.approx(ref.cross_validation.mean, rel=1e-9)
