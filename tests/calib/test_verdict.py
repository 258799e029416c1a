"""The verdict's rules on the parameters (uncertainties, aspect ratio, distortion) and the coverage map."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.fit import calibrate
from sogdd.calib.targets.board import Board
from sogdd.calib.verdict import coverage, verdict

SIZE = (640, 480)


def cells(points: np.ndarray, size, grid=(8, 6)) -> np.ndarray:
    """Corners per cell, cell by cell: the frame spans [-0.5, w - 0.5] x [-0.5, h - 0.5] (pixel centres
    at integers), cut into equal cells; a corner on the frame's far edge belongs to the last cell."""
    (w, h), (gx, gy) = size, grid
    xe = -0.5 + np.arange(gx + 1) * w / gx
    ye = -0.5 + np.arange(gy + 1) * h / gy
    out = np.zeros((gy, gx), int)
    for j in range(gy):
        for i in range(gx):
            inx = (points[:, 0] >= xe[i]) & ((points[:, 0] < xe[i + 1]) | (i == gx - 1))
            iny = (points[:, 1] >= ye[j]) & ((points[:, 1] < ye[j + 1]) | (j == gy - 1))
            out[j, i] = int(np.sum(inx & iny))
    return out


def shares(counts: np.ndarray) -> tuple[float, float]:
    """Covered share of all cells and of the border cells, counted cell by cell."""
    gy, gx = counts.shape
    border = [counts[j, i] > 0 for j in range(gy) for i in range(gx) if j in (0, gy - 1) or i in (0, gx - 1)]
    return float(np.mean(counts > 0)), sum(border) / len(border)


def used(cal) -> np.ndarray:
    return np.concatenate([b.image_points[u] for b, u in zip(cal.boards, cal.corner_used) if b is not None])


def texts(cal) -> str:
    return " | ".join(f"{lv}: {t}" for lv, t in verdict(cal))


@pytest.fixture(scope="module")
def sound(synthetic):
    return calibrate(synthetic.boards(14, noise=0.05, seed=21, spread=1.6), SIZE)


def test_coverage_counts_every_cell_to_the_frames_edges(sound):
    # one corner in each border cell of the right column and the bottom row, at the cells' far edges
    w, h = SIZE
    pts = np.array([[w - 0.5, -0.5 + (j + 0.5) * h / 6] for j in range(6)]
                   + [[-0.5 + (i + 0.5) * w / 8, h - 0.5] for i in range(7)])
    cal = dataclasses.replace(sound, boards=(Board(pts, np.c_[np.arange(13), np.zeros(13, int)]),),
                              corner_used=(np.ones(13, bool),))
    counts, covered, edge = coverage(cal)
    np.testing.assert_array_equal(counts, cells(pts, SIZE))
    assert counts[:, -1].tolist() == [1] * 6 and counts[-1, :].tolist() == [1] * 8
    assert (covered, edge) == pytest.approx((13 / 48, 13 / 24))
    # and the coverage of a real calibration, cell by cell
    counts, covered, edge = coverage(sound)
    np.testing.assert_array_equal(counts, cells(used(sound), SIZE))
    assert (covered, edge) == pytest.approx(shares(counts))


def test_one_view_is_bad_for_its_missing_standard_deviations(synthetic):
    cal = calibrate(synthetic.boards(1, seed=2), SIZE, min_views=1)
    found = [t for lv, t in verdict(cal) if lv == "bad" and t.startswith("no standard deviations")]
    assert len(found) == 1 and "one view" in found[0]


def test_undetermined_intrinsics_are_bad(sound):
    assert "undetermined" not in texts(sound) and verdict(sound)[0][0] == "ok"
    loose = dataclasses.replace(sound, std={**sound.std, "cx": 1.5 * sound.K[0, 2]})
    assert "bad: undetermined intrinsics (cx = " in texts(loose)


@pytest.mark.parametrize("rel,std_fy,flagged", [
    (0.05, None, True),     # 5 %, many deviations apart
    (0.005, None, False),   # within the 1 % tolerance: square pixels, fitted
    (0.05, 20.0, False),    # beyond the tolerance but within 3 standard deviations
])
def test_fx_and_fy_must_agree(sound, rel, std_fy, flagged):
    K = sound.K.copy()
    K[1, 1] = K[0, 0] * (1 - rel)
    std = {**sound.std, "fx": std_fy or sound.std["fx"], "fy": std_fy or sound.std["fy"]}
    cal = dataclasses.replace(sound, K=K, std=std)
    assert ("bad: fx and fy differ by" in texts(cal)) == flagged


def test_fisheye_coefficients_that_cancel_are_nonsense(synthetic):
    """Five views in the centre: a fisheye fit with k3 ~ 7 and k4 ~ -21 whose terms cancel."""
    fd = np.array([0.08, -0.02, 0.01, 0.0])
    few = calibrate(synthetic.boards(5, noise=0.05, seed=2, spread=0.2, dist=fd, model="fisheye"), SIZE,
                    model="fisheye")
    assert few.dist[2] > 3 and few.dist[3] < -10
    assert "bad: implausible distortion" in texts(few) and "and they fit noise: with k" in texts(few)
    assert all(np.isfinite(v) for v in few.std.values())  # computed, though OpenCV gives none
    good = calibrate(synthetic.boards(14, noise=0.05, seed=2, spread=1.6, dist=fd, model="fisheye"), SIZE,
                     model="fisheye")
    assert "implausible" not in texts(good) and "folds" not in texts(good)
    nonsense = dataclasses.replace(good, dist=np.array([0.08, -0.5, 7.2, -25.6]))
    assert "bad: implausible distortion" in texts(nonsense)


