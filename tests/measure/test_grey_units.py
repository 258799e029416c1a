"""An independent anchor for the grey-level unit of ``hr``.

The unit is defined by a rendered right-angle corner: "a corner of contrast T has
strength T" (:mod:`sogdd.measure.units`). These tests render their own corners
with :func:`sogdd.synthetic.render_polygons` (another size, place, background
and contrast than the calibration image, which they never read), so a unit
calibrated at the wrong contrast fails here, where round trips cannot see it.
"""

from __future__ import annotations

import numpy as np
import pytest

import sogdd
from sogdd.synthetic import Polygon, render_polygons

#: the vertex on a pixel corner, as the definition's calibration corner has it
VERTEX = (40.5, 35.5)


def corner(contrast: float, vertex=VERTEX, background: float = 90.0) -> np.ndarray:
    """A right-angle corner (the quadrant right of and below ``vertex``), float on [0, 1]."""
    x, y = vertex
    quad = np.array([[x, y], [x + 300, y], [x + 300, y + 300], [x, y + 300]])
    return render_polygons((80, 90), [Polygon(quad, background + contrast)], background=background) / 255.0


def strongest(img: np.ndarray, **kw):
    c = sogdd.detect_corners(img, preset="hr", **kw)
    return c, (float(c.response[0]) if len(c) else None)


def test_a_corner_of_contrast_30_has_strength_30():
    c, s = strongest(corner(30.0), threshold=1.0)
    assert len(c) == 1 and np.hypot(*(c.xy[0] - VERTEX)) < 0.3
    assert s == pytest.approx(30.0, abs=0.3)


@pytest.mark.parametrize("contrast", [12.0, 30.0, 75.0])
def test_strength_is_the_contrast_on_any_background(contrast):
    for background in (20.0, 150.0):
        _, s = strongest(corner(contrast, background=background), threshold=1.0)
        assert s == pytest.approx(contrast, rel=0.01)


def test_threshold_20_rejects_contrast_19_and_keeps_contrast_21():
    assert sogdd.resolve_params("hr").threshold == 20.0
    assert len(sogdd.detect_corners(corner(19.0), preset="hr")) == 0
    c = sogdd.detect_corners(corner(21.0), preset="hr")
    assert len(c) == 1 and c.response[0] == pytest.approx(21.0, abs=0.3)


def test_other_vertex_phases_read_stronger_never_weaker():
    """Off the pixel corner the sampled peak is higher (up to ~1.25x with the vertex on a pixel centre)."""
    for vertex in ((40.37, 35.81), (40.0, 36.0), (40.25, 35.9)):
        _, s = strongest(corner(30.0, vertex), threshold=1.0)
        assert 29.9 < s < 38.0
