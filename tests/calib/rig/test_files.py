"""A rig's files: rig.yaml read back by cv2.FileStorage with every node, rig.json's keys, each camera's own
files, and camera names refused at the door. The rigs are built by hand (no fit): the files are the test."""

from __future__ import annotations

import csv
import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from sogdd.calib.demo import demo_calibration
from sogdd.calib.detection import ViewRecord
from sogdd.calib.rig.files import check_camera_names, read_rig, write_rig, write_rig_json, write_rig_yaml
from sogdd.calib.rig.result import RigCalibration, RigCamera


def _rig(names=("left", "right"), model_selection=None) -> RigCalibration:
    """A rig of ``names`` by hand: each camera the demo calibration, posed 4 squares apart along x, turned."""
    cal = demo_calibration()
    cams = []
    for k, n in enumerate(names):
        R = cv2.Rodrigues(np.array([0.01 * k, np.deg2rad(-5.0 * k), 0.0]))[0]
        T = np.array([-4.0 * k, 0.05 * k, 0.1 * k])
        std = {"fx": 0.1 + k, "fy": 0.2, "cx": 0.3, "cy": 0.4, **{c: 0.001 for c in cal.coefficients()},
               "T": [0.0, 0.0, 0.0] if k == 0 else [0.01, 0.02, float("nan")],
               "baseline": 0.0 if k == 0 else 0.011, "rotation_deg": 0.0 if k == 0 else 0.02}
        K = cal.K.copy()
        K[0, 0] += 10 * k  # each camera its own matrix, so that a mix-up shows
        cams.append(RigCamera(n, replace(cal, K=K), R, T, std))
    return RigCalibration(tuple(cams), tuple(f"{v + 1}" for v in range(len(cal.names))), cal.rvecs, cal.tvecs,
                          np.asarray(cal.view_used), 0.031, 0.03, np.zeros((0, 0)), {}, square=25.0,
                          notes=("a note",), model_selection=model_selection)


def test_rig_yaml_reads_back_through_opencv_with_every_node(tmp_path):
    rig = _rig()
    path = write_rig_yaml(rig, tmp_path / "rig.yaml")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    node = fs.getNode("cameras")
    assert node.isSeq() and [node.at(i).string() for i in range(node.size())] == ["left", "right"]
    for cam in rig.cameras:
        n = cam.name
        assert fs.getNode(f"model_{n}").string() == "pinhole"
        np.testing.assert_allclose(fs.getNode(f"camera_matrix_{n}").mat(), cam.K)
        D = fs.getNode(f"distortion_coefficients_{n}").mat()
        assert D.shape == (1, 5)
        np.testing.assert_allclose(D.ravel(), cam.dist)
        size = fs.getNode(f"image_size_{n}")
        assert [int(size.at(i).real()) for i in range(size.size())] == [640, 480]
        assert fs.getNode(f"R_{n}").mat().shape == (3, 3) and fs.getNode(f"T_{n}").mat().shape == (3, 1)
        np.testing.assert_allclose(fs.getNode(f"R_{n}").mat(), cam.R)
        np.testing.assert_allclose(fs.getNode(f"T_{n}").mat().ravel(), cam.T)
    np.testing.assert_array_equal(fs.getNode("R_left").mat(), np.eye(3))
    np.testing.assert_array_equal(fs.getNode("T_left").mat(), np.zeros((3, 1)))
    # two cameras: stereoCalibrate's and stereoRectify's nodes, by their names and shapes
    shapes = {k: fs.getNode(k).mat().shape for k in ("R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q")}
    assert shapes == {"R": (3, 3), "T": (3, 1), "E": (3, 3), "F": (3, 3), "R1": (3, 3), "R2": (3, 3),
                      "P1": (3, 4), "P2": (3, 4), "Q": (4, 4)}
    right = rig.camera("right")
    np.testing.assert_allclose(fs.getNode("R").mat(), right.R, atol=1e-12)  # the reference is the identity
    np.testing.assert_allclose(fs.getNode("T").mat().ravel(), right.T, atol=1e-12)
    assert fs.getNode("square").real() == 25.0 and fs.getNode("rms").real() == pytest.approx(0.031)
    fs.release()
    back = read_rig(path)
    assert list(back["cameras"]) == ["left", "right"] and set(back["stereo"]) >= {"E", "F", "Q"}
    np.testing.assert_allclose(back["cameras"]["right"]["camera_matrix"], right.K)
    assert back["cameras"]["right"]["T"].shape == (3,) and back["cameras"]["left"]["image_size"] == (640, 480)


