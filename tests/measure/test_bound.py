"""The pruned measure (``soddc_measure(..., floor=T)``) that detection uses.

Contract: exact, bit for bit as the full map, at every pixel at or above ``T`` and
in the 3x3 patch sub-pixel refinement reads around it; ``-inf`` only where the
measure is below ``T``.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

import sogdd
from sogdd.measure import soddc
from sogdd.measure.filters import basis_tile, kernel_radius, steerable_basis
from sogdd.measure.soddc import soddc_measure
from sogdd.measure.window import reflect_index
from sogdd.select import stage
from sogdd.synthetic import pattern_image

REAL_MIN_PIXELS = soddc.PRUNE_MIN_PIXELS  # read at import, before tests/conftest.py's fixture sets it to 0


def _check_floor_contract(img, spec, floor, **kw):
    full = soddc_measure(img, spec)
    pruned = soddc_measure(img, spec, floor=floor, prune=True, **kw)
    exact = np.isfinite(pruned)
    np.testing.assert_array_equal(pruned[exact], full[exact])
    assert np.all(pruned[~exact] == -np.inf)
    assert np.all(full[~exact] < floor)  # only pixels provably below the floor are skipped
    h, w = full.shape
    if min(h, w) >= 3:  # the 3x3 patch refine_quadratic reads (moved inside at the edges) is exact
        rows, cols = np.nonzero(full >= floor)
        r, c = np.clip(rows, 1, h - 2), np.clip(cols, 1, w - 2)
        dy, dx = np.mgrid[-1:2, -1:2]
        assert exact[r[:, None, None] + dy, c[:, None, None] + dx].all()
    else:
        assert exact.all()
    return exact


def _photo_like(h, w, rng):
    img = ndimage.gaussian_filter(rng.uniform(0, 255, (h, w)), 2.0) * 3 - 250
    img[h // 3 : 2 * h // 3, w // 4 : w // 2] += 90
    return np.clip(img + rng.normal(0, 2, (h, w)), 0, 255)


def test_floor_contract_on_a_pattern_and_pruning_pays(pattern):
    img = pattern[0].astype(np.float64)
    spec = sogdd.resolve_params("paper").measure_spec()
    exact = _check_floor_contract(img, spec, 1e9)
    assert exact.mean() < 0.6  # most of a rendered pattern is proven below T_h


@pytest.mark.parametrize("tile_rows", [1, 4, 7])  # 70 rows: a last tile of 2 rows joins the one before
def test_floor_contract_does_not_depend_on_tiles_or_threads(rng, tile_rows):
    img = _photo_like(70, 300, rng)
    spec = sogdd.resolve_params("paper").measure_spec()
    a = soddc_measure(img, spec, floor=1e8, tile_rows=tile_rows, threads=2, prune=True)
    b = soddc_measure(img, spec, floor=1e8, tile_rows=64, threads=1, prune=True)
    fin = np.isfinite(a) & np.isfinite(b)
    np.testing.assert_array_equal(a[fin], b[fin])
    _check_floor_contract(img, spec, 1e8, tile_rows=tile_rows, threads=2)


@settings(max_examples=40, deadline=None)
@given(
    h=st.integers(2, 40),
    w=st.integers(2, 300),
    k=st.integers(1, 9),
    sigma2=st.floats(0.4, 3.0),
    window=st.sampled_from([1, 3, 5, 7, 9]),
    level=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**31 - 1),
    tile_rows=st.integers(1, 12),
)
def test_floor_contract_random(h, w, k, sigma2, window, level, seed, tile_rows):
    rng = np.random.default_rng(seed)
    img = _photo_like(h, w, rng) if seed % 2 else rng.uniform(0, 255, (h, w))
    spec = sogdd.resolve_params("paper", n_orientations=k, sigma2=sigma2, window=window).measure_spec()
    full = soddc_measure(img, spec)
    pos = full[full > 0]
    floor = float(np.quantile(pos, level)) if pos.size else 1.0
    _check_floor_contract(img, spec, max(floor, 1e-300), tile_rows=tile_rows, threads=2)


def test_floor_needs_a_square_window_and_a_positive_value():
    img = np.zeros((10, 10))
    with pytest.raises(ValueError):
        soddc_measure(img, sogdd.resolve_params("paper", window_shape="disk").measure_spec(), floor=1e9)
    with pytest.raises(ValueError):
        soddc_measure(img, sogdd.resolve_params("paper").measure_spec(), floor=0.0)


@pytest.mark.parametrize("params", [{}, {"nms_radius": 3}, {"levels": 2}, {"threshold": 1e7, "border": 5}])
def test_detection_is_that_of_the_full_map(pattern, rng, monkeypatch, params):
    img = np.clip(pattern[0] + rng.normal(0, 4, pattern[0].shape), 0, 255).astype(np.uint8)
    pruned = sogdd.detect_corners(img, **params)
    monkeypatch.setattr(stage, "_absolute_floor", lambda *a, **k: None)
    full = sogdd.detect_corners(img, **params)
    assert len(pruned) > 10
    np.testing.assert_array_equal(pruned.xy, full.xy)
    np.testing.assert_array_equal(pruned.response, full.response)


def test_relative_and_quantile_thresholds_use_the_full_map():
    p = sogdd.resolve_params("paper", threshold=1e9, threshold_rel=0.01)
    assert stage._absolute_floor(p, p.measure_spec(), p.threshold) is None
    p = sogdd.resolve_params("authors")
    assert stage._absolute_floor(p, p.measure_spec(), p.threshold) is None
    p = sogdd.resolve_params("paper")
    assert stage._absolute_floor(p, p.measure_spec(), p.threshold) == 1e9


@pytest.mark.parametrize("reflect_image", [False, True])
@pytest.mark.parametrize("zero_mean", [False, True])
@pytest.mark.parametrize("shape", [(40, 57), (3, 4), (1, 9)])
def test_basis_tile_is_the_reflected_correlation(reflect_image, zero_mean, shape, rng):
    """The numba separable filter against scipy's 2-D correlation, both padding schemes."""
    img = rng.uniform(0, 255, shape)
    sigma2 = 1.2
    r = kernel_radius(sigma2)
    basis = steerable_basis(sigma2, r, zero_mean=zero_mean)
    H, W = shape
    M, r0, r1 = 4, min(2, H - 1), H
    got = basis_tile(img, r0, r1, M, basis, reflect_image=reflect_image)
    rows = np.arange(r0 - M, r1 + M)
    cols = np.arange(-M, W + M)
    if reflect_image:
        big = np.pad(img, M + r + 2 * max(H, W), mode="symmetric")
        off = M + r + 2 * max(H, W)
        want = np.stack([ndimage.correlate(big, k, mode="constant") for k in basis.kernels()])
        want = want[:, rows[:, None] + off, cols[None, :] + off]
    else:
        want = np.stack([ndimage.correlate(img, k, mode="reflect") for k in basis.kernels()])
        want = want[:, reflect_index(rows, H)[:, None], reflect_index(cols, W)[None, :]]
    scale = np.abs(img).max() * 2
    assert np.max(np.abs(got - want)) <= 1e-12 * scale


