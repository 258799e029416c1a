"""The randomized rendered corpus (``sogdd eval calibration --sweep``): its draws, its renders, its scores."""

import dataclasses
import json
import math

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.calibration.comparators import Detection
from sogdd.evaluation.calibration.sweep import (
    LENSES,
    MAX_PIXELS,
    draw_factors,
    factors_from_dict,
    motion_kernel,
    render_factors,
    sweep_camera,
    sweep_target,
    sweep_view,
)
from sogdd.evaluation.calibration.sweep_metrics import FACTOR_BINS, score_detection
from sogdd.evaluation.calibration.target import ChessboardTarget

SMALL = 320 * 240


def _median_cell(pts, cols, rows):
    g = pts.reshape(rows, cols, 2)
    return float(np.median(np.concatenate([np.linalg.norm(np.diff(g, axis=1), axis=2).ravel(),
                                           np.linalg.norm(np.diff(g, axis=0), axis=2).ravel()])))


def _plain(f):
    """The view with every effect off but a slight blur: only the geometry left."""
    return dataclasses.replace(f, noise=0.0, blur=0.5, motion=0.0, jpeg=None, glare=0.0, ramp=0.0,
                               vignetting=0.0, texture=0.0, rectangles=0, hand=None, second=None)


def test_a_view_is_reproducible_alone_and_views_differ():
    a, b = sweep_view(7, 3, max_pixels=SMALL), sweep_view(7, 3, max_pixels=SMALL)
    assert np.array_equal(a.image, b.image) and np.array_equal(a.corners, b.corners)
    assert a.factors == draw_factors(7, 3, max_pixels=SMALL)
    assert draw_factors(7, 4, max_pixels=SMALL) != a.factors
    assert draw_factors(8, 3, max_pixels=SMALL) != a.factors
    # the factors as sweep.json holds them give the same image
    again = render_factors(factors_from_dict(json.loads(json.dumps(a.factors.to_dict()))))
    assert np.array_equal(again.image, a.image)


def _check_scalars(f):
    assert min(640 * 480, MAX_PIXELS) * 0.98 <= f.width * f.height <= MAX_PIXELS
    assert abs(f.width / f.height - {"4:3": 4 / 3, "16:9": 16 / 9, "3:2": 1.5}[f.aspect]) < 0.01
    assert 3 <= f.cols <= 12 and 3 <= f.rows <= 12
    fit = 0.9 * min(f.width, f.height) / math.hypot(f.cols + 1, f.rows + 1)
    assert 8.0 <= f.cell_px <= min(300.0, fit) + 1e-9
    assert 0 <= f.tilt <= 70 and 0 <= f.roll < 360 and 0 <= f.tilt_axis < 360
    assert f.lens in LENSES
    k1 = {"none": (0, 0), "pincushion": (0.01, 0.1), "barrel": (-0.4, -0.01), "fisheye": (0, 0)}[f.lens]
    assert k1[0] <= f.k1 <= k1[1] and f.k2 == pytest.approx(0.5 * f.k1 ** 2 if f.lens == "barrel" else 0.0)
    assert (120 <= f.fov <= 200) if f.lens == "fisheye" else (45 <= f.fov <= 85)
    assert 0 <= f.margin <= 1.5 and (f.edge == 1.0 or 0.3 <= f.edge <= 0.9)
    assert 10 <= f.dark <= 100 and 100 <= f.light <= 250 and f.light >= f.dark + 5 and 20 <= f.background <= 235
    assert 0 <= f.ramp <= 0.5 and 0 <= f.vignetting <= 0.6
    diag = math.hypot(f.width, f.height)
    assert f.glare == 0 or (30 <= f.glare <= 150 and 0.05 <= f.glare_sigma / diag <= 0.3)
    assert 0 <= f.noise <= 12 and 0.3 <= f.blur <= 3 and 0 <= f.motion <= 20
    assert f.jpeg is None or 30 <= f.jpeg <= 95
    assert f.texture == 0 or 8 <= f.texture <= 50
    assert f.rectangles == 0 or 3 <= f.rectangles <= 15
    assert f.supersample == (4 if f.width * f.height <= 3_000_000 else 2)


