"""The calibration evaluation: label-aligned scores, the quick protocol end to end, the command, the page."""

from __future__ import annotations

import json
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.calibration import ChessboardTarget
from sogdd.evaluation.calibration.comparators import available, method_names
from sogdd.evaluation.calibration.metrics import SYMMETRIES, align_labels, error_stats, score_view
from sogdd.evaluation.calibration.protocol import run_real, run_sequences
from sogdd.evaluation.calibration.sequences import sequences
from sogdd.report.calibration_section import calibration_stage, write_results


def _truth(cols=6, rows=5, cell=20.0):
    t = ChessboardTarget(cols, rows, 1.0)
    lab = t.labels()
    # a slightly sheared grid, so that no two corners are equally far from a point
    xy = 50.0 + lab @ np.array([[cell, 1.5], [-2.0, cell * 0.9]])
    return xy, lab, np.ones(len(lab), dtype=bool)


def test_exact_detection_scores_perfectly():
    xy, lab, inside = _truth()
    s = score_view(xy, lab, xy, lab, inside)
    assert (s.n_correct, s.n_wrong, s.recalled, s.flipped) == (30, 0, 30, False)
    assert s.errors.max() == 0


def test_wrong_label_counter_catches_a_planted_mislabel():
    xy, lab, inside = _truth()
    bad = lab.copy()
    bad[[7, 8]] = bad[[8, 7]]  # two neighbours swap labels
    s = score_view(xy, bad, xy, lab, inside)
    assert (s.n_wrong, s.n_correct, s.recalled) == (2, 28, 28)
    # a corner labelled one column off, alone, is wrong too
    off = lab.copy()
    off[12] += [1, 0]
    assert score_view(xy, off, xy, lab, inside).n_wrong == 1


def test_labels_are_aligned_by_one_symmetry_and_offset_per_view():
    xy, lab, inside = _truth(5, 5)
    for A in SYMMETRIES:
        det = lab @ A.T + np.array([3, -7])  # the board read turned or mirrored, labels relative
        s = score_view(xy, det, xy, lab, inside)
        assert s.n_wrong == 0 and s.n_correct == 25
        assert s.flipped == (round(np.linalg.det(A)) < 0)
    A, o, n = align_labels(lab[:, ::-1], lab)
    assert n == 25 and round(np.linalg.det(A)) == -1


def test_error_metric_catches_a_planted_half_pixel_shift():
    xy, lab, inside = _truth()
    s = score_view(xy + np.array([0.3, 0.4]), lab, xy, lab, inside)
    st = error_stats(s.errors)
    assert s.n_wrong == 0
    assert st["mean"] == pytest.approx(0.5, abs=1e-9) and st["max"] == pytest.approx(0.5, abs=1e-9)
    # one corner far off (but nearer its own corner than any other) shows in the max, not as a wrong label
    far = xy.copy()
    far[3] += [4.0, 0.0]
    s = score_view(far, lab, xy, lab, inside)
    assert s.n_wrong == 0 and error_stats(s.errors)["max"] == pytest.approx(4.0)


def test_points_only_scores_are_one_to_one():
    xy, lab, inside = _truth()
    pts = np.concatenate([xy, xy[:3] + 0.2, [[500.0, 500.0]]])  # duplicates and a stray point
    s = score_view(pts, None, xy, lab, inside)
    assert s.n_correct == 30 and s.recalled == 30 and s.errors.max() == 0 and not s.found


def test_quick_protocol_end_to_end():
    seqs = sequences(["sharp"], quick=True)
    rows = run_sequences(seqs, ["opencv", "hr"], draws=1)
    by = {r["method"]: r for r in rows}
    cv = by["opencv"]
    assert cv["boards"] == 3 and cv["wrong_labels"] == 0 and cv["recall"] == 1.0
    assert 0 < cv["corner"]["mean"] < 0.1 and cv["corner"]["max"] < 0.5
    cal = cv["calibration"]
    assert cal["draws"] == 1 and 0 < cal["projection_difference"] < 5 and cal["rms"] < 0.1
    assert by["hr"]["kind"] == "points" and "boards" not in by["hr"]
    assert 0 < by["hr"]["corner"]["mean"] < 0.1


def test_missing_comparators_are_skipped_with_a_note(monkeypatch):
    import sogdd.evaluation.calibration.comparators as comp

    monkeypatch.setitem(comp._PROBES, "mrgingham", lambda: False)
    ok, note = available("mrgingham")
    assert not ok and "mrgingham" in note and "apt-get" in note
    with pytest.raises(ValueError, match="unknown method"):
        method_names("opencv,nope")


def test_cli_quick_run_writes_json_table_and_plot(tmp_path, capsys):
    out = tmp_path / "cal"
    rc = main(["eval", "calibration", "--quick", "--sequences", "sharp", "--methods", "opencv", "--no-real",
               "--quiet", "--json", "--out", str(out)])
    assert rc == 0
    res = json.loads(capsys.readouterr().out)
    assert res["quick"] and res["synthetic"][0]["method"] == "opencv"
    assert (out / "calibration.png").stat().st_size > 1000
    assert json.loads((out / "calibration.json").read_text())["synthetic"] == res["synthetic"]
    assert "| sharp | `opencv` | 3 of 3 |" in (out / "calibration.md").read_text()


