"""Each corner once, in every preset: points that sub-pixel refinement brings together are merged.

The image: one bright triangle on a 24 x 32 grid, a vertex 2 px below the top edge and an edge
leaving through the bottom. The measure peaks on both sides of each (the border's reflection
mirrors the corner) and the gradient refinement takes both peaks onto one point: without the
merge ``paper`` reports 5 corners, two pairs of them within 1e-4 px.

Points the refinement refuses keep their quadratic peak, 0.2-0.5 px from a point refined onto the
same corner (:data:`sogdd.select.refine.COINCIDENT`): a noisy rendered scene holds such pairs,
and so do the 12 repeatability photos of the shared data.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import sogdd
from sogdd.select import assemble, refine
from sogdd.select.refine import COINCIDENT, first_distinct, refine_gradient
from sogdd.select.stage import select_corners
from sogdd.synthetic import Polygon, pattern_image, render_polygons

#: thresholds off: every local maximum above 0 is a candidate, ranked
OFF = dict(threshold=None, threshold_rel=None, quantile=None)


def edge_triangle() -> np.ndarray:
    """A bright triangle whose vertex (24.3, 2.02) lies 2 px below the image's top edge, uint8."""
    q = np.array([[5.3, 14.4], [24.3, 29.0], [24.3, 2.02]])
    return np.round(render_polygons((24, 32), [Polygon(q, 200.0)], background=40.0)).astype(np.uint8)


def _closest_pair(xy: np.ndarray) -> float:
    """The smallest distance between two points (inf for fewer than two)."""
    return float(cKDTree(xy).query(xy, k=2)[0][:, 1].min()) if len(xy) > 1 else np.inf


@pytest.fixture
def no_merge(monkeypatch):
    """Detection with the merge switched off (every refined point kept), to show what it removes."""
    def detect(*args, **kw):
        with monkeypatch.context() as m:
            m.setattr(refine, "one_per_point", lambda xy, s, tol: np.arange(len(xy)))
            return sogdd.detect_corners(*args, **kw)

    return detect


def test_the_merge_radius():
    # the documented value; the assertions below use literals, so a change of it is seen here
    assert COINCIDENT == 0.5


def test_paper_reports_each_corner_once(no_merge):
    img = edge_triangle()
    every = no_merge(img)
    got = sogdd.detect_corners(img)
    assert len(cKDTree(every.xy).query_pairs(1e-3)) >= 2  # the image holds refined pairs on one point
    assert _closest_pair(got.xy) > 0.5
    d, i = cKDTree(every.xy).query(got.xy)
    assert np.all(d == 0) and np.all(np.diff(i) > 0)  # the rest unchanged, strongest first
    gone = np.setdiff1d(np.arange(len(every)), i)
    assert len(gone) == len(every) - len(got) >= 2
    near, j = cKDTree(got.xy).query(every.xy[gone])
    assert np.all(near < 1e-3) and np.all(got.response[j] >= every.response[gone])  # the stronger stays


@pytest.fixture
def radius_0_1(monkeypatch):
    """Detection with the merge radius of sogdd before half a pixel (0.1 px), to show what it left."""
    def detect(*args, **kw):
        with monkeypatch.context() as m:
            m.setattr(assemble, "COINCIDENT", 0.1)
            return sogdd.detect_corners(*args, **kw)

    return detect


@pytest.mark.parametrize("preset", ["paper", "hr"])
def test_refused_refinements_leave_no_pair_within_half_a_pixel(preset, radius_0_1):
    """A point whose refinement is refused keeps its peak, within 0.5 px of one refined onto its corner."""
    img, vertices = pattern_image((240, 320), seed=0, noise=20)
    before = radius_0_1(img, preset)
    got = sogdd.detect_corners(img, preset)
    assert len(cKDTree(before.xy).query_pairs(0.5)) >= 1  # the scene holds such pairs at 0.1 px
    assert len(cKDTree(got.xy).query_pairs(0.5)) == 0
    d, i = cKDTree(before.xy).query(got.xy)
    assert np.all(d == 0) and np.all(np.diff(i) > 0)  # the rest unchanged, strongest first
    gone = np.setdiff1d(np.arange(len(before)), i)
    near, j = cKDTree(got.xy).query(before.xy[gone])
    assert len(gone) >= 1 and np.all(near <= 0.5)  # each went into a kept point within 0.5 px
    assert np.all(got.response[j] >= before.response[gone])  # the stronger one
    # no rendered vertex is lost: those found within 1 px still are
    np.testing.assert_array_equal(cKDTree(got.xy).query(vertices)[0] < 1,
                                  cKDTree(before.xy).query(vertices)[0] < 1)


def test_repeatability_photos_report_each_corner_once(data_dir, radius_0_1):
    """The 12 repeatability photos: pairs within 0.5 px at the old radius, none now, in every preset."""
    photos = sorted((data_dir / "repeatability").glob("*.bmp"))
    if len(photos) != 12:
        pytest.skip(f"{data_dir / 'repeatability'} holds {len(photos)} photos, not the 12 of the data set")
    images = [sogdd.read_image(f) for f in photos]
    old = sum(len(cKDTree(radius_0_1(img).xy).query_pairs(0.5)) for img in images)
    assert old >= 1  # paper's, at 0.1 px
    for preset in ("paper", "authors", "hr"):
        pairs = [len(cKDTree(sogdd.detect_corners(img, preset).xy).query_pairs(0.5)) for img in images]
        assert sum(pairs) == 0, f"{preset}: {dict(zip([f.name for f in photos], pairs))}"


