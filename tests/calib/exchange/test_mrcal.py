"""mrcal's .cameramodel: round trips, refusals, and mrcal itself projecting through our files (where it
installs)."""

from __future__ import annotations

import ast
import json
import subprocess

import cv2
import numpy as np
import pytest

from sogdd.calib.exchange import StoredCamera, StoredRig, read_calibration, write_calibration_as

DIST = {"pinhole4": [-0.21, 0.043, 0.0011, -0.0007], "pinhole": [-0.21, 0.043, 0.0011, -0.0007, 0.013],
        "rational": [0.31, -0.12, 0.0011, -0.0007, 0.02, 0.62, -0.08, 0.05],
        "fisheye": [0.021, -0.0043, 0.0011, -0.0002], "omnidir": [1.21, -0.1, 0.02, 0.001, -0.0005]}
K = [[612.345678901, 0, 319.871234567], [0, 611.987654321, 241.123456789], [0, 0, 1]]
POSES = [(np.eye(3), np.zeros(3)),
         (cv2.Rodrigues(np.array([0.011, -0.031, 0.0021]))[0], np.array([-120.31, 1.27, 0.73])),
         (cv2.Rodrigues(np.array([-0.021, 0.45, 0.013]))[0], np.array([231.0, -11.7, 40.2]))]
POINTS = np.array([[x, y, 1000.0] for x in (-400.0, -100.0, 0.0, 250.0, 450.0) for y in (-300.0, 0.0, 350.0)])


def rig(model: str, n: int = 3) -> StoredRig:
    return StoredRig(tuple(StoredCamera(name, model, K, DIST[model], (640, 480), *POSES[k])
                           for k, name in enumerate(("left", "right", "top")[:n])))



@pytest.mark.parametrize("model", ["pinhole4", "pinhole", "rational"])
def test_a_rig_round_trips_to_float_precision(tmp_path, model):
    src = rig(model)
    files = write_calibration_as(src, tmp_path / "rig", "mrcal")
    assert [f.name for f in files] == ["camera-0.cameramodel", "camera-1.cameramodel", "camera-2.cameramodel"]
    back = read_calibration(tmp_path / "rig")
    assert back.names == src.names
    for a, b in zip(src.cameras, back.cameras):
        assert b.model == model and np.array_equal(a.K, b.K) and np.array_equal(a.dist, b.dist)
        assert np.abs(a.R - b.R).max() < 1e-14 and np.abs(a.T - b.T).max() == 0
        assert np.abs(a.project(POINTS, in_reference=True) - b.project(POINTS, in_reference=True)).max() < 1e-9


def test_the_file_is_mrcals_layout(tmp_path):
    path = write_calibration_as(rig("rational", 1), tmp_path / "c.cameramodel", "mrcal")[0]
    d = ast.literal_eval(path.read_text())
    assert list(d) == ["lensmodel", "intrinsics", "imagersize", "extrinsics"]
    assert d["lensmodel"] == "LENSMODEL_OPENCV8" and d["imagersize"] == [640, 480]
    assert d["intrinsics"] == [K[0][0], K[1][1], K[0][2], K[1][2], *DIST["rational"]]  # OpenCV's order
    assert d["extrinsics"] == [0.0] * 6


@pytest.mark.parametrize(("model", "why"), [("fisheye", "no OpenCV equidistant fisheye model"),
                                             ("omnidir", "no unified omnidirectional")])
def test_what_mrcal_cannot_hold_is_refused_and_nothing_written(tmp_path, model, why):
    with pytest.raises(ValueError, match=why):
        write_calibration_as(rig(model, 2), tmp_path / "rig", "mrcal")
    assert not (tmp_path / "rig").exists()


def test_mrcal_models_sogdd_lacks_are_refused_and_the_pinhole_read(tmp_path):
    splined = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100"
    (tmp_path / "s.cameramodel").write_text(f"{{'lensmodel': '{splined}', 'intrinsics': [1, 2, 3, 4], "
                                            "'imagersize': [4, 4]}")
    with pytest.raises(ValueError, match="has no sogdd model"):
        read_calibration(tmp_path / "s.cameramodel")
    (tmp_path / "p.cameramodel").write_text("# a comment\n{'lensmodel': 'LENSMODEL_PINHOLE', # and another\n"
                                            " 'intrinsics': [500, 501, 320, 240], 'imagersize': [640, 480],\n"
                                            " 'extrinsics': [0, 0, 0, 0, 0, 0]}\n")
    cam = read_calibration(tmp_path / "p.cameramodel").cameras[0]
    assert (cam.name, cam.model, cam.dist.tolist(), cam.K[1, 1]) == ("p", "pinhole4", [0, 0, 0, 0], 501.0)


@pytest.mark.parametrize("model", ["pinhole4", "pinhole", "rational"])
def test_mrcal_projects_through_our_cameramodel_as_we_do(tmp_path, mrcal_python, model):
    src = rig(model)
    write_calibration_as(src, tmp_path / "rig", "mrcal")
    script = (
        "import json, sys, numpy as np, mrcal\n"
        "pts = np.array(json.loads(sys.argv[1]))\n"
        "out = []\n"
        "for f in sys.argv[2:]:\n"
        "    m = mrcal.cameramodel(f)\n"
        "    p = mrcal.transform_point_rt(m.extrinsics_rt_fromref(), pts)\n"
        "    out.append(mrcal.project(p, *m.intrinsics()).tolist())\n"
        "print(json.dumps(out))\n")
    files = [str(tmp_path / "rig" / f"camera-{k}.cameramodel") for k in range(3)]
    run = subprocess.run([mrcal_python, "-c", script, json.dumps(POINTS.tolist()), *files],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    theirs = np.array(json.loads(run.stdout))
    ours = np.array([c.project(POINTS, in_reference=True) for c in src.cameras])
    assert theirs.shape == ours.shape == (3, len(POINTS), 2)
    assert np.abs(theirs - ours).max() < 1e-6
    assert np.ptp(ours[2, :, 0]) > 100  # the points spread over the image


def test_a_cameramodel_mrcal_writes_reads_back(tmp_path, mrcal_python):
    script = ("import numpy as np, mrcal, sys\n"
              "m = mrcal.cameramodel(intrinsics=('LENSMODEL_OPENCV5', np.array([600.5, 601.25, 320.75, "
              "240.125, -0.2, 0.05, 0.001, -0.002, 0.01])), imagersize=(640, 480), "
              "extrinsics_rt_fromref=np.array([0.01, -0.02, 0.03, -100.0, 2.0, 3.0]))\n"
              "m.write(sys.argv[1])\n")
    run = subprocess.run([mrcal_python, "-c", script, str(tmp_path / "m.cameramodel")], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    cam = read_calibration(tmp_path / "m.cameramodel").cameras[0]
    assert cam.model == "pinhole" and cam.dist.tolist() == [-0.2, 0.05, 0.001, -0.002, 0.01]
    assert cam.K.tolist() == [[600.5, 0, 320.75], [0, 601.25, 240.125], [0, 0, 1]]
    assert np.abs(cam.R - cv2.Rodrigues(np.array([0.01, -0.02, 0.03]))[0]).max() < 1e-15
    assert cam.T.tolist() == [-100.0, 2.0, 3.0]
