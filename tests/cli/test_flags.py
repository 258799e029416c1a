"""Every parameter has a flag, and --help lists every value a text parameter takes."""

import dataclasses

import cv2
import numpy as np
import pytest

import sogdd
from sogdd.cli.main import main
from sogdd.formats.features import read_features
from sogdd.params import CHOICES, Params
from sogdd.synthetic import pattern_image

# how the measure is computed: the presets' recipes (paper vs the authors' code), not user settings
_RECIPE = {"kernel_radius_rule", "zero_mean", "padding", "authors_measure", "gray_weights", "gray_round",
           "channel_order"}


@pytest.fixture(scope="module")
def image():
    return pattern_image((120, 160), seed=2)[0]


def _help(capsys, command="detect") -> str:
    with pytest.raises(SystemExit):
        main([command, "--help"])
    return " ".join(capsys.readouterr().out.split())


def test_every_setting_has_a_flag_and_help_lists_every_choice(capsys):
    text = _help(capsys)
    for field in dataclasses.fields(Params):
        if field.name not in _RECIPE:
            assert "--" + field.name.replace("_", "-") in text, field.name
    assert "--no-x-junctions" in text and "--mask PATH" in text
    for name, values in CHOICES.items():
        for v in values:
            assert v in text, (name, v)
    assert "gaussian" in text and "adaptive" in text and "grey" in text


def test_threshold_units_and_x_junctions_flags_match_the_api(tmp_path, image, capsys):
    f = tmp_path / "a.png"
    cv2.imwrite(str(f), image)
    out = tmp_path / "c.npz"
    assert main(["detect", str(f), "--threshold-units", "grey", "--threshold", "20", "--x-junctions",
                 "-o", str(out)]) == 0
    (r,) = read_features(out)
    want = sogdd.detect_corners(image, threshold_units="grey", threshold=20.0, x_junctions=True)
    np.testing.assert_array_equal(r.corners.xy, want.xy)
    assert r.params["threshold_units"] == "grey" and r.params["x_junctions"] is True
    assert main(["detect", str(f), "--preset", "hr", "--no-x-junctions", "-o", str(out)]) == 0
    (r,) = read_features(out)
    np.testing.assert_array_equal(r.corners.xy, sogdd.detect_corners(image, preset="hr", x_junctions=False).xy)
    with pytest.raises(SystemExit) as info:
        main(["detect", str(f), "--threshold-units", "lux"])
    assert info.value.code == 2 and "invalid choice: 'lux'" in capsys.readouterr().err


def test_mask_file(tmp_path, image, capsys):
    f = tmp_path / "a.png"
    cv2.imwrite(str(f), image)
    mask = np.zeros(image.shape, np.uint8)
    mask[:, :80] = 255
    cv2.imwrite(str(tmp_path / "m.png"), mask)
    out = tmp_path / "c.json"
    assert main(["detect", str(f), "--mask", str(tmp_path / "m.png"), "-o", str(out)]) == 0
    (r,) = read_features(out)
    want = sogdd.detect_corners(image, mask=mask)
    assert 0 < len(want) < len(sogdd.detect_corners(image))
    np.testing.assert_allclose(r.corners.xy, want.xy, atol=6e-5)
    assert np.all(r.corners.xy[:, 0] < 80)
    assert r.params["mask"].startswith("120x160:sha256:")
    # a mask of another size fails that image, with the reason
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), image[:60])
    assert main(["detect", str(f), str(small), "--mask", str(tmp_path / "m.png"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "small.png" in err and "mask shape (120, 160) does not match image shape (60, 160)" in err
    assert [x.image for x in read_features(out)] == ["a.png"]
    assert main(["detect", str(f), "--mask", str(tmp_path / "none.png")]) == 2
    assert "--mask" in capsys.readouterr().err


def test_response_refuses_selection_flags(tmp_path, image, capsys):
    f = tmp_path / "a.png"
    cv2.imwrite(str(f), image)
    assert main(["response", str(f), "-o", str(tmp_path / "r.npy"), "--x-junctions"]) == 2
    assert "--x-junctions: point selection" in capsys.readouterr().err
