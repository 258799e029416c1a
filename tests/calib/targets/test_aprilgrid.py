"""AprilGrid (Kalibr's target): OpenCV's tags, Kalibr's point numbers, sogdd's corners, on rendered views
with exact corners; OpenCV's own ArUco corner refinement as the comparator; a camera calibrated end to end."""

from __future__ import annotations

import functools
import json

import cv2
import numpy as np
import pytest

from sogdd.calib.files import read_camera
from sogdd.calib.targets.aprilgrid import OPENCV_CORNERS, AprilGrid, detect_aprilgrid, detector_parameters
from sogdd.calib.targets.spec import parse_board
from sogdd.cli.main import main

DICT = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
#: tags 0, 1, 2 of ``t36h11`` in Kalibr's target generator (``kalibr_create_target_pdf``, from the AprilTags
#: C++ library)
KALIBR_CODES = (0xD5D628584, 0xD97F18B49, 0xDD280910E)
GRID = AprilGrid(4, 4, 0.088, 0.3)


def kalibr_bits(code: int) -> np.ndarray:
    """The 6 x 6 bits as Kalibr draws them, 1 white, row 0 at the top of the printed target: bit ``6 i + j``
    of the code at ``[i, j]``, black when 0, then ``np.rot90(..., 2)`` (its ``rotation=2``)."""
    m = np.array([[(code >> (6 * i + j)) & 1 for j in range(6)] for i in range(6)])
    return np.rot90(m, 2)


def test_kalibr_prints_opencvs_tag_turned_half_a_turn():
    for t, code in enumerate(KALIBR_CODES):
        opencv = (cv2.aruco.generateImageMarker(DICT, t, 10, borderBits=2)[2:8, 2:8] > 0).astype(int)
        assert np.array_equal(kalibr_bits(code), np.rot90(opencv, 2))
        assert not np.array_equal(kalibr_bits(code), opencv)  # the turn is seen: the check can fail
    # OpenCV's corners (top left, top right, bottom right, bottom left of its marker) turned half a turn,
    # as (right, up) on the printed target
    assert OPENCV_CORNERS == ((1, 0), (0, 0), (0, 1), (1, 1))


