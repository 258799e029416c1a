"""sogdd check end to end: rendered views of a chessboard through a known distortion-free camera checked
against a stored camera.json, the verdict's exit code (0 pass, 4 warn, 3 fail), --json, and the one-line
errors (exit 2) for bad inputs.

The views are drawn here with :func:`sogdd.synthetic.render_polygons` (a planar board through a pinhole
without distortion is a set of exact quadrilaterals), so the test needs no evaluation code.
"""

from __future__ import annotations

import json
import re

import cv2
import numpy as np
import pytest

from sogdd.calib.rig.demo import demo_rig
from sogdd.calib.rig.files import write_rig
from sogdd.cli.main import main
from sogdd.synthetic import Polygon, render_polygons

SIZE = (640, 480)
K_TRUE = np.array([[520.0, 0, 323.0], [0, 519.0, 237.0], [0, 0, 1]])
COLS, ROWS = 9, 6


#: a second camera for a rig: x_right = R x_left + T (squares), turned 4 degrees about y towards the left one
K_RIGHT = np.array([[540.0, 0, 317.0], [0, 541.0, 244.0], [0, 0, 1]])
R_RIGHT, T_RIGHT = cv2.Rodrigues(np.array([0.0, np.radians(-4.0), 0.0]))[0], np.array([-3.0, 0.05, 0.1])
LEFT = (K_TRUE, np.eye(3), np.zeros(3))
PAPER = np.array([[-2.0, -2, 0], [COLS + 1, -2, 0], [COLS + 1, ROWS + 1, 0], [-2, ROWS + 1, 0]])


def _in(rvec, tvec, K, R, T):
    """The board pose ``(rvec, tvec)`` of the left camera as a camera ``(K, R, T)`` sees it: rvec, tvec, K."""
    return cv2.Rodrigues(R @ cv2.Rodrigues(rvec)[0])[0], R @ tvec + T, K


def _polygons(rvec, tvec, K=K_TRUE) -> list[Polygon]:
    """The board's paper and its dark squares, projected (square (a, b) covers [a-1, a] x [b-1, b])."""
    def quad(u0, v0, u1, v1, level):
        obj = np.array([[u0, v0, 0], [u1, v0, 0], [u1, v1, 0], [u0, v1, 0]], float)
        px, _ = cv2.projectPoints(obj, rvec, tvec, K, np.zeros(5))
        return Polygon(px.reshape(4, 2), level)

    out = [quad(-2.0, -2.0, COLS + 1.0, ROWS + 1.0, 215.0)]
    out += [quad(a - 1.0, b - 1.0, float(a), float(b), 35.0)
            for a in range(COLS + 1) for b in range(ROWS + 1) if (a + b) % 2 == 0]
    return out


