"""sogdd convert's options: an option the chosen format has no use for is a one-line error, nothing written."""

from __future__ import annotations

import pytest

from sogdd.calib.demo import demo_calibration
from sogdd.calib.files import write_calibration
from sogdd.cli.main import main


@pytest.fixture(scope="module")
def calib(tmp_path_factory):
    out = tmp_path_factory.mktemp("convert") / "calib"
    write_calibration(demo_calibration(), out)
    return out


@pytest.mark.parametrize("src, to, extra, says", [
    ("folder", "mrgingham", ["--scale", "0.001"], "--scale does not apply to --to mrgingham"),
    ("folder", "mrgingham", ["--board", "aprilgrid:6x6:0.088:0.3"], "--board applies to --to kalibr-corners"),
    ("yaml", "kalibr", ["--pattern", "9x6"], "--pattern applies to --to mrgingham and kalibr-corners"),
    ("yaml", "ros", ["--used-only"], "--used-only applies to --to mrgingham and kalibr-corners"),
    ("folder", "kalibr-corners", ["--from", "kalibr"], "--from names a calibration's format"),
])
def test_an_option_the_format_has_no_use_for_is_refused(calib, tmp_path, capsys, src, to, extra, says):
    inp = calib if src == "folder" else calib / "camera.yaml"
    out = tmp_path / "out.file"
    assert main(["convert", str(inp), str(out), "--to", to, *extra]) == 2
    err = capsys.readouterr().err
    assert says in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_the_options_a_format_uses_are_taken(calib, tmp_path):
    assert main(["convert", str(calib), str(tmp_path / "c.vnl"), "--to", "mrgingham", "--pattern", "9x6",
                 "--used-only"]) == 0
    assert main(["convert", str(calib / "camera.yaml"), str(tmp_path / "k.yaml"), "--to", "ros",
                 "--scale", "0.001"]) == 0
    assert (tmp_path / "c.vnl").is_file() and (tmp_path / "k.yaml").is_file()
