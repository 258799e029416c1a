"""The lattice's pieces: homographies, the leave-one-out check, ray neighbours."""

import numpy as np
import pytest

from sogdd.calib.targets.chessboard.lattice import _edges_follow, ray_neighbours
from sogdd.calib.targets.chessboard.mapping import _curved_errors, apply, check, homography
from sogdd.calib.targets.chessboard.xcorners import XCorners


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


def test_ray_neighbours_follow_the_lattice_where_the_hessians_spread_is_biased():
    """A grid sheared to axes at 8 and 53 degrees (a board tilted far from the camera): the true edge lines lie
    22.5 degrees either side of the light axis, but the Hessian's spread, biased towards 45 degrees by the
    smoothing (and a smear), says 44. The rays along the spread the neighbours draw link the grid all the same;
    along the Hessian's alone, no corner has a neighbour on every ray."""
    n = 6
    lab = np.array([(i, j) for j in range(n) for i in range(n)], float)
    a0, a1 = np.radians(8.0), np.radians(53.0)
    axes = 30.0 * np.array([[np.cos(a0), np.sin(a0)], [np.cos(a1), np.sin(a1)]])
    xy = 50.0 + lab @ axes
    mid = (a0 + a1) / 2  # the light axis bisects the edge lines; it turns by 90 degrees at each step
    light = np.mod(np.where(lab.sum(axis=1) % 2 == 0, mid, mid + np.pi / 2), np.pi)
    biased = XCorners(xy, np.full(len(xy), 100.0), light, np.full(len(xy), np.radians(44.0)))
    inner = np.flatnonzero((lab.min(axis=1) > 0) & (lab.max(axis=1) < n - 1))

    def linked(nb):  # the inner corners whose four rays reach exactly their four edge neighbours
        return sum(set(nb[k].tolist()) == {k + 1, k - 1, k + n, k - n} for k in inner)

    assert linked(ray_neighbours(biased)[0]) == len(inner)
    import sogdd.calib.targets.chessboard.lattice as lattice

    own = np.full((len(xy), 4), -1, dtype=np.int64)  # the test along the Hessian's edge lines alone
    d = np.hypot(*(xy[None] - xy[:, None]).transpose(2, 0, 1))
    order = np.argsort(d, axis=1)[:, 1:]
    v = xy[order] - xy[:, None]
    ang = np.arctan2(v[..., 1], v[..., 0])
    lattice._rays(np.take_along_axis(d, order, axis=1), order.astype(np.int64), ang, light, biased.spread,
                  biased.edges, own, np.full((len(xy), 4), np.inf))
    assert linked(own) <= len(inner) // 4


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


def test_the_compiled_mod_is_numpys_to_the_bit():
    """The growth's angle wraps (compiled, mostly without fmod) give numpy's mod, signs of zeros too."""
    from sogdd.calib.targets.chessboard.lattice import _mod

    rng = np.random.default_rng(3)
    for b in (np.pi, 2 * np.pi):
        edge = [0.0, -0.0, b, -b, 2 * b, -2 * b, np.nextafter(b, 0), -np.nextafter(b, 0), 1e-300, -1e-300,
                -1e-17, np.nextafter(2 * b, 0), -np.nextafter(2 * b, 0), 7 * b, -7.5 * b]
        a = np.r_[rng.uniform(-3 * b, 3 * b, 20000), b / 2 + rng.normal(size=2000) * 1e-13, edge]
        got = np.array([_mod(v, b) for v in a])
        want = np.mod(a, b)
        assert np.array_equal(got, want) and np.array_equal(np.signbit(got), np.signbit(want))


