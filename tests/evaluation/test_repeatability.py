"""Repeatability beyond the paper: the blur family and the fixed-count (top-n) mode."""

import json

import cv2
import numpy as np
import pytest

from sogdd import baselines
from sogdd.baselines.registry import BaselineDetector
from sogdd.cli.main import main
from sogdd.corners import Corners
from sogdd.evaluation.repeatability import (
    ALL_FAMILIES,
    FAMILIES,
    Transform,
    apply_blur,
    apply_transform,
    evaluate_repeatability,
    family_grid,
    gaussian_kernel,
    motion_angle,
    motion_kernel,
    top_n_label,
)
from sogdd.evaluation.specs import DetectorSpec
from sogdd.report.tables import repeatability_modes_table, repeatability_table
from sogdd.synthetic import pattern_image


def _moments(k: np.ndarray):
    """Centroid (x, y) and covariance of a 2-D kernel as a distribution on pixel centres."""
    ys, xs = np.mgrid[: k.shape[0], : k.shape[1]]
    cx, cy = (k * xs).sum(), (k * ys).sum()
    dx, dy = xs - cx, ys - cy
    cov = np.array([[(k * dx * dx).sum(), (k * dx * dy).sum()], [(k * dx * dy).sum(), (k * dy * dy).sum()]])
    return cx, cy, cov


# -- the blur family -----------------------------------------------------------------
def test_families_paper_six_unchanged_blur_seventh():
    assert FAMILIES == ("rotation", "scale", "anisotropic", "shear", "jpeg", "noise")
    assert ALL_FAMILIES == FAMILIES + ("blur",)
    grid = [t.param for t in family_grid("blur")]
    assert grid[:10] == [("gaussian", s) for s in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0)]
    assert grid[10:] == [("motion", n) for n in (3, 5, 7, 9, 11, 13, 15)]
    assert Transform("blur", ("motion", 7)).label == "motion L=7"
    assert 0 < len(family_grid("blur", quick=True)) < len(grid)


@pytest.mark.parametrize("sigma", [0.5, 1.5, 5.0])
def test_gaussian_kernel_sums_to_one_and_has_the_asked_variance(sigma):
    k = gaussian_kernel(sigma)
    x = np.arange(len(k)) - len(k) // 2
    assert k.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.allclose(k, k[::-1])
    # sampled on +-ceil(4 sigma): the variance is sigma^2 up to sampling (tiny for sigma >= 1)
    assert (k * x * x).sum() == pytest.approx(sigma**2, rel=0.02 if sigma >= 1 else 0.2)


@pytest.mark.parametrize("length", [3, 7, 15])
@pytest.mark.parametrize("angle", [0.0, 0.4, 1.3, 2.6])
def test_motion_kernel_length_direction_and_centre(length, angle):
    k = motion_kernel(length, angle)
    assert k.sum() == pytest.approx(1.0, abs=1e-12)
    assert k.shape[0] == k.shape[1] and k.shape[0] % 2 == 1
    c = k.shape[0] // 2
    cx, cy, cov = _moments(k)
    assert (cx, cy) == (pytest.approx(c, abs=1e-9), pytest.approx(c, abs=1e-9))  # no shift
    evals, evecs = np.linalg.eigh(cov)
    # L taps at unit spacing: variance (L^2 - 1)/12 along the segment, plus at most 1/4 from the
    # bilinear splat; across it only the splat's
    along = (length**2 - 1) / 12
    assert along - 1e-9 <= evals[1] <= along + 0.25
    assert evals[0] <= 0.25
    major = evecs[:, 1]
    err = np.arccos(min(1.0, abs(major @ [np.cos(angle), np.sin(angle)])))
    assert err < 0.3 / length  # the segment's direction (the splat tilts short kernels slightly)


def test_motion_kernel_at_zero_angle_is_the_box_filter():
    k = motion_kernel(9, 0.0)
    c = k.shape[0] // 2
    assert np.allclose(k[c, c - 4 : c + 5], 1 / 9) and k.sum() == pytest.approx(k[c].sum())


def test_motion_angle_is_seeded():
    assert motion_angle(5, 9) == motion_angle(5, 9)
    angles = {motion_angle(s, 9) for s in range(20)}
    assert len(angles) == 20 and all(0 <= a < np.pi for a in angles)
    img = pattern_image((120, 160))[0].astype(np.uint8)
    np.testing.assert_array_equal(apply_blur(img, "motion", 9, seed=3), apply_blur(img, "motion", 9, seed=3))
    assert not np.array_equal(apply_blur(img, "motion", 9, seed=3), apply_blur(img, "motion", 9, seed=4))


@pytest.mark.parametrize("param", [("gaussian", 0.5), ("gaussian", 3.0), ("motion", 3), ("motion", 15)])
def test_blur_keeps_corners_where_they_are(param):
    """Identity geometry: the map is the identity, and a blurred impulse keeps its centroid
    (so a blurred corner is not moved by the transform)."""
    img = np.zeros((61, 61), np.uint8)
    img[30, 30] = 255
    out, a, valid = apply_transform(img, Transform("blur", param), seed=11)
    np.testing.assert_array_equal(a, np.hstack([np.eye(2), np.zeros((2, 1))]))
    assert valid.all() and out.shape == img.shape and out.dtype == np.uint8
    w = out.astype(np.float64)
    ys, xs = np.mgrid[:61, :61]
    assert (w * xs).sum() / w.sum() == pytest.approx(30, abs=0.1)
    assert (w * ys).sum() / w.sum() == pytest.approx(30, abs=0.1)
    # an X-corner (point-symmetric about its vertex) stays point-symmetric about the same pixel
    ys, xs = np.mgrid[:61, :61]
    x_corner = np.where((xs - 30) * (ys - 30) > 0, 220, 30).astype(np.uint8)
    x_corner[(xs == 30) | (ys == 30)] = 125
    out = apply_transform(x_corner, Transform("blur", param), seed=11)[0].astype(int)
    inner = out[12:49, 12:49]  # away from the reflected border
    np.testing.assert_array_equal(inner, inner[::-1, ::-1])
    assert not np.array_equal(out, x_corner)  # and it was blurred