def _check_geometry(f):
    cam, target = sweep_camera(f), sweep_target(f)
    pts = cam.project(target.object_points(), np.array(f.rvec), np.array(f.tvec))
    # the whole board in the frame: inner corners 4 px inside, outer squares 2 px inside
    assert np.all(pts >= 4) and np.all(pts <= np.array([f.width - 5, f.height - 5]))
    edge = cam.project(target.outline(per_side=24), np.array(f.rvec), np.array(f.tvec))
    assert np.all(edge >= 2 - 1e-9) and np.all(edge <= np.array([f.width - 3, f.height - 3]) + 1e-9)
    # the cells are as drawn (the median lattice edge), and the tilt is what the pose shows
    assert _median_cell(pts, f.cols, f.rows) == pytest.approx(f.cell_px, rel=0.03)
    R = cv2.Rodrigues(np.array(f.rvec))[0]
    centre = R @ (np.array([(f.cols - 1) / 2, (f.rows - 1) / 2, 0]) * target.square) + np.array(f.tvec)
    tilt = np.degrees(np.arccos(abs(R[:, 2] @ centre) / np.linalg.norm(centre)))
    assert tilt == pytest.approx(f.tilt, abs=1e-6)
    if f.second is not None:
        s = f.second
        assert 2.0 <= s.cell_px <= max(2.0, f.cell_px / 3) + 1e-9 and 3 <= s.cols <= 12 and 3 <= s.rows <= 12
        other = cam.project(ChessboardTarget(s.cols, s.rows, s.square).outline(with_margin=True),
                            np.array(s.rvec), np.array(s.tvec))
        main_paper = cam.project(target.outline(with_margin=True), np.array(f.rvec), np.array(f.tvec))
        poly = main_paper.astype(np.float32).reshape(-1, 1, 2)
        assert all(cv2.pointPolygonTest(poly, (float(x), float(y)), True) < -4 for x, y in other)
    if f.hand is not None:
        assert 90 <= f.hand.grey <= 200 and 1 <= f.hand.fingers <= 4
        assert 1.0 <= f.hand.palm / f.cell_px <= 2.0 and 1.5 <= f.hand.length / f.cell_px <= 4.0


def test_every_factor_stays_in_its_range_over_40_draws():
    draws = [draw_factors(11, k) for k in range(40)]
    for f in draws:
        _check_scalars(f)
        _check_geometry(f)
    # the draws spread over the ranges: every lens, on and off factors both ways, big and small frames
    assert {f.lens for f in draws} == set(LENSES)
    for on in (lambda f: f.hand is not None, lambda f: f.second is not None, lambda f: f.texture > 0,
               lambda f: f.rectangles > 0, lambda f: f.jpeg is not None, lambda f: f.glare > 0,
               lambda f: f.margin == 0, lambda f: f.edge < 1):
        assert 0 < sum(map(on, draws)) < len(draws)
    pixels = [f.width * f.height for f in draws]
    assert min(pixels) < 1e6 and max(pixels) > 4e6
    assert min(f.cell_px for f in draws) < 20 and max(f.cell_px for f in draws) > 60
    # max_pixels caps the frame
    assert all(draw_factors(11, k, max_pixels=SMALL).width * draw_factors(11, k, max_pixels=SMALL).height
               <= SMALL for k in range(10))
    with pytest.raises(ValueError, match="max_pixels"):
        draw_factors(1, 0, max_pixels=100)


def test_the_truth_is_where_the_corners_are_rendered():
    # with the effects off, OpenCV's sub-pixel search started 0.4 px off comes back to the truth
    for k in range(4):
        f = _plain(draw_factors(5, k, max_pixels=640 * 480))
        for g in (f, dataclasses.replace(f, supersample=2)):
            v = render_factors(g)
            start = (v.corners + 0.4).astype(np.float32).reshape(-1, 1, 2)
            win = max(2, int(0.2 * g.cell_px))
            got = cv2.cornerSubPix(v.image.astype(np.float32), start, (win, win), (-1, -1),
                                   (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-4)).reshape(-1, 2)
            assert np.median(np.linalg.norm(got - v.corners, axis=1)) < 0.2