def test_three_cameras_have_no_pair_nodes(tmp_path):
    rig = _rig(("a", "b-2", "c_3"))
    fs = cv2.FileStorage(str(write_rig_yaml(rig, tmp_path / "rig.yaml")), cv2.FILE_STORAGE_READ)
    assert all(fs.getNode(k).empty() for k in ("R", "T", "E", "F", "R1", "P2", "Q"))
    assert fs.getNode("T_c_3").mat().shape == (3, 1) and fs.getNode("camera_matrix_b-2").mat()[0, 0] == \
        pytest.approx(rig.camera("b-2").K[0, 0])
    fs.release()
    assert "stereo" not in read_rig(tmp_path / "rig.yaml")


def test_rig_json_holds_the_cameras_with_their_standard_deviations(tmp_path):
    rig = _rig()
    d = json.loads(write_rig_json(rig, tmp_path / "rig.json").read_text())
    assert {"cameras", "rms", "sigma", "frames", "square", "notes", "stereo"} <= set(d)
    assert "model_selection" not in d
    left, right = d["cameras"]
    keys = {"name", "model", "camera_matrix", "distortion_coefficients", "image_size", "R", "T", "std"}
    assert keys <= set(right)
    assert right["name"] == "right" and right["image_size"] == [640, 480]
    assert np.allclose(right["T"], rig.camera("right").T) and np.array(right["R"]).shape == (3, 3)
    assert {"fx", "fy", "cx", "cy", "baseline", "T", "rotation_deg", "k1", "k3"} <= set(right["std"])
    assert right["std"]["T"][2] is None  # NaN is null, never an invalid JSON NaN
    assert left["std"]["baseline"] == 0.0 and right["std"]["fx"] == pytest.approx(1.1)
    assert [f["name"] for f in d["frames"]] == list(rig.frames) and d["frames"][8]["used"] is False
    assert d["square"] == 25.0 and d["notes"] == ["a note"]
    assert set(d["stereo"]) == {"R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q"}


def test_rig_json_holds_each_cameras_rotation_angle_with_its_std(tmp_path):
    """``rotation_deg`` is the angle of ``R`` (the norm of its rotation vector), its std the fit's."""
    rig = _rig(("left", "right", "third"))
    d = json.loads(write_rig_json(rig, tmp_path / "rig.json").read_text())
    for cam, c in zip(rig.cameras, d["cameras"]):
        angle = np.degrees(np.linalg.norm(cv2.Rodrigues(np.array(c["R"]))[0]))
        assert c["rotation_deg"] == pytest.approx(angle, abs=1e-9) == cam.rotation_deg
        assert c["std"]["rotation_deg"] == cam.std["rotation_deg"]
    turns = [np.degrees(np.linalg.norm([0.01 * k, np.deg2rad(5.0 * k), 0.0])) for k in range(3)]  # as _rig's
    assert [c["rotation_deg"] for c in d["cameras"]] == pytest.approx(turns, abs=1e-9)
    assert [c["std"]["rotation_deg"] for c in d["cameras"]] == [0.0, 0.02, 0.02]


@pytest.mark.parametrize("deg", [0.0, 1e-7, 0.5, 5.0, 90.0, 179.0, 179.9999])
def test_the_rotation_angle_keeps_its_digits_from_zero_to_a_half_turn(deg):
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    cam = replace(_rig().cameras[1], R=cv2.Rodrigues(np.deg2rad(deg) * axis)[0])
    assert cam.rotation_deg == pytest.approx(deg, rel=1e-9, abs=1e-12)
    assert np.isnan(replace(cam, R=np.full((3, 3), np.nan)).rotation_deg)  # a camera without a pose


