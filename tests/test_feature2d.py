"""SOGDD keeps OpenCV's Feature2D contract: each call checked against what cv2.SIFT_create() does for it."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

import sogdd
from sogdd.descriptors import DESC_SIZE, compute_keypoints, describable, describe
from sogdd.synthetic import pattern_image


@pytest.fixture(scope="module")
def bgr():
    grey = pattern_image((200, 260), seed=5)[0]
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)


@pytest.fixture(scope="module", params=["sift", "sogdd"])
def pair(request, bgr):
    """(detector, image): OpenCV's SIFT as the reference, and ours, through the same calls."""
    det = cv2.SIFT_create() if request.param == "sift" else sogdd.SOGDD(levels=2, max_corners=60)
    return det, bgr


def _pts(kps):
    return np.array([(k.pt[0], k.pt[1], k.size, k.angle, k.octave) for k in kps]).reshape(-1, 5)


def test_detect_then_compute_is_detect_and_compute(pair):
    det, img = pair
    kps = det.detect(img, None)
    k1, d1 = det.compute(img, kps)
    k2, d2 = det.detectAndCompute(img, None)
    assert len(k1) > 10 and len(k1) == len(k2) == d1.shape[0]
    np.testing.assert_array_equal(_pts(k1), _pts(k2))
    np.testing.assert_array_equal(d1, d2)
    # describing the described keypoints again gives the same (the angles they now carry are used)
    k3, d3 = det.compute(img, k1)
    np.testing.assert_array_equal(_pts(k3), _pts(k1))
    np.testing.assert_array_equal(d3, d1)


