"""The lattice's pieces: homographies, the leave-one-out check, ray neighbours."""

import numpy as np

from sogdd.calib.targets.lattice import _curved_errors, _edges_follow, apply, check, homography, ray_neighbours
from sogdd.calib.targets.xcorners import XCorners


def grid(n=5, cell=20.0):
    lab = np.array([(i, j) for j in range(n) for i in range(n)], float)
    H = np.array([[cell, 2.0, 30.0], [1.0, cell * 0.9, 40.0], [0.004, 0.002, 1.0]])
    return lab, apply(H, lab), H


def test_homography_recovers_a_perspective_map():
    lab, xy, H = grid()
    G = homography(lab, xy)
    assert np.allclose(G / G[2, 2], H, atol=1e-8)
    assert homography(lab[:5:1][:3], xy[:3]) is None  # too few points
    line = np.c_[np.arange(6.0), np.zeros(6)]
    assert homography(line, line * 3) is None  # all on one line


def test_check_flags_only_the_displaced_corner():
    lab, xy, _ = grid()
    assert check(xy, lab.astype(int)).all()
    xy[12] += [3.0, 0.0]  # the centre, about 0.15 cell off
    ok = check(xy, lab.astype(int))
    assert not ok[12] and ok.sum() == len(ok) - 1


def test_ray_neighbours_link_a_grid_of_x_corners():
    lab, xy, _ = grid(cell=30.0)
    parity = lab.sum(axis=1) % 2
    light = np.where(parity == 0, np.pi / 4, 3 * np.pi / 4)
    xc = XCorners(xy, np.full(len(xy), 100.0), light, np.full(len(xy), np.pi / 4))
    nb, dist = ray_neighbours(xc)
    inner = (lab.min(axis=1) > 0) & (lab.max(axis=1) < 4)
    assert (nb[inner] >= 0).all()
    # the same light axis on both sides: no polarity flip, no neighbours
    same = XCorners(xy, np.full(len(xy), 100.0), np.full(len(xy), np.pi / 4), np.full(len(xy), np.pi / 4))
    assert (ray_neighbours(same)[0] < 0).all()


def barrel_grid(n=7, cell=30.0, k=-0.1):
    """A grid bent by strong barrel distortion ``x_d = x (1 + k r^2)`` about its centre: rows are curves."""
    lab = np.array([(i, j) for j in range(n) for i in range(n)], float)
    u = (lab - (n - 1) / 2) / ((n - 1) / 2) * 0.9 + [0.3, 0.1]
    r2 = (u ** 2).sum(axis=1, keepdims=True)
    return lab.astype(int), 200.0 + cell * (n - 1) / 2 / 0.9 * u * (1 + k * r2)


def test_the_check_follows_curved_rows_but_still_flags_a_displaced_corner():
    lab, xy = barrel_grid()
    assert not check(xy, lab, tol=0.12, curved=False).all()  # beyond a local homography
    assert check(xy, lab, tol=0.12).all()
    for k in (24, 0, 3):  # the centre, a corner of the board, an edge
        bad = xy.copy()
        bad[k, 0] += 0.2 * np.sort(np.hypot(*(xy - xy[k]).T))[1]  # 0.2 of its cell
        ok = check(bad, lab, tol=0.12)
        # a displaced corner may spoil one neighbour's fit too (the detector checks twice)
        assert not ok[k] and ok.sum() >= len(ok) - 2


def test_the_third_order_check_follows_a_stronger_lens_and_flags_a_displaced_corner():
    """A board of 7 x 4 corners through barrel distortion twice as strong: the second order misses it."""
    lab, xy = barrel_grid(k=-0.2)
    keep = lab[:, 1] < 4
    lab, xy = lab[keep], xy[keep]
    assert np.max(_curved_errors(xy, lab, np.arange(len(xy)), 0.12, 2)) > 0.2  # beyond the second order
    assert np.max(_curved_errors(xy, lab, np.arange(len(xy)), 0.12, 3)) < 0.01  # a cubic of the label
    assert check(xy, lab, tol=0.12).all()
    for k in (8, 0, 27):  # inside, a corner of the board, the far corner
        bad = xy.copy()
        bad[k, 1] += 0.25 * np.sort(np.hypot(*(xy - xy[k]).T))[1]
        assert not check(bad, lab, tol=0.12)[k]


def test_edges_follow_a_sheared_cell_by_the_light_axis():
    axes = np.array([[np.cos(a), np.sin(a)] for a in np.radians([30.0, 100.0])])  # 70 degrees apart
    light = np.radians(65.0)  # the bisector
    assert _edges_follow(light, np.radians(35.0), axes)  # the edge lines on the axes
    assert _edges_follow(light, np.radians(60.0), axes)  # a spread 25 degrees too wide (a biased estimate)
    assert not _edges_follow(light + np.radians(15.0), np.radians(50.0), axes)  # the light axis turned
    assert not _edges_follow(light, np.radians(85.0), axes)  # edge lines 50 degrees off
