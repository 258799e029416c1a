"""Any kind of inputs through one call (sogdd.calib.inputs): which kind, the rules at the door, and the
command's every form calling it."""

from __future__ import annotations

import numpy as np
import pytest

from sogdd.calib import inputs as calib_inputs
from sogdd.calib.inputs import calibrate_inputs_into, input_kind
from sogdd.calib.session import ParameterError, calibrate_into
from sogdd.cli.main import main


@pytest.mark.parametrize(("given", "kind"), [
    ("frames/*.png", "images"), (["a.png", "b.jpg"], "images"), ("take1.MP4", "video"),
    ({"left": "l/*.png", "right": ["r1.png", "r2.png"]}, "rig"), ({"left": "l/*.png"}, "rig"),
    ({"left": "left.mp4", "right": "right.avi"}, "rig-video"),
])
def test_the_kind_of_the_inputs(given, kind):
    assert input_kind(given) == kind


@pytest.mark.parametrize(("given", "words"), [
    (["take1.mp4", "a.png"], "a video is calibrated alone: give one video file, not 2 inputs"),
    ({"left": "left.mp4", "right": "r/*.png"},
     "a rig's cameras are all videos (camera NAME VIDEO, one each) or all images, not a mix"),
])
def test_inputs_of_no_kind_are_refused(given, words):
    with pytest.raises(ParameterError) as info:
        input_kind(given)
    assert str(info.value) == words


@pytest.mark.parametrize(("given", "kw", "words"), [
    ("f/*.png", {"allow_missing": True}, "--allow-missing-frames is for a rig (--camera NAME PATTERN... per "
                                          "camera)"),
    ("take1.mp4", {"boards": "all"}, "--boards all is for images; a video's frame gives one view"),
    ({"left": "l.mp4", "right": "r.mp4"}, {"allow_missing": True},
     "--allow-missing-frames is for a rig of images; a rig of videos matches its frames by index"),
])
def test_the_rules_at_the_door_in_the_commands_words(given, kw, words, tmp_path):
    with pytest.raises(ParameterError) as info:
        calibrate_inputs_into(given, tmp_path / "out", "chessboard:9x6", **kw)
    flags = {"allow_missing": "--allow-missing-frames", "boards": "--boards", "camera": "--camera"}
    assert info.value.worded(**flags) == words and not (tmp_path / "out").exists()


def test_images_are_calibrated_as_calibrate_into_does(rendered_frames, tmp_path):
    one, files = calibrate_inputs_into(rendered_frames, tmp_path / "a", "chessboard:9x6", model="pinhole",
                                       report=False)
    ref, _ = calibrate_into(rendered_frames, tmp_path / "b", "chessboard:9x6", model="pinhole", report=False)
    assert np.array_equal(one.calibration.K, ref.calibration.K) and sorted(files) == sorted(_)


@pytest.mark.parametrize("argv", [
    ["f/*.png"], ["take1.mp4"], ["--camera", "left", "l/*.png", "--camera", "right", "r/*.png"],
    ["--camera", "left", "l/*.png"], ["--camera", "left", "left.mp4", "--camera", "right", "right.mp4"],
])
def test_every_form_of_the_command_calls_the_one_function(argv, tmp_path, monkeypatch, capsys):
    seen = []

    def record(inputs, out, board, **kw):
        seen.append(inputs)
        raise ValueError("recorded")

    monkeypatch.setattr(calib_inputs, "calibrate_inputs_into", record)
    assert main(["calibrate", *argv, "--board", "chessboard:9x6", "--out", str(tmp_path / "o")]) == 2
    assert "recorded" in capsys.readouterr().err
    expected = argv if argv[0] != "--camera" else {argv[i + 1]: [argv[i + 2]] for i in range(0, len(argv), 3)}
    assert seen == [expected]
