"""COLMAP interoperability: coordinate conversion, cameras, GT alignment, pycolmap end to end."""

import json

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.sfm import DENSE_NA, align_similarity, camera_errors, read_strecha_cameras
from sogdd.formats.colmap import (
    descriptors_to_colmap,
    find_camera_prior,
    from_colmap_xy,
    keypoints_to_colmap,
    to_colmap_xy,
)


# ------------------------------------------------------------------ conversions
def test_colmap_pixel_centres_are_half_a_pixel_off():
    xy = np.array([[0.0, 0.0], [10.25, 3.5], [639.0, 479.0]])
    np.testing.assert_allclose(to_colmap_xy(xy), xy + 0.5)
    np.testing.assert_allclose(from_colmap_xy(to_colmap_xy(xy)), xy)
    kp = keypoints_to_colmap(xy, size=np.array([8.0, 16.0, 4.0]), angle_deg=np.array([0.0, 90.0, 180.0]))
    assert kp.dtype == np.float32 and kp.shape == (3, 4)
    np.testing.assert_allclose(kp[:, :2], xy + 0.5)
    np.testing.assert_allclose(kp[:, 2], [4.0, 8.0, 2.0])  # scale = size / 2
    np.testing.assert_allclose(kp[:, 3], [0.0, np.pi / 2, np.pi], rtol=1e-6)


def test_descriptor_scale():
    rng = np.random.default_rng(0)
    unit = rng.uniform(0, 1, (5, 128)).astype(np.float32)
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    u8 = descriptors_to_colmap(unit)
    assert u8.dtype == np.uint8
    np.testing.assert_array_equal(u8, np.clip(np.round(unit * 512), 0, 255).astype(np.uint8))
    opencv_scale = np.array([[0.0, 12.0, 254.6, 300.0]], np.float32)  # SIFT's own scale: kept
    np.testing.assert_array_equal(descriptors_to_colmap(opencv_scale), [[0, 12, 255, 255]])


def test_camera_priors(tmp_path):
    (tmp_path / "K.txt").write_text("2759.48 0 1520.69\n0 2764.16 1006.81\n0 0 1\n")
    p = find_camera_prior(tmp_path)
    assert p.model == "PINHOLE" and p.params == (2759.48, 2764.16, 1520.69, 1006.81)
    other = tmp_path / "y"
    other.mkdir()
    (other / "cam.yaml").write_text(
        "pinhole:\n  fx: 477.1\n  fy: 478.4\n  cx: 317.3\n  cy: 241.0\n  width: 640\n  height: 480\n"
        "model: pinhole_radial_tangential\nradial_tangential:\n  radial:\n  - 0.0175\n  - 0.0452\n"
        "  t1: 0.0\n  t2: 0.0\n")
    q = find_camera_prior(other)
    # OpenCV-convention principal point + 0.5 for COLMAP
    assert q.model == "OPENCV" and q.params == pytest.approx((477.1, 478.4, 317.8, 241.5, 0.0175, 0.0452, 0, 0))
    empty = tmp_path / "none"
    empty.mkdir()
    assert find_camera_prior(empty) is None


# ------------------------------------------------------------------ GT alignment
def _random_rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_similarity_recovered():
    rng = np.random.default_rng(2)
    src = rng.normal(size=(10, 3))
    r = _random_rotation(rng)
    dst = 2.5 * src @ r.T + np.array([1.0, -2.0, 3.0])
    s, r_est, t = align_similarity(src, dst)
    assert s == pytest.approx(2.5)
    np.testing.assert_allclose(r_est, r, atol=1e-10)
    np.testing.assert_allclose(t, [1.0, -2.0, 3.0], atol=1e-10)


def _strecha_file(path, r_c2w, c):
    k = "2759.48 0 1520.69\n0 2764.16 1006.81\n0 0 1\n"
    rows = "\n".join(" ".join(f"{v:.12g}" for v in row) for row in r_c2w)
    path.write_text(f"{k}0 0 0\n{rows}\n{' '.join(f'{v:.12g}' for v in c)}\n3072 2048\n")


def test_pose_errors_against_strecha_cameras(tmp_path):
    rng = np.random.default_rng(4)
    gt_r = [_random_rotation(rng) for _ in range(5)]  # world to camera
    gt_c = rng.normal(size=(5, 3)) * 3
    for i in range(5):
        _strecha_file(tmp_path / f"{i:04d}.jpg.camera", gt_r[i].T, gt_c[i])  # files hold camera-to-world
    gt = read_strecha_cameras(tmp_path)
    assert sorted(gt) == [f"{i:04d}.jpg" for i in range(5)]
    np.testing.assert_allclose(gt["0002.jpg"].R, gt_r[2], atol=1e-10)
    # a reconstruction in another frame: x_est = (R_s x_gt + t_s) * s_s
    r_s, t_s, s_s = _random_rotation(rng), np.array([5.0, 0, 1]), 0.3
    est = {}
    for i in range(5):
        c_est = s_s * (r_s @ gt_c[i] + t_s)
        est[f"{i:04d}.jpg"] = (gt_r[i] @ r_s.T, c_est)
    e = camera_errors(est, gt)
    assert e["aligned"] and e["n"] == 5
    assert e["rotation_deg_mean"] < 1e-6 and e["position_mean"] < 1e-9
    # one camera turned by 2 degrees about its optical axis
    a = np.radians(2.0)
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    est["0001.jpg"] = (rz @ est["0001.jpg"][0], est["0001.jpg"][1])
    e2 = camera_errors(est, gt)
    assert e2["per_camera"]["0001.jpg"]["rotation_deg"] == pytest.approx(2.0, abs=1e-6)
    assert e2["per_camera"]["0000.jpg"]["rotation_deg"] < 1e-6
    assert not camera_errors({"0000.jpg": est["0000.jpg"]}, gt)["aligned"]


