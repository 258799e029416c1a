"""The rig's report page and its verdict in plain words."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from sogdd.calib.detection import Thumbnail
from sogdd.calib.model_selection import CandidateScore, ModelSelection
from sogdd.calib.report import selection_table
from sogdd.calib.rig.demo import DEMO_RIG, demo_rig, demo_rig_boards
from sogdd.calib.rig.files import rig_dict
from sogdd.calib.rig.fit import calibrate_rig
from sogdd.calib.rig.report import rectified_pair, write_rig_report
from sogdd.calib.rig.verdict import rig_verdict, shared_frames, uncertainty_summary
from sogdd.calib.targets.board import Board


def test_the_demo_rig_is_recovered():
    rig = demo_rig()
    right = rig.camera("right")
    R_true, T_true = DEMO_RIG["right"][2], DEMO_RIG["right"][3]
    assert np.linalg.norm(right.T - T_true) < 0.02 * np.linalg.norm(T_true)
    assert np.degrees(np.linalg.norm(right.R - R_true)) < 0.2
    assert abs(right.K[0, 0] - DEMO_RIG["right"][0][0, 0]) < 2


def test_the_verdict_states_the_baseline_and_its_uncertainty():
    rig = demo_rig()
    texts = [t for _, t in rig_verdict(rig)]
    line = next(t for t in texts if t.startswith("right: the baseline to left is"))
    assert f"{rig.camera('right').baseline:.4g}" in line
    assert shared_frames(rig)["right"] == int(np.sum(rig.camera("right").calibration.view_used & rig.frame_used
                                                     & rig.camera("left").calibration.view_used))


def test_the_far_point_uncertainty_is_smallest_where_the_corners_are():
    centre, worst = uncertainty_summary(demo_rig(), "left")
    assert 0 < centre < worst


def test_a_camera_tied_by_few_frames_is_reported():
    boards, sizes = demo_rig_boards(12)
    seen = [f for f, b in enumerate(boards["right"]) if b is not None]
    for f in seen[4:]:  # the right camera keeps its boards only in 4 frames...
        boards["right"][f] = None
    shared = [f for f in seen[:4] if boards["left"][f] is not None]
    for f in shared[1:]:  # ... of which the left camera sees one...
        boards["left"][f] = None
    b = boards["right"][shared[0]]  # ... and the right camera's own calibration rejects its view of it
    noisy = b.image_points + np.random.default_rng(0).normal(0, 6.0, b.image_points.shape)
    boards["right"][shared[0]] = Board(noisy, b.labels, size=b.size)
    rig = calibrate_rig(boards, sizes, models="pinhole", pattern=(9, 6), min_views=3)
    assert not rig.camera("right").calibration.view_used[shared[0]]
    found = [(lv, t) for lv, t in rig_verdict(rig) if t.startswith("right: no frame")]
    assert found and found[0][0] == "bad"


def test_the_report_has_every_figure_and_each_camera_its_own_page(tmp_path):
    rig = demo_rig()
    thumbs = {c.name: [Thumbnail(np.full((180, 240), 128, np.uint8), 0.375)] * len(rig.frames)
              for c in rig.cameras}
    page = write_rig_report(rig, tmp_path, thumbnails=thumbs)
    names = {p.name for p in (tmp_path / "report").glob("*.png")}
    assert {"extrinsics.png", "errors.png", "uncertainty_left.png", "uncertainty_right.png",
            "rectified_right.png"} <= names
    text = page.read_text()
    assert "Verdict" in text and "vertical disparity" in text and 'href="right/report.html"' in text
    assert (tmp_path / "left" / "report.html").is_file()


def test_the_rectified_pair_puts_shared_corners_on_one_row(tmp_path):
    page = write_rig_report(demo_rig(), tmp_path)
    text = page.read_text()
    value = float(text.split("left / right: ")[1].split(" px RMS")[0])
    assert value < 0.2  # 0.05 px corner noise; a wrong rectification is pixels off


def test_the_report_shows_the_figures_rig_json_holds(tmp_path):
    """The rotation and the rectified pair's disparity are computed once, in the library: the page shows
    what rig.json holds (rig_dict), to the digits it prints."""
    rig = demo_rig()
    text = write_rig_report(rig, tmp_path).read_text()
    d = rig_dict(rig)
    right = d["cameras"][1]
    assert f"<td>{right['rotation_deg']:.3f} ± {right['std']['rotation_deg']:.2g}</td>" in text
    assert f"left / right: {right['rectified']['vertical_disparity_px']:.3f} px RMS" in text
    check = rectified_pair(rig, "right")
    assert right["rectified"]["frame"] == rig.frames[check.frame]
    assert right["rectified"]["shared_corners"] == len(check.shared) == 54  # the whole 9 x 6 board
    assert check.points[0].keys() == check.points[1].keys()


def test_a_model_selection_table_is_shown_as_in_the_camera_report(tmp_path):
    """Fixed decimals, the chosen model marked, "within noise" in words: no True/False, no e-notation."""
    rows = (CandidateScore("pinhole4", 4, 0.0501, 0.051, 0.0012, 1.6e-6, 8.4e-6, True),
            CandidateScore("pinhole", 5, 0.0500, 0.051, 0.0011, 0.0, 0.0, True),
            CandidateScore("rational", 8, 0.0499, 0.7225, 0.3777, 0.7084, 0.7408, False))
    sel = ModelSelection("pinhole4", rows, (), "the simplest within noise")
    rig = dataclasses.replace(demo_rig(), model_selection={"left": sel})
    text = write_rig_report(rig, tmp_path).read_text()
    table = text.split("Lens model chosen by the data")[1]
    assert "<h3>left: pinhole4</h3>" in table and "<b>pinhole4</b>" in table
    assert "chosen" in table and "within noise" in table and "0.0510 &plusmn; 0.0012" in table
    assert "True" not in table and "False" not in table and not re.search(r"\de-\d", table)
    assert selection_table(sel) in table  # the one-camera report's table, not a second one


def test_no_title_runs_under_a_colour_bar_nor_leaves_its_figure(tmp_path, drawn_figures):
    write_rig_report(demo_rig(), tmp_path)
    names = set(drawn_figures.figures)
    assert {"uncertainty_left.png", "uncertainty_right.png", "extrinsics.png", "rectified_right.png"} <= names
    for name, fig in drawn_figures.figures.items():
        assert drawn_figures.overlaps(fig) == [], name


def test_the_cameras_are_named_in_a_legend_not_on_top_of_each_other(tmp_path, drawn_figures):
    rig = demo_rig()
    write_rig_report(rig, tmp_path)
    ax = drawn_figures.figures["extrinsics.png"].axes[0]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [c.name for c in rig.cameras]
    assert len(ax.texts) == 0  # no label at the cameras' centres, a baseline apart at the figure's scale


def test_no_marker_is_drawn_outside_a_rectified_image(tmp_path, drawn_figures, monkeypatch):
    """A corner the rectification maps off the picture is not drawn, and the picture keeps its frame."""
    import sogdd.calib.rig.report as module

    def far_off(rig, name):
        check = rectified_pair(rig, name)
        other = dict(check.points[1])
        other[(99, 99)] = np.array([-400.0, 2000.0])  # far outside the rectified image
        return dataclasses.replace(check, points=(check.points[0], other))

    monkeypatch.setattr(module, "rectified_pair", far_off)
    thumbs = {c.name: [Thumbnail(np.full((180, 240), 128, np.uint8), 0.375)] * len(demo_rig().frames)
              for c in demo_rig().cameras}
    write_rig_report(demo_rig(), tmp_path, thumbnails=thumbs)
    fig = drawn_figures.figures["rectified_right.png"]
    for ax in fig.axes:
        x0, x1, y1, y0 = ax.get_images()[0].get_extent()
        assert ax.get_xlim() == (x0, x1) and ax.get_ylim() == (y1, y0)
        markers = [line for line in ax.lines if line.get_marker() == "+"]
        xy = np.concatenate([line.get_xydata() for line in markers])
        assert len(xy) == 54  # the board's corners, without the one off the picture
        assert np.all((xy >= [x0, y0]) & (xy <= [x1, y1]))


@pytest.mark.parametrize("name", ["left", "right"])
def test_each_camera_keeps_its_own_view_of_the_fit(name):
    cam = demo_rig().camera(name)
    assert cam.calibration.rms < 0.1 and len(cam.calibration.names) == len(demo_rig().frames)


def test_the_verdict_does_not_ask_a_rig_camera_for_the_halves_cross_validation():
    texts = [t for _, t in rig_verdict(demo_rig())]
    assert not any("no cross-validation" in t for t in texts)
