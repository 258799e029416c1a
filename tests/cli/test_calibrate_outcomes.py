"""sogdd calibrate's outcomes a script relies on: a bad verdict's own exit code (3, the outputs written),
file names no output can hold refused at the door, SIGTERM as Ctrl-C (exit 143, --out as it was), what a
killed run left removed by the next, and the inputs and output folders a user means.

The verdict is replaced (monkeypatch) where the exit code's rule is tested, so that the test does not hang
on what the rendered views' verdict happens to be.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap

import pytest

from sogdd.calib import verdict as verdict_module
from sogdd.calib.rig import verdict as rig_verdict_module
from sogdd.calib.targets.chessboard import search as chessboard
from sogdd.cli.main import main
from sogdd.formats.safe_write import claimed


def _run(capsys, *argv):
    code = main(["calibrate", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def _tree(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _cams(folder, right=None):
    return ("--camera", "left", folder / "left" / "*.png", "--camera", "right",
            (right or folder / "right") / "*.png")


FAST = ("--board", "chessboard:9x6", "--model", "pinhole", "--no-report")


# --------------------------------------------------------------------------------------------------
# the verdict's exit code


@pytest.mark.parametrize("level, code", [("bad", 3), ("warn", 0)])
def test_a_bad_verdict_exits_3_with_the_outputs_written(rendered_frames, tmp_path, capsys, monkeypatch, level,
                                                        code):
    monkeypatch.setattr(verdict_module, "verdict", lambda cal: [(level, "the finding")])
    out = tmp_path / "calib"
    got, text, err = _run(capsys, rendered_frames, *FAST, "--out", out, "--json")
    assert got == code, err
    d = json.loads(text)
    assert d["verdict_level"] == level and d["verdict"] == [{"level": level, "text": "the finding"}]
    assert (out / "camera.yaml").is_file() and (out / "views.csv").is_file()
    got, text, _ = _run(capsys, rendered_frames, *FAST, "--out", out)
    assert got == code and f"  {level}: the finding" in text


def test_a_bad_verdict_outranks_an_unreadable_input(rendered_frames, tmp_path, capsys, monkeypatch):
    imgs = tmp_path / "imgs"
    shutil.copytree(rendered_frames, imgs)
    (imgs / "broken.png").write_bytes(b"not a png")
    monkeypatch.setattr(verdict_module, "verdict", lambda cal: [("ok", "sound")])
    code, _, err = _run(capsys, imgs, *FAST, "--out", tmp_path / "a")
    assert code == 2 and "broken.png" in err
    monkeypatch.setattr(verdict_module, "verdict", lambda cal: [("bad", "unsound")])
    code, _, err = _run(capsys, imgs, *FAST, "--out", tmp_path / "b")
    assert code == 3 and "broken.png" in err


@pytest.mark.parametrize("level, code", [("bad", 3), ("ok", 0)])
def test_a_rigs_bad_verdict_exits_3(rendered_rig, tmp_path, capsys, monkeypatch, level, code):
    folder, _, _ = rendered_rig
    monkeypatch.setattr(rig_verdict_module, "rig_verdict", lambda rig: [(level, "the finding")])
    out = tmp_path / "rig"
    got, text, err = _run(capsys, *_cams(folder), *FAST, "--out", out, "--json")
    assert got == code, err
    assert json.loads(text)["verdict_level"] == level and (out / "rig.yaml").is_file()


# --------------------------------------------------------------------------------------------------
# file names


def _no_search(monkeypatch):
    """Any board search fails the test: the checks come before any work."""
    def search(*a, **k):
        raise AssertionError("a board was searched for")

    monkeypatch.setattr(chessboard, "find_boards", search)


def test_a_non_utf8_file_name_is_refused_before_any_work(rendered_frames, tmp_path, capsys, monkeypatch):
    imgs = tmp_path / "imgs"
    shutil.copytree(rendered_frames, imgs)
    os.rename(imgs / "f3.png", os.path.join(os.fsencode(imgs), b"caf\xe9.png"))
    _no_search(monkeypatch)
    for given in (imgs, imgs / "*.png"):
        code, _, err = _run(capsys, given, "--board", "chessboard:9x6", "--out", tmp_path / "o", "--jobs", 1)
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
        assert err.startswith("sogdd: error: ") and "caf\\xe9.png: the file name is not valid UTF-8" in err
    assert not (tmp_path / "o").exists()


def test_a_non_utf8_file_name_in_a_rig_is_refused_before_any_work(rendered_rig, tmp_path, capsys, monkeypatch):
    folder, _, _ = rendered_rig
    right = tmp_path / "right"
    shutil.copytree(folder / "right", right)
    os.rename(right / "right03.png", os.path.join(os.fsencode(right), b"right\xe903.png"))
    _no_search(monkeypatch)
    code, _, err = _run(capsys, *_cams(folder, right), "--board", "chessboard:9x6", "--out", tmp_path / "rig")
    assert code == 2 and err.count("\n") == 1 and "right\\xe903.png: the file name is not valid UTF-8" in err
    assert not (tmp_path / "rig").exists()


@pytest.mark.parametrize("rig", [False, True])
def test_a_non_utf8_output_folder_is_refused_before_any_work(rendered_rig, tmp_path, rig):
    """In a process of its own: OpenCV's writers crash on such a name (a segmentation fault, not an error)."""
    folder, _, _ = rendered_rig
    out = os.path.join(os.fsencode(tmp_path), b"caf\xe9")
    images = _cams(folder) if rig else (folder / "left",)
    proc = subprocess.run([sys.executable, "-m", "sogdd", "calibrate", *map(str, images), "--board",
                           "chessboard:9x6", "--quiet", "--out", out], capture_output=True, timeout=600)
    err = proc.stderr.decode()
    assert proc.returncode == 2 and err.count("\n") == 1, err
    assert "caf\\xe9: the name is not valid UTF-8" in err and os.listdir(tmp_path) == []


