"""A calibration's views chosen from a video (:mod:`sogdd.calib.video`), on a rendered video of a board moving
before a known camera, some of its frames smeared by motion (``board_video``, tests/conftest.py)."""

from __future__ import annotations

import itertools
import re

import cv2
import numpy as np
import pytest

from sogdd.calib.session import ParameterError
from sogdd.calib.video import choose_frames, frame_name, is_video, pose_distance, read_frames

SPEC = "chessboard:9x6"


@pytest.fixture(scope="module")
def chosen(board_video):
    """The frames chosen from the whole video, at most 40."""
    return choose_frames(board_video.path, SPEC, 40)


def test_every_frame_is_read_in_order(board_video):
    frames = [(i, f.shape) for i, f in read_frames(board_video.path, step=10)]
    assert [i for i, _ in frames] == list(range(0, board_video.frames, 10))
    assert {s for _, s in frames} == {(480, 640, 3)}


def test_the_choice_is_sharp_spread_and_explained(board_video, chosen):
    assert 8 <= len(chosen) <= 40
    idx = [c.index for c in chosen]
    assert idx == sorted(idx) and not set(idx) & set(board_video.blurred)  # never a smeared frame
    assert len({i // 12 for i in idx}) >= 6  # from most of the 9 stretches between the video's poses
    for a, b in itertools.combinations(chosen, 2):  # no two frames at near poses
        assert pose_distance(a.pose, b.pose) > 1.0
    for c in chosen:
        assert c.size == (640, 480) and len(c.board) == 54 and c.thumbnail is not None
        assert c.reasons[0].startswith("sharp (") and c.reasons[1].startswith("new pose (")
    assert sum(any(r.startswith("new coverage (") for r in c.reasons) for c in chosen) >= 2
    assert max(c.precision for c in chosen) <= 2.0 * min(c.precision for c in chosen)


def test_max_views_and_step_bound_the_choice(board_video):
    few = choose_frames(board_video.path, SPEC, 4, step=3, thumbnails=False)
    assert len(few) == 4 and all(c.index % 3 == 0 and c.thumbnail is None for c in few)
    assert all(any(r.startswith("new coverage (") for r in c.reasons) for c in few)  # coverage first


def test_names_and_suffixes():
    assert frame_name("a/take.MOV", 7) == "take.MOV#frame000007"
    assert is_video("x.avi") and is_video("y.MKV") and not is_video("z.png")


def test_bad_inputs_are_one_line_errors(tmp_path):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    for path, words in ((bad, "not a video OpenCV can read"), (tmp_path / "none.mp4", "no such file")):
        with pytest.raises(ValueError, match=re.escape(words)) as exc:
            choose_frames(path, SPEC, 5)
        assert "\n" not in str(exc.value)
    with pytest.raises(ParameterError, match="max_views must be >= 1, got 0"):
        choose_frames(bad, SPEC, 0)
    blank = tmp_path / "blank.avi"
    w = cv2.VideoWriter(str(blank), cv2.VideoWriter_fourcc(*"MJPG"), 25, (160, 120), False)
    for k in range(6):
        w.write(np.full((120, 160), 100 + k, np.uint8))
    w.release()
    assert choose_frames(blank, SPEC, 5) == []