def test_labels_are_kalibrs_points_in_sogdds_frame():
    g = AprilGrid(3, 2, 0.05, 0.25)
    # Kalibr's createGridPoints: point r * 2 cols + c at ((c // 2) (1 + g) s + (c % 2) s, the same in r)
    k = np.arange(4 * 3 * 2)
    c, r = k % 6, k // 6
    x = (c // 2) * 1.25 * 0.05 + (c % 2) * 0.05
    y = (r // 2) * 1.25 * 0.05 + (r % 2) * 0.05
    top = 1.25 * 0.05 + 0.05
    assert g.steps == (4, 5)
    assert np.allclose(g.labels() * g.unit, np.c_[x, top - y], atol=1e-15)
    # tag t's points b, b + 1, b + 2 cols + 1, b + 2 cols (bottom left, bottom right, top right, top left)
    for t in range(6):
        b = (t // 3) * 12 + (t % 3) * 2
        bl, br, tr, tl = b, b + 1, b + 7, b + 6
        assert g.tag_points(np.array([t]))[0].tolist() == [br, bl, tl, tr]
    # right-handed with the normal away from the camera: i right, j down the printed target
    lab = g.labels()
    assert lab[1, 0] > lab[0, 0] and lab[6, 1] < lab[0, 1]


@pytest.mark.parametrize("text", ["aprilgrid:6x6:0.088:0.3", "aprilgrid:4x3:25:0.25", "aprilgrid:1x1:1:1"])
def test_a_specification_reads_back_what_it_writes(text):
    spec = parse_board(text)
    assert str(spec) == text and parse_board(str(spec)) == spec and spec.kind == "aprilgrid"


def test_the_grid_of_a_specification():
    g = parse_board("AprilGrid:6x5:0.088:0.3").aprilgrid()
    assert (g.cols, g.rows, g.tag_size, g.spacing, g.steps) == (6, 5, 0.088, 0.3, (10, 13))
    assert abs(g.unit - 0.0088) < 1e-15


@pytest.mark.parametrize("bad, words", [
    ("aprilgrid:6x6:0.088", "expected"), ("aprilgrid:6:0.088:0.3", "is not COLSxROWS"),
    ("aprilgrid:0x6:0.088:0.3", "from 1 to 587 tags"), ("aprilgrid:30x30:0.088:0.3", "from 1 to 587 tags"),
    ("aprilgrid:6x6:-1:0.3", "SIZE"), ("aprilgrid:6x6:big:0.3", "SIZE"), ("aprilgrid:6x6:inf:0.3", "SIZE"),
    ("aprilgrid:6x6:0.088:0", "SPACING"), ("aprilgrid:6x6:0.088:1.5", "SPACING"),
    ("aprilgrid:6x6:0.088:0.333", "SPACING"), ("aprilgrid:6x6:0.088:nan", "SPACING")])
def test_a_bad_specification_is_one_line_naming_it(bad, words):
    with pytest.raises(ValueError, match=words) as e:
        parse_board(bad)
    assert repr(bad) in str(e.value) and "\n" not in str(e.value)


def test_no_grid_and_bad_arguments():
    assert detect_aprilgrid(np.full((200, 200), 128, np.uint8), GRID) is None
    with pytest.raises(TypeError, match="AprilGrid"):
        detect_aprilgrid(np.zeros((20, 20), np.uint8), "aprilgrid:4x4:0.088:0.3")
    with pytest.raises(ValueError, match="min_corners"):
        detect_aprilgrid(np.zeros((20, 20), np.uint8), GRID, min_corners=0)


CAM_SIZE = (640, 480)


@functools.lru_cache(maxsize=1)
def views(render):
    """Rendered views of the 4 x 4 grid: tags of 40-60 px, tilts up to 45 degrees, blur 0.7 and 1.2 px,
    noise 2 grey levels."""
    cam = render.camera_for(*CAM_SIZE)
    sq = (3 * 1.3 + 1) * 0.088 / 7
    stand_in = render.Board(8, 8, sq)  # a chessboard of the grid's centre and span, to place it
    poses = render.random_poses(cam, stand_in, 4, seed=1, tilt_max=45,
                                cell_px=(40 * sq / 0.088, 60 * sq / 0.088))
    return [render.render_aprilgrid(cam, 4, 4, 0.088, 0.3, rv, tv, blur=blur, noise=2.0, rng=k)
            for k, (rv, tv) in enumerate(poses) for blur in (0.7, 1.2)]


def opencv_corners(image, variant):
    """OpenCV's tags with its own corner refinement: corners (N, 2) and Kalibr's point numbers.

    ``variant``: ``"subpix"`` ArUco's ``CORNER_REFINE_SUBPIX`` as it comes; ``"subpix-wide"`` the same with
    the window no longer cut to a share of the marker's bits (``relativeCornerRefinmentWinSize = 1``: the
    window is ``cornerRefinementWinSize``, 5 px); ``"cornersubpix"`` ``cv2.cornerSubPix`` (half-width 5 px,
    to 0.01 px) on ArUco's unrefined corners, as Kalibr refines its tags' (with 2 px)."""
    method = cv2.aruco.CORNER_REFINE_NONE if variant == "cornersubpix" else cv2.aruco.CORNER_REFINE_SUBPIX
    params = detector_parameters(method)
    if variant == "subpix-wide":
        params.relativeCornerRefinmentWinSize = 1.0
    corners, ids, _ = cv2.aruco.ArucoDetector(DICT, params).detectMarkers(image)
    if ids is None:
        return np.zeros((0, 2)), np.zeros(0, np.int64)
    ids = ids.reshape(-1)
    on = ids < GRID.cols * GRID.rows
    xy = np.asarray(corners, np.float64).reshape(-1, 4, 2)[on].reshape(-1, 2)
    if variant == "cornersubpix":
        crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)
        xy = cv2.cornerSubPix(image, xy.astype(np.float32).reshape(-1, 1, 2), (5, 5), (-1, -1), crit)
        xy = xy.reshape(-1, 2).astype(np.float64)
    return xy, GRID.tag_points(ids[on]).reshape(-1)


VARIANTS = ("subpix", "subpix-wide", "cornersubpix")


def test_every_label_right_and_corners_twice_as_accurate_as_opencvs(render):
    ours, theirs, found, seen = [], {k: [] for k in VARIANTS}, 0, 0
    for v in views(render):
        b = detect_aprilgrid(v.image, GRID)
        assert b is not None and b.source == "aprilgrid" and np.all(np.diff(b.ids) > 0)
        assert np.array_equal(b.labels, v.labels[b.ids])  # no wrong label
        assert (b.size == (8, 8)) == (len(b) == 64)
        err = np.hypot(*(b.image_points - v.corners[b.ids]).T)
        assert err.max() < 0.1, err.max()
        found, seen = found + len(b), seen + int(v.inside.sum())
        common = b.ids
        got = {k: opencv_corners(v.image, k) for k in VARIANTS}
        for _, pts in got.values():
            common = np.intersect1d(common, pts)
        assert len(common) >= 4
        ours.append(err[np.searchsorted(b.ids, common)])
        for k, (xy, pts) in got.items():
            order = np.argsort(pts)
            theirs[k].append(np.hypot(*(xy[order][np.searchsorted(pts[order], common)] - v.corners[common]).T))
    ours = np.concatenate(ours)
    means = {k: float(np.concatenate(e).mean()) for k, e in theirs.items()}
    assert found >= 0.7 * seen  # most corners of the views are found
    print(f"\nAprilGrid corners, mean error over the {len(ours)} corners all found: "
          f"sogdd {ours.mean():.4f} px; "
          + ", ".join(f"OpenCV {k} {m:.4f} px (ratio {ours.mean() / m:.3f})" for k, m in means.items())
          + f"; sogdd found {found} of the {seen} corners in the views")
    assert ours.mean() < 0.03
    assert ours.mean() <= 0.5 * min(means.values()), (ours.mean(), means)


def test_a_grid_cut_by_the_frame_is_a_partial_board_with_its_labels(render):
    cam = render.camera_for(*CAM_SIZE)
    R = cv2.Rodrigues(np.array([0.15, -0.25, 0.1]))[0]
    centre = np.array([1, 1, 0.0]) * (3 * 1.3 + 1) * 0.088 / 2
    ray = cam.undistort(np.array([[610.0, 240.0]]))[0]
    t = cam.K[0, 0] * 0.088 / 50 * np.r_[ray, 1.0] - R @ centre  # tags of 50 px, the right part cut
    v = render.render_aprilgrid(cam, 4, 4, 0.088, 0.3, cv2.Rodrigues(R)[0].ravel(), t, blur=0.8, noise=2.0,
                                rng=7)
    assert 8 <= v.inside.sum() <= 56  # cut: some of the corners inside, some not
    b = detect_aprilgrid(v.image, GRID)
    assert b is not None and b.size is None and 8 <= len(b) < 64
    assert np.array_equal(b.labels, v.labels[b.ids])
    assert np.all(render.in_frame(v.corners[b.ids], CAM_SIZE, 0.0)) and len(b) >= 0.7 * v.inside.sum()
    assert np.hypot(*(b.image_points - v.corners[b.ids]).T).max() < 0.1


def test_a_tag_read_with_a_wrong_id_goes(render, monkeypatch):
    # swap two tags' IDs as a misread would: their corners lie elsewhere than the IDs say
    v = views(render)[0]
    from sogdd.calib.targets import aprilgrid

    real = aprilgrid.find_tags

    def misread(u8, grid, params=None):
        quads, ids = real(u8, grid, params)
        ids = ids.copy()
        ids[[0, -1]] = ids[[-1, 0]]
        order = np.argsort(ids)
        return quads[order], ids[order]

    monkeypatch.setattr(aprilgrid, "find_tags", misread)
    b = detect_aprilgrid(v.image, GRID)
    assert b is not None and np.array_equal(b.labels, v.labels[b.ids])
    assert np.hypot(*(b.image_points - v.corners[b.ids]).T).max() < 0.1


def test_a_corner_astray_is_measured_again_from_its_neighbours(render, monkeypatch):
    # OpenCV's corner of one tag 4 px astray: the refinement alone finds no corner or the wrong one there
    v = views(render)[2]
    from sogdd.calib.targets import aprilgrid

    real = aprilgrid.find_tags
    quads, ids = real(np.asarray(v.image), GRID)
    k = len(ids) // 2
    moved = (quads[k, 0] - quads[k].mean(axis=0)) * 0.12 + np.array([3.0, -2.5])

    def astray(u8, grid, params=None):
        q, i = real(u8, grid, params)
        q = q.copy()
        q[k, 0] += moved
        return q, i

    monkeypatch.setattr(aprilgrid, "find_tags", astray)
    b = detect_aprilgrid(v.image, GRID)
    point = GRID.tag_points(ids[k:k + 1])[0, 0]
    assert point in b.ids and np.array_equal(b.labels, v.labels[b.ids])
    assert np.hypot(*(b.image_points[b.ids == point][0] - v.corners[point])) < 0.1
    assert np.hypot(*(b.image_points - v.corners[b.ids]).T).max() < 0.1


@pytest.mark.slow
def test_sogdd_calibrate_recovers_the_camera(render, tmp_path, capsys):
    cam = render.camera_for(*CAM_SIZE)
    stand_in = render.Board(12, 12, 0.06)  # the 6 x 6 grid's centre and span
    poses = render.random_poses(cam, stand_in, 8, seed=4, tilt_max=40, cell_px=(32 * 0.06 / 0.088,
                                                                                 42 * 0.06 / 0.088))
    folder = tmp_path / "views"
    folder.mkdir()
    for k, (rv, tv) in enumerate(poses):
        v = render.render_aprilgrid(cam, 6, 6, 0.088, 0.3, rv, tv, blur=0.7, noise=1.0, rng=k)
        cv2.imwrite(str(folder / f"a{k}.png"), v.image)
    out = tmp_path / "out"
    code = main(["calibrate", str(folder), "--board", "aprilgrid:6x6:0.088:0.3", "--model", "pinhole4",
                 "--out", str(out), "--no-report", "--quiet"])
    text, err = capsys.readouterr()
    assert code in (0, 3), err
    K = read_camera(out / "camera.yaml")["camera_matrix"]
    assert abs(K[0, 0] - cam.K[0, 0]) < 0.005 * cam.K[0, 0], (K[0, 0], cam.K[0, 0])
    # the object points in the tag size's unit without --square: one label step is SIZE / q = 0.088 / 10
    assert abs(json.loads((out / "camera.json").read_text())["square"] - 0.0088) < 1e-12


def test_a_grid_in_negative_is_found_with_the_same_corners(render):
    """A heated grid in a thermal camera shows its tags in negative: the spec finds it, with the positive
    image's IDs and corners."""
    from sogdd.calib.targets.spec import view_boards

    cam = render.camera_for(*CAM_SIZE)
    R = cv2.Rodrigues(np.array([0.1, -0.2, 0.05]))[0]
    centre = np.array([1, 1, 0.0]) * (3 * 1.3 + 1) * 0.088 / 2
    t = cam.K[0, 0] * 0.088 / 60 * np.r_[0.0, 0.0, 1.0] - R @ centre
    v = render.render_aprilgrid(cam, 4, 4, 0.088, 0.3, cv2.Rodrigues(R)[0].ravel(), t, blur=0.8, noise=2.0,
                                rng=3)
    spec = parse_board("aprilgrid:4x4:0.088:0.3")
    pos, neg = view_boards(v.image, spec).boards, view_boards(255 - v.image, spec).boards
    assert len(pos) == len(neg) == 1 and len(neg[0]) == 64 and np.array_equal(pos[0].ids, neg[0].ids)
    assert np.hypot(*(neg[0].image_points - v.corners[neg[0].ids]).T).max() < 0.1