# --------------------------------------------------------------------------------------------------
# signals, and what a killed run leaves

DRIVER = """
    import os, signal, sys
    from sogdd.calib import report, session
    from sogdd.cli.main import main

    where, sig, argv = sys.argv[1], int(sys.argv[2]), sys.argv[3:]

    def hit(real):
        def wrapped(*a, **k):
            os.kill(os.getpid(), sig)
            return real(*a, **k)
        return wrapped

    if where == "fit":  # after the detection, while the camera is fitted
        session.calibrate = hit(session.calibrate)
    else:  # while the outputs are written (the new folder holds camera.yaml and the CSVs by then)
        report.write_report = hit(report.write_report)
    sys.exit(main(["calibrate", *argv]))
"""


def _killed(tmp_path, where, sig, *argv):
    script = tmp_path / "driver.py"
    script.write_text(textwrap.dedent(DRIVER))
    return subprocess.run([sys.executable, str(script), where, str(int(sig)), *map(str, argv)],
                          capture_output=True, text=True, timeout=600)


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".sogdd.tmp"))


@pytest.mark.slow
@pytest.mark.parametrize("where", ["fit", "write"])
def test_sigterm_leaves_the_output_folder_as_it_was_and_exits_143(rendered_frames, tmp_path, capsys, where):
    out = tmp_path / "calib"
    code, text, _ = _run(capsys, rendered_frames, *FAST, "--out", out)
    assert (out / "camera.yaml").is_file()
    before = _tree(out)
    proc = _killed(tmp_path, where, signal.SIGTERM, rendered_frames, "--board", "chessboard:9x6", "--model",
                   "rational", "--out", out, "--quiet")
    assert proc.returncode == 143, proc.stderr[-3000:]
    assert proc.stderr == f"sogdd: interrupted; {out} left as it was\n"
    assert _tree(out) == before and _leftovers(tmp_path) == []


