"""The fit weighs each corner by its measured precision, and smeared views go, with their reason."""

import csv
from dataclasses import replace

import cv2
import numpy as np
import pytest

from sogdd.calib import calibrate
from sogdd.calib.cameras import project
from sogdd.calib.session import calibrate_images, write_outputs
from sogdd.calib.solvers import fit_camera
from sogdd.calib.targets.board import Board
from sogdd.calib.weighting import SMEARED, corner_weights, smeared_views, typical_precision

SMEARED_VIEWS = (1, 5, 9)


def smear(img: np.ndarray, length: int, angle: float, skew: float) -> np.ndarray:
    """A board moving during the exposure: a line-kernel motion blur (``cv2.filter2D``), and the rolling
    shutter's skew, each row read ``skew`` px per row later along the motion."""
    k = np.zeros((length, length))
    c = (length - 1) / 2
    for t in np.linspace(-c, c, 4 * length):
        k[int(round(c + t * np.sin(angle))), int(round(c + t * np.cos(angle)))] += 1
    img = cv2.filter2D(img, -1, k / k.sum(), borderType=cv2.BORDER_REFLECT)
    h, w = img.shape
    u = np.array([np.cos(angle), np.sin(angle)]) * skew
    M = np.array([[1.0, u[0], -u[0] * h / 2], [0.0, 1.0 + u[1], -u[1] * h / 2]])
    return cv2.warpAffine(img, M, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


@pytest.fixture(scope="module")
def smeared_set(render, tmp_path_factory):
    """Twelve rendered views (blur 0.8 px, noise 2), three of them taken moving: smeared over 17 px and
    skewed by 0.3 % (a rolling shutter)."""
    cam = render.camera_for(640, 480)
    target = render.Board(9, 6, 1.0)
    folder = tmp_path_factory.mktemp("smeared")
    for k, (rv, tv) in enumerate(render.random_poses(cam, target, 12, seed=1)):
        clean = render.render_scene(cam, target, rv, tv, blur=0.8)
        if k in SMEARED_VIEWS:
            clean = smear(clean, 17, 0.3 + k, 0.003)
        cv2.imwrite(str(folder / f"v{k:02d}.png"), render.add_noise(clean, 2.0, np.random.default_rng(100 + k)))
    return cam, folder


def test_smeared_views_are_rejected_or_weighed_down_and_the_focal_length_is_no_worse(smeared_set, tmp_path):
    cam, folder = smeared_set
    result = calibrate_images(folder, "chessboard:9x6", model="pinhole4")
    cal = result.calibration
    assert cal.n_used + sum(r.startswith("smeared") for r in cal.reasons) == 12  # nothing else lost
    plain = calibrate([replace(b, precision=None) for b in cal.boards], cam.size, model="pinhole4",
                      cross_validate=False)
    err, err_plain = abs(cal.K[0, 0] / cam.fx - 1), abs(plain.K[0, 0] / cam.fx - 1)
    assert err <= err_plain, (err, err_plain)  # measured: 0.003 % against 0.027 %
    write_outputs(result, tmp_path / "out", report=False)
    rows = {r["view"]: r for r in csv.DictReader(open(tmp_path / "out" / "views.csv"))}
    for k in SMEARED_VIEWS:
        r = rows[f"v{k:02d}.png"]
        assert float(r["precision_px"]) > 2 * cal.typical_precision
        if r["status"] == "rejected":
            assert r["reason"].startswith("smeared: corners ") and "less precise than the set's median" in r[
                "reason"]
            assert float(r["reason"].split("smeared: corners ")[1].split("x")[0]) > SMEARED
        else:  # kept, weighed down
            assert r["status"] == "used" and float(r["weight"]) < 0.5
    assert sum(rows[f"v{k:02d}.png"]["status"] == "rejected" for k in SMEARED_VIEWS) >= 1
    sharp = [r for n, r in rows.items() if int(n[1:3]) not in SMEARED_VIEWS]
    assert all(r["status"] == "used" and 0.7 < float(r["weight"]) <= 2.0 for r in sharp)
    corners = list(csv.DictReader(open(tmp_path / "out" / "corners.csv")))
    assert all(0 < float(c["sigma_px"]) < 0.2 for c in corners)


def test_equal_precision_leaves_the_fit_as_it_was(synthetic):
    boards = synthetic.boards(8, noise=0.05, seed=4)
    same = [replace(b, precision=np.full(len(b), 0.05)) for b in boards]
    a, b = calibrate(boards, synthetic.SIZE), calibrate(same, synthetic.SIZE)
    np.testing.assert_allclose(a.K, b.K, rtol=1e-12)
    assert np.isnan(a.typical_precision) and b.typical_precision == 0.05


BIASED = (2, 6)


def biased_set(synthetic):
    """Ten views with noise 0.05 px; two of them stretched by 1 % along x about the image centre (a
    wrong geometry, as a moving board's), their corners 2.5x less precise than the others' (below the
    smeared rule: kept, weighed down)."""
    boards = synthetic.boards(10, noise=0.05, seed=5)
    centre = np.array(synthetic.SIZE) / 2
    out = []
    for v, b in enumerate(boards):
        if v in BIASED:
            out.append(replace(b, image_points=centre + (b.image_points - centre) * [1.01, 1.0],
                               precision=np.full(len(b), 0.125)))
        else:
            out.append(replace(b, precision=np.full(len(b), 0.05)))
    return out


@pytest.mark.parametrize("fit", ["one camera", "rig"])
def test_imprecise_corners_count_less_in_the_fit(synthetic, fit):
    """The weighted fit stays near the fit without the two biased views; the plain one is pulled away
    (``fx, fy, cx, cy`` measured: 0.69 px against 3.2 for one camera)."""
    weighted = biased_set(synthetic)
    plain = [replace(b, precision=None) for b in weighted]
    clean = [None if v in BIASED else b for v, b in enumerate(plain)]
    if fit == "rig":
        from sogdd.calib.rig.fit import calibrate_rig

        def intrinsics(boards):
            K = calibrate_rig({"a": boards}, {"a": synthetic.SIZE}, reject=False).cameras[0].calibration.K
            return K[[0, 1, 0, 1], [0, 1, 2, 2]]
    else:
        def intrinsics(boards):
            K = calibrate(boards, synthetic.SIZE, reject=False, cross_validate=False).K
            return K[[0, 1, 0, 1], [0, 1, 2, 2]]
    a, b, c = intrinsics(weighted), intrinsics(plain), intrinsics(clean)
    assert np.linalg.norm(a - c) < 0.3 * np.linalg.norm(b - c), (a - c, b - c)


def test_the_rule_keeps_min_views_and_says_why():
    lab = np.array([[0, 0], [1, 0]])
    boards = [Board(np.zeros((2, 2)), lab, precision=[s, s]) for s in (0.05, 0.05, 0.06, 0.5, 0.3)]
    assert typical_precision(boards) == 0.06
    assert list(smeared_views(boards, np.ones(5, bool), 3)) == [3, 4]  # the worst first
    assert list(smeared_views(boards, np.ones(5, bool), 4)) == [3]
    assert smeared_views(boards, np.array([1, 1, 1, 0, 1], bool), 3) == {
        4: "smeared: corners 5.5x less precise than the set's median (0.3 px against 0.055)"}
    assert corner_weights(boards[3], 0.06).tolist() == pytest.approx([0.12, 0.12])
    assert corner_weights(boards[0], 0.06).tolist() == pytest.approx([1.2, 1.2])


def test_weighted_refinement_keeps_the_flags():
    """OpenCV's flags hold the same parameters in the weighted refinement (here the principal point)."""
    import cv2 as _cv2

    K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    rng = np.random.default_rng(0)
    poses = [((0.4 * np.sin(a), 0.4 * np.cos(a), 0.1), (-4.0, -2.5, 12.0 + a % 3)) for a in range(8)]
    img = [project(obj, K, np.zeros(5), "pinhole", r, t) + rng.normal(0, 0.1, (54, 2)) for r, t in poses]
    w = [np.full(54, 2.0 if v % 2 else 0.5) for v in range(8)]
    Kw, _, _, _, std = fit_camera([obj] * 8, img, (641, 481), "pinhole", _cv2.CALIB_FIX_PRINCIPAL_POINT, w)
    assert (Kw[0, 2], Kw[1, 2]) == (320.0, 240.0) and std[2] == std[3] == 0
    Kw, D, _, _, _ = fit_camera([obj] * 8, img, (640, 480), "pinhole", _cv2.CALIB_ZERO_TANGENT_DIST, w)
    assert D[2] == D[3] == 0 and abs(Kw[0, 0] - 600) < 2
