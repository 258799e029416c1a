"""sogdd's own files as an exchange format: what sogdd calibrate writes reads in; what --to sogdd writes reads
back through sogdd's own readers."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import MODELS
from sogdd.calib.demo import demo_calibration
from sogdd.calib.exchange import StoredCamera, StoredRig, read_calibration, write_calibration_as
from sogdd.calib.files import read_camera, write_calibration
from sogdd.calib.rig import read_rig, write_rig
from sogdd.calib.rig.demo import demo_rig


@pytest.fixture(scope="module")
def rig():
    return demo_rig()


def test_an_output_folder_of_one_camera_reads_in_exactly(tmp_path):
    cal = demo_calibration()
    write_calibration(cal, tmp_path)
    for source in (tmp_path, tmp_path / "camera.yaml", tmp_path / "camera.json"):
        cam = read_calibration(source).cameras[0]
        assert cam.model == cal.model and cam.image_size == cal.image_size
        assert np.array_equal(cam.K, cal.K) and np.array_equal(cam.dist, np.ravel(cal.dist))


def test_a_rig_folder_reads_in_exactly_from_yaml_and_json(tmp_path, rig):
    write_rig(rig, tmp_path)
    for source in (tmp_path, tmp_path / "rig.yaml", tmp_path / "rig.json"):
        back = read_calibration(source)
        assert back.names == rig.names
        for a, b in zip(rig.cameras, back.cameras):
            assert np.array_equal(b.K, a.K) and np.array_equal(b.dist, np.ravel(a.dist))
            assert np.array_equal(b.R, a.R) and np.array_equal(b.T, np.ravel(a.T))


def test_what_to_sogdd_writes_reads_back_through_sogdds_readers(tmp_path, rig):
    one = write_calibration_as(demo_calibration(), tmp_path / "one", "sogdd")
    assert [p.name for p in one] == ["camera.yaml"]
    cam = read_camera(one[0])
    assert np.array_equal(cam["camera_matrix"], demo_calibration().K) and cam["model"] == "pinhole"
    two = write_calibration_as(rig, tmp_path / "two", "sogdd")
    assert [p.name for p in two] == ["rig.yaml"]
    back = read_rig(two[0])
    assert list(back["cameras"]) == list(rig.names)
    assert np.array_equal(back["cameras"]["right"]["T"], np.ravel(rig.camera("right").T))
    assert cv2.FileStorage(str(two[0]), cv2.FILE_STORAGE_READ).getNode("R_right").mat().shape == (3, 3)


@pytest.mark.parametrize("model", ["pinhole4", "pinhole", "rational", "fisheye", "omnidir"])
def test_every_model_round_trips_bit_for_bit(tmp_path, model):
    dist = np.linspace(-0.2, 0.3, len(MODELS[model])) + 1e-3 / 7
    K = [[612.345678901, 0, 319.871234567], [0, 611.987654321, 241.123456789], [0, 0, 1]]
    R = cv2.Rodrigues(np.array([0.011, -0.031, 0.0021]))[0]
    src = StoredRig((StoredCamera("a", model, K, dist, (640, 480)),
                     StoredCamera("b", model, K, dist[::-1], (640, 480), R, [-120.31, 1.27, 0.73])))
    for rig in (StoredRig(src.cameras[:1]), src):
        write_calibration_as(rig, tmp_path / model, "sogdd")
        back = read_calibration(tmp_path / model)
        assert len(back.cameras) == len(rig.cameras)
        for a, b in zip(rig.cameras, back.cameras):
            assert b.model == model and np.array_equal(a.K, b.K) and np.array_equal(a.dist, b.dist)
            assert np.array_equal(a.R, b.R) and np.array_equal(a.T, b.T)


def test_a_json_that_is_no_calibration_is_refused(tmp_path):
    (tmp_path / "x.json").write_text(json.dumps({"cameras": [{"name": "a"}]}))
    with pytest.raises(ValueError, match="camera 'a' lacks"):
        read_calibration(tmp_path / "x.json", "sogdd")


def test_a_calibrate_output_folder_is_not_overwritten_by_a_conversion(tmp_path):
    write_calibration(demo_calibration(), tmp_path)
    before = (tmp_path / "camera.yaml").read_bytes()
    cam = StoredCamera("c", "pinhole4", [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]], [0.0] * 4, (640, 480))
    with pytest.raises(ValueError, match="part of a sogdd calibrate output folder"):
        write_calibration_as(cam, tmp_path, "sogdd")
    assert (tmp_path / "camera.yaml").read_bytes() == before


def test_the_files_standard_deviations_are_read_where_they_are(tmp_path, rig):
    """camera.yaml's std_intrinsics, camera.json's std, rig.json's per camera (with the pose's), and a rig.yaml
    alone its cameras' from NAME/camera.yaml; a converted file (--to sogdd) holds none: unknown, NaN."""
    cal = demo_calibration()
    write_calibration(cal, tmp_path / "one")
    for name in ("camera.yaml", "camera.json"):
        back = read_calibration(tmp_path / "one" / name, "sogdd")
        cam = back.cameras[0]
        assert back.square == cal.square and cam.rms == pytest.approx(cal.rms)
        assert [cam.std[n] for n in ("fx", "fy", "cx", "cy")] == pytest.approx([cal.std[n] for n in
                                                                              ("fx", "fy", "cx", "cy")])
    write_rig(rig, tmp_path / "rig")
    both = [read_calibration(tmp_path / "rig" / n, "sogdd") for n in ("rig.json", "rig.yaml")]
    for got in both:
        right = got.camera("right")
        assert right.std["fx"] == pytest.approx(rig.camera("right").std["fx"])
        assert right.pose_std["baseline"] == pytest.approx(rig.camera("right").std["baseline"])
        assert right.rms == pytest.approx(rig.camera("right").calibration.rms)
    (tmp_path / "rig" / "rig.json").unlink()
    alone = read_calibration(tmp_path / "rig" / "rig.yaml", "sogdd").camera("right")
    assert alone.std["fx"] == pytest.approx(rig.camera("right").std["fx"], rel=1e-6)
    assert np.isnan(alone.pose_std["baseline"])
    write_calibration_as(both[0], tmp_path / "converted", "sogdd")
    bare = read_calibration(tmp_path / "converted", "sogdd")
    assert all(np.isnan(c.std["fx"]) and np.isnan(c.rms) for c in bare.cameras) and bare.square is None
    with pytest.raises(ValueError, match="no such file"):
        read_calibration(tmp_path / "nothere.yaml", "sogdd")