@pytest.mark.slow
def test_what_a_killed_run_left_beside_the_folder_the_next_run_removes(rendered_frames, tmp_path, capsys):
    out = tmp_path / "calib"
    proc = _killed(tmp_path, "write", signal.SIGKILL, rendered_frames, "--board", "chessboard:9x6", "--model",
                   "pinhole", "--out", out, "--quiet")
    assert proc.returncode == -signal.SIGKILL
    left = _leftovers(tmp_path)
    assert len(left) == 1 and left[0].startswith(".calib.new-") and not out.exists()
    old = tmp_path / ".calib.old-0badcafe.sogdd.tmp"  # killed during the final renames
    old.mkdir()
    (old / "camera.yaml").write_text("%YAML:1.0\n")
    live = tmp_path / ".calib.new-1234abcd.sogdd.tmp"  # a run that is still writing
    live.mkdir()
    with claimed(live):
        _run(capsys, rendered_frames, *FAST, "--out", out)
    assert (out / "camera.yaml").is_file() and _leftovers(tmp_path) == [live.name]


# --------------------------------------------------------------------------------------------------
# the inputs and output folders a user means


def test_a_one_camera_run_replaces_a_rigs_output_and_the_reverse(rendered_rig, tmp_path, capsys):
    folder, _, _ = rendered_rig
    out = tmp_path / "out"
    _run(capsys, *_cams(folder), *FAST, "--out", out)
    assert (out / "rig.yaml").is_file()
    code, _, err = _run(capsys, folder / "left", *FAST, "--out", out)
    assert "did not write" not in err and (out / "camera.yaml").is_file() and not (out / "rig.yaml").exists()
    _run(capsys, *_cams(folder), *FAST, "--out", out)
    assert (out / "rig.yaml").is_file() and not (out / "camera.yaml").exists()
    (out / "notes.txt").write_text("mine")  # a rig's output and a file of the user's: that file is named
    code, _, err = _run(capsys, folder / "left", *FAST, "--out", out)
    assert code == 2 and "holds notes.txt, which sogdd calibrate did not write" in err


def test_a_second_run_into_a_folder_among_the_inputs_reads_the_same_images(rendered_frames, tmp_path, capsys):
    inp = tmp_path / "inp"
    shutil.copytree(rendered_frames, inp)
    for _ in range(2):
        code, text, err = _run(capsys, "-r", inp, "--board", "chessboard:9x6", "--model", "pinhole", "--out",
                               inp / "calib")
        assert "holds the input" not in err and "8 of 8 views used" in text, err
    assert (inp / "calib" / "report" / "view_0007.png").is_file()


def test_a_broken_link_matched_by_a_pattern_is_reported(rendered_frames, tmp_path, capsys):
    imgs = tmp_path / "imgs"
    shutil.copytree(rendered_frames, imgs)
    (imgs / "f8.png").symlink_to(tmp_path / "gone.png")
    code, text, err = _run(capsys, imgs / "*.png", *FAST, "--out", tmp_path / "o")
    assert "f8.png" in err and "unreadable f8.png" in text
    rows = {r["view"]: r for r in csv.DictReader(open(tmp_path / "o" / "views.csv"))}
    assert rows["f8.png"]["status"] == "unreadable" and len(rows) == 9


@pytest.mark.parametrize("kind", ["folder", "broken link"])
def test_a_rigs_image_that_is_a_folder_or_a_broken_link_is_named(rendered_rig, tmp_path, capsys, kind):
    folder, _, _ = rendered_rig
    right = tmp_path / "right"
    shutil.copytree(folder / "right", right)
    (right / "right08.png").unlink()
    if kind == "folder":
        (right / "right08.png").mkdir()
    else:
        (right / "right08.png").symlink_to(tmp_path / "gone.png")
    code, text, err = _run(capsys, *_cams(folder, right), *FAST, "--out", tmp_path / "rig")
    assert "lacks frame" not in err and "right08.png" in err and "Traceback" not in err, err
    rows = {r["view"]: r for r in csv.DictReader(open(tmp_path / "rig" / "right" / "views.csv"))}
    assert rows["right08.png"]["status"] == "unreadable"
