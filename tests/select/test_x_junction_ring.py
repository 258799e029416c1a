"""``hr`` reports each X-junction of a checkerboard once, on its saddle, and nothing of its ring.

Around an X-junction the measure has a ring of maxima about 2 px from it;
:mod:`sogdd.select.x_junctions` replaces them by the saddle point. A ring radius
that is too small leaves ring maxima beside the saddle (an 8 px board then gives
more than twice as many points as it has junctions).
"""

import numpy as np
import pytest
from scipy.spatial import cKDTree

import sogdd
from sogdd.synthetic import Polygon, render_polygons


def checkerboard(cell: float, n: int, off: tuple[float, float], size: tuple[int, int], noise: float = 0.0):
    """An ``n`` x ``n`` board of ``cell`` px squares at ``off``; the image and its inner junctions."""
    polys = []
    for i in range(n):
        for j in range(n):
            if (i + j) % 2 == 0:
                x, y = off[0] + j * cell, off[1] + i * cell
                sq = np.array([[x, y], [x + cell, y], [x + cell, y + cell], [x, y + cell]])
                polys.append(Polygon(sq, 200.0))
    img = render_polygons(size, polys, background=50.0)
    if noise:
        img = img + np.random.default_rng(0).normal(0, noise, img.shape)
    inner = np.array([[off[0] + j * cell, off[1] + i * cell] for i in range(1, n) for j in range(1, n)])
    return np.clip(np.round(img), 0, 255).astype(np.uint8), inner


@pytest.mark.parametrize("cell, off, noise", [(8.0, (20.3, 20.6), 0.0), (8.0, (17.75, 21.1), 2.0),
                                              (6.0, (15.5, 15.5), 0.0)])
def test_one_point_per_x_junction_and_none_on_its_ring(cell, off, noise):
    n = 10
    img, inner = checkerboard(cell, n, off, (int(off[1] + n * cell + 20), int(off[0] + n * cell + 20)), noise)
    c = sogdd.detect_corners(img, preset="hr")
    # the points inside the board (its outer edge has L- and T-corners of its own)
    lo, hi = np.array(off) + cell / 2, np.array(off) + (n - 0.5) * cell
    xy = c.xy[np.all((c.xy > lo) & (c.xy < hi), axis=1)]
    d_to_junction, nearest = cKDTree(inner).query(xy)
    assert d_to_junction.max() < 0.5, "a point beside an X-junction: its ring was not replaced"
    assert len(xy) == len(inner) and len(set(nearest.tolist())) == len(inner)