def test_motion_blur_is_a_centred_symmetric_line():
    k = motion_kernel(10.0, 30.0)
    assert k.shape == (13, 13) and k.sum() == pytest.approx(1.0) and np.allclose(k, k[::-1, ::-1])
    ys, xs = np.mgrid[0:13, 0:13] - 6
    assert (k * xs).sum() == pytest.approx(0, abs=1e-12) and (k * ys).sum() == pytest.approx(0, abs=1e-12)
    # its second moment along the line: 41 points evenly over 10 px, each splatted bilinearly (+ 1/6)
    d = xs * np.cos(np.radians(30)) + ys * np.sin(np.radians(30))
    assert (k * d * d).sum() == pytest.approx(100 / 12 * 42 / 40 + 1 / 6, rel=0.01)
    assert (k * d * d).sum() > 2 * (k * (xs * xs + ys * ys - d * d)).sum()  # along the line, not across
    with pytest.raises(ValueError):
        motion_kernel(-1.0, 0.0)


def test_a_hand_covers_corners_that_are_then_not_expected():
    views = [sweep_view(2, k, max_pixels=SMALL) for k in range(40) if draw_factors(2, k, max_pixels=SMALL).hand]
    assert len(views) >= 3
    covered = [v for v in views if v.covered.any()]
    assert covered, "no hand covered a corner"
    for v in covered[:3]:
        assert not np.any(v.expected & v.covered) and v.expected.sum() + v.covered.sum() == len(v.corners)
        # the same view without the hand (the same noise): the image changes next to every covered corner
        f = dataclasses.replace(v.factors, jpeg=None)
        diff = render_factors(f).image != render_factors(dataclasses.replace(f, hand=None)).image
        ys, xs = np.nonzero(diff)
        changed = np.stack([xs, ys], axis=1).astype(float)
        reach = 0.3 * f.cell_px * 1.5 + 2 + 4 * f.blur + f.motion
        for c in v.corners[v.covered]:
            assert np.min(np.linalg.norm(changed - c, axis=1)) <= reach


def test_scores_count_complete_boards_wrong_labels_and_off_board_points():
    v = sweep_view(1, 4, max_pixels=SMALL)
    truth = Detection(v.corners.copy(), v.labels.copy())
    r = score_detection(v, truth)
    assert r["complete"] and r["wrong"] == 0 and r["off_board"] == 0 and r["error_mean"] == 0
    # one corner short: not complete
    assert not score_detection(v, Detection(v.corners[1:], v.labels[1:]))["complete"]
    # a point 10 px from every corner: off the board, and a wrong label
    far = np.concatenate([v.corners, v.corners[:1] + [0.0, v.factors.cell_px / 2]])
    r = score_detection(v, Detection(far, np.concatenate([v.labels, [[99, 99]]])))
    assert r["complete"] and r["off_board"] == 1 and r["wrong"] == 1
    # the labels turned by a half turn are the same board
    cols, rows = v.pattern
    assert score_detection(v, Detection(v.corners, np.array([cols - 1, rows - 1]) - v.labels))["complete"]
    # two labels swapped: two wrong labels, not complete
    lab = v.labels.copy()
    lab[[0, 1]] = lab[[1, 0]]
    r = score_detection(v, Detection(v.corners, lab))
    assert r["wrong"] == 2 and not r["complete"]


