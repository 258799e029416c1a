import numpy as np
import pytest

import sogdd
from sogdd.cli.main import main

GOOD = np.zeros((16, 16), np.uint8)


@pytest.mark.parametrize(
    "image, msg",
    [
        (np.zeros((0, 5), np.uint8), "empty"),
        (np.zeros((1, 1), np.uint8), "too small"),
        (np.full((8, 8), np.nan), "NaN"),
        (np.full((8, 8), np.inf), "NaN or inf"),
        (np.zeros((8, 8, 5), np.uint8), "colour"),
        (np.zeros((4, 8, 8, 3), np.uint8), "shape"),
        (np.zeros((8, 8), np.int32), "dtype"),
        (np.zeros((8, 8), np.complex64), "dtype"),
        (np.full((8, 8), 3.0), "[0, 1]"),
        ("image.png", "read_image"),
    ],
)
def test_bad_images(image, msg):
    with pytest.raises(ValueError, match=None) as exc:
        sogdd.detect_corners(image)
    assert msg in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(ValueError):
        sogdd.corner_response(image)


@pytest.mark.parametrize(
    "params",
    [
        {"n_orientations": 0},
        {"n_orientations": 2.5},
        {"sigma2": 0.0},
        {"sigma2": -1.0},
        {"sigma2": float("nan")},
        {"window": 4},
        {"window": 0},
        {"threshold": float("inf")},
        {"quantile": 1.5},
        {"nms_radius": 0},
        {"max_corners": 0},
        {"border": -1},
        {"levels": 0},
        {"scale_factor": 1.0},
        {"subpixel": "cubic"},
    ],
)
def test_bad_parameters(params):
    with pytest.raises(ValueError) as exc:
        sogdd.detect_corners(GOOD, **params)
    assert "\n" not in str(exc.value)


def test_unknown_keyword_is_python_s_own_one_line_error():
    """detect_corners shows every keyword in its signature (0.2.0), so an unknown one is a TypeError."""
    with pytest.raises(TypeError, match="bogus") as exc:
        sogdd.detect_corners(GOOD, bogus=1)
    assert "\n" not in str(exc.value)
    with pytest.raises(ValueError, match="bogus"):  # resolve_params still names it
        sogdd.resolve_params("paper", bogus=1)


def test_bad_preset_and_mask():
    with pytest.raises(ValueError, match="preset"):
        sogdd.detect_corners(GOOD, preset="nope")
    with pytest.raises(ValueError, match="mask shape"):
        sogdd.detect_corners(GOOD, mask=np.ones((3, 3), np.uint8))
    with pytest.raises(ValueError, match="mask must be"):
        sogdd.detect_corners(GOOD, mask=np.ones((16, 16), np.float32))


def test_files(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        sogdd.read_image(tmp_path / "missing.png")
    bad = tmp_path / "corrupt.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\nthis is not a png")
    with pytest.raises(ValueError, match="corrupt"):
        sogdd.read_image(bad)
    empty = tmp_path / "empty.jpg"
    empty.write_bytes(b"")
    with pytest.raises(ValueError):
        sogdd.read_image(empty)


@pytest.mark.parametrize(
    "argv",
    [
        ["detect", "MISSING.png"],
        ["detect", "CORRUPT"],
        ["detect", "GOOD", "--window", "4"],
        ["detect", "GOOD", "--sigma2", "0"],
        ["detect", "GOOD", "--n-orientations", "0"],
        ["response", "GOOD", "--output", "r.txt"],
        ["detect", "TINY"],
    ],
)
def test_cli_bad_input_exit_2_one_line(argv, tmp_path, capsys):
    import cv2

    good = tmp_path / "good.png"
    cv2.imwrite(str(good), np.random.default_rng(0).integers(0, 255, (32, 32), dtype=np.uint8))
    corrupt = tmp_path / "corrupt.png"
    corrupt.write_bytes(b"garbage")
    tiny = tmp_path / "tiny.png"
    cv2.imwrite(str(tiny), np.zeros((1, 1), np.uint8))
    subst = {"MISSING.png": str(tmp_path / "missing.png"), "CORRUPT": str(corrupt),
             "GOOD": str(good), "TINY": str(tiny)}
    code = main([subst.get(a, a) for a in argv])
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err
    assert len([ln for ln in err.splitlines() if ln.startswith("sogdd: error")]) == 1


@pytest.mark.parametrize(
    "name, value",
    [("padding", "zero"), ("kernel_radius_rule", "big"), ("zero_mean", "yes"), ("authors_measure", 1),
     ("gray_round", None), ("gray_weights", (0.3, 0.6)), ("gray_weights", (0.3, float("nan"), 0.1))],
)
def test_every_params_field_is_validated(name, value):
    with pytest.raises(ValueError, match=name):
        sogdd.resolve_params("paper", **{name: value})


@pytest.mark.parametrize("preset,kw,some", [("paper", {"threshold": 1.0}, True),
                                            ("hr", {"threshold": 1.0}, True), ("hr", {}, True),
                                            ("authors", {}, False)])
def test_small_images_detect_without_error(preset, kw, some):
    """Every size from 2 x 2: gradient refinement is skipped below cv2.cornerSubPix's minimum (11 px at
    the 7 x 7 window), never an OpenCV assertion (9 and 10 px images failed so)."""
    rng = np.random.default_rng(0)
    found = 0
    for h in range(2, 14):
        for w in range(2, 14):
            c = sogdd.detect_corners(rng.integers(0, 256, (h, w), dtype=np.uint8), preset=preset, **kw)
            assert np.isfinite(c.xy).all()
            found += len(c)
    assert found > 0 or not some  # the authors' 0.99 quantile and clamp leave none on uniform noise


@pytest.mark.parametrize("command", ["detect", "response"])
def test_cli_opencv_error_is_one_line(command, tmp_path, capsys, monkeypatch):
    """An OpenCV error inside detection is a one-line message and exit 2, never a traceback."""
    import cv2

    from sogdd.cli import detect as cli_detect
    from sogdd.cli import response as cli_response

    def boom(*a, **k):
        cv2.cornerSubPix(np.zeros((5, 5), np.float32), np.zeros((1, 1, 2), np.float32), (3, 3), (-1, -1),
                         (cv2.TERM_CRITERIA_COUNT, 1, 0))

    monkeypatch.setattr(cli_detect, "detect_corners", boom)
    monkeypatch.setattr(cli_response, "corner_response", boom)
    img = tmp_path / "a.png"
    cv2.imwrite(str(img), np.zeros((20, 20), np.uint8))
    argv = [command, str(img)] + (["-o", str(tmp_path / "r.npy")] if command == "response" else [])
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sogdd: error:") and "Assertion failed" in err[0]