def test_a_distortion_that_folds_over(sound):
    # r (1 - 0.6 r^2) peaks at r = 0.75, beyond the corners' largest ray (about 0.6) and short of the frame
    beyond = dataclasses.replace(sound, dist=np.array([-0.6, 0, 0, 0, 0]))
    assert "warn: the distortion folds over" in texts(beyond) and "beyond the corners" in texts(beyond)
    assert "not those of a lens" not in texts(beyond)  # an extrapolation, which a sound fit may make too
    # r (1 - 1.2 r^2) peaks at r = 0.53, where the corners are
    inside = dataclasses.replace(sound, dist=np.array([-1.2, 0, 0, 0, 0]))
    assert "bad: the distortion folds over" in texts(inside) and "inside the corners" in texts(inside)
    assert "not those of a lens" in texts(inside)
    assert "folds" not in texts(sound)


def test_rational_coefficients_are_judged_by_their_map(synthetic):
    rat = calibrate(synthetic.boards(14, noise=0.05, seed=21, spread=1.6), SIZE, model="rational")
    assert np.abs(rat.dist).max() > 1 and "folds" not in texts(rat)
    # another sound fit whose numerator and denominator both vanish near r = 0.6: a spike over a sliver
    # of rays, not a fold
    near = calibrate(synthetic.boards(14, noise=0.05, seed=2, spread=1.6), SIZE, model="rational")
    r2 = np.linspace(0, 0.7, 200) ** 2
    k1, k2, _, _, k3, k4, k5, k6 = near.dist
    assert (1 + r2 * (k4 + r2 * (k5 + r2 * k6))).min() < 0 < near.cross_validation.mean_within < 0.5
    assert "folds" not in texts(near)
    # (1 - 0.25 r^2) (1 + 5 r^2) / (1 + 5 r^2): a k4 of 5 with the same map as k1 = -0.25
    same = dataclasses.replace(rat, dist=np.array([4.75, -1.25, 0, 0, 0, 5.0, 0, 0]))
    assert "folds" not in texts(same) and "implausible" not in texts(same)
    # a numerator that turns the map over at r = 1 / 3, inside the corners
    fold = dataclasses.replace(rat, dist=np.array([-3.0, 0, 0, 0, 0, 0, 0, 0]))
    assert "bad: the distortion folds over" in texts(fold)


@pytest.mark.parametrize("n, few", [(9, True), (10, False)])
def test_few_views_is_fewer_than_ten_used(synthetic, n, few):
    cal = calibrate(synthetic.boards(n, noise=0.05, seed=21, spread=1.6), SIZE)
    assert cal.n_used == n
    found = [(lv, t.split(":")[0]) for lv, t in verdict(cal) if t.startswith("few views")]
    assert found == ([("warn", f"few views ({n} used)")] if few else [])


def long_lens(n: int = 20, dist=(-0.10, 0.43, 0.0, 0.0), seed: int = 0):
    """A pinhole4 calibration of a long lens (fx = 1840 px at 1224 x 1024: 23 degrees to the frame's corner,
    as rig3_ecocheck's cameras) from ``n`` views of a 9 x 6 board 22-32 squares away, over the whole frame."""
    K = np.array([[1840.0, 0, 612], [0, 1840, 512], [0, 0, 1]])
    size = (1224, 1024)
    obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    rng = np.random.default_rng(seed)
    boards = []
    while len(boards) < n:
        rv = rng.normal(size=3) * [1, 1, 0.3]
        rv *= np.deg2rad(35) * rng.uniform() / np.linalg.norm(rv)
        centre = np.array(size) / 2 + rng.uniform(-0.45, 0.45, 2) * size
        t = np.linalg.solve(K, [*centre, 1.0]) * rng.uniform(22, 32) - cv2.Rodrigues(rv)[0] @ [4.0, 2.5, 0]
        p = project(obj, K, np.array(dist), "pinhole4", rv, t)
        if np.all((p > 5) & (p < np.array(size) - 6)):
            boards.append(Board(p + rng.normal(0, 0.1, p.shape), obj[:, :2].astype(int)))
    return calibrate(boards, size, model="pinhole4")


def test_terms_that_cancel_but_held_out_corners_need_are_the_lenss():
    """A long lens's k1 = -0.10, k2 = 0.43 all but cancel at the frame's corner; without k2 the held-out
    corners are predicted worse, so the verdict says they are the lens's, not that they are implausible."""
    cal = long_lens()
    (found,) = [(lv, t) for lv, t in verdict(cal) if "at the frame's corner its terms" in t]
    assert found[0] == "ok" and "they are the lens's: without k2 the model predicts" in found[1]
    assert "5-fold cross-validation" in found[1] and "implausible" not in texts(cal)


def test_terms_that_fit_noise_are_told_how_to_hold_them_for_their_model():
    """The same lens with k2 = 0 and cancelling coefficients put in: held-out corners do as well without
    k2, and a pinhole4 (k3 already held) is told to hold k2, not k3."""
    cal = long_lens(dist=(-0.10, 0.0, 0.0, 0.0))
    cancel = dataclasses.replace(cal, dist=np.array([-0.3, 1.6, 0.0, 0.0]))
    text = texts(cancel)
    assert "bad: implausible distortion (k1 = -0.3, k2 = 1.6)" in text
    assert "they fit noise: with k2 held at 0" in text
    assert "cv2.CALIB_FIX_K2" in text and "CALIB_FIX_K3" not in text
    # too few views to cross-validate: the sizes alone, and still the model's own top term
    few = dataclasses.replace(cancel, view_used=np.r_[np.ones(3, bool), np.zeros(17, bool)])
    text = texts(few)
    assert "bad: implausible distortion" in text and "too few views to test them" in text
    assert "cv2.CALIB_FIX_K2" in text and "CALIB_FIX_K3" not in text
