"""The rig's frames: images matched by the number in their names, else by sorted order; one-line errors."""

from __future__ import annotations

import pytest

from sogdd.calib.rig.frames import frame_number, match_frames


def test_frames_are_matched_by_the_last_number_in_the_stem():
    frames, paths = match_frames({
        "left": ["l/left10.jpg", "l/left2.jpg", "l/left1.jpg"],
        "right": ["r/cam1_000002.png", "r/cam1_000001.png", "r/cam1_000010.png"],
    })
    # numeric order, not the strings' (10 after 2), leading zeros ignored, the camera's digits in the prefix too
    assert frames == ("1", "2", "10")
    assert paths == {"left": ("l/left1.jpg", "l/left2.jpg", "l/left10.jpg"),
                     "right": ("r/cam1_000001.png", "r/cam1_000002.png", "r/cam1_000010.png")}
    assert frame_number("cam0_000012.png") == 12 and frame_number("2024-05-01_7.tif") == 7
    assert frame_number("x12/left.png") is None  # the folder's digits are not the frame's


def test_without_numbers_the_frames_are_the_sorted_order():
    frames, paths = match_frames({"a": ["a/b.png", "a/a.png", "a/c.png"],
                                  "b": ["b/z.png", "b/y.png", "b/x.png"]})
    assert frames == ("1", "2", "3")
    assert paths["a"] == ("a/a.png", "a/b.png", "a/c.png") and paths["b"] == ("b/x.png", "b/y.png", "b/z.png")


def test_different_counts_without_numbers_are_one_line():
    with pytest.raises(ValueError, match=r"different numbers of images \(a 2, b 1\).*sorted order") as e:
        match_frames({"a": ["a/x.png", "a/y.png"], "b": ["b/x.png"]})
    assert "\n" not in str(e.value)


def test_frames_that_do_not_match_name_what_each_camera_lacks():
    left = [f"left{k}.png" for k in range(1, 21)]
    right = [f"right{k}.png" for k in range(1, 21) if k not in (3, 7)] + ["right25.png"]
    with pytest.raises(ValueError) as e:
        match_frames({"left": left, "right": right})
    msg = str(e.value)
    assert "\n" not in msg
    assert "right lacks frames 3, 7" in msg and "left lacks frame 25" in msg
    # a long list is cut to a few numbers
    with pytest.raises(ValueError, match=r"right lacks frames 1, 2, 3, 4, 5 and 5 more"):
        match_frames({"left": [f"l{k}.png" for k in range(1, 11)], "right": ["r11.png"]})


def test_missing_frames_are_allowed_only_when_asked():
    frames, paths = match_frames({"left": ["l1.png", "l2.png", "l3.png"], "right": ["r1.png", "r3.png"]},
                                 allow_missing=True)
    assert frames == ("1", "2", "3") and paths["right"] == ("r1.png", None, "r3.png")
    with pytest.raises(ValueError, match="right lacks frame 2"):
        match_frames({"left": ["l1.png", "l2.png", "l3.png"], "right": ["r1.png", "r3.png"]})


def test_a_number_repeated_in_one_camera_is_an_error():
    with pytest.raises(ValueError, match=r"camera left: a/left01.png and b/left1.png both have frame number 1"):
        match_frames({"left": ["a/left01.png", "b/left1.png"], "right": ["r1.png"]})


def test_some_names_with_numbers_and_some_without_is_an_error():
    with pytest.raises(ValueError, match=r"camera right: r/right.png has no frame number in its name"):
        match_frames({"left": ["l/left1.png"], "right": ["r/right.png"]})


def test_a_camera_without_images_is_an_error():
    with pytest.raises(ValueError, match="camera right: no input images"):
        match_frames({"left": ["l1.png"], "right": []})
