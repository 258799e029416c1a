"""The ``hr`` preset: the study's winner, grey-level threshold, X-junctions on their saddle."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

import sogdd
from sogdd.measure.units import grey_strength, measure_threshold
from sogdd.params import PRESETS, resolve_params
from sogdd.select.x_junctions import find_saddles
from sogdd.synthetic import Polygon, pattern_image, render_polygons

WINNER = Path(__file__).resolve().parent / "fixtures" / "hr_study_winner.json"


def checkerboard(cell: float, n: int = 8, angle: float = 0.0, phase=(0.3, 0.6), psf: float = 0.7,
                 shape=(96, 96)) -> tuple[np.ndarray, np.ndarray]:
    """A rendered board (16x supersampled, Gaussian PSF) and its inner corners (x, y)."""
    c, s = np.cos(np.deg2rad(angle)), np.sin(np.deg2rad(angle))
    rot = np.array([[c, -s], [s, c]])
    centre = np.array([(shape[1] - 1) / 2 + phase[0], (shape[0] - 1) / 2 + phase[1]])
    half = n * cell / 2

    def to_img(uv):
        return (np.asarray(uv, dtype=np.float64) - half) @ rot.T + centre

    polys = []
    for i in range(n):
        for j in range(n):
            if (i + j) % 2 == 0:
                sq = np.array([[i, j], [i + 1, j], [i + 1, j + 1], [i, j + 1]], dtype=np.float64) * cell
                polys.append(Polygon(to_img(sq), 40.0))
    img = render_polygons(shape, polys, background=210.0)
    if psf > 0:
        img = cv2.GaussianBlur(img, (0, 0), psf, borderType=cv2.BORDER_REFLECT)
    inner = np.array([(i * cell, j * cell) for i in range(1, n) for j in range(1, n)])
    return np.clip(np.round(img), 0, 255).astype(np.uint8), to_img(inner)


def _nearest(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.hypot(*(a[:, None, :] - b[None, :, :]).transpose(2, 0, 1))
    return d.min(axis=1), d.argmin(axis=1)


def test_hr_parameters_are_the_study_winner():
    """PRESETS['hr'] is the configuration the study chose (a copy of studies/hr/winner.json)."""
    if not WINNER.is_file():
        pytest.skip("the study's winner.json is not in this checkout")
    w = json.loads(WINNER.read_text())
    hr = asdict(PRESETS["hr"])
    assert {k: hr[k] for k in w["params"]} == w["params"]
    from sogdd.select.x_junctions import X_RING_RADIUS

    assert X_RING_RADIUS == w["x_ring_radius"]


def test_paper_preset_unchanged_by_hr():
    p = resolve_params("paper")
    assert (p.threshold_units, p.x_junctions, p.sigma2, p.n_orientations, p.window) == (
        "measure", False, 1.2, 8, 7)


def test_grey_threshold_is_contrast_invariant():
    """Scaling the image's contrast by a scales every strength by a: threshold a*T keeps the same corners."""
    img, _ = pattern_image((160, 200))
    base = img.astype(np.float64)
    lo = base * 0.4 / 255.0  # a dim copy: contrast x 0.4, float image on [0, 1]
    t = 40.0
    a = sogdd.detect_corners(base / 255.0, preset="hr", threshold=t)
    b = sogdd.detect_corners(lo, preset="hr", threshold=0.4 * t)
    assert len(a) > 10 and len(a) == len(b)
    np.testing.assert_allclose(b.xy, a.xy, atol=1e-4)  # cv2.cornerSubPix works in float32
    np.testing.assert_allclose(b.response, 0.4 * a.response, rtol=1e-9)


def test_grey_units_round_trip_and_calibration():
    spec = resolve_params("hr").measure_spec()
    for t in (1.0, 17.0, 100.0):
        assert grey_strength(np.array([measure_threshold(t, spec)]), spec)[0] == pytest.approx(t, rel=1e-12)


@pytest.mark.parametrize("cell,angle", [(5.0, 0.0), (6.0, 20.0), (8.0, 0.0), (12.0, 35.0)])
def test_hr_one_point_per_x_corner_within_0_1_px(cell, angle):
    img, truth = checkerboard(cell, n=max(4, int(56 / cell)), angle=angle)
    c = sogdd.detect_corners(img, preset="hr")
    d, idx = _nearest(truth, c.xy)
    assert np.all(d < 0.1), f"max error {d.max():.3f} px"
    assert len(np.unique(idx)) == len(truth)  # a distinct detection for every X-corner
    # exactly one detection within 1 px of each X-corner (no ring of peaks around it)
    dd, _ = _nearest(c.xy, truth)
    assert np.sum(dd < 1.0) == len(truth)


