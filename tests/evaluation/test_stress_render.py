"""The stress renders: their ground truth lands on the rendered corners, and each stress is what it says."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import Camera
from sogdd.evaluation.calibration import render as R
from sogdd.evaluation.calibration.sequences import sequences
from sogdd.evaluation.calibration.stress import STRESS_SCENES, StressSequence, stress_camera, stress_scene


def _sub_pix(image: np.ndarray, start: np.ndarray, win: int = 3) -> np.ndarray:
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)
    pts = start.astype(np.float32).reshape(-1, 1, 2).copy()
    return cv2.cornerSubPix(image.astype(np.float32), pts, (win, win), (-1, -1), crit).reshape(-1, 2)


@pytest.mark.parametrize("name", STRESS_SCENES)
def test_truth_lands_on_the_rendered_corners(name):
    """cornerSubPix started 0.7 px off the truth, on a noise-free render, comes back to within 0.15 px."""
    sc = stress_scene(name, rng=5, noise=0.0)
    assert sc.image.shape == (480, 640) and sc.image.dtype == np.uint8 and sc.inside.all()
    assert sc.labels.shape == (sc.pattern[0] * sc.pattern[1], 2)
    found = _sub_pix(sc.image, sc.corners + [0.5, -0.5])
    err = np.linalg.norm(found - sc.corners, axis=1)
    assert np.median(err) < (0.15 if name != "jpeg" else 0.25) and err.max() < 0.5, err.max()


def test_narrow_outer_squares_have_the_requested_width():
    """Face on, 20 px cells: the outer dark square ends 0.4 cell beyond the first corner, then background."""
    f, sq_px = 1000.0, 20.0
    cam = Camera(np.array([[f, 0, 99.5], [0, f, 79.5], [0, 0, 1]]), (0.0, 0, 0, 0), (200, 160))
    target = R.ChessboardTarget(4, 3, 0.01, edge=0.4)
    assert target.margin == 0.0
    z = f * target.square / sq_px
    c0 = np.array([60.5, 50.0])  # inner corner (0, 0) on a pixel boundary: no pixel straddles x = 60.5
    tvec = np.array([(c0[0] - 99.5) * z / f, (c0[1] - 79.5) * z / f, z])
    img = R.render_scene(cam, target, np.zeros(3), tvec, supersample=8)
    dark, light, bg = R._LEVELS
    row = int(c0[1] - 0.2 * sq_px)  # inside the cut top row, above corner (0, 0): square (0, 0) is dark
    # the dark square's coverage along the row sums to its width in px
    left = img[row, :int(c0[0]) + 1]
    width = np.sum((bg - left) / (bg - dark))
    assert abs(width - 0.4 * sq_px) < 1e-6
    assert img[row, int(c0[0] - 0.4 * sq_px) - 2] == bg and img[row, int(c0[0]) - 2] == dark
    # the full board (edge 1, bit-identical to before) has the full square and a white margin
    full = R.render_scene(cam, R.ChessboardTarget(4, 3, 0.01), np.zeros(3), tvec, supersample=8)
    assert full[row, int(c0[0] - sq_px) + 2] == dark and full[row, int(c0[0] - sq_px) - 2] == light


def test_edge_scene_cut_and_default_render_is_unchanged():
    sc = stress_scene("edge", rng=2)
    assert 0.3 <= sc.target.edge <= 0.6 and sc.target.margin == 0.0
    u0, u1, v0, v1 = sc.target.squares_extent()
    assert np.isclose(-u0, sc.target.edge * sc.target.square)


def test_default_render_is_repeatable_and_true_to_its_corners():
    """The sequences' renders (the docs' tables) are repeatable, and their corners are where the camera puts
    them: cornerSubPix on the noise-free render lands on the projected corners. (A checksum of the float
    image, kept here before, differs between numpy builds while the image does not.)"""
    from sogdd.evaluation.calibration.sequences import camera_for

    cam = camera_for(320, 240)
    t = R.ChessboardTarget(7, 5, 0.02)
    rv, tv = R.random_sequence(cam, t, 1, seed=3, cell_px=(20, 26))[0]
    scene = R.render_scene(cam, t, rv, tv)
    assert np.array_equal(scene, R.render_scene(cam, t, rv, tv))
    view = R.render_view(cam, t, rv, tv, blur=0.8, noise=2, falloff=0.3, rng=1).image
    assert np.array_equal(view, R.render_view(cam, t, rv, tv, blur=0.8, noise=2, falloff=0.3, rng=1).image)
    truth = cam.project(t.object_points(), rv, tv).astype(np.float32)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    found = cv2.cornerSubPix(scene.astype(np.float32), truth.reshape(-1, 1, 2) + 0.3, (5, 5), (-1, -1), crit)
    assert np.abs(found.reshape(-1, 2) - truth).max() < 0.1


def test_fisheye_covers_160_degrees_and_its_rays_invert_its_projection():
    cam = stress_camera("fisheye")
    w, h = cam.size
    for az in (0.0, np.pi):  # 80 degrees off the axis, left and right: inside the frame
        a = np.radians(80.0)
        p = cam.project(np.array([[np.sin(a) * np.cos(az), np.sin(a) * np.sin(az), np.cos(a)]]))[0]
        assert 0 <= p[0] <= w - 1 and 0 <= p[1] <= h - 1
        assert abs(np.hypot(*(p - cam.K[:2, 2])) - cam.fx * a) < 1e-9  # equidistant: r = f theta
    # the field of view across the width, from the rays of the frame's side pixels
    d = cam.rays(np.array([[0.0, cam.K[1, 2]], [w - 1.0, cam.K[1, 2]]]))
    assert np.degrees(np.arccos(np.clip(d[0] @ d[1], -1, 1))) >= 160
    rng = np.random.default_rng(0)
    px = rng.uniform([0, 0], [w - 1, h - 1], (200, 2))
    assert np.abs(cam.project(cam.rays(px)) - px).max() < 1e-9
    # OpenCV's fisheye projection agrees in front of the camera, with and without k
    pts = rng.uniform([-1, -1, 0.2], [1, 1, 1], (50, 3))
    for k in ((0.0, 0, 0, 0), (0.03, -0.01, 0.002, 0.0)):
        c = Camera(cam.K, k, cam.size, model="fisheye")
        cv, _ = cv2.fisheye.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), cam.K, np.array(k))
        assert np.abs(c.project(pts) - cv.reshape(-1, 2)).max() < 1e-9


def test_fisheye_samples_are_exact_near_the_rim():
    """Every sample's board position projects back onto the sample, rays up to 90 degrees off the axis."""
    from sogdd.evaluation.calibration.raster import sample_coords

    cam = stress_camera("fisheye")
    # a board facing the camera 85 degrees off the axis: the rays that meet it reach ~90 degrees
    a = np.radians(85.0)
    d = np.array([np.sin(a), 0.0, np.cos(a)])
    Rm = np.stack([np.cross([0.0, 1, 0], d), [0.0, 1, 0], d], axis=1)
    Rm[:, 0] /= np.linalg.norm(Rm[:, 0])
    tvec = 0.3 * d - Rm @ np.array([0.03, 0.02, 0.0])
    small = Camera(cam.K, cam.dist, (640, 480), model="fisheye")
    u, v = sample_coords(small, Rm, tvec, 4)
    rows, cols = np.mgrid[0:u.shape[0]:7, 0:u.shape[1]:7]
    uv = np.stack([u[rows, cols].ravel(), v[rows, cols].ravel()], axis=1)
    ok = np.all(np.isfinite(uv), axis=1) & (np.abs(uv).max(axis=1) < 0.2)
    assert ok.sum() > 100
    pts = np.concatenate([uv[ok], np.zeros((ok.sum(), 1))], axis=1)
    back = small.project(pts, cv2.Rodrigues(Rm)[0].ravel(), tvec)
    want = np.stack([-0.5 + (cols.ravel()[ok] + 0.5) / 4, -0.5 + (rows.ravel()[ok] + 0.5) / 4], axis=1)
    assert np.abs(back - want).max() < 1e-7
    angles = np.degrees(np.arccos(small.rays(want)[:, 2]))
    assert angles.max() > 88


