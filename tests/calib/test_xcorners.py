"""X-corner candidates: positions, edge lines and light axes on a rendered board."""

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from sogdd.calib.targets.xcorners import find_xcorners
from sogdd.evaluation.calibration.render import Camera, ChessboardTarget, render_view

CAM = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (0.0, 0, 0, 0), (480, 360))


def board(roll=0.4):
    R = np.array([0.0, 0.0, roll])
    Rm, _ = cv2.Rodrigues(R)
    t = np.array([0.0, 0.0, 0.8]) - Rm @ np.array([0.12, 0.075, 0.0])
    return render_view(CAM, ChessboardTarget(9, 6, 0.03), R, t, blur=1.0, noise=2.0, rng=2), roll


def test_every_corner_with_its_edge_lines_and_alternating_light_axis():
    v, roll = board()
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


def test_mask_and_scale():
    v, _ = board()
    mask = np.zeros(v.image.shape, bool)
    mask[:, :240] = True
    assert np.all(find_xcorners(v.image, mask=mask).xy[:, 0] < 240.5)
    coarse = find_xcorners(v.image, scale=0.5)
    assert cKDTree(coarse.xy).query(v.corners)[0].max() < 1.0


@pytest.mark.parametrize("kwargs, message", [
    (dict(min_strength=-1.0), "min_strength"), (dict(scale=0.0), "scale"), (dict(mask=np.ones((3, 3))), "mask"),
])
def test_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        find_xcorners(np.zeros((20, 20), np.uint8), **kwargs)
