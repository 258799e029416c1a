"""Converting between every format, by the library and by sogdd convert: a chain through all of them gives the
numbers back; errors are one line with exit code 2; the input is never overwritten."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import numpy as np
import pytest

from sogdd.calib.demo import demo_calibration
from sogdd.calib.exchange import (
    FORMATS,
    convert,
    detect,
    exchange_format,
    read_calibration,
    write_calibration_as,
)
from sogdd.calib.files import write_calibration
from sogdd.calib.rig import write_rig
from sogdd.calib.rig.demo import demo_rig
from sogdd.cli.main import main

pytest.importorskip("yaml")
pytest.importorskip("pycolmap")
FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "exchange"


@pytest.fixture(scope="module")
def rig_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("rig")
    write_rig(demo_rig(), out)
    return out


def test_the_registry_lists_each_format_module_once():
    assert list(FORMATS) == ["sogdd", "ros", "kalibr", "mrcal", "colmap"]
    assert all(f.name == n and f.summary for n, f in FORMATS.items())
    with pytest.raises(ValueError, match="unknown format 'matlab'; choose one of sogdd, ros"):
        exchange_format("matlab")


def test_a_rig_goes_through_every_format_and_comes_back(tmp_path, rig_folder):
    """sogdd -> ros -> mrcal -> colmap -> sogdd, each read by recognising its files (Kalibr refuses the
    demo's k3: below)."""
    rig = demo_rig()
    src = rig_folder
    for k, fmt in enumerate(("ros", "mrcal", "colmap", "sogdd")):
        out = tmp_path / f"{k}-{fmt}"
        convert(src, out, fmt)
        assert detect(out).name == fmt
        src = out
    back = read_calibration(src)
    assert len(back.cameras) == 2  # colmap named them camera1, camera2
    for a, b in zip(rig.cameras, back.cameras):
        assert np.abs(b.K - a.K).max() < 1e-12 and np.abs(b.dist - np.ravel(a.dist)).max() == 0
        assert np.abs(b.R - a.R).max() < 1e-14 and np.abs(b.T - np.ravel(a.T)).max() < 1e-12


def test_the_command_converts_and_scales(tmp_path, rig_folder, capsys):
    assert main(["convert", str(rig_folder), str(tmp_path / "pair"), "--to", "ros", "--scale", "0.001"]) == 0
    out = capsys.readouterr().out
    assert "left (pinhole), right (pinhole) as ros" in out and "right.yaml" in out
    back = read_calibration(tmp_path / "pair")
    T = 0.001 * np.ravel(demo_rig().camera("right").T)
    assert np.abs(back.camera("right").T - T).max() < 1e-14 * np.linalg.norm(T)


def test_one_camera_by_the_command(tmp_path, capsys):
    write_calibration(demo_calibration(), tmp_path / "calib")
    assert main(["convert", str(tmp_path / "calib"), str(tmp_path / "cam.cameramodel"), "--to", "mrcal"]) == 0
    assert "camera (pinhole) as mrcal" in capsys.readouterr().out
    cam = read_calibration(tmp_path / "cam.cameramodel", "mrcal").cameras[0]
    assert cam.model == "pinhole" and np.array_equal(cam.K, demo_calibration().K)


@pytest.mark.parametrize(("argv", "message"), [
    (["{rig}", "{out}/k.yaml", "--to", "kalibr"], "Kalibr's radtan has no k3"),
    (["{missing}", "{out}/k.yaml", "--to", "ros"], "no such file or folder"),
    (["{rig}/rig.json", "{out}/x", "--to", "ros", "--from", "mrcal"], "not an mrcal .cameramodel"),
    (["{out}", "{out}/x", "--to", "ros"], "not a calibration in a format sogdd reads"),
    (["{rig}", "{out}/x", "--to", "ros", "--scale", "-2"], "the scale must be a positive number"),
    (["{rig}", "{out}/x", "--to", "matlab"], "invalid choice: 'matlab'"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, rig_folder, capsys, argv, message):
    out = tmp_path / "out"
    out.mkdir()
    subst = {"{rig}": str(rig_folder), "{out}": str(out), "{missing}": str(tmp_path / "nothing.yaml")}
    for key, value in subst.items():
        argv = [a.replace(key, value) for a in argv]
    try:
        code = main(["convert", *argv])
    except SystemExit as exc:  # argparse's usage errors exit from the parser
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("sogdd: error:") and message in err[0]
    assert list(out.iterdir()) == []


def test_an_input_is_never_overwritten(tmp_path, capsys):
    write_calibration(demo_calibration(), tmp_path)
    before = (tmp_path / "camera.yaml").read_bytes()
    # ROS writes NAME.yaml in a folder: the camera is called "camera", whose camera.yaml is the input
    assert main(["convert", str(tmp_path), str(tmp_path), "--to", "ros"]) == 2
    assert "that is the input" in capsys.readouterr().err
    assert (tmp_path / "camera.yaml").read_bytes() == before


def test_pyyaml_and_pycolmap_are_imported_only_when_a_format_needs_them():
    """No module of the package imports them at its top: a user who asks for no such format needs neither."""
    package = Path(exchange_format("ros").read.__code__.co_filename).parent
    top = {}
    for p in package.glob("*.py"):
        for node in ast.parse(p.read_text()).body:
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
                top[p.name] = top.get(p.name, []) + names
    assert "ros.py" in top and not any(n in ("yaml", "pycolmap") for names in top.values() for n in names)


def test_a_missing_pyyaml_is_one_line_saying_how_to_install_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "yaml", None)  # import yaml now raises ImportError
    src = FIXTURES / "ros_ost.yaml"
    assert main(["convert", str(src), str(tmp_path / "c.cameramodel"), "--to", "mrcal"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'sogdd[formats]'" in err[0]
    # writing needs no PyYAML
    write_calibration_as(demo_calibration(), tmp_path / "c.yaml", "ros")
    assert (tmp_path / "c.yaml").read_text().startswith("image_width: 640\n")