# -- top-n ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def busy_image():
    """Rendered polygons plus a seeded texture: many candidates for every detector."""
    img, _ = pattern_image((160, 200), seed=4)
    tex = np.random.default_rng(0).uniform(0, 60, (20, 25))
    tex = cv2.resize(tex, (200, 160), interpolation=cv2.INTER_CUBIC)
    return np.clip(img * 0.7 + tex, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("name", baselines.available())
def test_top_n_keeps_exactly_n_strongest_for_every_registry_detector(name, busy_image):
    n = 40
    det = baselines.get(name)
    perm = det.permissive().detect_corners(busy_image)
    top = det.top_n(busy_image, n)
    # exactly n where the threshold-off run has n candidates; all of them where it has fewer
    assert len(top) == min(n, len(perm))
    want = np.sort(np.nan_to_num(perm.response, nan=-np.inf))[::-1][: len(top)]
    np.testing.assert_array_equal(np.nan_to_num(top.response, nan=-np.inf), want)
    assert np.all(np.diff(np.nan_to_num(top.response, nan=-np.inf)) <= 0)


def test_top_n_reaches_n_on_most_detectors(busy_image):
    """The permissive runs have enough candidates for N = 40 on this image, AKAZE included
    (it has no top-k parameter of its own). ORB (31 px border, FAST threshold 20), zhang2013 and
    zhang2021 keep fewer points than that on a 160 x 200 image even with the threshold off."""
    names = ("harris", "shi-tomasi", "fast", "sift", "kaze", "akaze", "sogdd", "sogdd-authors", "zhang2020")
    assert [len(baselines.get(nm).top_n(busy_image, 40)) for nm in names] == [40] * len(names)


def test_top_n_rejects_a_bad_count(busy_image):
    with pytest.raises(ValueError, match="n must be an integer"):
        baselines.get("harris").top_n(busy_image, 0)


class _NoStrength(BaselineDetector):
    name = "no-strength-test"
    has_strength = False
    defaults = {"threshold": 0.0}

    def _detect(self, grey, mask):
        xy = np.array([[5.0, 5.0], [9.0, 3.0], [1.0, 8.0], [4.0, 4.0]])
        return Corners(xy, np.full(4, np.nan))


def test_top_n_without_a_strength_keeps_the_detectors_own_first_points():
    c = _NoStrength().top_n(np.zeros((12, 12), np.uint8), 3)
    assert c.xy.tolist() == [[5.0, 5.0], [9.0, 3.0], [1.0, 8.0]]


# -- the protocol, the tables and the CLI ----------------------------------------------
def test_repeatability_both_modes_side_by_side(busy_image):
    specs = [DetectorSpec("harris"), DetectorSpec("akaze")]
    rep = evaluate_repeatability([("busy", busy_image)], specs, families=("noise", "blur"), quick=True,
                                 progress=False, top_n=25)
    assert rep.detectors == ["harris", "akaze", top_n_label("harris", 25), top_n_label("akaze", 25)]
    summ = rep.summary()
    for s in ("harris", "akaze"):
        assert rep.points()[top_n_label(s, 25)] <= 25
        assert summ[s]["overall"] == pytest.approx(summ[s]["noise"])  # blur is not in the overall
    # blur hurts: the strongest sigma is below the mildest for each detector
    for d in rep.detectors:
        x, y = rep.curve(d, "blur", "gaussian")
        assert list(x) == [1.0, 2.5, 4.0] and y[-1] < y[0]
    modes = repeatability_modes_table(rep)
    assert "top-25: overall" in modes and "blur†" in modes and "beyond the paper" in modes
    assert "blur (beyond the paper)" in repeatability_table(rep)


def test_cli_repeatability_top_n_json(tmp_path, busy_image, capsys):
    cv2.imwrite(str(tmp_path / "busy.png"), busy_image)
    code = main(["eval", "repeatability", "--images", str(tmp_path), "--quick", "--families", "blur",
                 "--detectors", "fast,akaze", "--top-n", "30", "--jobs", "1", "--quiet", "--json"])
    assert code == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["top_n"] == 30 and obj["beyond_paper"] == ["blur"]
    assert set(obj["detectors"]) == {"fast", "akaze", "fast [top-30]", "akaze [top-30]"}
    assert 0 < obj["points"]["akaze [top-30]"] <= 30


def test_cli_repeatability_bad_top_n_exits_2(tmp_path, busy_image, capsys):
    cv2.imwrite(str(tmp_path / "busy.png"), busy_image)
    assert main(["eval", "repeatability", "--images", str(tmp_path), "--top-n", "0", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sogdd: error:") and len(err.strip().splitlines()) == 1
