"""X-junction stage and grey-level units (sogdd.select.x_junctions), with explicit parameters."""

from __future__ import annotations

import numpy as np
import pytest

import sogdd
from sogdd.measure.oracle import reference_measure
from sogdd.measure.units import corner_unit, grey_strength, measure_threshold
from sogdd.params import resolve_params
from sogdd.select.x_junctions import find_saddles
from sogdd.synthetic import Polygon, pattern_image, render_polygons

GREY = dict(n_orientations=4, threshold_units="grey")


def test_grey_units_round_trip():
    spec = resolve_params("paper", threshold=None, **GREY).measure_spec()
    for t in (1.0, 17.0, 100.0):
        assert grey_strength(np.array([measure_threshold(t, spec)]), spec)[0] == pytest.approx(t, rel=1e-12)


def test_corner_unit_is_the_l_corner_peak_by_the_definition():
    """The calibration constant against the direct eq. 22-25 computation (sogdd.measure.oracle)."""
    from sogdd.measure.units import calibration_images

    spec = resolve_params("paper", threshold=None, **GREY).measure_spec()
    L, _ = calibration_images()
    assert corner_unit(spec) == pytest.approx(float(reference_measure(L, spec).max()), rel=1e-9)


def test_grey_threshold_scales_with_contrast():
    """Contrast x a scales every strength by a: threshold a*T keeps exactly the same corners."""
    img, _ = pattern_image((160, 200))
    base = img.astype(np.float64)
    dim = base * 0.4 / 255.0  # dim copy; an offset would leak through the kernels' ~1e-5 mean
    a = sogdd.detect_corners(base / 255.0, threshold=40.0, x_junctions=True, **GREY)
    b = sogdd.detect_corners(dim, threshold=16.0, x_junctions=True, **GREY)
    assert len(a) > 10 and len(a) == len(b)
    # float32 inside cv2.cornerSubPix: positions agree to ~1e-5 px, not bit for bit
    np.testing.assert_allclose(b.xy, a.xy, atol=1e-4)
    np.testing.assert_allclose(b.response, 0.4 * a.response, rtol=1e-9)


def test_saddle_on_an_x_junction_and_none_on_an_l_apex():
    q = np.array([[30.4, 30.7], [90, 30.7], [90, 90], [30.4, 90]])
    x_img = render_polygons((61, 61), [Polygon(q, 200.0), Polygon(2 * q[0] - q, 200.0)], background=50.0)
    xy, s = find_saddles(x_img, 1.2)
    best = xy[np.argmax(s)]
    assert np.hypot(*(best - q[0])) < 0.05
    l_img = render_polygons((61, 61), [Polygon(q, 200.0)], background=50.0)
    xy, s = find_saddles(l_img, 1.2)
    assert len(s) == 0  # the apex's iterate leaves the pixel; a clean L-corner has no saddle at all


def test_x_junctions_need_grey_units():
    with pytest.raises(ValueError, match="x_junctions needs threshold_units='grey'"):
        resolve_params("paper", x_junctions=True)
    with pytest.raises(ValueError, match="threshold_units must be"):
        resolve_params("paper", threshold_units="volts")


def test_one_per_point_keeps_the_strongest_greedily():
    """Points that converged together are one; a chain keeps what the strongest leaves."""
    from sogdd.select.refine import one_per_point

    xy = np.array([[10.0, 10.0], [10.06, 10.0], [10.12, 10.0], [30.0, 5.0], [30.0, 5.05]])
    s = np.array([2.0, 3.0, 1.0, 5.0, 5.0])
    # 1 is strongest near 0 and 2 (0.06 px each): both dropped; 3 and 4 tie: the first is kept
    assert one_per_point(xy, s, 0.1).tolist() == [1, 3]
    s2 = np.array([3.0, 2.0, 1.0, 5.0, 4.0])
    # 0 drops 1; 2 is 0.12 px from 0, so it stays (1, dropped, suppresses nothing)
    assert one_per_point(xy, s2, 0.1).tolist() == [0, 2, 3]


def test_newton_steps_reusing_a_cell_are_the_steps_taken_one_call_at_a_time():
    """An iterate that stays in its pixel's cell reads the derivatives computed there again: the same bits
    as steps taken one call at a time (each call starts with no cell), from the image or a crop of it."""
    from sogdd.measure.filters import kernel_radius, steerable_basis
    from sogdd.select.x_junctions import newton_steps

    t = np.arange(64) - 30.4
    board = np.where((t[:, None] > 0) == (t[None, :] + 0.7 > 0), 200.0, 40.0)  # an X-junction
    rng = np.random.default_rng(0)
    img = np.clip(np.pad(board, ((3, 9), (20, 5)), mode="reflect") + rng.normal(0, 3.0, (76, 89)), 0, 255)
    H, W = img.shape
    b = steerable_basis(1.5, kernel_radius(1.5))
    xy, st = find_saddles(img, 1.5)
    sx, sy = xy[np.argmax(st)]
    near = np.array([(sx + a, sy + c) for a in (-0.7, 0, 0.7) for c in (-0.7, 0, 0.7)])  # these converge
    x0 = np.r_[near[:, 0], rng.uniform(-1, W, 200), [0.0, W - 1.0, 3.0]]
    y0 = np.r_[near[:, 1], rng.uniform(-1, H, 200), [0.0, H - 1.0, H - 2.0]]
    runs = []
    for off, crop in ((0, img), (20, img[20:60])):  # the image; a crop of rows, where iterates stop at its edge
        at_once = [x0.copy(), y0.copy(), np.zeros(len(x0), np.int64)]
        newton_steps(crop, off, H, W, *at_once, 6, b.gauss, b.d1, b.d2)
        one_by_one = [x0.copy(), y0.copy(), np.zeros(len(x0), np.int64)]
        for k in range(1, 7):
            newton_steps(crop, off, H, W, *one_by_one, k, b.gauss, b.d1, b.d2)
        for g, w in zip(at_once, one_by_one):
            assert np.array_equal(g, w)
        runs.append(at_once)
    assert (runs[0][2] == 6).all() and (runs[1][2] < 6).any()  # the crop stopped some
    conv = np.hypot(runs[0][0][:9] - sx, runs[0][1][:9] - sy)
    assert conv.max() < 1e-3  # ... and these found the junction: iterates that stayed in one cell