@pytest.mark.parametrize("argv, msg", [
    (["--sequences", "nope"], "unknown sequence"),
    (["--methods", "nope"], "unknown method"),
    (["--draws", "0"], "--draws"),
])
def test_cli_bad_arguments_exit_2(argv, msg, capsys):
    assert main(["eval", "calibration", "--quick", "--no-real", *argv]) == 2
    err = capsys.readouterr().err
    assert msg in err and "Traceback" not in err


def test_results_page_section_reads_the_command_output(tmp_path):
    page = SimpleNamespace(md=[], summary={}, figs=tmp_path / "figures" / "results")
    runs = tmp_path / "figures" / "calibration"
    calibration_stage(page, runs)
    assert "sogdd eval calibration --out" in page.md[-1]
    res = {"version": "x", "command": "sogdd eval calibration --quick", "quick": True, "seconds": 1.0,
           "notes": ["a note"], "sequences": {"sharp": "quick"},
           "synthetic": [{"sequence": "sharp", "method": "opencv", "kind": "board", "frames": 3, "boards": 3,
                          "recall": 1.0, "wrong_labels": 0, "corner": error_stats(np.array([0.01, 0.03])),
                          "calibration": {"projection_difference": 0.2, "focal_error": 0.5, "rms": 0.03},
                          "ms_per_frame": 4.0}],
           "real": []}
    write_results(res, runs)
    page = SimpleNamespace(md=[], summary={}, figs=tmp_path / "figures" / "results")
    calibration_stage(page, runs)
    text = "\n".join(page.md)
    assert "| sharp | `opencv` | 3 of 3 | 1.000 | 0 | 0.0200 |" in text
    assert "![calibration](figures/calibration/calibration.png)" in text


@pytest.mark.skipif(not (Path(os.environ.get("SOGDD_DATA", "/nonexistent")) / "calibration").is_dir(),
                    reason="needs $SOGDD_DATA/calibration")
def test_real_photos_scored():
    root = Path(os.environ["SOGDD_DATA"]) / "calibration"
    rows = run_real(root, ["opencv", "mrgingham"], sets=("chessboard_hard",))
    assert [r["method"] for r in rows] == ["opencv"]  # mrgingham: square boards only
    r = rows[0]
    assert r["boards"] == 1 and r["matched"] == 24 and r["label_distance"] < 0.5


def test_views_option_keeps_cut_views_in_proportion(capsys):
    from sogdd.evaluation.calibration.protocol import _chosen
    from sogdd.evaluation.calibration.sequences import SEQUENCES

    seq = SEQUENCES["partial"]  # 15 views, the last 6 cut by the frame
    idx = [i for i, _ in _chosen(seq, 5)]
    assert idx == [0, 1, 2, 9, 10]
    assert len(_chosen(seq, None)) == 15 and len(_chosen(seq, 40)) == 15
    assert main(["eval", "calibration", "--quick", "--no-real", "--views", "2"]) == 2
    assert "--views must be >= 3" in capsys.readouterr().err


def test_cli_merge_adds_sequences_to_one_result(tmp_path, capsys):
    out = str(tmp_path / "cal")
    base = ["eval", "calibration", "--quick", "--methods", "opencv", "--no-real", "--quiet", "--out", out]
    assert main(base + ["--sequences", "sharp"]) == 0
    assert main(base + ["--sequences", "partial", "--merge"]) == 0
    res = json.loads((Path(out) / "calibration.json").read_text())
    assert [r["sequence"] for r in res["synthetic"]] == ["sharp", "partial"]
    assert len(res["commands"]) == 2 and "--merge" in res["commands"][1]
    capsys.readouterr()
    assert main(["eval", "calibration", "--quick", "--no-real", "--merge"]) == 2
    assert "--merge needs --out" in capsys.readouterr().err


def test_points_only_do_not_pair_with_corners_outside_the_frame():
    xy, lab, inside = _truth()
    inside = inside.copy()
    inside[0] = False  # a corner cut by the frame: a stray point beside it is not scored
    pts = np.concatenate([xy[1:], [xy[0] + [6.0, 0.0]]])
    s = score_view(pts, None, xy, lab, inside)
    assert s.n_correct == 29 and s.errors.max() == 0


def test_the_figure_of_sequences_without_a_calibration(tmp_path):
    """The stress scenes are scored but not calibrated: no projection difference to put on a log axis."""
    from sogdd.report.calibration_section import calibration_figure

    rows = [{"sequence": "stress", "method": m, "corner": {"mean": 0.03}, "calibration": None}
            for m in ("sogdd", "opencv")]
    path = calibration_figure({"synthetic": rows}, tmp_path / "c.png")
    assert path.stat().st_size > 1000