def test_background_board_is_small_apart_and_returned_as_truth():
    sc = stress_scene("background", rng=4, noise=0.0)
    (other,) = sc.others
    assert other.pattern == sc.pattern
    g = other.corners.reshape(other.pattern[1], other.pattern[0], 2)
    cells = np.concatenate([np.linalg.norm(np.diff(g, axis=1), axis=2).ravel(),
                            np.linalg.norm(np.diff(g, axis=0), axis=2).ravel()])
    assert 2.5 <= cells.min() and cells.max() <= 5.5
    # the two boards' boxes are apart, and the small board is rendered: its corners are X-junctions
    lo, hi = sc.corners.min(axis=0), sc.corners.max(axis=0)
    assert not np.any(np.all((other.corners >= lo) & (other.corners <= hi), axis=1))
    box = np.r_[other.corners.min(axis=0) - 2, other.corners.max(axis=0) + 2].astype(int)
    patch = sc.image[box[1]:box[3], box[0]:box[2]].astype(float)
    assert patch.max() - patch.min() > 80  # dark and light squares, not a blur of background


def test_dots_are_printed_inside_white_squares_only():
    sc = stress_scene("dots", rng=6, noise=0.0, blur=0.0)
    centres = sc.target.dot_centres()
    assert len(centres) > 20
    px = sc.camera.project(np.c_[centres, np.zeros(len(centres))], sc.rvec, sc.tvec)
    vals = sc.image[np.rint(px[:, 1]).astype(int), np.rint(px[:, 0]).astype(int)]
    assert np.median(vals) < 80  # dark dots
    # 0.2 cell clear of the square's edges: the points 0.1 cell inside each white square's edge stay white
    sq = sc.target.square
    probes = []
    for a in range(1, sc.target.cols):
        for b in range(1, sc.target.rows):
            if (a + b) % 2:
                for fu, fv in ((0.1, 0.5), (0.9, 0.5), (0.5, 0.1), (0.5, 0.9), (0.1, 0.1), (0.9, 0.9)):
                    probes.append(((a - 1 + fu) * sq, (b - 1 + fv) * sq, 0.0))
    pp = sc.camera.project(np.array(probes), sc.rvec, sc.tvec)
    white = sc.image[np.rint(pp[:, 1]).astype(int), np.rint(pp[:, 0]).astype(int)]
    assert white.min() > 150


