"""The rig evaluation: the rendered rigs' exact truth, independent sessions, the metrics, the comparators, the
command."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import undistort
from sogdd.cli.main import main
from sogdd.evaluation.calibration import rig_comparators as rc
from sogdd.evaluation.calibration.rig_metrics import (
    calibration_ratios,
    epipolar_rms,
    heldout_corners,
    perfect_estimate,
    score_estimate,
)
from sogdd.evaluation.calibration.rigs import (
    QUICK_RIGS,
    RIGS,
    board_in_camera,
    render_rig_session,
    rig_poses,
    rigs,
)

SPEC = QUICK_RIGS["quick"]


@pytest.fixture(scope="module")
def session():
    return render_rig_session(SPEC, 3, seed=5)


def test_true_corners_project_through_the_true_rig(session):
    obj = SPEC.target.object_points()
    first, other = SPEC.cameras
    for f in session.frames:
        Rb = cv2.Rodrigues(f.rvec)[0]
        for c in SPEC.cameras:
            # OpenCV's own projection of the composed pose x_c = R_c (R_b X + t_b) + T_c
            rv = cv2.Rodrigues(c.R @ Rb)[0]
            cvp = cv2.projectPoints(obj, rv, c.R @ f.tvec + c.T, np.asarray(c.camera.K),
                                    np.asarray(c.camera.dist))[0].reshape(-1, 2)
            assert np.abs(f.views[c.name].corners - cvp).max() < 1e-6
        # the two views of a corner lie on each other's epipolar lines: x1^T [T]x R x0 = 0
        a = undistort(f.views[first.name].corners, first.camera.K, first.camera.dist)[0]
        b = undistort(f.views[other.name].corners, other.camera.K, other.camera.dist)[0]
        t = other.T
        E = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]]) @ other.R
        ha, hb = np.c_[a, np.ones(len(a))], np.c_[b, np.ones(len(b))]
        assert np.abs(np.einsum("ni,ij,nj->n", hb, E, ha)).max() < 1e-9 * np.linalg.norm(t)


def test_a_rendered_view_puts_the_corners_where_the_truth_says(session):
    view = session.frames[0].views["right"]
    board = rc.sogdd_boards({"right": [view.image]}, (9, 6))[0]["right"][0]
    idx = board.labels[:, 1] * 9 + board.labels[:, 0]
    assert board.size == (9, 6) and np.abs(board.image_points - view.corners[idx]).max() < 0.15


def test_frames_of_each_kind_are_placed_as_asked():
    poses = rig_poses(RIGS["trio"], 8, seed=3)
    kinds = [k for *_, k in poses]
    assert kinds.count("cut") == 1 and kinds.count("some") == 1
    rvec, tvec, _ = poses[kinds.index("some")]
    obj = RIGS["trio"].target.object_points()
    seen = []
    for c in RIGS["trio"].cameras:
        p = c.camera.project(obj, *board_in_camera(c, rvec, tvec))
        w, h = c.camera.size
        seen.append(int(np.sum((p[:, 0] >= 4) & (p[:, 1] >= 4) & (p[:, 0] <= w - 5) & (p[:, 1] <= h - 5))))
    assert min(seen) < 9 and sorted(seen)[1:] == [54, 54]


def test_sessions_with_different_seeds_are_independent(session):
    again = render_rig_session(SPEC, 1, seed=5)
    other = render_rig_session(SPEC, 1, seed=6)
    assert np.array_equal(again.frames[0].views["left"].image, session.frames[0].views["left"].image)
    assert not np.allclose(other.frames[0].tvec, session.frames[0].tvec)
    # new grey levels too: the background (a corner pixel far from the board) differs
    a, b = other.frames[0].views["left"].image, session.frames[0].views["left"].image
    assert abs(float(np.median(a)) - float(np.median(b))) > 1


def test_a_perfect_calibration_scores_zero_and_a_wrong_one_does_not():
    held = heldout_corners(SPEC, 3, seed=1)
    row = score_estimate(perfect_estimate(SPEC), SPEC, held)
    cam = row["cameras"]["right"]
    assert row["rotation_deg"] == 0 and row["translation_mm"] == 0 and row["epipolar"] == 0
    assert cam["fx"] == 0 and cam["projection_difference"] == 0
    bad = perfect_estimate(SPEC)
    bad.R["right"] = cv2.Rodrigues(np.array([np.radians(0.05), 0, 0]))[0] @ bad.R["right"]
    bad.T["right"] = bad.T["right"] + [0.0, 0.0, 3.0]
    r = score_estimate(bad, SPEC, held)
    assert r["rotation_deg"] == pytest.approx(0.05, abs=1e-4) and r["translation_mm"] == pytest.approx(3.0)
    # a tilt about the baseline's own axis turns the epipolar lines: a vertical disparity of ~fx * 0.05 deg
    assert 0.2 < epipolar_rms(bad, "left", "right", *held["right"]) < 2.0


def test_opencv_corners_are_oriented_as_the_truth(session):
    images = {n: session.images(n) for n in SPEC.names}
    corners, _ = rc.opencv_corners(images, (9, 6))
    checked = 0
    for n in SPEC.names:
        for f, c in enumerate(corners[n]):
            if c is not None:
                assert np.abs(c - session.frames[f].views[n].corners).max() < 0.3
                checked += 1
    assert checked >= 4


def test_comparators_skip_cleanly_when_absent_or_failing(monkeypatch):
    monkeypatch.setitem(rc._PROBES, "mrcal", lambda: False)
    ok, note = rc.rig_available("mrcal")
    assert not ok and "mrcal" in note and "apt-get" in note
    est, note = rc.run_rig_method("mrcal", boards=None, corners={}, sizes={}, pattern=(9, 6), square=25.0)
    assert est is None and "not installed" in note
    few = {"left": [None, None], "right": [None, None]}
    est, note = rc.run_rig_method("opencv-stereo-fix", boards=None, corners=few,
                                  sizes={"left": (640, 480), "right": (640, 480)}, pattern=(9, 6), square=25.0)
    assert est is None and note.startswith("opencv-stereo-fix failed:") and "\n" not in note
    with pytest.raises(ValueError, match="unknown rig method"):
        rc.rig_method_names("sogdd,nope")
    with pytest.raises(ValueError, match="unknown rig"):
        rigs(["nope"])


def test_calibration_ratio_of_a_known_spread():
    rng = np.random.default_rng(1)
    vals = [(np.array([rng.normal(5.0, 0.5)]), np.array([[1.0]]), np.array([5.0])) for _ in range(200)]
    r = calibration_ratios({"q": vals})["q"]
    assert r["ratio"] == pytest.approx(0.5, abs=0.06) and abs(r["bias_in_predicted_std"]) < 0.15


@pytest.mark.slow
def test_cli_rigs_quick_writes_json_and_table(tmp_path, capsys):
    out = tmp_path / "rigs"
    rc_ = main(["eval", "calibration", "--rigs", "--quick", "--no-real", "--methods", "sogdd,opencv-stereo-fix",
                "--out", str(out)])
    assert rc_ == 0
    res = json.loads((out / "rigs.json").read_text())
    by = {r["method"]: r for r in res["rendered"]}
    assert set(by) == {"sogdd", "opencv-stereo-fix"}
    for r in by.values():
        assert 0 <= r["rotation_deg"] < 1 and 0 <= r["translation_mm"] < 20 and r["epipolar"] < 1
    assert "| quick | sogdd |" in (out / "rigs.md").read_text()
    assert "Rig calibration" in capsys.readouterr().out


def test_cli_rigs_rejects_what_it_does_not_take():
    assert main(["eval", "calibration", "--rigs", "--quick", "--no-real", "--views", "3"]) == 2
    assert main(["eval", "calibration", "--quick", "--no-real", "--sessions", "3"]) == 2


def test_sogdd_states_its_projection_uncertainty_where_the_methods_are_compared():
    from sogdd.calib.rig.demo import demo_rig
    from sogdd.calib.rig.uncertainty import projection_uncertainty
    from sogdd.evaluation.calibration.rig_comparators import from_rig_calibration, uncertainty_pixels

    rig = demo_rig()
    est = from_rig_calibration(rig)
    assert set(est.uncertainty) == {"left", "right"}
    _, direct = projection_uncertainty(rig, "right", uncertainty_pixels((640, 480)))
    assert np.allclose(est.uncertainty["right"], direct) and all(v > 0 for v in direct)
