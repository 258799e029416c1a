"""Views of one camera with different EXIF orientations (a phone turned between shots): calibrated on the
sensor's pixel grid, and said so; views that agree: calibrated as the images are shown."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from sogdd.calib import calibrate_images
from sogdd.cli.main import main

K_TRUE = np.array([[560.0, 0.0, 330.0], [0.0, 558.0, 228.0], [0.0, 0.0, 1.0]])


@pytest.fixture(scope="module")
def sensor_frames(render):
    """Eight 640 x 480 frames of a 9 x 6 board as the sensor saw them."""
    cam = render.Camera(K_TRUE, (-0.2, 0.06, 0.001, -0.0005, 0.0), (640, 480))
    board = render.Board(9, 6, 1.0)
    return [render.render_view(cam, board, rv, tv, supersample=2, blur=0.8, noise=2.0, rng=k).image
            for k, (rv, tv) in enumerate(render.random_poses(cam, board, 8, seed=5))]


def _write(folder, frames, orientations):
    """The sensor's pixels stored as they are, each file tagged with its EXIF orientation (how to show it)."""
    folder.mkdir()
    for k, (img, turn) in enumerate(zip(frames, orientations)):
        exif = Image.Exif()
        exif[0x0112] = turn
        Image.fromarray(img).save(folder / f"f{k}.png", exif=exif.tobytes())
    return folder


def test_a_phone_turned_between_shots_is_calibrated_on_its_sensor(sensor_frames, tmp_path, capsys):
    folder = _write(tmp_path / "turned", sensor_frames, [1, 3, 6, 1, 6, 3, 1, 6])
    cal = calibrate_images(folder, "chessboard:9x6", model="pinhole").calibration
    assert cal.n_used == 8 and cal.image_size == (640, 480) and cal.pixel_grid == "sensor"
    np.testing.assert_allclose(cal.K, K_TRUE, atol=3.0)  # the sensor's camera, not a blend of frames
    assert any("sensor's pixel grid" in n and "(1, 3, 6)" in n for n in cal.notes)
    # the command says so in its summary, camera.json and the report
    out = tmp_path / "out"
    rc = main(["calibrate", str(folder), "--board", "chessboard:9x6", "--model", "pinhole", "--out", str(out),
               "--quiet"])
    assert rc in (0, 3)  # 3: a bad verdict (eight views cover little of the frame), the outputs written
    said = capsys.readouterr().out
    assert "note: calibrated on the sensor's pixel grid" in said and "(1, 3, 6)" in said
    stored = json.loads((out / "camera.json").read_text())
    assert stored["pixel_grid"] == "sensor" and stored["image_width"] == 640
    assert any("(1, 3, 6)" in n for n in stored["notes"])
    assert "sensor&#x27;s pixel grid" in (out / "report.html").read_text()


def test_a_half_turn_alone_does_not_mix_frames_silently(sensor_frames, tmp_path):
    """Orientations 1 and 3 give images of one size: without the sensor's grid the frames mix unseen."""
    folder = _write(tmp_path / "half", sensor_frames, [1, 3] * 4)
    cal = calibrate_images(folder, "chessboard:9x6", model="pinhole").calibration
    np.testing.assert_allclose(cal.K, K_TRUE, atol=3.0)
    assert cal.n_used == 8 and cal.pixel_grid == "sensor"


def test_one_orientation_for_all_is_applied_as_before(sensor_frames, tmp_path):
    folder = _write(tmp_path / "upright", sensor_frames, [6] * 8)  # every shot turned: shown turned
    cal = calibrate_images(folder, "chessboard:9x6", model="pinhole").calibration
    assert cal.image_size == (480, 640) and cal.pixel_grid == "image"
    assert not any("sensor" in n for n in cal.notes)
    # orientation 6 shows the sensor turned a quarter clockwise: (x, y) -> (h - 1 - y, x)
    fx, fy, cx, cy = K_TRUE[0, 0], K_TRUE[1, 1], K_TRUE[0, 2], K_TRUE[1, 2]
    np.testing.assert_allclose([cal.K[0, 0], cal.K[1, 1], cal.K[0, 2], cal.K[1, 2]], [fy, fx, 479 - cy, cx],
                               atol=3.0)
    ignored = calibrate_images(folder, "chessboard:9x6", model="pinhole",
                               read_options={"ignore_orientation": True}).calibration
    assert ignored.image_size == (640, 480) and ignored.pixel_grid == "image"


def test_a_rig_camera_turned_between_shots_is_calibrated_on_its_sensor(render, tmp_path):
    import cv2

    from sogdd.calib.rig.session import calibrate_rig_images

    left = render.Camera(K_TRUE, (-0.2, 0.06, 0.001, -0.0005, 0.0), (640, 480))
    right = render.Camera(np.array([[590.0, 0, 318.0], [0, 589.0, 243.0], [0, 0, 1]]), (-0.22, 0.06, 0, 0, 0),
                          (640, 480))
    R, T = cv2.Rodrigues(np.array([0.0, np.deg2rad(-3.0), 0.0]))[0], np.array([-1.0, 0.05, 0.1])
    board = render.Board(9, 6, 1.0)
    frames = {"left": [], "right": []}
    for rv, tv in render.random_poses(left, board, 40, seed=7):
        rv_r, tv_r = cv2.Rodrigues(R @ cv2.Rodrigues(rv)[0])[0].ravel(), R @ tv + T
        edge = right.project(board.outline(), rv_r, tv_r)
        if len(frames["left"]) < 8 and np.all(np.isfinite(edge) & (edge >= 4) & (edge <= [635, 475])):
            for name, cam, r, t in (("left", left, rv, tv), ("right", right, rv_r, tv_r)):
                frames[name].append(render.render_view(cam, board, r, t, supersample=2, blur=0.8, noise=2.0,
                                                         rng=7).image)
    assert len(frames["left"]) == 8
    for name, turns in (("left", [1, 3, 6, 1, 6, 3, 1, 6]), ("right", [1] * 8)):
        folder = _write(tmp_path / name, frames[name], turns)
        for k in range(8):
            (folder / f"f{k}.png").rename(folder / f"{name}{k + 1:02d}.png")
    rig = calibrate_rig_images({"left": tmp_path / "left", "right": tmp_path / "right"}, "chessboard:9x6",
                               model="pinhole", thumbnails=False).rig
    cams = {c.name: c.calibration for c in rig.cameras}
    np.testing.assert_allclose(cams["left"].K, K_TRUE, atol=3.0)
    assert cams["left"].pixel_grid == "sensor" and cams["right"].pixel_grid == "image"
    assert any(n.startswith("camera left: calibrated on the sensor's pixel grid") for n in rig.notes)