def test_hr_on_rendered_polygons_within_0_5_px():
    img, truth = pattern_image((240, 320), seed=3)
    c = sogdd.detect_corners(img, preset="hr")
    d, _ = _nearest(truth, c.xy)
    assert np.mean(d < 0.5) >= 0.9, f"{np.mean(d < 0.5):.2f} of vertices within 0.5 px"


def test_saddles_reject_l_corner_apex():
    q = np.array([[30.4, 30.7], [90, 30.7], [90, 90], [30.4, 90]])
    img = render_polygons((61, 61), [Polygon(q, 200.0)], background=50.0)
    xy, s = find_saddles(img, 1.2)
    # the apex's Newton iterates leave the pixel, and the clean rendering has no other saddle
    assert len(s) == 0, f"{len(s)} saddles, nearest {np.hypot(*(xy - q[0]).T).min():.2f} px from the apex"


def test_registry_and_spec_names():
    from sogdd import baselines

    det = baselines.get("sogdd-hr")
    img, truth = checkerboard(6.0)
    a = det.detect_corners(img)
    b = baselines.get("sogdd", preset="hr").detect_corners(img)
    np.testing.assert_array_equal(a.xy, b.xy)
    assert len(a) >= len(truth)
    with pytest.raises(ValueError, match="unknown preset"):
        baselines.get("sogdd", preset="nope")


def test_hr_reports_one_point_per_corner(monkeypatch):
    """Two Upsilon peaks of one vertex that the adaptive refinement brings together are one corner."""
    from sogdd.select import refine
    from sogdd.synthetic import pattern_image

    img = pattern_image((240, 320), seed=0)[0]
    got = sogdd.detect_corners(img, preset="hr")
    assert refine.COINCIDENT == 0.5  # the documented merge radius; literals below, not the constant
    assert len(cKDTree(got.xy).query_pairs(0.5)) == 0
    # the merge of every preset (sogdd.select.refine.first_distinct) switched off
    monkeypatch.setattr(refine, "one_per_point", lambda xy, s, tol: np.arange(len(xy)))
    every = sogdd.detect_corners(img, preset="hr")
    assert len(cKDTree(every.xy).query_pairs(0.1)) > 0  # the image has such pairs
    d, _ = cKDTree(got.xy).query(every.xy)
    assert len(every) > len(got) and np.all(d <= 0.5)  # only coincident points went
    np.testing.assert_array_equal(got.xy, every.xy[d == 0])  # the rest unchanged, in order


@pytest.mark.parametrize("threads,band_rows", [("1", 1024), ("2", 1024), ("2", 37)])
def test_saddles_from_the_measures_responses_equal_the_search(monkeypatch, threads, band_rows):
    """Detection takes the X-junction candidates from the measure's tiles: saddle_search's result exactly."""
    from sogdd.select import bands as _bands
    from sogdd.select import stage

    img, _ = checkerboard(9.0, shape=(120, 140))
    img = np.clip(img + np.random.default_rng(3).normal(0, 2, img.shape), 0, 255).astype(np.uint8)
    monkeypatch.setenv("SOGDD_NUM_THREADS", threads)
    banded = _bands.stream_peaks
    monkeypatch.setattr(stage, "stream_peaks", lambda *a, **k: banded(*a, band_rows=band_rows, **k))
    tiles = []
    cls = stage.SaddleCandidates

    class Spy(cls):
        def __call__(self, top, lo, hi, planes):
            tiles.append(hi - lo)
            return super().__call__(top, lo, hi, planes)

    monkeypatch.setattr(stage, "SaddleCandidates", Spy)
    shared = sogdd.detect_corners(img, preset="hr")
    assert sum(tiles) == img.shape[0]  # every row's candidates, from one tile each
    monkeypatch.setattr(stage, "SaddleCandidates", lambda *a: None)  # add_x_junctions searches itself
    searched = sogdd.detect_corners(img, preset="hr")
    assert len(shared) > 20
    np.testing.assert_array_equal(shared.xy, searched.xy)
    np.testing.assert_array_equal(shared.response, searched.response)