def test_with_a_mask(pair):
    det, img = pair
    mask = np.zeros(img.shape[:2], np.uint8)
    mask[:, : img.shape[1] // 2] = 255
    k1, d1 = det.compute(img, det.detect(img, mask))
    k2, d2 = det.detectAndCompute(img, mask)
    assert 0 < len(k2) and all(k.pt[0] < img.shape[1] // 2 + 1 for k in k2)
    np.testing.assert_array_equal(_pts(k1), _pts(k2))
    np.testing.assert_array_equal(d1, d2)


def test_return_types(pair):
    det, img = pair
    kps = det.detect(img, None)
    assert isinstance(kps, tuple) and all(isinstance(k, cv2.KeyPoint) for k in kps)
    k, d = det.compute(img, kps)
    assert isinstance(k, tuple) and isinstance(d, np.ndarray) and d.dtype == np.float32 and d.shape[1] == 128
    k, d = det.detectAndCompute(img, None)
    assert isinstance(k, tuple) and isinstance(d, np.ndarray) and d.dtype == np.float32
    assert all(0 <= kp.angle < 360 for kp in k)  # described keypoints carry their orientation


def test_empty_input(pair):
    det, img = pair
    k, d = det.compute(img, [])
    assert k == () and d.shape == (0, 128) and d.dtype == np.float32
    flat = np.full((64, 64, 3), 90, np.uint8)
    assert det.detect(flat, None) == ()
    k, d = det.detectAndCompute(flat, None)
    assert k == () and d.shape == (0, 128)


def test_use_provided_keypoints(pair, bgr):
    det, img = pair
    # OpenCV's Python binding passes no keypoints in: nothing to describe
    k, d = det.detectAndCompute(img, None, None, True)
    assert k == () and d.shape == (0, 128)
    if isinstance(det, sogdd.SOGDD):  # ours takes them as keypoints=, and describes exactly them
        given = cv2.SIFT_create().detect(img, None)[:20]
        k, d = det.detectAndCompute(img, None, useProvidedKeypoints=True, keypoints=given)
        k2, d2 = det.compute(img, given)
        assert len(k) == 20
        np.testing.assert_array_equal(d, d2)
        np.testing.assert_allclose([kp.pt for kp in k], [kp.pt for kp in given])
        with pytest.raises(ValueError, match="useProvidedKeypoints=True"):
            det.detectAndCompute(img, None, keypoints=given)


def test_given_angles_are_used_like_sift(bgr):
    """SIFT describes a keypoint at the angle it carries; so do we (a negative one is assigned)."""
    sift = cv2.SIFT_create()
    kp = cv2.KeyPoint(100.0, 90.0, 12.0, 33.0)
    (sk,), _ = sift.compute(bgr, [kp])
    (ok,), ours = sogdd.SOGDD().compute(bgr, [kp])
    assert sk.angle == ok.angle == 33.0
    (free,), other = sogdd.SOGDD().compute(bgr, [cv2.KeyPoint(100.0, 90.0, 12.0, -1.0)])
    assert 0 <= free.angle < 360
    assert not np.array_equal(ours, other) or free.angle == pytest.approx(33.0)


def test_compute_drops_what_it_cannot_describe_and_says_so_in_the_keypoints(bgr):
    """OpenCV's Feature2D.compute removes the keypoints it cannot describe (ORB does, near the border)."""
    orb = cv2.ORB_create()
    inside, near = cv2.KeyPoint(100, 100, 31), cv2.KeyPoint(3, 3, 31)
    k, d = orb.compute(bgr, [near, inside])
    assert len(k) == 1 == d.shape[0] and k[0].pt == inside.pt  # the reference behaviour
    h, w = bgr.shape[:2]
    kps = [cv2.KeyPoint(50, 60, 8), cv2.KeyPoint(w + 20, 10, 8), cv2.KeyPoint(-3, 10, 8),
           cv2.KeyPoint(70, 80, 8), cv2.KeyPoint(10, 10, 0), cv2.KeyPoint(w - 0.5, h - 0.5, 8)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a size-0 keypoint leaks no numpy warning
        k, d = sogdd.SOGDD().compute(bgr, kps)
    assert [kp.pt for kp in k] == [(50, 60), (70, 80), (w - 0.5, h - 0.5)]
    # no row of zeros for a point outside (the last point, on flat background at the corner, has no gradient)
    assert d.shape == (3, 128) and (np.abs(d[:2]).sum(axis=1) > 0).all()
    # the kept ones are described as they would be alone
    np.testing.assert_array_equal(d[:2], sogdd.SOGDD().compute(bgr, [kps[0], kps[3]])[1])


def test_detect_sizes_are_the_descriptor_sizes(bgr):
    det = sogdd.SOGDD(levels=2, max_corners=80)
    kps = det.detect(bgr)
    levels = np.array([k.octave for k in kps])
    assert set(levels.tolist()) == {0, 1}
    np.testing.assert_array_equal([k.size for k in kps], DESC_SIZE * 2.0**levels)
    own = sogdd.SOGDD(levels=2, max_corners=80, desc_size=None).detect(bgr)
    c = det.detect_corners(bgr)
    np.testing.assert_array_equal([k.size for k in own], c.size)
    with pytest.raises(ValueError, match="desc_size"):
        sogdd.SOGDD(desc_size=0)


def test_detect_and_compute_descriptors_are_those_of_describe_at_desc_size(bgr):
    """What the evaluations measure (describe at DESC_SIZE x scale_factor ** level) is detectAndCompute's."""
    det = sogdd.SOGDD(levels=2, max_corners=50)
    _, d = det.detectAndCompute(bgr, None)
    c = det.detect_corners(bgr)
    np.testing.assert_array_equal(d, describe(bgr, c, size=DESC_SIZE, channel_order="bgr"))


def test_describe_refuses_points_outside_the_image():
    img, _ = pattern_image((200, 260), seed=5)
    c = sogdd.detect_corners(img)
    crop = img[:100, :100]
    outside = int((~describable(crop.shape, c.xy, c.size)).sum())
    assert 0 < outside < len(c)
    with pytest.raises(ValueError) as exc:
        describe(crop, c)
    assert "\n" not in str(exc.value) and f"{outside} of {len(c)} points" in str(exc.value)
    kept = c.subset(describable(crop.shape, c.xy, c.size))
    d = describe(crop, kept)
    assert d.shape == (len(kept), 128) and (np.abs(d).sum(axis=1) > 0).all()
    zero = sogdd.Corners(np.array([[10.0, 10.0]]), size=np.array([0.0]))
    with pytest.raises(ValueError, match="size <= 0"):
        describe(img, zero)


def test_compute_keypoints_checks_its_input(bgr):
    with pytest.raises(ValueError, match="cv2.KeyPoint"):
        compute_keypoints(bgr, [(1, 2)])
    with pytest.raises(ValueError, match="unknown descriptor method"):
        compute_keypoints(bgr, [], "sosnet")


def test_orientation_needs_positive_sizes(bgr):
    from sogdd.descriptors import assign_orientations

    with pytest.raises(ValueError, match="positive finite diameter"):
        assign_orientations(bgr[:, :, 0], np.array([[10.0, 10.0]]), np.array([0.0]))