@pytest.mark.parametrize("n", [1, 2, 3])
def test_max_corners_gives_n_distinct_corners(n, no_merge):
    """With the paper's threshold: the cut comes after the merge and is refilled from the next peaks."""
    img = edge_triangle()
    assert _closest_pair(no_merge(img, max_corners=2).xy) < 1e-3  # the two strongest are one point
    all_ = sogdd.detect_corners(img)
    top = sogdd.detect_corners(img, max_corners=n)
    assert len(all_) >= 3 and len(top) == n
    assert _closest_pair(top.xy) > 0.5
    # merging every peak, then cutting: the refill gives exactly that
    np.testing.assert_array_equal(top.xy, all_.xy[:n])
    np.testing.assert_array_equal(top.response, all_.response[:n])


@pytest.mark.parametrize("preset", ["paper", "authors", "hr"])
@pytest.mark.parametrize("n", [4, 12])
def test_every_preset_gives_n_distinct_corners(preset, n):
    img = edge_triangle()
    every = sogdd.detect_corners(img, preset, **OFF)
    assert len(every) >= 4 and _closest_pair(every.xy) > 0.5
    top = sogdd.detect_corners(img, preset, max_corners=n, **OFF)
    assert len(top) == min(n, len(every))  # authors' 9-px border leaves 5 maxima
    assert _closest_pair(top.xy) > 0.5
    if preset != "hr":  # hr's adaptive windows see the other points kept, so its positions depend on n
        np.testing.assert_array_equal(top.xy, every.xy[:n])


def test_first_distinct_refills_the_cut():
    q = np.array([[5.0, 5.0], [5.0, 5.00001], [9.0, 9.0], [9.05, 9.0], [2.0, 2.0], [7.0, 1.0]])
    s = np.array([6.0, 5.0, 4.0, 3.0, 2.0, 1.0])
    asked = []

    def place(m):
        asked.append(m)
        return q[:m]

    keep, xy = first_distinct(place, s, 3)
    assert keep.tolist() == [0, 2, 4]
    # 3 asked, 2 distinct: one more, still 2 (the 4th is the 3rd): one more, 3
    assert asked == [3, 4, 5]
    np.testing.assert_array_equal(xy, q[:5])
    assert first_distinct(lambda m: q[:m], s, None)[0].tolist() == [0, 2, 4, 5]
    assert first_distinct(lambda m: q[:m], s, 10)[0].tolist() == [0, 2, 4, 5]  # fewer than asked: all
    assert first_distinct(lambda m: q[:m], s, 2, tol=1e-6)[0].tolist() == [0, 1]  # a smaller radius


def test_first_distinct_drops_what_is_not_allowed_and_refills():
    q = np.array([[5.0, 5.0], [-3.0, 1.0], [9.0, 9.0], [2.0, 2.0]])
    keep, _ = first_distinct(lambda m: q[:m], np.array([4.0, 3.0, 2.0, 1.0]), 2, allowed=lambda p: p[:, 0] >= 0)
    assert keep.tolist() == [0, 2]


def _prefixes(q: np.ndarray):
    """``place`` for fixed positions: the first m of ``q``."""
    return lambda m: q[:m]


def test_first_distinct_is_the_merge_of_all_then_the_cut(rng):
    """For positions that do not depend on the prefix, the refilled cut is the full merge's first N."""
    for _ in range(20):
        q = rng.integers(0, 6, (60, 2)) + rng.normal(0, 0.01, (60, 2)) * rng.integers(0, 2, (60, 1))
        s = np.sort(rng.integers(0, 5, 60).astype(float))[::-1]  # ranked, with ties
        full = first_distinct(_prefixes(q), s, None)[0]
        for n in (1, 5, 17, 60):
            np.testing.assert_array_equal(first_distinct(_prefixes(q), s, n)[0], full[:n])


class _HostDevice:
    """A device measure (sogdd.select.stage.DeviceMeasure) served from the CPU map: the GPU path's host side.

    ``gradient`` refines on the "device" the points it is asked for and records how many, as
    :class:`sogdd.gpu.detect._DeviceMeasure` gathers their patches on the device.
    """

    def __init__(self, img: np.ndarray, p) -> None:
        from sogdd.measure.soddc import soddc_measure

        self.grey = img.astype(np.float64)
        self.resp = soddc_measure(self.grey, p.measure_spec())
        self.shape = self.resp.shape
        self.asked: list[int] = []

    def peaks(self, threshold, nms_radius, border):
        from sogdd.select.peaks import maxima_above

        rows, cols = maxima_above(self.resp, threshold, nms_radius)
        r = np.clip(rows, 1, self.shape[0] - 2)[:, None, None] + np.arange(-1, 2)[None, :, None]
        c = np.clip(cols, 1, self.shape[1] - 2)[:, None, None] + np.arange(-1, 2)[None, None, :]
        return rows, cols, self.resp[rows, cols], self.resp[r, c]

    def whole(self):
        return self.resp

    def gradient(self, rows, cols, xy):
        self.asked.append(len(rows))
        return refine_gradient(self.grey, xy)


def test_device_path_merges_and_refills_on_the_device():
    """The GPU path's host side (no GPU): the device refines the cut, then the refill; no host image."""
    img = edge_triangle()
    p = sogdd.resolve_params("paper", max_corners=3)
    dev = _HostDevice(img, p)
    got = select_corners(None, p, device=dev)  # grey None: a device input refined on the device
    cpu = sogdd.detect_corners(img, max_corners=3)
    np.testing.assert_array_equal(got.xy, cpu.xy)
    np.testing.assert_array_equal(got.response, cpu.response)
    assert len(got) == 3 and _closest_pair(got.xy) > 0.5
    assert dev.asked == [3, 1]  # the strongest 3, one of them a duplicate, then one more