def _poses(n: int, seed: int, cameras=(LEFT,)):
    """``n`` board poses (in the left camera's frame) whose paper every one of ``cameras`` sees whole."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        axis = rng.normal(size=3)
        axis[2] *= 0.3
        rvec = axis / np.linalg.norm(axis) * np.radians(rng.uniform(15, 35))
        R = cv2.Rodrigues(rvec)[0]
        centre = np.array([rng.uniform(-2.5, 2.5), rng.uniform(-1.5, 1.5), rng.uniform(13, 17)])
        tvec = centre - R @ np.array([(COLS - 1) / 2, (ROWS - 1) / 2, 0.0])
        edges = [cv2.projectPoints(PAPER, *_in(rvec, tvec, *c), np.zeros(5))[0].reshape(-1, 2) for c in cameras]
        if all(np.all((e > 5) & (e < np.array(SIZE) - 6)) for e in edges):
            out.append((rvec, tvec))
    return out


def _shoot(path, rvec, tvec, K, rng):
    img = render_polygons(SIZE[::-1], _polygons(rvec, tvec, K), background=110.0, supersample=8)
    img = cv2.GaussianBlur(img, (0, 0), 0.8) + rng.normal(0, 2.0, img.shape)
    assert cv2.imwrite(str(path), np.clip(np.rint(img), 0, 255).astype(np.uint8))


@pytest.fixture(scope="module")
def views(tmp_path_factory):
    """Five rendered views of the 9 x 6 board (blur 0.8 px, noise 2 grey levels): v1.png ... v5.png."""
    folder = tmp_path_factory.mktemp("views")
    rng = np.random.default_rng(4)
    for k, (rv, tv) in enumerate(_poses(5, seed=9), start=1):
        _shoot(folder / f"v{k}.png", rv, tv, K_TRUE, rng)
    return folder


def _camera_json(path, scale: float = 1.0, std: float = 0.05):
    """A stored camera.json: the true camera, its focal length ``scale`` times the truth."""
    K = K_TRUE.copy()
    K[0, 0] *= scale
    K[1, 1] *= scale
    path.write_text(json.dumps({
        "model": "pinhole", "image_width": SIZE[0], "image_height": SIZE[1], "camera_matrix": K.tolist(),
        "distortion_coefficients": [0.0] * 5, "std": dict.fromkeys(("fx", "fy", "cx", "cy", "k1"), std),
        "rms": 0.05, "square": 1.0}))
    return path


def _run(capsys, *argv):
    code = main(["check", *map(str, argv), "--quiet"])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_same_camera_passes(views, tmp_path, capsys):
    stored = _camera_json(tmp_path / "camera.json")
    code, out, err = _run(capsys, stored, views / "*.png", "--board", "chessboard:9x6")
    assert (code, err) == (0, "")
    assert out.startswith("pass: 5 view(s) agree with the stored calibration")
    assert "  fx " in out and "views (RMS px): v1.png" in out


def test_an_unreadable_image_is_named_and_the_others_checked(views, tmp_path, capsys):
    """A pass with an image that could not be read exits 2 (as sogdd calibrate), the image on stderr."""
    stored = _camera_json(tmp_path / "camera.json")
    (tmp_path / "broken.png").write_bytes(b"not an image")
    code, out, err = _run(capsys, stored, views / "*.png", tmp_path / "broken.png", "--board", "chessboard:9x6")
    assert code == 2
    assert out.startswith("pass: 5 view(s) agree")
    assert re.search(r"not checked \S*broken\.png: unreadable: ", out)
    assert err.startswith("sogdd: error: ") and "broken.png" in err and err.count("\n") == 1


def test_a_focal_length_moved_by_one_percent_fails(views, tmp_path, capsys):
    """The stored camera's focal length 1 % shorter than the one that took the views: exit 3, the reason
    names the focal length and the change."""
    stored = _camera_json(tmp_path / "camera.json", scale=1 / 1.01)
    code, out, err = _run(capsys, stored, views, "--board", "chessboard:9x6")
    assert (code, err) == (3, "")
    first = out.splitlines()[0]
    assert first.startswith(("fail: fx moved by +", "fail: fy moved by +")) and "% of fx" in first


def test_a_small_change_warns(views, tmp_path, capsys):
    """0.3 % is beyond the warning's floor (0.2 %) but not the failure's (0.5 %): exit 4."""
    stored = _camera_json(tmp_path / "camera.json", scale=1 / 1.003)
    code, out, _ = _run(capsys, stored, views, "--board", "chessboard:9x6")
    assert code == 4
    assert out.startswith("warn: f")


def test_json_output(views, tmp_path, capsys):
    stored = _camera_json(tmp_path / "camera.json", scale=1 / 1.01)
    code, out, _ = _run(capsys, stored, views / "*.png", "--json")
    d = json.loads(out)
    assert code == 3 and d["verdict"] == "fail" and d["reason"].startswith("f")
    cam = d["cameras"][0]
    assert sorted(cam["view_rms"]) == [f"v{k}.png" for k in range(1, 6)]
    assert cam["difference_pct"]["fx"] == pytest.approx(1.0, abs=0.1)  # the truth is 1.01 times the stored
    assert cam["sigmas"]["fx"] > 5


@pytest.fixture(scope="module")
def rig_views(tmp_path_factory):
    """Five frames of the two-camera rig: left/left1.png ... and right/right1.png ..."""
    folder = tmp_path_factory.mktemp("rig_views")
    cams = {"left": LEFT, "right": (K_RIGHT, R_RIGHT, T_RIGHT)}
    rng = np.random.default_rng(5)
    for name in cams:
        (folder / name).mkdir()
    for k, (rv, tv) in enumerate(_poses(5, seed=3, cameras=tuple(cams.values())), start=1):
        for name, cam in cams.items():
            _shoot(folder / name / f"{name}{k}.png", *_in(rv, tv, *cam), rng)
    return folder


def _rig_json(path, turn_deg: float = 0.0):
    """A stored rig.json: the two true cameras, the right one's stored rotation off by ``turn_deg`` about y."""
    R = cv2.Rodrigues(np.array([0.0, np.radians(turn_deg), 0.0]))[0] @ R_RIGHT
    std = {**dict.fromkeys(("fx", "fy", "cx", "cy"), 0.05), "rotation_deg": 0.02, "baseline": 0.005}
    cams = [{"name": n, "model": "pinhole", "camera_matrix": K.tolist(), "distortion_coefficients": [0.0] * 5,
             "image_size": list(SIZE), "R": R_.tolist(), "T": T.tolist(), "rms": 0.05, "std": std}
            for n, K, R_, T in (("left", K_TRUE, np.eye(3), np.zeros(3)), ("right", K_RIGHT, R, T_RIGHT))]
    path.write_text(json.dumps({"cameras": cams, "square": 1.0}))
    return path


