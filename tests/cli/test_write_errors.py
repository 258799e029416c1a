"""Every write error is an error: a full disk on stdout is one line and exit
2, never exit 0 with a truncated CSV; a reader that stops early ends the command quietly; an output
that is a folder is refused before any detection, and write errors name the file, not its temporary."""

import resource
import signal
import subprocess
import sys

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.corners import Corners
from sogdd.formats.features import FeatureRecord, write_features

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux file limits and /dev/full")


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    """An image whose CSV (threshold off) is about 0.7 MB: far more than a pipe or a disk buffer holds."""
    p = tmp_path_factory.mktemp("img") / "noise.png"
    cv2.imwrite(str(p), np.random.default_rng(3).integers(0, 256, (400, 400), dtype=np.uint8))
    return str(p)


def _sogdd(*args, **kw):
    return subprocess.run([sys.executable, "-m", "sogdd", *args], capture_output=True, timeout=300, **kw)


def _one_error(stderr: bytes) -> str:
    text = stderr.decode()
    assert "Traceback" not in text, text
    lines = [ln for ln in text.splitlines() if ln.startswith("sogdd: error:")]
    assert len(lines) == 1, text
    return lines[0]


def test_a_disk_that_fills_mid_output_is_an_error_not_a_truncated_csv(noisy, tmp_path):
    full = _sogdd("detect", noisy, "--threshold", "none", "--max-corners", "200")
    assert full.returncode == 0 and len(full.stdout) > 5000
    limit = 200_000  # the file system takes this much, then refuses (as a nearly full disk does)

    def small_disk():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    out = tmp_path / "c.csv"
    with open(out, "wb") as f:
        r = subprocess.run([sys.executable, "-m", "sogdd", "detect", noisy, "--threshold", "none"], stdout=f,
                           stderr=subprocess.PIPE, timeout=300, preexec_fn=small_disk)
    assert out.stat().st_size == limit  # the output did not fit
    assert r.returncode == 2
    assert "cannot write to stdout: File too large" in _one_error(r.stderr)


def test_dev_full_is_one_line_and_exit_2(noisy):
    with open("/dev/full", "wb") as f:
        r = subprocess.run([sys.executable, "-m", "sogdd", "detect", noisy, "--threshold", "none",
                            "--format", "json"], stdout=f, stderr=subprocess.PIPE, timeout=300)
    assert r.returncode == 2
    assert "No space left on device" in _one_error(r.stderr)


def test_a_reader_that_stops_early_ends_the_command_quietly(noisy):
    p = subprocess.Popen([sys.executable, "-m", "sogdd", "detect", noisy, "--threshold", "none"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = p.stdout.readline()  # | head -1
    p.stdout.close()
    err = p.stderr.read()
    code = p.wait(timeout=300)
    assert first == b"x,y,response,size\n"
    assert err == b""  # no traceback, no "Exception ignored"
    assert code == 141  # 128 + SIGPIPE, as a shell reports for cat or seq in the same place


def test_an_output_that_is_a_folder_is_refused_before_detection(tmp_path, noisy, capsys, monkeypatch):
    calls = []
    monkeypatch.setattr("sogdd.cli.detect.detect_corners", lambda *a, **k: calls.append(1))
    folder = tmp_path / "adir.csv"
    folder.mkdir()
    assert main(["detect", noisy, "-o", str(folder)]) == 2
    err = capsys.readouterr().err
    assert calls == [] and "is a folder" in err and ".sogdd.tmp" not in err


def test_write_errors_name_the_target_not_a_temporary_file(tmp_path):
    c = FeatureRecord("a.png", Corners(np.array([[1.0, 2.0]]), [1.0]), (4, 4))
    target = tmp_path / "adir.npz"
    target.mkdir()
    with pytest.raises(OSError) as info:
        write_features(target, c)
    assert str(target) in str(info.value) and ".sogdd.tmp" not in str(info.value)
    with pytest.raises(OSError) as info:  # mkstemp's own message names the temporary file
        write_features(tmp_path / "missing" / "x.csv", c)
    assert "x.csv" in str(info.value) and ".sogdd.tmp" not in str(info.value)


def test_response_output_that_is_a_folder_is_refused_before_the_map(tmp_path, noisy, capsys, monkeypatch):
    calls = []
    monkeypatch.setattr("sogdd.cli.response.corner_response", lambda *a, **k: calls.append(1))
    (tmp_path / "r.npy").mkdir()
    for out in (tmp_path / "r.npy", tmp_path / "missing" / "r.npy"):
        assert main(["response", noisy, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert calls == [] and "Traceback" not in err and ("is a folder" in err or "does not exist" in err)
