import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

import sogdd
from sogdd.image.grey import to_gray255
from sogdd.select.refine import refine_gradient, refine_quadratic
from sogdd.synthetic import Polygon, render_polygons
from sogdd.synthetic import pattern_image as make_pattern


def _match(xy, gt, tol=2.0):
    d, _ = cKDTree(xy).query(gt)
    return d <= tol, d


def test_rendered_polygons_recall_and_subpixel_accuracy(pattern):
    img, gt = pattern
    c = sogdd.detect_corners(img)
    hit, d = _match(c.xy, gt)
    assert hit.mean() >= 0.95
    rms = np.sqrt(np.mean(d[hit] ** 2))
    assert rms < 0.35, rms
    assert len(c) <= 1.1 * len(gt)  # few false corners on a clean pattern


def test_peak_of_measure_lies_inside_the_corner():
    """The measure's own peak is biased towards the inside; the gradient refinement removes it."""
    sq = np.array([[40.3, 30.6], [90.3, 30.6], [90.3, 80.6], [40.3, 80.6]])
    img = np.round(render_polygons((110, 130), [Polygon(sq, 220.0)], background=30.0)).astype(np.uint8)
    centre = sq.mean(axis=0)
    quad = sogdd.detect_corners(img, subpixel="quadratic")
    grad = sogdd.detect_corners(img, subpixel=True)
    _, iq = cKDTree(quad.xy).query(sq)
    _, ig = cKDTree(grad.xy).query(sq)
    # quadratic peaks sit ~1 px closer to the centre than the true vertices
    inward = np.linalg.norm(sq - centre, axis=1) - np.linalg.norm(quad.xy[iq] - centre, axis=1)
    assert np.all(inward > 0.5)
    assert np.max(np.linalg.norm(grad.xy[ig] - sq, axis=1)) < 0.25


def test_rotation_by_90_degrees_rotates_detections(pattern):
    img, _ = pattern
    h, w = img.shape
    a = sogdd.detect_corners(img, subpixel=False)
    b = sogdd.detect_corners(np.rot90(img), subpixel=False)
    # np.rot90 (counter-clockwise): (x, y) -> (y, w - 1 - x)
    mapped = np.stack([a.xy[:, 1], w - 1 - a.xy[:, 0]], axis=1)
    assert len(a) == len(b)
    d, _ = cKDTree(b.xy).query(mapped)
    assert d.max() < 1e-9
    # with sub-pixel refinement the rotated points agree to well below a pixel
    a2 = sogdd.detect_corners(img)
    b2 = sogdd.detect_corners(np.rot90(img))
    m2 = np.stack([a2.xy[:, 1], w - 1 - a2.xy[:, 0]], axis=1)
    d2, _ = cKDTree(b2.xy).query(m2)
    assert np.median(d2) < 0.01 and d2.max() < 0.1
    assert h != w


def test_corners_api(pattern):
    img, _ = pattern
    c = sogdd.detect_corners(img, max_corners=10)
    assert len(c) == 10
    assert c.xy.shape == (10, 2) and c.response.shape == (10,) and c.size.shape == (10,)
    assert np.all(np.diff(c.response) <= 0)
    np.testing.assert_array_equal(c.rc(), c.xy[:, ::-1])
    kps = c.to_keypoints()
    assert isinstance(kps[0], cv2.KeyPoint)
    assert kps[0].pt == pytest.approx(tuple(c.xy[0]))
    assert kps[0].response == pytest.approx(c.response[0])
    assert kps[0].size == pytest.approx(c.size[0])


def test_threshold_options(pattern):
    img, _ = pattern
    r = sogdd.corner_response(img)
    base = sogdd.detect_corners(img, threshold=None, subpixel=False)
    assert np.all(base.response > 0)
    hi = sogdd.detect_corners(img, threshold=1e12, subpixel=False)
    assert np.all(hi.response > 1e12) and len(hi) < len(base)
    rel = sogdd.detect_corners(img, threshold=None, threshold_rel=0.1, subpixel=False)
    assert np.all(rel.response > 0.1 * r.max())
    q = sogdd.detect_corners(img, threshold=None, quantile=0.999, subpixel=False)
    assert np.all(q.response > np.quantile(r[r > 0], 0.999))


