"""The drift check (:mod:`sogdd.calib.drift`): new views against a stored camera or rig
(:mod:`sogdd.calib.exchange.native` reads it with its standard deviations).

The camera's views are rendered (the ``render`` fixture: a chessboard through a known camera with
distortion, exact truth), calibrated and written as ``sogdd calibrate`` writes them; new views of the
same camera must pass, views of the camera with its focal length 1 % longer must fail. The rules' floors
and the rig's relative poses are checked on projected boards (:mod:`sogdd.calib.demo`).
"""

from __future__ import annotations

import json
import shutil
from dataclasses import replace

import cv2
import numpy as np
import pytest

from sogdd.calib import calibrate
from sogdd.calib.cameras import project
from sogdd.calib.demo import DEMO_DIST, DEMO_K, DEMO_SIZE, demo_boards
from sogdd.calib.drift import FAIL_PCT, FAIL_SIGMA, WARN_PCT, WARN_SIGMA, check_calibration
from sogdd.calib.exchange import native, stored_rig
from sogdd.calib.files import write_calibration
from sogdd.calib.rig.demo import demo_rig, synthetic_rig
from sogdd.calib.rig.files import write_rig
from sogdd.calib.session import calibrate_images
from sogdd.calib.targets.board import Board

BOARD = "chessboard:9x6"
#: a camera matrix times this: fx and fy 1 % longer, the principal point where it was
FOCAL_1PCT = np.array([[1.01, 1, 1], [1, 1.01, 1], [1, 1, 1]])


def _shoot(render, camera, n: int, seed: int, folder):
    """``n`` rendered views of the 9 x 6 board through ``camera`` into ``folder`` (blur 0.8, noise 2)."""
    folder.mkdir()
    board = render.Board(9, 6)
    for k, (rv, tv) in enumerate(render.random_poses(camera, board, n, seed=seed)):
        view = render.render_view(camera, board, rv, tv, supersample=2, blur=0.8, noise=2.0, rng=100 * seed + k)
        assert cv2.imwrite(str(folder / f"v{k:02d}.png"), view.image)
    return folder


@pytest.fixture(scope="module")
def rendered(render, tmp_path_factory):
    """The stored calibration (10 rendered views, written as sogdd calibrate writes it), five new views of
    the same camera, and five of the camera with fx and fy 1 % longer."""
    root = tmp_path_factory.mktemp("drift")
    camera = render.camera_for(640, 480)
    result = calibrate_images(_shoot(render, camera, 10, 1, root / "calib"), BOARD, model="pinhole",
                              thumbnails=False)
    write_calibration(result.calibration, root / "stored")
    K = camera.K * FOCAL_1PCT
    return {"stored": root / "stored", "truth": camera, "same": _shoot(render, camera, 5, 2, root / "same"),
            "moved": _shoot(render, render.Camera(K, camera.dist, camera.size), 5, 2, root / "moved")}


@pytest.mark.parametrize("name", ["camera.yaml", "camera.json"])
def test_the_same_cameras_new_views_pass(rendered, name):
    check = check_calibration(rendered["stored"] / name, rendered["same"] / "*.png", board=BOARD)
    assert check.verdict == "pass", check.reason
    assert check.reason.startswith("5 view(s) agree with the stored calibration")
    cam = check.cameras[0]
    assert len(cam.views) == 5 and cam.skipped == {} and cam.corners == 5 * 54
    assert cam.rms < 0.1 and all(r < 0.1 for r in cam.view_rms)
    assert all(abs(cam.difference_pct[n]) < WARN_PCT for n in ("fx", "fy", "cx", "cy"))
    assert all(abs(cam.sigmas[n]) < WARN_SIGMA for n in ("fx", "fy", "cx", "cy"))
    # the stored standard deviations are read from either file
    assert all(0 < cam.stored_std[n] < 1 for n in ("fx", "fy", "cx", "cy"))
    assert all(0 < cam.fresh_std[n] < 1 for n in ("fx", "fy", "cx", "cy"))


