"""The hr preset on the compiled kernel: weighted window sums, pruning, bands, saddles in bands.

The Gaussian window's sums run in the tiled kernel (weighted column sums, then
row sums, in a fixed order): ~1e-15 relative from the literal definition
(another rounding order), and bit for bit the same whatever the tiles, threads,
masks and bands.
"""

import cv2
import numpy as np
import pytest
from scipy import ndimage

import sogdd
from sogdd.image.rows import exact_grey
from sogdd.measure.filters import basis_tile, kernel_radius, steerable_basis
from sogdd.measure.gaussian_window import gaussian_window_reference, gaussian_window_spec
from sogdd.measure.soddc import soddc_measure
from sogdd.measure.units import measure_threshold
from sogdd.select import x_junctions as saddles
from sogdd.select.bands import stream_peaks
from sogdd.select.peaks import select_peaks
from sogdd.select.refine import refine_quadratic
from sogdd.select.x_junctions import _derivatives, _rows_of, find_saddles, strength_maxima


def second_derivatives(grey, sigma2, radius):
    """(g_xx, g_xy, g_yy) of the whole image, filtered as the measure filters it (basis_tile)."""
    g = basis_tile(grey, 0, grey.shape[0], 0, steerable_basis(sigma2, radius), reflect_image=False)
    return g[0], g[1], g[2]


def bilinear_rows(maps, off, H, W, x, y):
    """Each map at sub-pixel points (bilinear, edge-clamped), float64: the oracle of the compiled sampler."""
    x0, x1 = _rows_of(x, W)
    y0, y1 = _rows_of(y, H)
    fx, fy = np.clip(x, 0.0, W - 1.0) - x0, np.clip(y, 0.0, H - 1.0) - y0
    r0, r1 = y0 - off, y1 - off
    return [((m[r0, x0] * (1 - fx) + m[r0, x1] * fx) * (1 - fy) + (m[r1, x0] * (1 - fx) + m[r1, x1] * fx) * fy)
            for m in maps]


def derivatives_bilinear(img, off, H, W, x, y, gauss, d1, d2):
    """The compiled derivatives at points (x_junctions._derivatives, the Newton steps' own evaluation)."""
    out = np.empty((5, len(x)))
    xs, ys = np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64)
    _derivatives(exact_grey(img), off, H, W, xs, ys, gauss, d1, d2, out)
    return out