def test_rig_json_holds_the_figures_the_report_shows(tmp_path):
    rig = _rig()
    d = json.loads(write_rig_json(rig, tmp_path / "rig.json").read_text())
    left, right = d["cameras"]
    assert d["frames_used"] == int(np.sum(rig.frame_used)) == 8 and left["views"] == len(rig.frames) == 9
    assert left["rectified"] is None and set(right["rectified"]) == {"frame", "shared_corners",
                                                                     "vertical_disparity_px"}
    assert right["rectified"]["shared_corners"] > 0 and right["rectified"]["frame"] in rig.frames
    rms = [float(v) if np.isfinite(v) else None for v in rig.camera("right").calibration.view_rms]
    assert [f["rms"]["right"] for f in d["frames"]] == rms and rms[-1] is None  # the frame not seen: null
    # a rig built by hand has no covariance to judge it by: null, rather than an invalid NaN or a guess
    assert right["projection_uncertainty_px"] == {"centre": None, "worst": None} and d["verdict"] is None


def test_rig_json_carries_the_model_selection_when_there_is_one(tmp_path):
    rig = _rig(model_selection={"left": {"chosen": "pinhole4", "score": np.float64(0.12)},
                                "right": {"chosen": "pinhole", "score": float("nan")}})
    d = json.loads(write_rig_json(rig, tmp_path / "rig.json").read_text())
    assert d["model_selection"] == {"left": {"chosen": "pinhole4", "score": 0.12},
                                    "right": {"chosen": "pinhole", "score": None}}


def test_each_camera_gets_its_own_files_named_by_its_images(tmp_path):
    rig = _rig()
    views = {c.name: tuple(ViewRecord(f"{c.name}{v + 1:02d}.png", f"/x/{c.name}{v + 1:02d}.png",
                                      "used" if c.calibration.view_used[v] else "no board", "", v)
                           for v in range(len(rig.frames))) for c in rig.cameras}
    files = write_rig(rig, tmp_path / "out", views=views)
    assert sorted(files) == ["left/camera.json", "left/camera.yaml", "left/corners.csv", "left/views.csv",
                             "rig.json", "rig.yaml", "right/camera.json", "right/camera.yaml",
                             "right/corners.csv", "right/views.csv"]
    rows = list(csv.DictReader(open(tmp_path / "out" / "right" / "views.csv")))
    assert [r["view"] for r in rows] == [f"right{v:02d}.png" for v in range(1, 10)]
    fs = cv2.FileStorage(str(tmp_path / "out" / "right" / "camera.yaml"), cv2.FILE_STORAGE_READ)
    np.testing.assert_allclose(fs.getNode("camera_matrix").mat(), rig.camera("right").K)
    fs.release()


def test_an_input_is_never_written_over(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "rig.yaml").write_bytes(b"my image")
    with pytest.raises(ValueError, match="that is the input"):
        write_rig(_rig(), out, inputs=[out / "rig.yaml"])
    assert (out / "rig.yaml").read_bytes() == b"my image"


@pytest.mark.parametrize("names, why", [
    (("left", "cam 2"), "use letters, digits"),
    (("left", "a/b"), "use letters, digits"),
    (("left", ""), "use letters, digits"),
    (("left", "gauche\u00e9"), "use letters, digits"),
    (("left", "Left"), "each camera needs its own name"),
    (("left", "report"), "the report's folder"),
])
def test_bad_camera_names_are_refused_at_the_door(names, why, tmp_path):
    with pytest.raises(ValueError, match=why) as e:
        check_camera_names(names)
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match=why):
        write_rig_yaml(_rig(names), tmp_path / "rig.yaml")
    assert not (tmp_path / "rig.yaml").exists()
