"""Relative and quantile thresholds in bands (sogdd.select.bands), the streaming quantile and the
crop-by-crop grey image, each against the whole-map computation it replaces."""

import numpy as np
import pytest

import sogdd
from sogdd import detector
from sogdd.image.grey import to_gray255
from sogdd.image.rows import GreyRows
from sogdd.measure.soddc import authors_measure, soddc_measure
from sogdd.select import stage
from sogdd.select.bands import positives, stream_peaks
from sogdd.select.peaks import select_peaks
from sogdd.select.refine import refine_quadratic
from sogdd.select.stream_quantile import StreamQuantile, quantile_from_order_stats, rank_floor


def _image(pattern, rng):
    """Pattern + noise with flat patches (det of exactly flat windows rounds to tiny +-)."""
    img = np.clip(pattern[0] + rng.normal(0, 4, pattern[0].shape), 0, 255)
    img[:40, :] = 137.0
    img[100:130, 50:200] = 60.0
    img[180:, 250:] = 201.0
    return img


def _authors_parts(img):
    spec = sogdd.resolve_params("authors").measure_spec()
    det, tr = soddc_measure(img, spec, raw=True)
    return spec, det, tr


@pytest.mark.parametrize("q", [0.0, 0.3, 0.5, 0.9, 0.99, 0.999])
def test_stream_quantile_is_numpys(rng, q):
    for trial in range(20):
        n = int(rng.integers(1, 3000))
        x = rng.integers(0, 50, n).astype(float) if trial % 2 else rng.lognormal(0, 5, n)  # ties / spread
        cuts = np.sort(rng.integers(0, n + 1, int(rng.integers(0, 8))))
        slack = int(rng.integers(0, 500))
        sq = StreamQuantile(q, n + slack)
        parts = np.split(x, cuts)
        for i, part in enumerate(parts):
            sq.add(part, slots=len(part) + (slack if i == len(parts) - 1 else 0))
        assert sq.count == n
        assert sq.result() == np.quantile(x, q)
        s = np.sort(x)
        assert quantile_from_order_stats(n, q, s.__getitem__) == np.quantile(x, q)


def test_stream_quantile_keeps_little_for_high_q(rng):
    x = rng.lognormal(0, 3, 200_000)
    sq = StreamQuantile(0.99, len(x))
    for part in np.array_split(x, 40):
        sq.add(part, slots=len(part))
    assert sq.result() == np.quantile(x, 0.99)
    assert sq.kept < 0.05 * len(x)  # about (1 - q) of the values, not all of them
    assert sq.floor <= sq.result()