def test_jpeg_has_8x8_block_artefacts():
    """JPEG at quality 75: the error against the uncompressed image jumps at the 8 x 8 block boundaries."""
    sc = stress_scene("jpeg", rng=7, noise=0.0)
    assert sc.jpeg == 75
    cells = np.linalg.norm(np.diff(sc.corners.reshape(sc.pattern[1], sc.pattern[0], 2), axis=1), axis=2)
    assert 18 <= np.median(cells) <= 32
    plain = np.clip(np.rint(sc.clean), 0, 255)
    err = sc.image.astype(float) - plain
    assert np.abs(err).max() > 5
    # the step of the error between neighbouring columns is larger across block boundaries
    step = np.abs(np.diff(err, axis=1)).mean(axis=0)
    across = step[7::8].mean()
    within = np.delete(step, np.s_[7::8]).mean()
    assert across > 1.3 * within


def test_scenes_are_seeded_and_names_checked():
    a, b = stress_scene("edge", rng=11), stress_scene("edge", rng=11)
    assert np.array_equal(a.image, b.image) and np.array_equal(a.corners, b.corners)
    with pytest.raises(ValueError, match="unknown stress scene"):
        stress_scene("nope", rng=0)


def test_stress_sequence_is_registered_by_name_only():
    (seq,) = sequences(["stress"])
    assert isinstance(seq, StressSequence) and seq.n_views == 15 and not seq.calibrate
    assert "stress" not in [s.name for s in sequences()]
    small = StressSequence(views_per_scene=1, scenes=("jpeg",))
    (view,) = small.clean_views()
    noisy = small.draw(view, (0, 0), 0)
    assert noisy.image.shape == (480, 640) and np.array_equal(noisy.corners, view.corners)