def test_the_sweep_command_writes_json_and_the_by_factor_table(tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["eval", "calibration", "--sweep", "3", "--seed", "4", "--max-pixels", str(SMALL),
            "--methods", "sogdd,opencv", "--quiet", "--out", str(out)]
    assert main(argv) == 0
    md = capsys.readouterr().out
    res = json.loads((out / "sweep.json").read_text())
    assert res["command"] == ("sogdd eval calibration --sweep 3 --seed 4 --max-pixels 76800 "
                              f"--methods sogdd,opencv --out {out}")
    assert res["methods"] == ["sogdd", "opencv"] and len(res["views"]) == 3
    for k, view in enumerate(res["views"]):
        assert view["index"] == k and set(view["results"]) == {"sogdd", "opencv"}
        assert factors_from_dict(view["factors"]) == draw_factors(4, k, max_pixels=SMALL)
    # every factor's bins hold every view once, and the overall row is the summary's
    rows = res["by_factor"]
    assert rows[0]["factor"] == "all" and rows[0]["views"] == 3
    for fb in FACTOR_BINS:
        assert sum(r["views"] for r in rows if r["factor"] == fb.name) == 3
    for m in ("sogdd", "opencv"):
        done = sum(v["results"][m]["complete"] for v in res["views"])
        assert res["summary"][m]["complete"] == rows[0]["complete"][m] == done
    assert md == (out / "sweep.md").read_text()
    assert "## Complete boards by factor" in md and "| all |  | 3 |" in md and "| lens |" in md
    assert 0 < res["render_seconds"] <= res["seconds"]


@pytest.mark.parametrize("extra, message", [
    (["--photos"], "drop --photos"),
    (["--rigs"], "drop --rigs"),
    (["--methods", "hr"], "points only"),
    (["--max-pixels", "100"], "--max-pixels"),
])
def test_the_sweep_command_refuses_what_it_cannot_do(extra, message, capsys):
    assert main(["eval", "calibration", "--sweep", "2", "--quiet", *extra]) == 2
    assert message in capsys.readouterr().err


def test_seed_and_a_zero_sweep_are_refused(capsys):
    assert main(["eval", "calibration", "--seed", "3", "--quiet"]) == 2
    assert "--seed needs --sweep" in capsys.readouterr().err
    assert main(["eval", "calibration", "--sweep", "0", "--quiet"]) == 2
    assert ">= 1 view" in capsys.readouterr().err


def test_each_method_is_called_once_untimed_before_the_views_it_is_scored_on(monkeypatch):
    """A first call compiles or imports: each method runs once on a small copy of view 0 before the views,
    so that the first view's time is a detection's."""
    from sogdd.evaluation.calibration import sweep_metrics
    from sogdd.evaluation.calibration.comparators import METHODS

    calls = []
    real = METHODS["opencv"]

    def spy(image, pattern):
        calls.append(image.shape)
        return real.detect(image, pattern)

    monkeypatch.setitem(METHODS, "opencv", dataclasses.replace(real, detect=spy))
    res = sweep_metrics.run_sweep(2, 1, ["opencv"], max_pixels=SMALL)
    assert len(calls) == 3 and len(res["views"]) == 2
    warm = sweep_view(1, 0, max_pixels=sweep_metrics.WARM_PIXELS)
    assert calls[0] == warm.image.shape
    assert calls[1:] == [sweep_view(1, k, max_pixels=SMALL).image.shape for k in range(2)]


def test_a_method_that_fails_is_scored_view_by_view_warm_up_included(monkeypatch):
    """A method that raises, on the untimed first call as on every view, leaves the sweep running: each view
    records the failure, and the other methods' results stand."""
    from sogdd.evaluation.calibration import sweep_metrics
    from sogdd.evaluation.calibration.comparators import METHODS

    def broken(image, pattern):
        raise RuntimeError("no board today")

    monkeypatch.setitem(METHODS, "opencv-sb", dataclasses.replace(METHODS["opencv-sb"], detect=broken))
    res = sweep_metrics.run_sweep(2, 1, ["opencv", "opencv-sb"], max_pixels=SMALL)
    assert [v["results"]["opencv-sb"]["failed"] for v in res["views"]] == ["RuntimeError: no board today"] * 2
    assert res["summary"]["opencv-sb"]["failed"] == 2 and res["summary"]["opencv"]["failed"] == 0