@pytest.mark.parametrize("kind", ["lognormal", "signed", "ties"])
def test_rank_floor_is_a_close_lower_bound_of_the_order_statistic(rng, kind):
    n = 5000
    x = {"lognormal": rng.lognormal(0, 4, n), "signed": rng.normal(0, 100, n),
         "ties": rng.integers(-3, 4, n).astype(float)}[kind]
    s = np.sort(x)
    for r in [0, 1, n // 2, n - 2, n - 1, *rng.integers(0, n, 20)]:
        lo = rank_floor(x, int(r))
        assert lo in x and lo <= s[r]
        # the same bucket (16 leading bits: the sign, the octave and its sixteenth), so close to it
        assert np.sign(lo) == np.sign(s[r]) or lo == s[r] or s[r] == 0
        assert lo >= s[r] * (16 / 17 if s[r] > 0 else 17 / 16)
    with pytest.raises(ValueError, match="rank"):
        rank_floor(x, n)


def test_stream_quantile_of_nothing():
    sq = StreamQuantile(0.5, 10)
    sq.add(np.zeros(0), slots=10)
    assert sq.result() is None


def test_the_flat_patches_are_clamped(pattern, rng):
    """The test image exercises the authors' clamp: some det lie in [-eps max|det|, 0)."""
    _, det, _ = _authors_parts(_image(pattern, rng))
    lim = -np.finfo(float).eps * np.abs(det).max()
    assert np.count_nonzero((det < 0) & (det >= lim)) > 100


@pytest.mark.parametrize("band_rows", [1, 7, 64, 1024])
@pytest.mark.parametrize("kw", [
    {"quantile": 0.99, "border": 9},
    {"quantile": 0.0, "border": 9, "quadratic": True},  # weak peaks among clamped pixels
    {"quantile": 0.5, "nms_radius": 3, "max_corners": 40, "quadratic": True},
    {"quantile": 0.9, "threshold_rel": 0.01, "threshold": 1e3, "border": 300},
    {"threshold_rel": 0.05, "border": 2, "quadratic": True},
    {"threshold": 0.0},
])
def test_authors_bands_give_the_peaks_of_the_whole_map(pattern, rng, band_rows, kw):
    img = _image(pattern, rng)
    spec, det, tr = _authors_parts(img)
    full = authors_measure(det, tr)
    mask = rng.random(img.shape) < 0.9 if band_rows == 7 else None
    quadratic = kw.pop("quadratic", False)
    rows, cols = select_peaks(full, mask=mask, **kw)
    got = stream_peaks(img, spec, mask=mask, band_rows=band_rows, quadratic=quadratic, **kw)
    assert got is not None
    r, c, v, off = got
    if kw.get("border") != 300:
        assert len(rows) > 10
    np.testing.assert_array_equal(r, rows)
    np.testing.assert_array_equal(c, cols)
    np.testing.assert_array_equal(v, full[rows, cols])
    np.testing.assert_array_equal(off, refine_quadratic(full, rows, cols) if quadratic else 0 * off)


def test_quadratic_patches_see_the_final_clamp(pattern, rng):
    """With q = 0 some selected peaks have clamped pixels in their patch, and the offsets still agree."""
    img = _image(pattern, rng)
    spec, det, tr = _authors_parts(img)
    full = authors_measure(det, tr)
    raw = det / (tr + np.finfo(float).eps)  # no clamp
    rows, cols = select_peaks(full, quantile=0.0)
    r, c = np.clip(rows, 1, img.shape[0] - 2), np.clip(cols, 1, img.shape[1] - 2)
    dy, dx = np.mgrid[-1:2, -1:2]
    iy, ix = r[:, None, None] + dy, c[:, None, None] + dx
    assert np.any(full[iy, ix] != raw[iy, ix])
    *_, off = stream_peaks(img, spec, quantile=0.0, quadratic=True, band_rows=50)
    np.testing.assert_array_equal(off, refine_quadratic(full, rows, cols))


@pytest.mark.parametrize("kw", [{"quantile": 0.95}, {"threshold_rel": 0.02},
                                {"threshold_rel": 0.001, "quantile": 0.5},
                                {"threshold": None, "quantile": 0.9, "border": 4}])
def test_paper_measure_bands_with_a_relative_floor(pattern, rng, kw):
    img = _image(pattern, rng)
    spec = sogdd.resolve_params("paper").measure_spec()
    full = soddc_measure(img, spec)
    floor = None
    if "quantile" not in kw:  # a floor below the final threshold, as sogdd.measure.relative_floor gives
        floor = kw["threshold_rel"] * full.max() * 0.5
    rows, cols = select_peaks(full, **kw)
    r, c, v, off = stream_peaks(img, spec, floor=floor, band_rows=33, quadratic=True, **kw)
    assert len(rows) > 10
    np.testing.assert_array_equal(r, rows)
    np.testing.assert_array_equal(c, cols)
    np.testing.assert_array_equal(v, full[rows, cols])
    np.testing.assert_array_equal(off, refine_quadratic(full, rows, cols))


def test_no_answer_where_the_threshold_could_be_negative():
    flat = np.zeros((60, 70))  # det 0 everywhere: no positive value
    spec = sogdd.resolve_params("authors").measure_spec()
    assert stream_peaks(flat, spec, threshold_rel=0.5) is None
    assert stream_peaks(flat, spec, threshold=-1.0, quantile=0.5) is None
    r, *_ = stream_peaks(flat, spec, quantile=0.5)  # no positive value: no peak above 0
    assert len(r) == 0


def _colour(rng, shape=(300, 420)):
    img, _ = sogdd.synthetic.pattern_image(shape, seed=3)
    col = np.stack([img, 0.7 * img + 40, 255 - img], axis=2) + rng.normal(0, 3, shape + (3,))
    col[:60] = (120, 130, 140)
    return np.clip(col, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("kw", [{"preset": "authors"}, {"preset": "authors", "subpixel": "quadratic"},
                                {"preset": "paper", "threshold": 1e9, "threshold_rel": 0.001},
                                {"preset": "paper", "threshold": None, "quantile": 0.9},
                                {"preset": "authors", "threshold_rel": 0.0, "quantile": None}])
def test_detect_corners_equals_the_whole_map_path(rng, monkeypatch, kw):
    col = _colour(rng)
    a = sogdd.detect_corners(col, **kw)
    monkeypatch.setattr(stage, "stream_peaks", lambda *args, **kws: None)
    monkeypatch.setattr(detector, "GreyRows", lambda img, **gray: to_gray255(img, **gray))
    b = sogdd.detect_corners(col, **kw)
    assert len(a) > 20
    np.testing.assert_array_equal(a.xy, b.xy)
    np.testing.assert_array_equal(a.response, b.response)


@pytest.mark.parametrize("case", ["u8", "u8round", "bgr", "rgba", "u16", "float", "bool", "range"])
def test_grey_rows_are_to_gray255(rng, case):
    kw = {}
    if case.startswith("u8") or case in ("bgr", "rgba"):
        img = rng.integers(0, 256, (37, 29, 4 if case == "rgba" else 3), dtype=np.uint8)
        kw = {"round_integer": case == "u8round", "channel_order": "bgr" if case == "bgr" else "rgb",
              "weights": (0.298936021293775, 0.587043074451121, 0.114020904255103)}
    elif case == "u16":
        img = rng.integers(0, 65536, (37, 29, 3), dtype=np.uint16)
    elif case == "float":
        img = rng.random((37, 29))
    elif case == "bool":
        img = rng.random((37, 29)) < 0.5
    else:
        img = rng.integers(0, 4096, (37, 29), dtype=np.uint16)
        kw = {"value_range": (0.0, 4095.0)}
    ref = to_gray255(img, **kw)
    g = GreyRows(img, **kw)
    assert g.shape == ref.shape
    for y0, y1, x0, x1 in [(0, 37, 0, 29), (3, 4, 0, 29), (10, 30, 5, 9)]:
        np.testing.assert_array_equal(g[y0:y1, x0:x1], ref[y0:y1, x0:x1])
    np.testing.assert_array_equal(g[2:9], ref[2:9])
    np.testing.assert_array_equal(np.asarray(g), ref)
    np.testing.assert_array_equal(np.asarray(g, np.float32), ref.astype(np.float32))
    with pytest.raises(TypeError):
        g[::2]


def test_detect_corners_falls_back_to_the_whole_map():
    """A black image with threshold_rel: no positive value, so the full map decides (nothing passes)."""
    black = np.zeros((80, 90, 3), np.uint8)
    assert len(sogdd.detect_corners(black, preset="authors", threshold_rel=0.5, quantile=None)) == 0


@pytest.mark.parametrize("floor", [-np.inf, 0.0, 0.7, np.inf])
def test_positives_split_at_the_floor_as_numpy(floor):
    """One compiled pass: positive finite values (where the mask is) at or above the floor, the rest counted."""
    rng = np.random.default_rng(4)
    sub = rng.normal(0.5, 1.0, (37, 53))
    sub[rng.random(sub.shape) < 0.05] = np.nan
    sub[rng.random(sub.shape) < 0.02] = np.inf
    mask = rng.random(sub.shape) < 0.7
    view = sub[3:30, 5:48]  # not contiguous, as a band's valid columns
    for m in (None, mask[3:30, 5:48]):
        pos = (view > 0) & np.isfinite(view) & (True if m is None else m)
        want = view[pos]
        vals, below, top = positives(view, m, floor)
        np.testing.assert_array_equal(vals, want[want >= floor])
        assert below == int((want < floor).sum()) and top == want.max()