@settings(max_examples=30, deadline=None)
@given(
    h=st.integers(1, 30),
    w=st.integers(1, 30),
    radius=st.integers(1, 4),
    border=st.integers(0, 6),
    levels=st.integers(2, 6),
    seed=st.integers(0, 2**31 - 1),
)
def test_peak_scan_equals_the_dilation_definition(h, w, radius, border, levels, seed):
    """select_peaks' compiled scan against threshold & 'equal to the dilated map' & valid area."""
    from sogdd.select.peaks import local_maxima, select_peaks, valid_area

    rng = np.random.default_rng(seed)
    resp = rng.integers(0, levels, (h, w)).astype(np.float64)  # plateaus and ties
    resp[rng.random((h, w)) < 0.1] = -np.inf
    mask = rng.random((h, w)) < 0.8
    thr = float(levels) / 3
    rows, cols = select_peaks(resp, threshold=thr, nms_radius=radius, border=border, mask=mask)
    inner = (slice(border, h - border), slice(border, w - border))
    lm = np.zeros((h, w), dtype=bool)
    if 2 * border < min(h, w):
        lm[inner] = local_maxima(resp[inner], radius)  # maxima of the valid area alone (the authors' rule)
    cand = valid_area(resp.shape, border, mask) & (resp > thr) & lm
    got = set(zip(rows.tolist(), cols.tolist()))
    assert got <= set(zip(*np.nonzero(cand)))
    # the scan of the few pixels above the threshold and the dilation give the same maxima
    from sogdd.select.peaks import count_above, maxima_scan_sparse

    scan = maxima_scan_sparse(resp, thr, radius)
    assert count_above(resp, thr, resp.size + 1) == np.count_nonzero(resp > thr)
    assert count_above(resp, thr, 2) == min(2, np.count_nonzero(resp > thr))
    dense = np.nonzero((resp > thr) & local_maxima(resp, radius))
    np.testing.assert_array_equal(np.stack(scan), np.stack(dense))
    # every candidate is kept or lies within the radius of a kept one of equal value
    for r, c in zip(*np.nonzero(cand)):
        assert any(max(abs(r - r2), abs(c - c2)) <= radius and resp[r2, c2] == resp[r, c] for r2, c2 in got)


@pytest.mark.parametrize("params", [{"threshold_rel": 0.05, "threshold": 1e9},
                                    {"threshold_rel": 0.02, "threshold": None},
                                    {"threshold_rel": 0.01, "threshold": 1e9, "border": 20}])