@pytest.mark.parametrize(("turn", "code"), [(0.0, 0), (0.5, 3)])
def test_a_rig_passes_in_place_and_fails_with_a_camera_turned(rig_views, tmp_path, capsys, turn, code):
    stored = _rig_json(tmp_path / "rig.json", turn)
    got, out, err = _run(capsys, stored, "--camera", "left", rig_views / "left", "--camera", "right",
                         rig_views / "right", "--board", "chessboard:9x6")
    assert (got, err) == (code, "")
    first = out.splitlines()[0]
    if code == 0:
        assert first.startswith("pass: 10 view(s) agree")
    else:
        assert first.startswith("fail: right: its rotation relative to left moved by 0.")
    assert "right relative to the first camera, over 5 frames: rotation" in out


def test_the_help_gives_the_library_limits():
    """The help's numbers are the library's constants."""
    from sogdd.calib import drift
    from sogdd.cli import check

    doc = " ".join(check.__doc__.split())
    assert f"beyond {drift.FAIL_SIGMA:g} standard deviations" in doc and f"{drift.FAIL_PCT:g} % of fx" in doc
    assert f"beyond {drift.WARN_SIGMA:g} sigma and {drift.WARN_PCT:g} %" in doc
    assert f"{drift.RMS_FAIL_FACTOR:g} times the stored RMS and {drift.RMS_FAIL_PX:g} px" in doc
    assert f"({drift.RMS_WARN_FACTOR:g} times and {drift.RMS_WARN_PX:g} px; {drift.ROT_WARN_DEG:g} degrees, " \
           f"{drift.BASELINE_WARN_PCT:g} %)" in doc
    assert f"{drift.ROT_FAIL_DEG:g} degrees, or {drift.BASELINE_FAIL_PCT:g} % of the baseline" in doc
    assert check.EXIT_CODES == {"pass": 0, "warn": 4, "fail": 3}


@pytest.fixture(scope="module")
def rig_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rig")
    write_rig(demo_rig(), folder)
    return folder / "rig.yaml"


@pytest.mark.parametrize("case", ["missing file", "no board", "rig with one camera's images",
                                  "camera with --camera", "another size", "unknown rig camera", "bad board",
                                  "rig without the board's size"])
def test_bad_input_is_one_line_and_exit_2(case, views, rig_file, tmp_path, capsys):
    stored = _camera_json(tmp_path / "camera.json")
    blank = tmp_path / "blank"
    blank.mkdir()
    for k in range(3):
        cv2.imwrite(str(blank / f"b{k}.png"), np.full(SIZE[::-1], 128, np.uint8))
    small = tmp_path / "small"
    small.mkdir()
    cv2.imwrite(str(small / "s.png"), cv2.resize(cv2.imread(str(views / "v1.png"), 0), (320, 240)))
    argv, says = {
        "missing file": ([tmp_path / "nothere.yaml", views], "nothere.yaml: no such file"),
        "no board": ([stored, blank], "no board"),
        "rig with one camera's images": ([rig_file, views], "is a rig of 2 cameras (left, right)"),
        "camera with --camera": ([stored, "--camera", "left", views], "is one camera, not a rig"),
        "another size": ([stored, small], "the images are 320x240 but the stored camera is 640x480"),
        "unknown rig camera": ([rig_file, "--camera", "middle", views],
                               "camera 'middle' is not in the stored rig"),
        "bad board": ([stored, views, "--board", "chessboard:9"], "--board"),
        "rig without the board's size": ([rig_file, "--camera", "left", views, "--camera", "right", views],
                                         "board chessboard:auto cannot check a rig"),
    }[case]
    code, out, err = _run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.startswith("sogdd: error: ") and err.count("\n") == 1 and says in err
    assert "Traceback" not in err
