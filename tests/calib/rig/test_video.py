"""A rig calibrated from videos, one per camera, frames matched by index (:mod:`sogdd.calib.rig.video`), on
videos rendered by the tests' own renderer (``render``, tests/calib/conftest.py) of a known two-camera rig:
the board held still at each of its poses for a few frames, a smeared frame between two poses, and two poses
the right camera does not see."""

from __future__ import annotations

import csv
import json
import re
from dataclasses import replace
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from sogdd.calib.rig.video import calibrate_rig_video
from sogdd.calib.video import frame_name, pick_frames, scan_video
from sogdd.cli.main import main

SPEC = "chessboard:9x6"
SIZE = (320, 240)
#: the rig: the left camera the reference; the right one 2.5 squares to its right, turned 4 degrees towards it
LEFT = (np.array([[300.0, 0, 161.0], [0, 300.0, 118.0], [0, 0, 1]]), (-0.1, 0.02, 0.001, -0.0005, 0.0))
RIGHT = (np.array([[310.0, 0, 157.0], [0, 309.0, 122.0], [0, 0, 1]]), (-0.12, 0.03, -0.0008, 0.0006, 0.0))
R_TRUE = cv2.Rodrigues(np.array([0.0, np.deg2rad(-4.0), 0.0]))[0]
T_TRUE = np.array([-2.5, 0.05, 0.1])
HOLD = 3  # frames the board is held still at each pose
SHARED, LEFT_ONLY = 10, 2  # poses both cameras see; poses the right camera does not see (its frames blank)
EXTRA = 5  # frames the long right video has past the left one's end