def _photo_like(h, w, seed=3):
    rng = np.random.default_rng(seed)
    img = ndimage.gaussian_filter(rng.uniform(0, 255, (h, w)), 1.5) * 3 - 250
    img[h // 3 : 2 * h // 3, w // 4 : w // 2] += 90
    img[h // 2 :, w // 2 :: 8] += 60  # stripes: saddles and close corners
    return np.clip(img + rng.normal(0, 2, (h, w)), 0, 255)


HR = sogdd.resolve_params("hr").measure_spec()


@pytest.mark.parametrize("shape", [(3, 4), (9, 5), (41, 57)])
@pytest.mark.parametrize("spec", [HR, gaussian_window_spec(1.2, 8, 5), gaussian_window_spec(2.0, 2, 7),
                                  gaussian_window_spec(1.44, 4, 3, "authors", True)])
def test_weighted_kernel_equals_the_definition(shape, spec):
    img = _photo_like(*shape)
    ref = gaussian_window_reference(img, spec)
    fast = soddc_measure(img, spec)
    # K = 8 responses of a 3-dimensional basis: Lambda is close to rank 3 on a tiny image, and det
    # amplifies any rounding (the OpenCV-filter implementation before this one was 1.6e-8 off at 3 x 4)
    tol = 1e-12 if spec.n_orientations <= 4 or min(shape) > 3 else 1e-7
    assert np.max(np.abs(fast - ref)) <= tol * np.max(np.abs(ref))


@pytest.mark.parametrize("tile_rows,threads", [(1, 2), (3, 1), (5, 2), (128, 1)])
def test_weighted_kernel_does_not_depend_on_tiles_or_threads(tile_rows, threads):
    img = _photo_like(23, 61)
    base = soddc_measure(img, HR, tile_rows=64, threads=1)
    np.testing.assert_array_equal(soddc_measure(img, HR, tile_rows=tile_rows, threads=threads), base)
    ref = gaussian_window_reference(img, HR)
    assert np.max(np.abs(base - ref)) <= 1e-12 * ref.max()


@pytest.mark.parametrize("tile_rows", [3, 7, 128])
def test_pruned_hr_measure_is_the_full_one_where_it_matters(tile_rows):
    rng = np.random.default_rng(5)
    img = np.clip(sogdd.synthetic.pattern_image((120, 160))[0] + rng.normal(0, 2, (120, 160)), 0, 255)
    floor = measure_threshold(20.0, HR)
    full = soddc_measure(img, HR)
    pruned = soddc_measure(img, HR, floor=floor, tile_rows=tile_rows, threads=2, prune=True)
    exact = np.isfinite(pruned)
    np.testing.assert_array_equal(pruned[exact], full[exact])
    assert np.all(pruned[~exact] == -np.inf) and np.all(full[~exact] < floor)
    rows, cols = np.nonzero(full >= floor)
    assert len(rows) > 20
    r, c = np.clip(rows, 1, 118), np.clip(cols, 1, 158)
    dy, dx = np.mgrid[-1:2, -1:2]
    assert exact[r[:, None, None] + dy, c[:, None, None] + dx].all()  # refine_quadratic's patches
    assert exact.mean() < 0.9  # the bound proves pixels below the floor


@pytest.mark.parametrize("band_rows", [1, 6, 1024])
def test_banded_hr_peaks_equal_the_full_map(band_rows):
    img = _photo_like(64, 90)
    p = sogdd.resolve_params("hr")
    thr = measure_threshold(p.threshold, HR)
    full = soddc_measure(img, HR)
    rows, cols = select_peaks(full, threshold=thr, nms_radius=1, border=2)
    got = stream_peaks(img, HR, threshold=thr, floor=thr, border=2, band_rows=band_rows, quadratic=True)
    assert len(rows) > 10
    np.testing.assert_array_equal(got[0], rows)
    np.testing.assert_array_equal(got[1], cols)
    np.testing.assert_array_equal(got[2], full[rows, cols])
    np.testing.assert_array_equal(got[3], refine_quadratic(full, rows, cols))


@pytest.mark.parametrize("band_rows,slack", [(256, 16), (5, 0), (1, 0), (2, 3)])
def test_saddles_in_bands_equal_the_whole_image(band_rows, slack, monkeypatch):
    """Maps in bands, Newton steps in crops: the whole image's points, for any band and crop size."""
    img = _photo_like(60, 80)
    r = kernel_radius(1.5)
    continued = []
    steps = saddles.newton_steps

    def spy(*a):
        continued.append(bool((a[6] > 0).any()))  # a point that left a crop and goes on in another
        return steps(*a)

    want = [find_saddles(img, 1.5, r, min_strength=ms, band_rows=60) for ms in (0.0, 3.0)]
    monkeypatch.setattr(saddles, "newton_steps", spy)
    monkeypatch.setattr(saddles, "SLACK", slack)
    for ms, w in zip((0.0, 3.0), want):
        got = find_saddles(img, 1.5, r, min_strength=ms, band_rows=band_rows)
        assert len(w[0]) > 5
        np.testing.assert_array_equal(got[0], w[0])
        np.testing.assert_array_equal(got[1], w[1])
    if slack == 0:
        assert any(continued)  # points that left their crop took the second path


@pytest.mark.parametrize("shape", [(1, 7), (7, 1), (2, 2), (30, 41)])
def test_saddle_derivatives_are_the_filtered_maps_interpolated(shape):
    """Hessian and gradient at Newton iterates, from the image, equal the filtered maps interpolated."""
    rng = np.random.default_rng(1)
    img = rng.uniform(0, 255, shape)
    b = steerable_basis(1.5, 5)
    H, W = shape
    maps = list(second_derivatives(img, 1.5, 5)) + [
        cv2.sepFilter2D(img, cv2.CV_64F, kx, ky, borderType=cv2.BORDER_REFLECT)
        for kx, ky in ((b.d1, b.gauss), (b.gauss, b.d1))]
    x, y = rng.uniform(-1, W, 50), rng.uniform(-1, H, 50)
    want = bilinear_rows(maps, 0, H, W, x, y)
    got = derivatives_bilinear(img, 0, H, W, x, y, b.gauss, b.d1, b.d2)
    assert got.shape == (5, 50)
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-12 * max(1.0, np.abs(w).max()))
    if H > 20:  # rows read from a crop: the same bits as from the image
        y = np.clip(y, 8, None)
        np.testing.assert_array_equal(derivatives_bilinear(img[2:], 2, H, W, x, y, b.gauss, b.d1, b.d2),
                                      derivatives_bilinear(img, 0, H, W, x, y, b.gauss, b.d1, b.d2))


def test_saddle_candidates_are_the_dilation_maxima():
    """One compiled pass gives the 3 x 3 maxima above the floor of the numpy definition, in raster order."""
    img = _photo_like(50, 70)
    gxx, gxy, gyy = second_derivatives(img, 1.5, kernel_radius(1.5))
    n = np.maximum(gxy * gxy - gxx * gyy, 0.0)
    dil = cv2.dilate(n, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
    t_n = float(np.quantile(n, 0.9))
    rows, cols = np.nonzero((n >= dil) & (n > t_n))
    got = strength_maxima(gxx, gxy, gyy, top=0, height=50, first=0, last=50, t_n=t_n)
    assert len(rows) > 10
    np.testing.assert_array_equal(got[0], rows)
    np.testing.assert_array_equal(got[1], cols)
    np.testing.assert_allclose(got[2], n[rows, cols], rtol=1e-12)  # fused multiply-adds: ulps apart


def test_hr_detection_reads_the_grey_image_in_crops_only(monkeypatch):
    """No H x W float64 grey image: crops, and the one float32 copy cornerSubPix reads."""
    from sogdd.image.rows import GreyRows

    img = np.clip(_photo_like(150, 170), 0, 255).astype(np.uint8)
    asked = []
    whole = GreyRows.__array__
    monkeypatch.setattr(GreyRows, "__array__", lambda self, dtype=None, copy=None: asked.append(dtype)
                        or whole(self, dtype, copy))
    got = sogdd.detect_corners(img, preset="hr")
    assert len(got) > 10 and asked == [np.float32]


@pytest.mark.parametrize("band_rows", [1, 6, 1024])
@pytest.mark.parametrize("threshold", [None, 4.0])
def test_saddle_candidates_from_measured_bands_equal_the_search(band_rows, threshold):
    """The measure's tiles, in any bands, give the X-junction stage saddle_search's points, bit for bit."""
    img = _photo_like(64, 90)
    thr = measure_threshold(20.0, HR)
    found = saddles.SaddleCandidates(img.shape, HR, threshold)
    stream_peaks(img, HR, threshold=thr, floor=thr, band_rows=band_rows, on_planes=found)
    want = saddles.saddle_search(img, HR, threshold)
    got = found.result(img)
    assert sum(len(p[0]) for p in found.parts) > 20 and len(want[0]) > 5
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    with pytest.raises(ValueError, match="zero-mean"):
        saddles.SaddleCandidates(img.shape, sogdd.resolve_params("authors").measure_spec(), threshold)
