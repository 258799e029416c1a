"""ROS camera_info: round trips, the stereo pair's rectification, the schema, a file as ROS writes it."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from sogdd.calib.exchange import StoredCamera, StoredRig, read_calibration, write_calibration_as
from sogdd.calib.exchange.ros import read_file
from sogdd.calib.rig.stereo import stereo_pair

yaml = pytest.importorskip("yaml")
FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "exchange"
DIST = {"pinhole4": [-0.21, 0.043, 0.0011, -0.0007], "pinhole": [-0.21, 0.043, 0.0011, -0.0007, 0.013],
        "rational": [0.31, -0.12, 0.0011, -0.0007, 0.02, 0.62, -0.08, 0.05],
        "fisheye": [0.021, -0.0043, 0.0011, -0.0002], "omnidir": [1.21, -0.1, 0.02, 0.001, -0.0005]}
K = [[612.345678901, 0, 319.871234567], [0, 611.987654321, 241.123456789], [0, 0, 1]]
R = cv2.Rodrigues(np.array([0.011, -0.031, 0.0021]))[0]
T = np.array([-120.31, 1.27, 0.73])
POINTS = np.array([[x, y, 1.0] for x in (-0.4, -0.1, 0.0, 0.25, 0.45) for y in (-0.3, 0.0, 0.35)])


def camera(model: str, name: str = "left", pose=None) -> StoredCamera:
    R, T = (np.eye(3), np.zeros(3)) if pose is None else pose
    return StoredCamera(name, model, K, DIST[model], (640, 480), R, T)


@pytest.mark.parametrize("model", ["pinhole4", "pinhole", "rational", "fisheye"])
def test_one_camera_round_trips_bit_for_bit_and_projects_as_ours(tmp_path, model):
    cam = camera(model)
    files = write_calibration_as(cam, tmp_path / "cam.yaml", "ros")
    back = read_calibration(files[0]).cameras[0]
    assert (back.name, back.model, back.image_size) == ("left", model, (640, 480))
    assert np.array_equal(back.K, cam.K) and np.array_equal(back.dist, cam.dist)
    assert np.abs(back.project(POINTS) - cam.project(POINTS)).max() < 1e-9


@pytest.mark.parametrize("model", ["pinhole4", "pinhole", "rational", "fisheye"])
def test_a_pair_round_trips_its_pose_through_the_rectification(tmp_path, model):
    rig = StoredRig((camera(model), camera(model, "right", (R, T))))
    files = write_calibration_as(rig, tmp_path / "pair", "ros")
    assert [f.name for f in files] == ["left.yaml", "right.yaml"]
    back = read_calibration(tmp_path / "pair")
    assert back.names == ("left", "right")
    right = back.camera("right")
    assert np.abs(right.R - R).max() < 1e-14 and np.abs(right.T - T).max() < 1e-12 * np.linalg.norm(T)
    assert np.array_equal(back.cameras[0].R, np.eye(3)) and not back.cameras[0].T.any()
    # the rectification is sogdd's (rig.yaml's): cv2.stereoRectify's R1, R2, P1, P2
    pair = stereo_pair(rig)
    _, R1, P1 = read_file(tmp_path / "pair" / "left.yaml")
    _, R2, P2 = read_file(tmp_path / "pair" / "right.yaml")
    for a, b in ((R1, pair.R1), (R2, pair.R2), (P1, pair.P1), (P2, pair.P2)):
        assert np.array_equal(a, b)
    assert P2[0, 3] < 0 and abs(P2[0, 3] / P2[0, 0] + np.linalg.norm(T)) < 1e-9 * np.linalg.norm(T)


def test_the_written_file_has_ros_fields_in_ros_order_and_types(tmp_path):
    path = write_calibration_as(camera("rational"), tmp_path / "c.yaml", "ros")[0]
    d = yaml.safe_load(path.read_text())
    assert list(d) == ["image_width", "image_height", "camera_name", "camera_matrix", "distortion_model",
                       "distortion_coefficients", "rectification_matrix", "projection_matrix"]
    assert isinstance(d["image_width"], int) and isinstance(d["camera_name"], str)
    assert d["distortion_model"] == "rational_polynomial"
    for key, shape in (("camera_matrix", (3, 3)), ("distortion_coefficients", (1, 8)),
                       ("rectification_matrix", (3, 3)), ("projection_matrix", (3, 4))):
        node = d[key]
        assert list(node) == ["rows", "cols", "data"] and (node["rows"], node["cols"]) == shape
        assert len(node["data"]) == shape[0] * shape[1] and all(isinstance(v, float) for v in node["data"])
    assert d["distortion_coefficients"]["data"] == DIST["rational"]  # OpenCV's order, as ROS's
    assert d["projection_matrix"]["data"] == [*K[0], 0.0, *K[1], 0.0, *K[2], 0.0]
    assert d["distortion_model"] == "rational_polynomial"


def test_models_go_out_under_ros_names(tmp_path):
    names = {}
    for model in ("pinhole4", "pinhole", "fisheye"):
        p = write_calibration_as(camera(model), tmp_path / f"{model}.yaml", "ros")[0]
        d = yaml.safe_load(p.read_text())
        names[model] = (d["distortion_model"], d["distortion_coefficients"]["cols"])
    assert names == {"pinhole4": ("plumb_bob", 4), "pinhole": ("plumb_bob", 5), "fisheye": ("equidistant", 4)}


def test_a_file_as_ros_camera_calibration_writes_it():
    rig = read_calibration(FIXTURES / "ros_ost.yaml")
    cam = rig.cameras[0]
    assert (cam.name, cam.model, cam.image_size) == ("narrow_stereo", "pinhole", (640, 480))
    assert cam.K.tolist() == [[635.8417, 0.0, 315.7282], [0.0, 638.0617, 237.4823], [0.0, 0.0, 1.0]]
    assert cam.dist.tolist() == [0.113556, -0.244127, 0.000648, -0.000791, 0.0]


def test_a_stereo_pair_as_ros_writes_it_gives_the_pose_back():
    """The fixture's R1, R2, P2 are cv2.stereoRectify's of a known pose, printed to 9 decimals."""
    rig = read_calibration(FIXTURES / "ros_stereo")
    assert rig.names == ("narrow_stereo/left", "narrow_stereo/right")
    right = rig.cameras[1]
    R_true = cv2.Rodrigues(np.array([0.0031, -0.0122, 0.0016]))[0]
    assert np.abs(right.R - R_true).max() < 1e-8
    assert np.abs(right.T - [-0.119873, 0.000412, -0.000937]).max() < 1e-9


def test_what_ros_cannot_hold_is_refused_and_nothing_written(tmp_path):
    with pytest.raises(ValueError, match="no omnidir model"):
        write_calibration_as(camera("omnidir"), tmp_path / "o.yaml", "ros")
    three = StoredRig((camera("pinhole"), camera("pinhole", "b", (R, T)), camera("pinhole", "c", (R.T, -T))))
    with pytest.raises(ValueError, match="one camera or a stereo pair; this rig has 3"):
        write_calibration_as(three, tmp_path / "three", "ros")
    with pytest.raises(ValueError, match="give a folder"):
        write_calibration_as(StoredRig(three.cameras[:2]), tmp_path / "pair.yaml", "ros")
    assert list(tmp_path.iterdir()) == []


def test_a_file_of_an_unknown_distortion_is_refused(tmp_path):
    text = (FIXTURES / "ros_ost.yaml").read_text().replace("plumb_bob", "double_sphere")
    (tmp_path / "x.yaml").write_text(text)
    with pytest.raises(ValueError, match="double_sphere with 5 coefficients has no sogdd model"):
        read_calibration(tmp_path / "x.yaml", "ros")
