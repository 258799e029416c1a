"""The renderer of the synthetic test images (``sogdd.synthetic``)."""

import cv2
import numpy as np
import pytest

from sogdd.synthetic import Polygon, render_polygons


def _render_float(shape, polygons, background, s):
    """The definition: paint every polygon in order on a float64 grid s times finer, then block-average."""
    h, w = shape
    fine = np.full((h * s, w * s), float(background))
    for poly in polygons:
        fv = ((np.asarray(poly.vertices, dtype=np.float64) + 0.5) * s - 0.5) * 256
        cv2.fillPoly(fine, [np.round(fv).astype(np.int32).reshape(-1, 1, 2)], float(poly.level),
                     lineType=cv2.LINE_8, shift=8)
    return fine.reshape(h, s, w, s).mean(axis=(1, 3))


@pytest.mark.parametrize("seed", range(12))
def test_render_is_the_painted_fine_grid_averaged(seed):
    """Overlapping, self-intersecting and partly outside polygons, several supersampling factors."""
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(5, 90)), int(rng.integers(5, 90))
    polys = [Polygon(rng.uniform(-20, 100, (int(rng.integers(3, 7)), 2)), float(rng.uniform(0, 255)))
             for _ in range(int(rng.integers(1, 6)))]
    s = int(rng.choice([1, 3, 8, 16]))
    bg = float(rng.uniform(0, 255))
    np.testing.assert_array_equal(render_polygons((h, w), polys, background=bg, supersample=s),
                                  _render_float((h, w), polys, bg, s))


def test_render_with_more_polygons_than_a_byte_holds():
    rng = np.random.default_rng(7)
    polys = [Polygon(rng.uniform(0, 40, (3, 2)), float(k % 251)) for k in range(300)]
    np.testing.assert_array_equal(render_polygons((40, 40), polys, background=3.0, supersample=4),
                                  _render_float((40, 40), polys, 3.0, 4))