def _poses(cams, board, n: int, rng) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` board poses (in the left camera's frame) whose paper is whole in both cameras, 6 px inside."""
    out = []
    paper = board.outline()
    while len(out) < n:
        axis, tilt = rng.uniform(0, 2 * np.pi), np.radians(rng.uniform(10, 40))
        R = cv2.Rodrigues(np.array([np.cos(axis), np.sin(axis), 0.0]) * tilt)[0] @ \
            cv2.Rodrigues(np.array([0.0, 0.0, np.radians(rng.uniform(-20, 20))]))[0]
        z = 300.0 * 10 / (rng.uniform(0.5, 0.8) * 240)
        ray = cams[0].undistort(np.array([[rng.uniform(110, 210), rng.uniform(85, 155)]]))[0]
        t = z * np.array([ray[0], ray[1], 1.0]) - R @ np.array([4.0, 2.5, 0.0])
        ok = True
        for cam, (rv, tv) in zip(cams, _both(cv2.Rodrigues(R)[0].ravel(), t)):
            edge = cam.project(paper, rv, tv)
            ok &= bool(np.all(np.isfinite(edge)) and np.all((edge >= 6) & (edge <= np.array(SIZE) - 7)))
        if ok:
            out.append((cv2.Rodrigues(R)[0].ravel(), t))
    return out


def _both(rv, t):
    """The board's pose in the left camera and in the right one (x_right = R x_left + T)."""
    return (rv, t), (cv2.Rodrigues(R_TRUE @ cv2.Rodrigues(rv)[0])[0].ravel(), R_TRUE @ t + T_TRUE)


def _write(path, frames) -> None:
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25, SIZE, False)
    assert w.isOpened()
    for f in frames:
        w.write(f)
    w.release()


@pytest.fixture(scope="module")
def rig_videos(render, tmp_path_factory):
    """``left.avi`` and ``right.avi`` (320 x 240 MJPG, the same length), ``right_long.avi`` (right's frames and
    :data:`EXTRA` more of the board at a pose of its own) and ``blank.avi``; ``smeared``: the frames between two
    poses (motion-blurred), ``left_only``: the frames the right camera does not see."""
    cams = [render.Camera(K, d, SIZE) for K, d in (LEFT, RIGHT)]
    board = render.Board(9, 6)
    rng = np.random.default_rng(11)
    keys = _poses(cams, board, SHARED + LEFT_ONLY + 1, rng)
    extra_pose, keys = keys[-1], keys[:-1]
    hidden = set(range(3, 3 + 2 * LEFT_ONLY, 2))  # two poses among the shared ones, the right camera blank
    bg = np.full(SIZE[::-1], render.LEVELS[2])
    smear = np.zeros((15, 15), np.float32)
    cv2.line(smear, (0, 3), (14, 11), 1.0, 1)
    smear /= smear.sum()
    frames = {"left": [], "right": []}
    smeared, left_only = [], []

    def scene(c, rv, t):
        return render.render_scene(cams[c], board, *_both(rv, t)[c], supersample=2, blur=0.6)

    for k, (rv, t) in enumerate(keys):
        imgs = [scene(0, rv, t), bg if k in hidden else scene(1, rv, t)]
        for _ in range(HOLD):
            if k in hidden:
                left_only.append(len(frames["left"]))
            for c, name in enumerate(frames):
                frames[name].append(render.add_noise(imgs[c], 1.5, rng))
        if k + 1 < len(keys):  # on the way to the next pose: smeared by the motion
            mid = (0.5 * (rv + keys[k + 1][0]), 0.5 * (t + keys[k + 1][1]))
            smeared.append(len(frames["left"]))
            for c, name in enumerate(frames):
                img = bg if {k, k + 1} & hidden and c == 1 else cv2.filter2D(scene(c, *mid), -1, smear)
                frames[name].append(render.add_noise(img, 1.5, rng))
    folder = tmp_path_factory.mktemp("rig_video")
    paths = SimpleNamespace(**{n: folder / f"{n}.avi" for n in ("left", "right", "right_long", "blank")})
    _write(paths.left, frames["left"])
    _write(paths.right, frames["right"])
    more = scene(1, *extra_pose)
    _write(paths.right_long, frames["right"] + [render.add_noise(more, 1.5, rng) for _ in range(EXTRA)])
    _write(paths.blank, [render.add_noise(bg, 1.5, rng) for _ in frames["left"]])
    return SimpleNamespace(paths=paths, folder=folder, frames=len(frames["left"]), smeared=tuple(smeared),
                           left_only=tuple(left_only))


@pytest.fixture(scope="module")
def scans(rig_videos):
    return [scan_video(p, SPEC, thumbnails=False) for p in (rig_videos.paths.left, rig_videos.paths.right)]


@pytest.fixture(scope="module")
def rig(rig_videos):
    p = rig_videos.paths
    return calibrate_rig_video({"left": p.left, "right": p.right}, SPEC, model="pinhole", thumbnails=False)


def test_the_rig_is_calibrated(rig):
    cal = rig.rig
    right = cal.camera("right")
    assert np.linalg.norm(right.T - T_TRUE) < 0.02 * np.linalg.norm(T_TRUE), right.T
    assert np.degrees(np.linalg.norm(cv2.Rodrigues(right.R @ R_TRUE.T)[0])) < 0.3
    for name, (K, _) in (("left", LEFT), ("right", RIGHT)):
        fx = cal.camera(name).K[0, 0]
        assert abs(fx - K[0, 0]) < 0.01 * K[0, 0], (name, fx)
    assert not any("unequal length" in n for n in cal.notes)


def test_frames_are_matched_by_index_and_explained(rig, rig_videos):
    frames = [int(f) for f in rig.frames]
    assert frames == sorted(frames) and len(frames) >= SHARED
    assert not set(frames) & set(rig_videos.smeared)  # never a frame smeared by the motion
    assert len({f // (HOLD + 1) for f in frames}) == len(frames)  # one frame per pose held
    for name in ("left", "right"):
        records = rig.views[name]
        assert [r.name for r in records] == [frame_name(f"{name}.avi", f) for f in frames]
        assert [r.view for r in records] == list(range(len(frames)))
    left_only = [f for f in frames if f in rig_videos.left_only]
    assert left_only  # a pose the right camera does not see is new to the left one
    for f, left, right in zip(frames, rig.views["left"], rig.views["right"]):
        assert left.status == "used" and left.choice.startswith("sharp (")
        if f in left_only:
            assert right.status == "no board" and left.choice.endswith("; seen by left only")
        else:
            assert right.status == "used" and right.choice.endswith("; seen by left, right")
            assert "new pose (" in left.choice or "new pose (" in right.choice


def test_frames_seen_by_both_cameras_come_first(scans, rig_videos):
    few = pick_frames(scans, 4)
    assert len(few) == 4 and all(v is not None for p in few for v in p.views)
    every = pick_frames(scans, 40)
    assert {p.index for p in every if p.views[1] is None} <= set(rig_videos.left_only)
    one = pick_frames(scans[:1], 40)  # one camera alone: its own rules
    assert all(len(p.views) == 1 for p in one)


def test_a_chessboard_frame_needs_a_whole_board(scans):
    """A frame whose boards are all partial (labels relative) is no rig frame: nothing fixes its labels."""
    cut = [replace(s, found=tuple(replace(f, board=replace(f.board, size=None)) for f in s.found))
           for s in scans]
    assert pick_frames(cut, 40, whole=True) == [] and len(pick_frames(cut, 40)) >= SHARED
    half = [scans[0], cut[1]]  # the left camera's boards whole: every frame still a candidate
    assert [p.index for p in pick_frames(half, 40, whole=True)] == [p.index for p in pick_frames(scans, 40)]


def test_unequal_videos_use_their_common_prefix(rig_videos):
    p = rig_videos.paths
    got = calibrate_rig_video({"left": p.left, "right": p.right_long}, SPEC, model="pinhole", thumbnails=False,
                              reject=False)
    n = rig_videos.frames
    note = [t for t in got.rig.notes if "unequal length" in t]
    assert note == [f"videos of unequal length (left {n}, right {n + EXTRA} frames): frames matched by index "
                    f"over the first {n}, the longer videos' later frames unused"]
    assert max(int(f) for f in got.frames) < n  # the right video's last frames, its own pose, are never taken


def _run(capsys, *argv):
    code = main(["calibrate", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_command_writes_the_rig(rig_videos, tmp_path, capsys):
    p, out = rig_videos.paths, tmp_path / "rig"
    code, text, err = _run(capsys, "--camera", "left", p.left, "--camera", "right", p.right, "--board", SPEC,
                           "--model", "pinhole", "--json", "--out", out)
    assert code in (0, 3), err
    got = json.loads(text)
    right = next(c for c in got["cameras"] if c["name"] == "right")
    assert abs(right["fx"] - RIGHT[0][0, 0]) < 0.01 * RIGHT[0][0, 0]
    assert np.linalg.norm(np.array(right["T"]) - T_TRUE) < 0.02 * np.linalg.norm(T_TRUE)
    for f in ("rig.yaml", "rig.json", "report.html", "left/camera.yaml", "right/views.csv",
              "right/corners.csv"):
        assert (out / f).is_file(), f
    rows = list(csv.DictReader(open(out / "left" / "views.csv")))
    assert len(rows) == got["frames"] >= SHARED
    for r in rows:
        assert re.fullmatch(r"left\.avi#frame\d{6}", r["view"]) and r["reasons"].startswith("sharp (")


def test_bad_rig_video_inputs_are_one_line_errors(rig_videos, tmp_path, capsys):
    p = rig_videos.paths
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    (tmp_path / "imgs").mkdir()

    def rig(left, *right):
        return ("--camera", "left", *left, "--camera", "right", *right)

    cases = [(rig([p.left], tmp_path / "imgs"), "all videos"),
             (rig([p.left, p.right], p.right), "camera left: give one video file, not 2"),
             (rig([p.left], tmp_path / "none.mp4"), "camera right: "),
             (rig([p.left], bad), "not a video OpenCV can read"),
             (rig([p.left], p.blank), "camera right: no board (chessboard:9x6) in any frame read of blank.avi"),
             (rig([p.left], p.left), "is the video of both camera left and camera right"),
             (rig([p.left], p.right, "--max-views", 0), "--max-views must be >= 1, got 0"),
             (rig([p.left], p.right, "--allow-missing-frames"), "--allow-missing-frames is for a rig of "
              "images")]
    for args, words in cases:
        out = tmp_path / "out"
        code, _, err = _run(capsys, *args, "--board", SPEC, "--out", out)
        assert code == 2, (args, err)
        assert words in err and len(err.strip().splitlines()) == 1, (args, err)
        assert "Traceback" not in err and not out.exists()
    code, _, err = _run(capsys, *rig([p.left], p.right), "--out", tmp_path / "o")
    assert code == 2 and "--board chessboard:auto cannot calibrate a rig" in err
