"""The repeatability transforms map points correctly, and eq. 27 is computed as stated."""

import numpy as np
import pytest

import sogdd
from sogdd.evaluation.repeatability.protocol import pair_repeatability, repeatability_score
from sogdd.evaluation.repeatability.transforms import (
    FAMILIES,
    Transform,
    apply_transform,
    family_grid,
    map_points,
)
from sogdd.synthetic import Polygon, render_polygons


def test_grid_sizes_follow_the_paper():
    sizes = {f: len(family_grid(f)) for f in FAMILIES}
    assert sizes == {"rotation": 18, "scale": 15, "anisotropic": 117, "shear": 20, "jpeg": 20,
                     "noise": 15}
    assert all(t.param != 0 for t in family_grid("rotation") + family_grid("shear"))
    assert all(t.param[0] != t.param[1] for t in family_grid("anisotropic"))
    assert 1.0 not in [t.param for t in family_grid("scale")]
    for f in FAMILIES:
        assert 0 < len(family_grid(f, quick=True)) <= 5


@pytest.mark.parametrize("t", [Transform("rotation", 30.0), Transform("rotation", -70.0),
                               Transform("scale", 1.7), Transform("scale", 0.6),
                               Transform("anisotropic", (0.8, 1.5)), Transform("shear", 0.6),
                               Transform("shear", -1.0)])
def test_warped_square_corners_land_where_mapped(t):
    # a big bright square; its corners, warped, must be where the affine map sends them
    verts = np.array([[40.3, 35.6], [100.7, 35.6], [100.7, 90.2], [40.3, 90.2]])
    img = render_polygons((128, 144), [Polygon(verts, 220.0)], background=30.0)
    img = np.clip(np.round(img), 0, 255).astype(np.uint8)
    out, a, valid = apply_transform(img, t)
    expect = map_points(verts, a)
    assert valid.shape == out.shape and valid.mean() > 0.3
    det = sogdd.detect_corners(out, threshold=None, max_corners=8)
    d = np.hypot(*(expect[:, None, :] - det.xy[None]).transpose(2, 0, 1)).min(axis=1)
    # shear makes very acute/obtuse angles: corner detectors shift those by ~1 px
    assert np.all(d < 1.5), d
    # the image centre maps to the output centre
    h, w = img.shape
    oh, ow = out.shape
    assert np.allclose(map_points([[(w - 1) / 2, (h - 1) / 2]], a), [[(ow - 1) / 2, (oh - 1) / 2]])


def test_photometric_transforms_keep_geometry(rng):
    img = rng.integers(0, 256, (40, 50)).astype(np.uint8)
    for t in (Transform("jpeg", 30), Transform("noise", 5)):
        out, a, valid = apply_transform(img, t, seed=3)
        assert out.shape == img.shape and out.dtype == np.uint8 and valid.all()
        assert np.allclose(a, [[1, 0, 0], [0, 1, 0]])
    n1, _, _ = apply_transform(img, Transform("noise", 5), seed=3)
    n2, _, _ = apply_transform(img, Transform("noise", 5), seed=3)
    assert np.array_equal(n1, n2)  # seeded
    assert abs(float(np.std(n1.astype(float) - img)) - 5) < 1.0


def test_repeatability_score():
    assert repeatability_score(10, 10, 10) == 1.0
    assert repeatability_score(5, 10, 20) == pytest.approx(2.5 * (0.1 + 0.05))
    assert repeatability_score(0, 0, 5) == 0.0


def test_pair_repeatability_common_region():
    # identity: all repeat; a point of the transformed image mapping outside is not counted
    ref = np.array([[10.0, 10.0], [20.0, 30.0], [40.0, 5.0]])
    a = np.array([[1.0, 0, 5.0], [0, 1.0, 0]])  # shift right by 5 px
    det = map_points(ref, a) + 0.5
    det = np.concatenate([det, [[2.0, 2.0]]])  # maps to x = -3: outside the reference
    lb, ld, lr, r = pair_repeatability(ref, det, a, (50, 50))
    assert (lb, ld, lr) == (3, 3, 3) and r == 1.0
    lb, ld, lr, r = pair_repeatability(ref, det + 4.0, a, (50, 50))
    assert lr == 0 and r == 0.0