def test_relative_threshold_prunes_and_detects_as_the_full_map(pattern, rng, monkeypatch, params):
    from sogdd.measure import relative_floor as _relative_floor

    img = np.clip(pattern[0] + rng.normal(0, 4, pattern[0].shape), 0, 255).astype(np.uint8)
    p = sogdd.resolve_params("paper", **params)
    grey = img.astype(np.float64)
    spec = p.measure_spec()
    full = soddc_measure(grey, spec)
    lo = _relative_floor.max_lower_bound(grey, spec, p.border)
    b = p.border
    assert 0 < lo <= full[b : full.shape[0] - b, b : full.shape[1] - b].max()
    floor = _relative_floor.relative_floor(grey, p, spec, threshold=p.threshold)
    assert floor is not None and floor >= p.threshold_rel * lo * 0.999
    assert np.isinf(soddc_measure(grey, spec, floor=floor)).any()  # it prunes (PRUNE_MIN_PIXELS = 0 here)
    pruned = sogdd.detect_corners(img, **params)
    monkeypatch.setattr(stage, "relative_floor", lambda *a, **k: None)
    unpruned = sogdd.detect_corners(img, **params)
    assert len(pruned) > 5
    np.testing.assert_array_equal(pruned.xy, unpruned.xy)
    np.testing.assert_array_equal(pruned.response, unpruned.response)


def test_max_lower_bound_respects_mask_and_border(rng):
    img = _photo_like(90, 120, rng)
    spec = sogdd.resolve_params("paper").measure_spec()
    full = soddc_measure(img, spec)
    mask = np.zeros(img.shape, bool)
    mask[40:70, 50:100] = True
    from sogdd.measure.relative_floor import max_lower_bound

    lo = max_lower_bound(img, spec, 5, mask)
    assert lo <= full[mask].max()
    assert max_lower_bound(img, spec, 60) == -np.inf  # no valid pixel


def test_masks_cover_neighbours_across_tiles_and_edge_patches():
    """A pixel of the tile above or below whose bound reaches the floor marks its 3x3 neighbours here;
    a pixel at or above the floor marks its (edge-shifted) 3x3 patch where nothing was evaluated."""
    from sogdd.measure.bound import need_from_keep, neighbour_need

    keep = np.zeros((6, 9), np.uint8)  # tile of 4 rows x 7 columns, with a ring
    keep[0, 4] = 1  # row -1, column 3
    keep[5, 1] = 1  # row 4 (next tile), column 0: its patch is moved to columns 0..2
    keep[2, 6] = 1
    need = np.empty((4, 7), np.uint8)
    need_from_keep(keep, need)
    want = np.zeros((4, 7), np.uint8)
    want[0, 2:5] = 1
    want[3, 0:3] = 1
    want[1, 5] = 1
    np.testing.assert_array_equal(need, want)
    out = np.full((4, 7), -np.inf)
    out[1, 6] = 5.0  # at the image's right edge: patch columns 4..6
    out[1, 5] = 1.0  # evaluated, below the floor
    lo, hi = neighbour_need(out, 2.0, 10, 100, need)
    want = np.zeros((4, 7), np.uint8)
    want[0:3, 4:7] = 1
    want[1, 5:7] = 0  # already evaluated
    np.testing.assert_array_equal(need, want)
    assert (lo, hi) == (0, 3)
    out[:] = -np.inf
    out[0, 0] = 5.0  # image row 0 (r0 = 0): the patch is rows 0..2
    lo, hi = neighbour_need(out, 2.0, 0, 100, need)
    assert (lo, hi) == (0, 3) and need[:3, :3].sum() == 8 and need.sum() == 8 and need[0, 0] == 0


def test_pruning_runs_where_it_pays_only(pattern):
    """K = 8: the bound runs by default; K = 4 (hr): the full map, which meets the same contract.

    (With the test suite's ``PRUNE_MIN_PIXELS = 0``, ``tests/conftest.py``; the real pixel rule is below.)
    """
    img = pattern[0].astype(np.float64)
    k8 = sogdd.resolve_params("paper").measure_spec()
    k4 = sogdd.resolve_params("hr").measure_spec()
    assert np.isinf(soddc_measure(img, k8, floor=1e9)).any()
    full4 = soddc_measure(img, k4)
    np.testing.assert_array_equal(soddc_measure(img, k4, floor=float(np.quantile(full4, 0.99))), full4)
    assert np.isinf(soddc_measure(img, k4, floor=float(np.quantile(full4, 0.99)), prune=True)).any()


def test_small_maps_are_not_pruned_by_default(monkeypatch):
    """Below ``PRUNE_MIN_PIXELS`` pixels the full map (the bound is not compiled for a first small image);
    above it the bound runs, and a band of a banded detection counts its own pixels."""
    monkeypatch.setattr(soddc, "PRUNE_MIN_PIXELS", REAL_MIN_PIXELS)
    assert REAL_MIN_PIXELS == 1 << 19
    k8 = sogdd.resolve_params("paper").measure_spec()
    small = pattern_image((480, 640))[0]  # 307,200 pixels
    assert not np.isinf(soddc_measure(small, k8, floor=1e9)).any()
    assert np.isinf(soddc_measure(small, k8, floor=1e9, prune=True)).any()
    big = pattern_image((512, 1024))[0]  # exactly 2^19
    assert np.isinf(soddc_measure(big, k8, floor=1e9)).any()