# ------------------------------------------------------------------ pycolmap
def _write_tiny_images(folder, n=3):
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for i in range(n):
        cv2.imwrite(str(folder / f"im{i}.png"), rng.integers(0, 255, (60, 80), dtype=np.uint8))


def test_database_keypoints_roundtrip(tmp_path):
    pycolmap = pytest.importorskip("pycolmap")
    from sogdd.formats.colmap import import_images, write_features

    _write_tiny_images(tmp_path / "img")
    db_path = tmp_path / "db.db"
    ids = import_images(db_path, tmp_path / "img")
    assert sorted(ids) == ["im0.png", "im1.png", "im2.png"]
    xy = np.array([[0.0, 0.0], [12.25, 40.5]])
    desc = np.full((2, 128), 1 / np.sqrt(128), np.float32)
    with pycolmap.Database.open(str(db_path)) as db:
        write_features(db, ids["im1.png"], xy, np.array([8.0, 8.0]), None, desc)
        assert db.num_cameras() == 1  # one shared camera
        kp = db.read_keypoints(ids["im1.png"])
        d = db.read_descriptors(ids["im1.png"])
    np.testing.assert_allclose(kp[:, :2], xy + 0.5)
    data = np.asarray(d.data if hasattr(d, "data") else d)
    assert data.shape == (2, 128) and int(data.max()) == round(512 / np.sqrt(128))


def test_cli_colmap_export(tmp_path, capsys):
    pycolmap = pytest.importorskip("pycolmap")
    _write_tiny_images(tmp_path / "img", 2)
    feat = tmp_path / "feat"
    feat.mkdir()
    xy = np.array([[10.0, 20.0], [30.0, 40.0], [50.0, 15.0]])
    np.savez(feat / "im0.png.npz", xy=xy, response=np.ones(3), size=np.full(3, 17.0), level=np.zeros(3, int))
    np.savez(feat / "im1.png.npz", xy=xy[:2], response=np.ones(2), size=np.full(2, 17.0),
             descriptors=np.ones((2, 128), np.float32) * 10)
    db = tmp_path / "out.db"
    assert main(["colmap", "export", str(feat), "--database", str(db)]) == 2  # images unknown
    assert main(["colmap", "export", str(feat), "--database", str(db), "--images", str(tmp_path / "img"),
                 "--quiet"]) == 0
    with pycolmap.Database.open(str(db)) as d:
        ims = {im.name: im.image_id for im in d.read_all_images()}
        np.testing.assert_allclose(d.read_keypoints(ims["im0.png"])[:, :2], xy + 0.5)
        assert d.num_keypoints_for_image(ims["im1.png"]) == 2
        assert d.num_descriptors_for_image(ims["im0.png"]) == 3  # computed with sogdd.describe


def _chair(data_dir):
    d = data_dir / "multiview" / "chair"
    if not d.is_dir():
        pytest.skip("chair image set not available")
    return d


def test_chair_sfm_end_to_end(data_dir, tmp_path):
    """pycolmap on 8 consecutive chair images with sogdd features: a model with most images registered."""
    pytest.importorskip("pycolmap")
    from sogdd.evaluation.sfm import run_sfm
    from sogdd.evaluation.specs import parse_spec

    chair = _chair(data_dir)
    names = [f"image{i:03d}.jpg" for i in range(8)]
    r = run_sfm(chair, parse_spec("sogdd"), tmp_path / "work", matcher="mnn", image_names=names)
    assert r["images"] == 8
    assert r["camera_prior"]["model"] == "OPENCV"
    assert r["registered"] >= 6
    assert r["points"] >= 100
    assert r["track_length"] >= 2.0
    assert 0 < r["reproj_error"] < 2.0
    assert r["features"] > 50 and r["seconds"] > 0
    import pycolmap

    if not pycolmap.has_cuda:
        assert r["dense_points"] == DENSE_NA


def test_cli_sfm_json(data_dir, tmp_path, capsys):
    pytest.importorskip("pycolmap")
    chair = _chair(data_dir)
    # a 4-image subset in its own folder keeps this quick
    sub = tmp_path / "imgs"
    sub.mkdir()
    for i in range(4):
        (sub / f"image{i:03d}.jpg").write_bytes((chair / f"image{i:03d}.jpg").read_bytes())
    for y in chair.glob("*.yaml"):
        (sub / y.name).write_bytes(y.read_bytes())
    rc = main(["eval", "sfm", "--images", str(sub), "--detectors", "sogdd", "--matcher", "mnn",
               "--out", str(tmp_path / "out"), "--json", "--quiet", "--no-dense"])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    r = obj["sogdd"]
    # a reconstruction, not just its keys: 3-4 cameras, tracks of 2+ views, sub-2 px reprojection
    assert 3 <= r["registered"] <= 4 and r["points"] > 50
    assert r["track_length"] >= 2.0 and 0 < r["reproj_error"] < 2.0 and r["seconds"] > 0
    assert (tmp_path / "out" / "sfm.json").is_file() and (tmp_path / "out" / "sfm.md").is_file()
