"""Sub-pixel stability: the refinement is a continuous function of its input.

``img`` and ``img.astype(np.float32) / 255`` differ by ~7.6e-6 grey levels once
converted back to the 0-255 scale, yet ``hr`` (0.2.0) moved one corner of
``calibration/chessboard_sony/frame07.jpg`` by 0.996 px between them. The cause:
``cv2.cornerSubPix`` with ``hr``'s 3 x 3 windows (half-window 1) often overshoots
and does not converge in its 30 iterations (15 of the 24 half-window-1 points of
that photo were still moving by more than 1e-3 px when it stopped, median 0.3 px),
and it stopped at a squared step of 1e-3 (0.03 px) elsewhere, so its last iterate
was a chaotic function of the input's last bits; the refusal of moves over 1 px
turned that into a jump (kept at 0.996, refused at 1.064). The refinement now
iterates the same step to its fixed point, damped where it overshoots
(:mod:`sogdd.select.refine`). The photo test and the tiny-change test of ``hr`` fail on
0.2.0 (its cornerSubPix loop moved these rendered corners by up to 1.6 px).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import sogdd
from sogdd.select.refine import forstner_points
from sogdd.synthetic import pattern_image


def test_uint8_and_float32_photo_give_the_same_hr_corners(data_dir):
    path = data_dir / "calibration" / "chessboard_sony" / "frame07.jpg"
    if not path.is_file():
        pytest.skip(f"{path} is not in the shared data")
    img = sogdd.read_image(path)
    a = sogdd.detect_corners(img, preset="hr")
    b = sogdd.detect_corners(img.astype(np.float32) / 255, preset="hr")
    assert len(a) == len(b) > 100
    d, _ = cKDTree(b.xy).query(a.xy)
    assert d.max() < 1e-3, f"a corner moved {d.max():.3f} px at {a.xy[np.argmax(d)]}"


def _noisy_pattern(seed: int) -> np.ndarray:
    img, _ = pattern_image((240, 320), seed=seed)
    rng = np.random.default_rng(seed)
    return np.clip(img + rng.normal(0, 6.0, img.shape), 0, 255)


@pytest.mark.parametrize("half", [1, 2, 3])
def test_refined_points_are_fixed_points_or_their_start(half):
    """Every point either converged (one more step moves it < 1e-5 px) or kept its start exactly."""
    rng = np.random.default_rng(half)
    grey = _noisy_pattern(half).astype(np.float32)
    c = sogdd.detect_corners(grey, preset="paper", threshold=1e8, value_range=(0, 255))
    start = c.xy + rng.uniform(-0.4, 0.4, c.xy.shape)  # near the vertices: inside a 3 x 3 window's reach
    n = len(start)
    assert n >= 50
    q = forstner_points(grey, start, np.full(n, half), np.full(n, 3.0))
    again = forstner_points(grey, q, np.full(n, half), np.full(n, np.inf), max_iter=1, tol=np.inf)
    kept = (q == start).all(axis=1)
    step = np.hypot(*(again - q).T)
    assert (step[~kept] < 1e-5).all(), f"{(step[~kept] >= 1e-5).sum()} points not at a fixed point"
    assert kept.mean() < 0.5  # most points converge


@pytest.mark.parametrize("preset", ["paper", "hr"])
def test_a_tiny_change_of_the_image_moves_no_corner(preset):
    """Noise of 1e-5 grey levels: the same corners, none moved by 1e-3 px (0.2.0's hr: up to 1.6 px here)."""
    moved = []
    for seed in range(4):
        img = _noisy_pattern(seed)
        tiny = img + np.random.default_rng(100 + seed).uniform(-1e-5, 1e-5, img.shape)
        a = sogdd.detect_corners(img, preset=preset, value_range=(0, 255))
        b = sogdd.detect_corners(tiny, preset=preset, value_range=(0, 255))
        assert len(a) == len(b) > 10
        moved.append(cKDTree(b.xy).query(a.xy)[0].max())
    assert max(moved) < 1e-3, f"corners moved by up to {max(moved):.4f} px"
