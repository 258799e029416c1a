"""The lens model chosen by cross-validation (sogdd.calib.model_selection), and the pinhole4 model.

Boards are projected through known cameras (the demo's poses, 9 x 6 corners, 0.1 px of noise): a lens
with k3 = 0 should keep k3 out, one that needs k3 should get it, a wide fisheye the fisheye model.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from sogdd.calib import calibrate, calibrate_images, select_model
from sogdd.calib.cameras import MODELS, project
from sogdd.calib.demo import DEMO_SIZE, demo_boards
from sogdd.calib.files import read_camera, write_camera_json, write_camera_yaml
from sogdd.calib.verdict import verdict
from sogdd.cli.main import main

K_WIDE = np.array([[420.0, 0, 322], [0, 419.0, 236], [0, 0, 1]])


@pytest.fixture(scope="module")
def mild():
    """A lens with k3 = 0 (k1, k2, p1, p2 only)."""
    return demo_boards(15, noise=0.1, seed=3)


def test_a_lens_without_k3_keeps_k3_out(mild):
    sel = select_model(mild, DEMO_SIZE)
    assert [r.model for r in sel.table] == ["pinhole4", "pinhole", "rational"]
    assert sel.chosen == "pinhole4"
    best = min(sel.table, key=lambda r: r.cv_rms)
    assert sel.row("pinhole4").within_noise and best.difference == 0.0
    # every score is of held-out corners: never below what the fit of all views reaches by much
    for r in sel.table:
        assert r.n_coefficients == len(MODELS[r.model])
        assert np.isfinite(r.cv_rms) and r.cv_rms > 0.9 * r.fit_rms and r.cv_se > 0 and not r.note
    assert "5-fold" in sel.rule and sel.notes == ()


def test_a_lens_that_needs_k3_gets_a_richer_model():
    boards = demo_boards(12, noise=0.1, seed=4, K=K_WIDE, dist=np.array([0.1, -0.1, 0, 0, 0.2]), spread=1.5)
    sel = select_model(boards, DEMO_SIZE)
    assert sel.chosen in ("pinhole", "rational")
    four = sel.row("pinhole4")
    assert not four.within_noise and four.difference > 0.05 * sel.row(sel.chosen).cv_rms


@pytest.mark.slow
def test_a_wide_fisheye_picks_fisheye():
    K = np.array([[180.0, 0, 322], [0, 180, 236], [0, 0, 1]])
    boards = demo_boards(10, noise=0.1, seed=2, K=K, dist=np.array([0.02, -0.01, 0, 0]), model="fisheye",
                         spread=1.6)
    sel = select_model(boards, DEMO_SIZE)
    assert "fisheye" in [r.model for r in sel.table] and any("fisheye added" in n for n in sel.notes)
    assert sel.chosen == "fisheye"
    assert all(not r.within_noise for r in sel.table if r.model != "fisheye")


def test_the_folds_are_deterministic_round_robin(mild):
    a = select_model(mild, DEMO_SIZE, folds=4, candidates=["pinhole4", "pinhole"])
    b = select_model(mild, DEMO_SIZE, folds=4, candidates=["pinhole4", "pinhole"])
    used = np.array(a.views)
    assert a.folds == b.folds == tuple(tuple(int(v) for v in used[f::4]) for f in range(4))
    assert sorted(v for f in a.folds for v in f) == list(a.views)
    assert [r.cv_rms for r in a.table] == [r.cv_rms for r in b.table]


def test_too_few_views_fall_back_with_a_note(mild):
    sel = select_model(mild[:3], DEMO_SIZE)
    assert sel.chosen == "pinhole4" and sel.folds == ()
    assert any("too few views to cross-validate" in n for n in sel.notes)
    assert all(np.isnan(r.cv_rms) and np.isfinite(r.fit_rms) for r in sel.table)
    loo = select_model(mild[:4], DEMO_SIZE)  # four views: leave-one-out, each fold three views
    assert len(loo.folds) == 4 and any("leave-one-out" in n for n in loo.notes)


def test_bad_parameters_fail_at_the_door(mild):
    for kw, text in [({"candidates": ["nope"]}, "unknown camera model"), ({"candidates": []}, "at least one"),
                     ({"folds": 1}, "folds must be"), ({"noise_se": -1}, "noise_se"), ({"tolerance": np.nan},
                                                                                       "tolerance")]:
        with pytest.raises(ValueError, match=text):
            select_model(mild, DEMO_SIZE, **kw)
    with pytest.raises(ValueError, match="give a model, not auto"):
        calibrate(mild, DEMO_SIZE, model="auto", flags=cv2.CALIB_FIX_K3)
    with pytest.raises(ValueError, match="choose auto or one of"):
        calibrate(mild, DEMO_SIZE, model="nope")


def test_calibrate_auto_records_the_table_and_equals_the_chosen_model(mild, tmp_path):
    cal = calibrate(mild, DEMO_SIZE, model="auto")
    sel = cal.model_selection
    assert sel is not None and cal.model == sel.chosen == "pinhole4"
    fixed = calibrate(mild, DEMO_SIZE, model="pinhole4")
    assert fixed.model_selection is None
    np.testing.assert_allclose(cal.K, fixed.K)
    np.testing.assert_allclose(cal.dist, fixed.dist)
    d = json.loads(write_camera_json(cal, tmp_path / "camera.json").read_text())
    assert d["model"] == "pinhole4" and d["model_selection"]["chosen"] == "pinhole4"
    assert [r["model"] for r in d["model_selection"]["table"]] == ["pinhole4", "pinhole", "rational"]
    assert d["model_selection"]["folds"] == [list(f) for f in sel.folds]
    assert any("chosen by 5-fold cross-validation" in t for _, t in verdict(cal))


def test_pinhole4_is_opencvs_four_coefficients_and_reads_back(mild, tmp_path):
    cal = calibrate(mild, DEMO_SIZE, model="pinhole4")
    assert cal.dist.shape == (4,) and list(cal.coefficients()) == ["k1", "k2", "p1", "p2"]
    assert list(cal.std) == ["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"]
    v = int(np.flatnonzero(cal.view_used)[0])
    obj = cal.boards[v].object_points(cal.square)
    cvp, _ = cv2.projectPoints(obj, cal.rvecs[v], cal.tvecs[v], cal.K, cal.dist)
    np.testing.assert_allclose(cvp.reshape(-1, 2), project(obj, cal.K, cal.dist, "pinhole4", cal.rvecs[v],
                                                           cal.tvecs[v]), atol=1e-9)
    path = write_camera_yaml(cal, tmp_path / "camera.yaml")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    D = fs.getNode("distortion_coefficients").mat()
    assert fs.getNode("model").string() == "pinhole4" and D.shape == (1, 4)
    np.testing.assert_allclose(D.ravel(), cal.dist)
    fs.release()
    assert read_camera(path)["model"] == "pinhole4"
    assert not [t for lv, t in verdict(cal) if lv == "bad"]


def test_calibrate_images_chooses_by_default(rendered_frames):
    result = calibrate_images(rendered_frames, "chessboard:9x6", square=25.0)
    cal = result.calibration
    assert cal.model_selection is not None and cal.model == cal.model_selection.chosen
    assert len(cal.model_selection.table) >= 3


def test_the_command_with_model_pinhole4(rendered_frames, tmp_path, capsys):
    out = tmp_path / "calib"
    code = main(["calibrate", str(rendered_frames / "*.png"), "--board", "chessboard:9x6", "--model",
                 "pinhole4", "--out", str(out), "--no-report", "--quiet", "--json"])
    text, err = capsys.readouterr()
    summary = json.loads(text)
    assert code == (3 if summary["verdict_level"] == "bad" else 0), err  # 3: written, but the verdict is bad
    assert summary["model"] == "pinhole4" and summary["model_selection"] is None and len(summary["dist"]) == 4
    fs = cv2.FileStorage(str(out / "camera.yaml"), cv2.FILE_STORAGE_READ)
    assert fs.getNode("model").string() == "pinhole4"
    assert fs.getNode("distortion_coefficients").mat().shape == (1, 4)
    fs.release()
    auto = tmp_path / "auto"
    code = main(["calibrate", str(rendered_frames / "*.png"), "--board", "chessboard:9x6", "--out", str(auto),
                 "--quiet"])
    text, _ = capsys.readouterr()
    assert code == (3 if any(line.startswith("  bad: ") for line in text.splitlines()) else 0)
    assert "models (cross-validated RMS px)" in text
    page = (auto / "report.html").read_text()
    assert "Lens model" in page and "cross-validated RMS" in page
    assert json.loads((auto / "camera.json").read_text())["model_selection"]["table"]


def test_the_folds_leave_every_training_set_min_views_or_fall_back_to_leave_one_out(mild):
    """Five views in two folds are folds of three and two views: holding out the three leaves two, too few
    for min_views = 3, so leave-one-out (five folds of one, four views to fit each) is used instead."""
    sel = select_model(mild[:5], DEMO_SIZE, folds=2, min_views=3, candidates=["pinhole4"], reject=False)
    assert len(sel.views) == 5
    assert len(sel.folds) == 5 and all(len(f) == 1 for f in sel.folds)
    assert all(len(sel.views) - len(f) >= 3 for f in sel.folds)
    assert sel.rule.startswith("5-fold cross-validation over 5 views")
    # six views in two folds of three leave three to fit: the two folds are kept
    six = select_model(mild[:6], DEMO_SIZE, folds=2, min_views=3, candidates=["pinhole4"], reject=False)
    assert [len(f) for f in six.folds] == [3, 3] and six.rule.startswith("2-fold cross-validation over 6 views")
