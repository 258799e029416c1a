"""refine_corners: accuracy on rendered boards (blur, tiny cells), against cornerSubPix, and its contract."""

from functools import cache

import cv2
import numpy as np
import pytest

from sogdd.calib.targets.refine import cell_sizes, refine_corners
from sogdd.evaluation.calibration.render import Camera, ChessboardTarget, render_view

CAM = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (-0.1, 0.02, 0.0, 0.0), (480, 360))


@cache
def view(dist=0.8, blur=1.0, noise=2.0, roll=0.3):
    R = np.array([0.35, -0.25, roll])
    Rm, _ = cv2.Rodrigues(R)
    t = np.array([0.0, 0.0, dist]) - Rm @ np.array([0.12, 0.075, 0.0])
    return render_view(CAM, ChessboardTarget(9, 6, 0.03), R, t, blur=blur, noise=noise, rng=7)


def starts(v, spread=1.0, seed=0):
    return v.corners + np.random.default_rng(seed).uniform(-spread, spread, v.corners.shape)


def errors(xy, v):
    return np.hypot(*(xy - v.corners).T)


def test_accurate_from_a_pixel_off():
    v = view()
    e = errors(refine_corners(v.image, starts(v)), v)
    assert e.mean() < 0.02 and e.max() < 0.06


def test_beats_cornersubpix_on_find_chessboard_corners_output():
    v = view()
    ok, found = cv2.findChessboardCorners(v.image, (9, 6))
    assert ok
    found = found.reshape(-1, 2)
    order = np.argmin(np.hypot(*(found[:, None] - v.corners[None]).transpose(2, 0, 1)), axis=1)
    truth = v.corners[order]
    ours = np.hypot(*(refine_corners(v.image, found.reshape(-1, 1, 2)) - truth).T)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    theirs = cv2.cornerSubPix(v.image, found.reshape(-1, 1, 2).copy(), (5, 5), (-1, -1), crit).reshape(-1, 2)
    theirs = np.hypot(*(theirs - truth).T)
    assert ours.mean() < 0.6 * theirs.mean()
    assert ours.max() < theirs.max()


def test_strong_blur_sends_no_point_away():
    v = view(dist=0.55, blur=2.5, noise=4.0)  # cells of about 27 px blurred over 5 px
    e = errors(refine_corners(v.image, starts(v)), v)
    assert e.mean() < 0.05 and e.max() < 0.5


def test_tiny_cells():
    v = view(dist=2.4, blur=0.8)
    assert np.median(cell_sizes(v.corners)) < 6.5
    e = errors(refine_corners(v.image, starts(v, 0.5)), v)
    assert e.mean() < 0.05 and e.max() < 0.15


def test_opencv_shapes_in_and_the_input_untouched():
    v = view()
    p = starts(v).astype(np.float32).reshape(-1, 1, 2)
    before = p.copy()
    out = refine_corners(v.image, p, window=(7, 7))
    assert out.shape == (54, 2) and out.dtype == np.float64
    assert np.array_equal(p, before)
    assert errors(out, v).mean() < 0.03


def test_a_point_without_a_corner_keeps_its_start():
    img = np.full((60, 60), 100.0)
    img[:, 30:] = 200.0  # an edge, not an X-corner: no centre of symmetry along the edge
    img[:, :] += np.random.default_rng(0).normal(0, 1, img.shape)
    flat = np.full((60, 60), 128.0)
    xy, q = refine_corners(flat, [[20.0, 20.0]], window=5, return_quality=True)
    assert xy.tolist() == [[20.0, 20.0]] and q[0] == 0.0
    xy, q = refine_corners(img, [[29.5, 30.0]], window=5, return_quality=True)
    assert np.hypot(*(xy[0] - [29.5, 30.0])) <= 5.0


def test_colour_and_float_images():
    v = view()
    colour = np.repeat(v.image[:, :, None], 3, axis=2)
    a = refine_corners(colour, starts(v))
    b = refine_corners(v.image.astype(np.float32) / 255.0, starts(v))
    c = refine_corners(v.image, starts(v))
    assert np.allclose(a, c, atol=1e-9) and np.allclose(b, c, atol=1e-6)


@pytest.mark.parametrize("kwargs, message", [
    (dict(points=np.zeros((3, 3))), "points"), (dict(window=0), "window"), (dict(cell=-1.0), "cell"),
    (dict(max_shift=0.0), "max_shift"), (dict(iterations=0), "iterations"),
    (dict(points=[[np.nan, 1.0]]), "finite"),
])
def test_bad_arguments_are_one_line_errors(kwargs, message):
    args = dict(points=[[10.0, 10.0]])
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        refine_corners(np.zeros((20, 20), np.uint8), **args)
