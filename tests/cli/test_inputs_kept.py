"""No command writes over one of its inputs, and none reads a device or a FIFO for ever.

An output that is an input (the same name, a symbolic or hard link, a relative
path through ``..``) is refused before any work, with exit 2 and the input
untouched; inputs that are not regular files are refused at the door.
"""

import os
import threading
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.formats import record as record_module
from sogdd.formats.record import source_stamp
from sogdd.synthetic import pattern_image


@pytest.fixture
def photo(tmp_path, monkeypatch):
    """``victim.png`` in a working folder that has a sub-folder ``sub``; its bytes."""
    monkeypatch.chdir(tmp_path)
    img, _ = pattern_image((120, 160), seed=3)
    cv2.imwrite("victim.png", img)
    (tmp_path / "sub").mkdir()
    return tmp_path / "victim.png", (tmp_path / "victim.png").read_bytes()


def _refused(argv, capsys, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    for w in words:
        assert w in err, err
    return err


@pytest.mark.parametrize("target", ["victim.png", "sub/../victim.png", "{abs}", "link.png", "hard.png"])
def test_overlay_over_the_input_is_refused(photo, capsys, target):
    path, before = photo
    os.symlink("victim.png", "link.png")
    os.link("victim.png", "hard.png")
    target = target.format(abs=path)
    _refused(["detect", "victim.png", "--overlay", target], capsys, "--overlay", "input")
    assert path.read_bytes() == before


def test_the_output_file_and_its_sidecar_are_not_inputs(photo, capsys):
    path, before = photo
    # an image named like a CSV (OpenCV reads by content) and a symbolic link standing for the output
    Path("shot.csv").write_bytes(before)
    _refused(["detect", "shot.csv", "-o", "shot.csv"], capsys, "--output", "input")
    os.symlink("victim.png", "out.json")
    _refused(["detect", "victim.png", "-o", "out.json"], capsys, "--output", "input")
    Path("all.csv.json").write_bytes(before)
    _refused(["detect", "all.csv.json", "-o", "all.csv"], capsys, "sidecar", "input")
    assert path.read_bytes() == before and Path("shot.csv").read_bytes() == before


def test_the_mask_is_an_input(photo, capsys):
    path, before = photo
    _refused(["detect", "victim.png", "--mask", "victim.png", "--overlay", "./victim.png"], capsys, "input")
    assert path.read_bytes() == before


def test_response_map_over_its_image_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    img, _ = pattern_image((120, 160), seed=1)
    cv2.imwrite("map.png", img)
    os.symlink("map.png", "r.npy")
    before = Path("map.png").read_bytes()
    _refused(["response", "map.png", "-o", "r.npy"], capsys, "--output", "input")
    assert Path("map.png").read_bytes() == before


def test_report_page_over_its_inputs_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("README.md").write_text("# mine\n")
    _refused(["report", "--out", "README.md", "--readme", "./README.md", "--data", str(tmp_path)], capsys,
             "--out", "input")
    assert Path("README.md").read_text() == "# mine\n"


def test_a_different_output_is_written(photo, capsys):
    path, before = photo
    assert main(["detect", "victim.png", "--overlay", "sub/over.png", "-o", "sub/c.csv"]) == 0
    assert Path("sub/over.png").is_file() and Path("sub/c.csv").is_file()
    assert path.read_bytes() == before


def _in_time(func, arg, seconds):
    """``func(arg)``, failing the test (not hanging it) when it does not return within ``seconds``."""
    out = {}
    t = threading.Thread(target=lambda: out.setdefault("v", func(arg)), daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"{func.__name__}({arg!r}) hangs"
    return out["v"]


@pytest.mark.parametrize("kind", ["device", "fifo"])
def test_devices_and_fifos_are_refused_at_the_door(tmp_path, capsys, monkeypatch, kind):
    monkeypatch.chdir(tmp_path)
    if kind == "device":
        name = "/dev/zero"
    else:
        name = "f.png"
        os.mkfifo(name)
    for argv in (["detect", name], ["response", name, "-o", "r.npy"],
                 ["detect", "--mask", name, "x.png"]):
        assert _in_time(main, argv, 60) == 2, f"sogdd {' '.join(argv)}"
        err = capsys.readouterr().err
        assert name in err and "not a file" in err and err.count("\n") == 1


def test_source_stamp_of_a_device_or_fifo_is_none_at_once(tmp_path):
    fifo = tmp_path / "f.png"
    os.mkfifo(fifo)
    for p in ("/dev/zero", fifo):
        assert _in_time(source_stamp, p, 30) == (None, None, None)


def test_source_stamp_reads_at_most_the_size_stat_reports(tmp_path, monkeypatch):
    """A file that grows while it is hashed gets the digest of the size its stamp states."""
    import hashlib

    f = tmp_path / "grows.png"
    f.write_bytes(b"abcdef")
    real = os.fstat

    def smaller(fd):
        st = real(fd)
        return SimpleNamespace(st_mode=st.st_mode, st_size=3, st_mtime_ns=st.st_mtime_ns)

    monkeypatch.setattr(record_module.os, "fstat", smaller)
    size, _, digest = source_stamp(f)
    assert size == 3 and digest == hashlib.sha256(b"abc").hexdigest()


@pytest.mark.parametrize("argv", [["detect", "x.png", "--out", "existing"],
                                  ["eval", "gt", "--out", "existing"],
                                  ["theory", "figures", "--out", "existing"]])
def test_out_folder_that_is_a_file_is_one_clear_line(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    Path("existing").write_text("keep me")
    with pytest.raises(SystemExit) as exc:  # a usage error, as argparse reports them
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "existing is a file, not a folder" in err and "Errno" not in err and err.count("\n") == 1
    assert Path("existing").read_text() == "keep me"


def test_image_reads_a_bytes_path(photo):
    import sogdd

    path, _ = photo
    img = sogdd.read_image(os.fsencode(path))
    assert img.shape[:2] == (120, 160) and np.asarray(img).dtype == np.uint8
