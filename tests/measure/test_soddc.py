import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sogdd
from sogdd.measure.filters import kernel_radius, orientations, sogdd_kernel
from sogdd.measure.oracle import reference_lambda, reference_measure
from sogdd.measure.soddc import VARSIGMA, soddc_measure
from sogdd.measure.window import window_halfwidths, window_offsets


def _assert_exact(fast, ref, floor=1e6):
    m = np.abs(ref) >= floor
    assert m.any()
    rel = np.abs(fast[m] - ref[m]) / np.abs(ref[m])
    assert rel.max() <= 1e-6, rel.max()


def _structured(h, w, rng):
    img = rng.uniform(0, 60, (h, w))
    img[h // 4 : 3 * h // 4, w // 5 : w // 2] += 150
    yy, xx = np.mgrid[:h, :w]
    img[(xx - yy) > w // 2] += 80
    return np.clip(img, 0, 255)


@pytest.mark.parametrize("preset", ["paper", "authors"])
@pytest.mark.parametrize("shape", [(37, 300), (64, 61)])
def test_fast_measure_equals_definition(preset, shape, rng):
    img = _structured(*shape, rng)
    spec = sogdd.resolve_params(preset).measure_spec()
    ref = reference_measure(img, spec)
    # small tiles and a width over the column block exercise every seam
    fast = soddc_measure(img, spec, tile_rows=9, threads=2)
    _assert_exact(fast, ref)
    # column sums are direct, so the result does not depend on tiling or threads
    np.testing.assert_array_equal(fast, soddc_measure(img, spec, tile_rows=64, threads=1))


def test_public_response_is_float64_map(pattern):
    img, _ = pattern
    r = sogdd.corner_response(img)
    assert r.dtype == np.float64 and r.shape == img.shape
    assert r.max() > 1e9  # strong rendered corners pass the paper threshold


@settings(max_examples=15, deadline=None)
@given(
    h=st.integers(3, 24),
    w=st.integers(3, 24),
    k=st.integers(1, 8),
    sigma2=st.floats(0.5, 3.0),
    window=st.sampled_from([1, 3, 5, 7]),
    shape=st.sampled_from(["square", "disk"]),
    seed=st.integers(0, 2**31 - 1),
)
def test_fast_equals_definition_random(h, w, k, sigma2, window, shape, seed):
    img = np.random.default_rng(seed).uniform(0, 255, (h, w))
    spec = sogdd.resolve_params(
        "paper", n_orientations=k, sigma2=sigma2, window=window, window_shape=shape
    ).measure_spec()
    ref = reference_measure(img, spec)
    fast = soddc_measure(img, spec, tile_rows=5)
    # The contract: relative 1e-6 wherever Upsilon >= 1e6 and Lambda is not nearly
    # singular. No float64 evaluation of det can promise more than ~cond * eps.
    lam = reference_lambda(img, spec)
    cond = np.linalg.cond(lam)
    m = (np.abs(ref) >= 1e6) & (cond <= 1e8)
    rel = np.abs(fast[m] - ref[m]) / np.abs(ref[m])
    assert rel.size == 0 or rel.max() <= 1e-6
    # Every draw compares every pixel too (K = 1 and 1x1 windows included): the
    # rounding error of det is a small multiple of Hadamard's bound prod(Lambda_kk)
    # >= det, so |fast - ref| stays a tiny fraction of prod(Lambda_kk) / (tr + varsigma).
    diag = np.diagonal(lam, axis1=2, axis2=3)
    hadamard = np.prod(diag, axis=2) / (diag.sum(axis=2) + VARSIGMA)
    assert np.isfinite(fast).all()
    assert np.all(np.abs(fast - ref) <= 1e-9 * hadamard + 1e-300)


def test_absolute_value_is_what_makes_the_measure_nonzero(pattern):
    """Without |.| the K responses span 3 dimensions, so Lambda is singular for K > 3."""
    img8 = pattern[0]
    img = img8.astype(np.float64)
    sigma2, K, r = 1.2, 8, kernel_radius(1.2)
    from scipy import ndimage

    resp = np.stack(
        [ndimage.convolve(img, sogdd_kernel(sigma2, t, r), mode="reflect") for t in orientations(K)]
    )
    y, x = np.unravel_index(np.argmax(sogdd.corner_response(img8)), img.shape)
    win = resp[:, y - 3 : y + 4, x - 3 : x + 4].reshape(K, -1)
    signed = np.linalg.eigvalsh(win @ win.T)
    absolute = np.linalg.eigvalsh(np.abs(win) @ np.abs(win).T)
    assert signed[:5].max() <= 1e-9 * signed.max()  # rank 3
    assert absolute.min() > 1e-6 * absolute.max()  # full rank
    lam = np.abs(win) @ np.abs(win).T
    ups = np.linalg.det(lam) / (np.trace(lam) + VARSIGMA)
    assert ups == pytest.approx(sogdd.corner_response(img8)[y, x], rel=1e-9)


def test_windows():
    assert len(window_offsets(window_halfwidths("disk", 5))) == 21
    assert all(dy * dy + dx * dx <= 5 for dy, dx in window_offsets(window_halfwidths("disk", 5)))
    assert len(window_offsets(window_halfwidths("square", 7))) == 49


def test_flat_image_has_zero_response():
    r = sogdd.corner_response(np.full((20, 20), 128, np.uint8))
    assert np.abs(r).max() < 1e-6


def test_authors_measure_rules(rng):
    img = _structured(40, 40, rng)
    r = sogdd.corner_response(img / 255.0, preset="authors")
    assert np.isfinite(r[r > -np.inf]).all()
    assert (r >= 0).mean() > 0.99  # tiny negative dets clamped to 0


def test_authors_measure_equals_the_numpy_rules(rng):
    """The compiled post-processing against the authors' rules written with numpy."""
    from sogdd.measure.soddc import authors_measure

    eps = float(np.finfo(np.float64).eps)
    for t in range(60):
        h, w = rng.integers(0, 20, 2)
        det = rng.normal(size=(h, w)) * 10.0 ** rng.integers(-20, 40)
        tr = np.abs(rng.normal(size=(h, w))) * 10.0 ** rng.integers(-20, 20)
        det[rng.random((h, w)) < 0.2] *= -1e-18  # tiny negatives, clamped
        det[rng.random((h, w)) < 0.05] = 0.0
        tr[rng.random((h, w)) < 0.05] = -eps  # 0 / 0 and x / 0
        if t % 7 == 0 and det.size:
            det.flat[0] = np.nan
        big = np.max(np.abs(det)) if det.size else 0.0
        d = np.where((det < 0) & (det >= -eps * big), 0.0, det)
        with np.errstate(all="ignore"):
            want = d / (tr + eps)
        want[~np.isfinite(want)] = -np.inf
        np.testing.assert_array_equal(authors_measure(det, tr), want)


def test_generic_responses_entry_matches_definition(rng):
    """soddc_from_responses (the path of the non-steerable baselines) against a direct sum."""
    from sogdd.measure.soddc import soddc_from_responses

    K, H, W = 5, 23, 290
    resp = rng.normal(0, 30, (K, H, W))
    halfw = window_halfwidths("disk", 7)
    fast = soddc_from_responses(resp, halfw, tile_rows=6)
    R = 3
    pad = np.pad(np.abs(resp), ((0, 0), (R, R), (R, R)), mode="symmetric")
    lam = np.zeros((H, W, K, K))
    for dy, dx in window_offsets(halfw):
        v = pad[:, R + dy : R + dy + H, R + dx : R + dx + W]
        lam += np.einsum("ihw,jhw->hwij", v, v)
    ref = np.linalg.det(lam) / (np.trace(lam, axis1=2, axis2=3) + VARSIGMA)
    m = (ref >= 1e6) & (np.linalg.cond(lam) <= 1e8)
    assert m.mean() > 0.5
    assert np.max(np.abs(fast[m] - ref[m]) / ref[m]) <= 1e-6
    with pytest.raises(ValueError):
        soddc_from_responses(resp, np.array([1, 1]))