def _einsum_normal_equations(w, b, offs, m0):
    """The normal equations of ``_fit_batch`` as numpy's einsums write them (the reference)."""
    m = np.broadcast_to(m0, b.shape[:2] + m0.shape[-1:])
    z = np.zeros_like(m)
    a = np.broadcast_to(offs, b.shape)
    r1 = np.concatenate([m, z, -b[..., :1] * a], axis=-1)
    r2 = np.concatenate([z, m, -b[..., 1:] * a], axis=-1)
    A = np.einsum("nk,nki,nkj->nij", w, r1, r1) + np.einsum("nk,nki,nkj->nij", w, r2, r2)
    rhs = np.einsum("nk,nki,nk->ni", w, r1, b[..., 0]) + np.einsum("nk,nki,nk->ni", w, r2, b[..., 1])
    return A + 1e-12 * np.eye(A.shape[-1]), rhs


@pytest.mark.parametrize("order", [1, 2, 3])
def test_the_compiled_normal_equations_are_the_einsums_to_the_bit(order):
    from sogdd.calib.targets.chessboard.mapping import _CURVE_OFFS, SUPPORT, _monomials, _normal_equations

    rng = np.random.default_rng(order)
    offs = (SUPPORT if order == 1 else _CURVE_OFFS).astype(float)
    m0 = _monomials(offs, order)
    for n in (1, 7, 30):
        w = (rng.random((n, len(offs))) < 0.6).astype(float)
        b = rng.normal(size=(n, len(offs), 2)) * 10.0 ** rng.uniform(-3, 3, size=(n, len(offs), 1))
        got = _normal_equations(w, b, offs, np.ascontiguousarray(m0))
        for g, e in zip(got, _einsum_normal_equations(w, b, offs, m0)):
            assert np.array_equal(g, e) and np.array_equal(np.signbit(g), np.signbit(e))


def x_corner_grid(cols, rows, cell=14.0, seed=0):
    """X-corners of a ``cols x rows`` chessboard seen through a mild perspective, with their labels."""
    lab = np.array([(i, j) for j in range(rows) for i in range(cols)])
    H = np.array([[cell, 0.08 * cell, 40.0], [-0.05 * cell, 0.95 * cell, 30.0], [2e-4, 1e-4, 1.0]])
    xy = apply(H, lab.astype(float)) + np.random.default_rng(seed).normal(0, 0.05, (len(lab), 2))
    parity = lab.sum(axis=1) % 2
    light = np.where(parity == 0, np.pi / 4, 3 * np.pi / 4)
    return XCorners(xy, np.full(len(xy), 100.0), light, np.full(len(xy), np.pi / 4)), lab


@pytest.mark.parametrize("size", [(6, 4), (45, 40)])  # the second outgrows the label grid several times
def test_grow_labels_every_corner_of_a_board_from_its_seed(size):
    from sogdd.calib.targets.chessboard.lattice import grow, seeds

    xc, lab = x_corner_grid(*size)
    nb, dist = ray_neighbours(xc)
    s = int(seeds(xc, nb, dist)[0])
    free = np.ones(len(xc), bool)
    lat = grow(xc, s, nb, free)
    assert len(lat) == len(xc) and not free.any()
    assert lat.index[0] == s and lat.labels[0].tolist() == [0, 0]
    assert len(np.unique(lat.index)) == len(lat)
    # the labels are the board's, up to one of the lattice's eight symmetries and a shift
    true = lab[lat.index] - lab[s]
    A = np.linalg.lstsq(lat.labels.astype(float), true.astype(float), rcond=None)[0]
    assert np.allclose(np.abs(A), np.round(np.abs(A))) and np.array_equal(lat.labels @ np.round(A), true)


def test_grow_keeps_within_a_limit():
    from sogdd.calib.targets.chessboard.lattice import grow, seeds

    xc, _ = x_corner_grid(9, 7)
    nb, dist = ray_neighbours(xc)
    s = int(seeds(xc, nb, dist)[0])
    lat = grow(xc, s, nb, np.ones(len(xc), bool), limit=4)
    ext = lat.labels.max(axis=0) - lat.labels.min(axis=0) + 1
    assert ext.max() <= 4 and len(lat) == 16