def test_a_focal_length_moved_by_one_percent_fails(rendered):
    check = check_calibration(rendered["stored"] / "camera.yaml", rendered["moved"], board=BOARD)
    assert check.verdict == "fail"
    assert check.reason.startswith(("fx moved by +", "fy moved by +"))
    assert check.reason.endswith("the camera has changed")
    cam = check.cameras[0]
    for n in ("fx", "fy"):
        assert cam.difference_pct[n] == pytest.approx(1.0, abs=0.15)
        assert cam.sigmas[n] > FAIL_SIGMA
    # the fresh fit finds the camera that took the views
    assert cam.fresh["fx"] == pytest.approx(1.01 * rendered["truth"].K[0, 0], rel=1e-3)
    assert abs(cam.difference_pct["cx"]) < WARN_PCT
    # a pose absorbs most of a focal length's change: the residuals alone would not have told
    assert cam.rms < 0.2


def test_the_check_is_json_able(rendered):
    check = check_calibration(rendered["stored"] / "camera.json", rendered["moved"], board=BOARD)
    d = json.loads(json.dumps(check.as_dict(), allow_nan=False))
    assert d["verdict"] == "fail" and d["findings"][0]["level"] == "fail"
    assert sorted(d["cameras"][0]["view_rms"]) == [f"v{k:02d}.png" for k in range(5)]


# --------------------------------------------------------------------------------------------------
# the rules, on projected boards

@pytest.fixture(scope="module")
def stored():
    return stored_rig(calibrate(demo_boards(14, noise=0.05), DEMO_SIZE))


def _moved(scale: float, noise: float = 0.02, dist=DEMO_DIST) -> list[Board]:
    K = DEMO_K * [[scale, 1, 1], [1, scale, 1], [1, 1, 1]]
    return demo_boards(6, noise=noise, seed=7, K=K, dist=np.asarray(dist))


def test_the_floor_keeps_a_tiny_stored_std_from_failing_a_tiny_change(stored):
    """A stored std of 1e-4 px makes a 0.05 % change many sigma: the % floor passes it."""
    cam = replace(stored.cameras[0], std=dict.fromkeys(("fx", "fy", "cx", "cy"), 1e-4))
    tiny = replace(stored, cameras=(cam,))
    check = check_calibration(tiny, _moved(1.0005, noise=0.005))
    c = check.cameras[0]
    assert max(abs(c.sigmas["fx"]), abs(c.sigmas["fy"])) > FAIL_SIGMA  # beyond the sigma limit ...
    assert abs(c.difference_pct["fx"]) < WARN_PCT  # ... but not the floor
    assert check.verdict == "pass"


@pytest.mark.parametrize(("scale", "verdict"), [(1.0, "pass"), (1.003, "warn"), (1.01, "fail")])
def test_the_focal_lengths_change_sets_the_verdict(stored, scale, verdict):
    check = check_calibration(stored, _moved(scale))
    assert check.verdict == verdict, check.reason
    pct = check.cameras[0].difference_pct["fx"]
    assert pct == pytest.approx(100 * (scale - 1), abs=0.1)
    assert (abs(pct) >= FAIL_PCT) == (verdict == "fail")


def test_a_changed_distortion_fails_on_the_residuals(stored):
    """The fresh fit holds the distortion: a lens whose distortion changed shows in the residuals."""
    check = check_calibration(stored, _moved(1.0, dist=(-0.1, 0.02, 0.001, -0.0005, 0.0)))
    assert check.verdict == "fail"
    assert any("does not explain the new views" in t for lv, t in check.findings if lv == "fail")


def test_views_without_a_board_are_reported_not_checked(stored):
    boards = _moved(1.0)
    few = Board(boards[0].image_points[:4], boards[0].labels[:4])
    check = check_calibration(stored, [*boards, None, few])
    assert check.verdict == "pass"
    assert check.cameras[0].skipped == {"view6": "no board", "view7": "4 corners, fewer than 6"}


# --------------------------------------------------------------------------------------------------
# a rig

@pytest.fixture(scope="module")
def rig_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rig")
    write_rig(demo_rig(), folder)
    return folder