def test_mask_border_and_nms(pattern):
    img, _ = pattern
    h, w = img.shape
    mask = np.zeros((h, w), np.uint8)
    mask[:, : w // 2] = 255
    c = sogdd.detect_corners(img, mask=mask, subpixel=False)
    assert len(c) and np.all(c.xy[:, 0] < w // 2)
    cb = sogdd.detect_corners(img, mask=mask.astype(bool), subpixel=False)
    np.testing.assert_array_equal(c.xy, cb.xy)
    b = sogdd.detect_corners(img, border=60, subpixel=False)
    assert np.all((b.xy >= 60).all(axis=1) & (b.xy[:, 0] < w - 60) & (b.xy[:, 1] < h - 60))
    wide = sogdd.detect_corners(img, threshold=None, nms_radius=6, subpixel=False)
    d = np.linalg.norm(wide.xy[:, None] - wide.xy[None], axis=2) + np.eye(len(wide)) * 99
    assert d.min() > 1  # no two maxima within one pixel once the radius is 6


def test_pyramid_levels_set_size(pattern):
    img, gt = pattern
    c = sogdd.detect_corners(img, levels=3, scale_factor=2.0)
    assert set(np.unique(c.level)) <= {0, 1, 2} and (c.level > 0).any()
    s0 = c.size[c.level == 0][0]
    s1 = c.size[c.level == 1][0]
    assert s1 == pytest.approx(2 * s0, rel=0.02)
    # coarse-level points land on true corners in full-resolution coordinates
    hit, _ = _match(c.xy[c.level == 1], gt, tol=3.0)
    assert hit.mean() > 0.7


def test_input_dtypes_and_colour_agree(pattern):
    img, _ = pattern
    ref = sogdd.corner_response(img)
    np.testing.assert_allclose(sogdd.corner_response(img.astype(np.float64) / 255), ref, rtol=1e-9)
    np.testing.assert_allclose(
        sogdd.corner_response(img.astype(np.uint16) * 257), ref, rtol=1e-9
    )
    rgb = np.dstack([img] * 3)
    # grey from equal channels is the grey image up to one rounding; the measure (a
    # det of a nearly singular 8x8 matrix) can amplify that, so compare the points
    np.testing.assert_allclose(to_gray255(rgb), img, rtol=1e-15)
    a, b = sogdd.detect_corners(rgb), sogdd.detect_corners(img)
    np.testing.assert_allclose(a.xy, b.xy, atol=1e-6)
    assert len(sogdd.detect_corners(np.dstack([img, img, img, np.full_like(img, 255)])))


def test_bgr_order_in_opencv_style_class():
    img, _ = make_pattern((120, 160), seed=3)
    bgr = np.dstack([img, np.zeros_like(img), np.zeros_like(img)])  # blue-only in BGR
    kps = sogdd.SOGDD(threshold=1e3).detect(bgr)
    rgb_same = sogdd.detect_corners(bgr[:, :, ::-1].copy(), threshold=1e3)  # same picture, RGB
    as_red = sogdd.detect_corners(bgr, threshold=1e3)  # misread as red-only
    assert len(kps) == len(rgb_same) > 0
    np.testing.assert_allclose([k.response for k in kps], rgb_same.response)
    assert as_red.response.max() > 10 * rgb_same.response.max()


def test_authors_preset(pattern):
    img, gt = pattern
    p = sogdd.resolve_params("authors")
    assert (p.sigma2, p.n_orientations, p.window, p.window_shape) == (1.44, 4, 5, "disk")
    c = sogdd.detect_corners(img, preset="authors")
    assert np.all((c.xy >= 9).all(axis=1))
    assert np.all(c.xy[:, 0] < img.shape[1] - 9) and np.all(c.xy[:, 1] < img.shape[0] - 9)
    assert np.allclose(c.xy, np.round(c.xy))  # integer positions, as the authors' code
    hit, _ = _match(c.xy, gt)
    assert hit.mean() > 0.6


def test_paper_preset_block_image(data_dir):
    """K = 8 is what makes T_h = 1e9 meaningful (README): many maxima pass on Block."""
    img = sogdd.read_image(next((data_dir / "corners_gt" / "block").glob("image.*")))
    k8 = sogdd.detect_corners(img, subpixel=False)
    k4 = sogdd.detect_corners(img, n_orientations=4, subpixel=False)
    assert len(k4) < 10 < 59 <= len(k8)  # Block has 59 GT corners


def test_opencv_style_compute_and_detect_and_compute():
    img, _ = make_pattern((160, 240), seed=7)
    det = sogdd.SOGDD()
    kps, desc = det.detectAndCompute(img, None)
    assert len(kps) == desc.shape[0] > 5 and desc.shape[1] == 128 and desc.dtype == np.float32
    assert all(0 <= k.angle < 360 for k in kps)
    kps2, desc2 = det.compute(img, det.detect(img))
    assert len(kps2) == len(kps) and desc2.shape == desc.shape
    # a rotated copy gives descriptors that still match their own points
    matcher = cv2.BFMatcher(cv2.NORM_L2, crossCheck=True)
    kr, dr = det.detectAndCompute(np.rot90(img).copy(), None)
    assert len(matcher.match(desc, dr)) > 0.5 * len(kps)


def test_paper_preset_states_the_papers_settings():
    """The experiments section: sigma^2 = 1.2, a 7 x 7 window, T_h = 1e9 (K = 8: see the README)."""
    p = sogdd.PRESETS["paper"]
    assert p.sigma2 == 1.2
    assert (p.n_orientations, p.window, p.window_shape) == (8, 7, "square")
    assert (p.threshold, p.threshold_rel, p.quantile, p.nms_radius, p.border) == (1e9, None, None, 1, 0)
    assert sogdd.resolve_params("paper").subpixel == "gradient"


@pytest.mark.parametrize("radius", [1, 2, 3, 5, 8])
def test_nms_contract_no_two_corners_within_the_radius(radius):
    """Of maxima within the (2r+1)^2 neighbourhood only one survives: Chebyshev distance > r."""
    img = np.random.default_rng(radius).uniform(0, 1, (90, 110))
    img = cv2.GaussianBlur(img, (0, 0), 1.0)  # plateaus and close maxima both occur
    img = (img - img.min()) / (img.max() - img.min())
    c = sogdd.detect_corners(img, threshold=None, nms_radius=radius, subpixel=False)
    assert len(c) > 10
    d = np.abs(c.xy[:, None, :] - c.xy[None, :, :]).max(axis=2) + np.eye(len(c)) * 1e9
    assert d.min() > radius


def test_gradient_refinement_refuses_moves_over_max_shift():
    """A point 2.1 px from a vertex moves onto it; one 3.5 px away keeps its position."""
    img = np.zeros((60, 60))
    img[30:, 30:] = 200.0  # an L-corner with its vertex at (29.5, 29.5)
    img = cv2.GaussianBlur(img, (0, 0), 0.8)
    near = refine_gradient(img, np.array([[31.0, 31.0]]))
    assert np.allclose(near, 29.5, atol=0.25)  # the gradient method's inward bias on a blurred vertex
    start = np.array([[32.0, 32.0]])  # 3.5 px from the vertex, inside the 7x7 window's reach
    np.testing.assert_array_equal(refine_gradient(img, start, max_shift=3.0), start)
    assert np.allclose(refine_gradient(img, start, max_shift=5.0), 29.5, atol=0.25)


def test_quadratic_fallback_is_clipped_to_half_a_pixel_and_blended_in():
    """Beyond +-2 px each axis takes its own parabola, clipped to +-0.5; between 1 and 2 px a linear blend."""
    b = np.array([0.0, 1.0, 0.0])  # a symmetric peak in y

    def off(right):  # rising to the right: the x vertex at right / (2 (2 - right))
        patch = np.array([0.0, 1.0, right])[None, :] + b[:, None]
        return refine_quadratic(np.pad(patch, 1), np.array([2]), np.array([2]), log=False)[0]

    np.testing.assert_allclose(off(1.5), [0.5 * 1.5 + 0.5 * 0.5, 0.0])  # the vertex at 1.5: half-way
    np.testing.assert_allclose(off(1.75), [0.5, 0.0])  # at 3.5: the clipped 1-D parabola alone
    np.testing.assert_allclose(off(1.2), [0.6 / 0.8, 0.0])  # at 0.75: inside, the 2-D solution
    # continuous in the patch: no jump as the vertex crosses 1 and 2 px (0.2.0 jumped from 1 to 0.5)
    xs = np.array([off(r)[0] for r in np.linspace(1.0, 1.8, 801)])
    assert np.abs(np.diff(xs)).max() < 0.01


def test_tie_breaking_keeps_a_candidate_unless_an_earlier_kept_one_is_within_the_radius():
    """The greedy definition, brute force, on random candidate lists in random order."""
    from sogdd.select.peaks import break_ties

    rng = np.random.default_rng(7)
    for _ in range(60):
        h, w = rng.integers(1, 40, 2)
        idx = rng.choice(h * w, int(rng.integers(0, min(h * w, 150) + 1)), replace=False)
        rows, cols = np.divmod(idx, w)
        radius = int(rng.integers(1, 7))
        want = np.ones(len(rows), bool)
        for j in range(len(rows)):
            near = np.maximum(np.abs(rows[:j] - rows[j]), np.abs(cols[:j] - cols[j])) <= radius
            want[j] = not (near & want[:j]).any()
        np.testing.assert_array_equal(break_ties(rows, cols, radius), want)
