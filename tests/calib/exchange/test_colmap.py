"""COLMAP through pycolmap: round trips, pycolmap projecting our cameras, the rig's poses, refusals."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.exchange import StoredCamera, StoredRig, read_calibration, write_calibration_as

pycolmap = pytest.importorskip("pycolmap")
if not hasattr(pycolmap, "Rig"):
    pytest.skip("pycolmap without rigs (COLMAP < 3.12)", allow_module_level=True)

DIST = {"pinhole4": [-0.21, 0.043, 0.0011, -0.0007], "pinhole": [-0.21, 0.043, 0.0011, -0.0007, 0.013],
        "rational": [0.31, -0.12, 0.0011, -0.0007, 0.02, 0.62, -0.08, 0.05],
        "fisheye": [0.021, -0.0043, 0.0011, -0.0002], "omnidir": [1.21, -0.1, 0.02, 0.001, -0.0005]}
K = [[612.345678901, 0, 319.871234567], [0, 611.987654321, 241.123456789], [0, 0, 1]]
POSES = [(np.eye(3), np.zeros(3)),
         (cv2.Rodrigues(np.array([0.011, -0.031, 0.0021]))[0], np.array([-120.31, 1.27, 0.73])),
         (cv2.Rodrigues(np.array([-0.021, 0.45, 0.013]))[0], np.array([231.0, -11.7, 40.2]))]
POINTS = np.array([[x, y, 1.0] for x in (-0.5, -0.1, 0.0, 0.25, 0.6) for y in (-0.4, 0.0, 0.45)])
COLMAP = {"pinhole4": "OPENCV", "pinhole": "FULL_OPENCV", "rational": "FULL_OPENCV",
          "fisheye": "OPENCV_FISHEYE"}


def rig(model: str, n: int = 3) -> StoredRig:
    return StoredRig(tuple(StoredCamera(f"c{k}", model, K, DIST[model], (640, 480), *POSES[k])
                           for k in range(n)))


@pytest.mark.parametrize("model", list(COLMAP))
def test_a_rig_round_trips_to_float_precision(tmp_path, model):
    src = rig(model)
    write_calibration_as(src, tmp_path / "model", "colmap")
    back = read_calibration(tmp_path / "model")
    assert back.names == ("camera1", "camera2", "camera3")  # COLMAP's cameras have ids, not names
    for a, b in zip(src.cameras, back.cameras):
        assert b.model == model and np.array_equal(a.dist, b.dist)
        assert np.abs(a.K - b.K).max() < 1e-12  # the principal point through + 0.5 and - 0.5
        assert np.abs(a.R - b.R).max() < 1e-15 and np.abs(a.T - b.T).max() < 1e-12


@pytest.mark.parametrize("model", list(COLMAP))
def test_pycolmap_reads_our_cameras_and_projects_as_we_do(tmp_path, model):
    src = rig(model, 1).cameras[0]
    write_calibration_as(src, tmp_path / "model", "colmap")
    rec = pycolmap.Reconstruction(str(tmp_path / "model"))
    cam = rec.cameras[1]
    assert cam.model.name == COLMAP[model] and (cam.width, cam.height) == (640, 480)
    theirs = np.asarray(cam.img_from_cam(POINTS), dtype=np.float64) - 0.5  # COLMAP's pixel centres at +0.5
    ours = src.project(POINTS)
    assert np.abs(theirs - ours).max() < 1e-9
    assert np.ptp(ours[:, 0]) > 300


def test_the_rig_goes_into_rigs_txt_as_sensor_from_rig(tmp_path):
    files = write_calibration_as(rig("pinhole4"), tmp_path / "model", "colmap")
    assert {"cameras.txt", "rigs.txt"} <= {f.name for f in files}
    rec = pycolmap.Reconstruction(str(tmp_path / "model"))
    (prig,) = rec.rigs.values()
    assert prig.ref_sensor_id.id == 1
    for k in (2, 3):
        pose = prig.sensor_from_rig(pycolmap.sensor_t(type=pycolmap.SensorType.CAMERA, id=k))
        x = np.array([0.3, -0.2, 1.7])  # a point in the reference camera's frame
        R, T = POSES[k - 1]
        assert np.abs(pose * x - (R @ x + T)).max() < 1e-12


def test_what_colmap_cannot_hold_is_refused_and_nothing_written(tmp_path):
    with pytest.raises(ValueError, match="COLMAP has no omnidir model"):
        write_calibration_as(rig("omnidir", 2), tmp_path / "model", "colmap")
    skewed = StoredCamera("c", "pinhole4", [[600.0, 0.5, 320], [0, 600, 240], [0, 0, 1]], DIST["pinhole4"],
                          (64, 48))
    with pytest.raises(ValueError, match="skew"):
        write_calibration_as(skewed, tmp_path / "model", "colmap")
    assert not (tmp_path / "model").exists()


def test_colmaps_simple_models_read_as_pinhole4_and_unknown_ones_are_refused(tmp_path):
    (tmp_path / "cameras.txt").write_text("# Camera list\n1 SIMPLE_RADIAL 640 480 500.5 320.5 240.5 -0.125\n")
    cam = read_calibration(tmp_path).cameras[0]
    assert cam.model == "pinhole4" and cam.dist.tolist() == [-0.125, 0, 0, 0]
    assert cam.K.tolist() == [[500.5, 0, 320.0], [0, 500.5, 240.0], [0, 0, 1]]
    (tmp_path / "cameras.txt").write_text("1 FOV 640 480 500 500 320 240 0.9\n")
    with pytest.raises(ValueError, match="COLMAP's FOV has no sogdd model"):
        read_calibration(tmp_path)


def test_cameras_without_a_rig_are_not_given_poses(tmp_path):
    (tmp_path / "cameras.txt").write_text("1 PINHOLE 640 480 500 500 320 240\n"
                                          "2 PINHOLE 640 480 510 510 320 240\n")
    with pytest.raises(ValueError, match="no rig holding them all"):
        read_calibration(tmp_path)


def test_a_reconstruction_is_never_replaced(tmp_path):
    (tmp_path / "images.txt").write_text("# Image list\n1 1 0 0 0 0 0 0 1 a.jpg\n\n")
    with pytest.raises(ValueError, match=r"holds a COLMAP reconstruction \(images.txt\)"):
        write_calibration_as(rig("pinhole4", 1), tmp_path, "colmap")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["images.txt"]