def _rig_boards(turn_deg: float = 0.0, frames: int = 6) -> dict[str, list]:
    """New frames seen by the demo rig, its right camera turned by ``turn_deg`` about its y axis."""
    d = synthetic_rig(cameras=2, frames=frames, noise=0.03, seed=11)
    lab = np.array([(i, j) for j in range(6) for i in range(9)])
    obj = np.c_[lab, np.zeros(len(lab))].astype(float)
    turn = cv2.Rodrigues(np.array([0.0, np.radians(turn_deg), 0.0]))[0]
    rng = np.random.default_rng(0)
    out: dict[str, list] = {"left": [], "right": []}
    for rv, tv in zip(d.rvecs, d.tvecs):
        Rb = cv2.Rodrigues(rv)[0]
        for c, name in enumerate(("left", "right")):
            R = turn @ d.R[c] if name == "right" else d.R[c]
            px = project((obj @ Rb.T + tv) @ R.T + d.T[c], d.K[c], d.dist[c])
            out[name].append(Board(px + rng.normal(0, 0.03, px.shape), lab, size=(9, 6)))
    return out


@pytest.mark.parametrize("name", ["rig.yaml", "rig.json"])
def test_a_rig_with_its_cameras_in_place_passes(rig_folder, name):
    s = native.read(rig_folder / name)
    assert s.names == ("left", "right") and s.cameras[1].pose_std["rotation_deg"] > 0 and s.square == 1.0
    assert all(c.rms > 0 and c.std["fx"] > 0 for c in s.cameras)
    check = check_calibration(s, _rig_boards())
    assert check.verdict == "pass", check.reason
    assert [c.name for c in check.cameras] == ["left", "right"]
    (pose,) = check.poses
    assert pose.name == "right" and pose.frames == 6 and pose.rotation_deg < 0.05 and pose.translation_pct < 0.5


def test_a_rig_yaml_alone_takes_its_cameras_standard_deviations_from_their_folders(rig_folder, tmp_path):
    shutil.copytree(rig_folder, tmp_path / "rig")
    (tmp_path / "rig" / "rig.json").unlink()
    s = native.read(tmp_path / "rig" / "rig.yaml")
    own = native.read(rig_folder / "right" / "camera.yaml").cameras[0]
    assert s.cameras[1].std == own.std and s.cameras[1].rms == pytest.approx(own.rms)
    assert np.isnan(s.cameras[1].pose_std["rotation_deg"])  # only rig.json holds it


def test_a_rig_camera_turned_half_a_degree_fails(rig_folder):
    check = check_calibration(rig_folder / "rig.yaml", _rig_boards(turn_deg=0.5))
    assert check.verdict == "fail"
    assert any(t.startswith("right: its rotation relative to left moved by 0.") for lv, t in check.findings
               if lv == "fail")
    assert check.poses[0].rotation_deg == pytest.approx(0.5, abs=0.05)


# --------------------------------------------------------------------------------------------------
# bad inputs: one line each

def test_bad_inputs_are_one_line_errors(rendered, rig_folder, stored, tmp_path):
    cases = [
        (lambda: check_calibration(tmp_path / "nothere.yaml", rendered["same"]), "nothere.yaml: no such file"),
        (lambda: check_calibration(rig_folder / "rig.yaml", rendered["same"], board=BOARD),
         "is a rig of 2 cameras (left, right): give each camera's images by its name"),
        (lambda: check_calibration(stored, {"left": rendered["same"]}), "is one camera, not a rig"),
        (lambda: check_calibration(rig_folder / "rig.yaml", {"middle": rendered["same"]}),
         "camera 'middle' is not in the stored rig"),
        (lambda: check_calibration(stored, [None, None]), "no view to check"),
    ]
    for call, says in cases:
        with pytest.raises(ValueError) as exc:
            call()
        assert says in str(exc.value) and "\n" not in str(exc.value)
    blank = tmp_path / "blank"
    blank.mkdir()
    for k in range(2):
        cv2.imwrite(str(blank / f"b{k}.png"), np.full((480, 640), 128, np.uint8))
    with pytest.raises(ValueError, match="no board"):
        check_calibration(rendered["stored"] / "camera.yaml", blank, board=BOARD)
    (tmp_path / "odd.json").write_text(json.dumps({"model": "odd", "image_width": 640, "image_height": 480,
                                                   "camera_matrix": np.eye(3).tolist(),
                                                   "distortion_coefficients": [0.0] * 5}))
    with pytest.raises(ValueError, match="odd"):
        native.read(tmp_path / "odd.json")
    (tmp_path / "junk.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="not a sogdd camera.json or rig.json"):
        native.read(tmp_path / "junk.json")
