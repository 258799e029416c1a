"""Kalibr's camchain: round trips of what it holds, refusals, the pose chain, the schema, a file as Kalibr
writes it."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from sogdd.calib.exchange import StoredCamera, StoredRig, read_calibration, write_calibration_as

yaml = pytest.importorskip("yaml")
FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "exchange"
DIST = {"pinhole4": [-0.21, 0.043, 0.0011, -0.0007], "pinhole": [-0.21, 0.043, 0.0011, -0.0007, 0.013],
        "rational": [0.31, -0.12, 0.0011, -0.0007, 0.02, 0.62, -0.08, 0.05],
        "fisheye": [0.021, -0.0043, 0.0011, -0.0002], "omnidir": [1.21, -0.1, 0.02, 0.001, -0.0005]}
K = [[612.345678901, 0, 319.871234567], [0, 611.987654321, 241.123456789], [0, 0, 1]]
POSES = [(np.eye(3), np.zeros(3)),
         (cv2.Rodrigues(np.array([0.011, -0.031, 0.0021]))[0], np.array([-0.12031, 0.00127, 0.00073])),
         (cv2.Rodrigues(np.array([-0.021, 0.45, 0.013]))[0], np.array([0.231, -0.0117, 0.0402]))]
POINTS = np.array([[x, y, 2.0] for x in (-0.8, -0.2, 0.0, 0.5, 0.9) for y in (-0.6, 0.0, 0.7)])


def rig(model: str, n: int = 3, dist=None) -> StoredRig:
    d = DIST[model] if dist is None else dist
    return StoredRig(tuple(StoredCamera(f"cam{k}x", model, K, d, (640, 480), *POSES[k]) for k in range(n)))


@pytest.mark.parametrize("model", ["pinhole4", "fisheye", "omnidir"])
def test_a_rig_round_trips_to_float_precision(tmp_path, model):
    src = rig(model)
    write_calibration_as(src, tmp_path / "camchain.yaml", "kalibr")
    back = read_calibration(tmp_path / "camchain.yaml")
    assert back.names == src.names  # through rostopic /NAME/image_raw
    for a, b in zip(src.cameras, back.cameras):
        assert b.model == model and np.array_equal(a.K, b.K) and np.array_equal(a.dist, b.dist)
        assert np.abs(a.R - b.R).max() < 1e-15 and np.abs(a.T - b.T).max() < 1e-15
        assert np.abs(a.project(POINTS, in_reference=True) - b.project(POINTS, in_reference=True)).max() < 1e-9


def test_a_pinhole_camera_without_k3_goes_as_radtan_and_comes_back_as_pinhole4(tmp_path):
    src = rig("pinhole", 1, dist=[-0.21, 0.043, 0.0011, -0.0007, 0.0])
    back = read_calibration(write_calibration_as(src, tmp_path / "c.yaml", "kalibr")[0]).cameras[0]
    assert back.model == "pinhole4" and back.dist.tolist() == [-0.21, 0.043, 0.0011, -0.0007]
    assert np.abs(back.project(POINTS) - src.cameras[0].project(POINTS)).max() < 1e-9


def test_the_written_file_has_kalibrs_fields_and_pose_chain(tmp_path):
    path = write_calibration_as(rig("omnidir"), tmp_path / "c.yaml", "kalibr")[0]
    d = yaml.safe_load(path.read_text())
    assert list(d) == ["cam0", "cam1", "cam2"] and "T_cn_cnm1" not in d["cam0"]
    assert list(d["cam1"]) == ["T_cn_cnm1", "cam_overlaps", "camera_model", "distortion_coeffs",
                               "distortion_model", "intrinsics", "resolution", "rostopic"]
    c = d["cam0"]
    assert (c["camera_model"], c["distortion_model"], c["resolution"]) == ("omni", "radtan", [640, 480])
    assert c["intrinsics"] == [1.21, K[0][0], K[1][1], K[0][2], K[1][2]]  # xi first, then fu, fv, pu, pv
    assert c["distortion_coeffs"] == [-0.1, 0.02, 0.001, -0.0005]
    for k in (1, 2):
        T = np.array(d[f"cam{k}"]["T_cn_cnm1"])
        (Rp, tp), (Rn, tn) = POSES[k - 1], POSES[k]
        assert T.shape == (4, 4) and T[3].tolist() == [0, 0, 0, 1]
        x = np.array([0.3, -0.2, 1.7])  # a point in cam k-1's frame lands in cam k's
        x_ref = Rp.T @ (x - tp)
        assert np.abs(T[:3, :3] @ x + T[:3, 3] - (Rn @ x_ref + tn)).max() < 1e-14


def test_a_camchain_as_kalibr_writes_it():
    back = read_calibration(FIXTURES / "camchain.yaml")
    assert back.names == ("cam0", "cam1", "cam2")
    assert [c.model for c in back.cameras] == ["pinhole4", "fisheye", "omnidir"]
    c0, c1, c2 = back.cameras
    assert c0.K.tolist() == [[458.654, 0, 367.215], [0, 457.296, 248.375], [0, 0, 1]]
    assert c0.dist[3] == 1.76187114e-05  # a bare exponent, which YAML 1.1 reads as a string
    assert c2.dist.tolist() == [1.1127, -0.0512, 0.0174, 0.0004, -0.0002] and c2.K[0, 0] == 1121.4
    Ra = cv2.Rodrigues(np.array([0.0021, -0.0117, 0.0013]))[0]
    Rb = cv2.Rodrigues(np.array([-0.0035, 0.0094, -0.0008]))[0]
    ta, tb = np.array([-0.110074, 0.000399, -0.000853]), np.array([-0.109521, -0.000212, 0.000371])
    assert np.abs(c1.R - Ra).max() < 1e-15 and np.abs(c1.T - ta).max() < 1e-15
    assert np.abs(c2.R - Rb @ Ra).max() < 1e-15 and np.abs(c2.T - (Rb @ ta + tb)).max() < 1e-15


@pytest.mark.parametrize(("model", "dist", "why"), [
    ("pinhole", None, "radtan has no k3"),
    ("rational", None, "Kalibr has no rational model"),
])
def test_what_kalibr_cannot_hold_is_refused_and_nothing_written(tmp_path, model, dist, why):
    with pytest.raises(ValueError, match=why):
        write_calibration_as(rig(model, 2, dist), tmp_path / "c.yaml", "kalibr")
    assert not (tmp_path / "c.yaml").exists()


def test_a_skew_is_refused(tmp_path):
    K_skew = [[600.0, 0.5, 320], [0, 600, 240], [0, 0, 1]]
    cam = StoredCamera("c", "pinhole4", K_skew, DIST["pinhole4"], (640, 480))
    with pytest.raises(ValueError, match="skew"):
        write_calibration_as(cam, tmp_path / "c.yaml", "kalibr")


def test_a_kalibr_model_sogdd_lacks_is_refused_on_reading(tmp_path):
    text = (FIXTURES / "camchain.yaml").read_text().replace("equidistant", "fov", 1)
    (tmp_path / "c.yaml").write_text(text)
    with pytest.raises(ValueError, match="cam1: camera_model pinhole with distortion_model fov"):
        read_calibration(tmp_path / "c.yaml")
