"""X-corner candidates: positions, edge lines and light axes on a rendered board."""

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.chessboard import xcorners
from sogdd.calib.targets.chessboard.xcorners import default_scale, find_xcorners
from sogdd.params import Params

CAM = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (0.0, 0, 0, 0), (480, 360))


def board(render, roll=0.4):
    R = np.array([0.0, 0.0, roll])
    Rm, _ = cv2.Rodrigues(R)
    t = np.array([0.0, 0.0, 0.8]) - Rm @ np.array([0.12, 0.075, 0.0])
    return render.render_view(CAM, render.Board(9, 6, 0.03), R, t, blur=1.0, noise=2.0, rng=2), roll


def pasted(v, size=(2400, 1800), at=(1013, 687)):
    """The view pasted into a large frame of the renderer's background level: the truth moves by ``at``.

    A frame above the search's pixel budget, for the cost of rendering a small one.
    """
    img = np.full(size[::-1], 110, np.uint8)  # the renderer's background level
    h, w = v.image.shape
    img[at[1] : at[1] + h, at[0] : at[0] + w] = v.image
    return img, v.corners + np.asarray(at, float)


def test_every_corner_with_its_edge_lines_and_alternating_light_axis(render):
    v, roll = board(render)
    xc = find_xcorners(v.image)
    d, k = cKDTree(xc.xy).query(v.corners)
    assert d.max() < 0.3  # every inner corner is a candidate
    edges = np.sort(xc.edges[k], axis=1)
    truth = np.sort(np.mod([roll, roll + np.pi / 2], np.pi))
    assert np.abs(edges - truth).max() < np.radians(4)
    parity = v.labels.sum(axis=1) % 2
    light = xc.light[k]
    turn = np.abs(np.mod(light - light[0] + np.pi / 2, np.pi) - np.pi / 2)  # 0 or pi/2
    assert np.array_equal(turn > np.pi / 4, parity != parity[0])
    assert np.all(np.abs(xc.spread[k] - np.pi / 4) < np.radians(4))  # perpendicular edges
    # the board's contrast (35 to 215) times sigma^2 / (sigma^2 + blur^2) = 1.5 / 2.5 at the search scale
    assert np.all(np.abs(xc.strength[k] - 108) < 15)


def test_mask(render):
    v, _ = board(render)
    mask = np.zeros(v.image.shape, bool)
    mask[:, :240] = True
    xy = find_xcorners(v.image, mask=mask).xy
    assert len(xy) >= 20 and np.all(xy[:, 0] < 240.5)


def test_a_reduced_scale_maps_the_points_back_without_a_shift(render):
    # a point x' at scale s is x = (x' + 1/2) / s - 1/2 at full scale (pixel centres at integers);
    # x' / s instead moves every point by 1/2 (1/s - 1) px, 0.5 at s = 1/2, 0.24 at the default 0.68
    v, _ = board(render)
    big, truth = pasted(v)
    assert default_scale(big.shape) < 0.7  # the default really searches at a reduced scale
    for img, at, scale in ((v.image, v.corners, 0.5), (big, truth, None)):
        xc = find_xcorners(img, scale=scale)
        d, k = cKDTree(xc.xy).query(at)
        err = xc.xy[k] - at
        assert d.max() < 0.25, scale
        assert np.all(np.abs(err.mean(axis=0)) < 0.1), scale  # no common shift


def test_search_scale_is_the_hr_presets():
    assert xcorners.SIGMA2 == Params.preset("hr").sigma2


def test_float_images_follow_the_cores_contract(render):
    # floats on [0, 1], else value_range, as sogdd.image.to_gray255: the same candidates as the uint8 image
    v, _ = board(render)
    ref = find_xcorners(v.image)
    levels = v.image.astype(np.float32)
    with pytest.raises(ValueError, match=r"float images must be on \[0, 1\].*value_range"):
        find_xcorners(levels)
    for img, rng in ((levels, (0, 255)), (levels / 255, None), (v.image.astype(np.uint16) * 16, (0, 4080))):
        xc = find_xcorners(img, value_range=rng)
        assert len(xc) == len(ref)
        assert cKDTree(xc.xy).query(ref.xy)[0].max() < 1e-3
        assert np.allclose(np.sort(xc.strength), np.sort(ref.strength), rtol=1e-4)


@pytest.mark.parametrize("kwargs, message", [
    (dict(min_strength=-1.0), "min_strength"), (dict(scale=0.0), "scale"), (dict(mask=np.ones((3, 3))), "mask"),
    (dict(value_range=(1, 1)), "value_range"),
])
def test_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        find_xcorners(np.zeros((20, 20), np.uint8), **kwargs)


def test_too_small_or_not_an_array():
    with pytest.raises(ValueError, match="8 x 8"):
        find_xcorners(np.zeros((7, 40), np.uint8))
    with pytest.raises(TypeError, match="numpy array"):
        find_xcorners([[0, 1], [1, 0]])
