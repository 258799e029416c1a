"""The parameter object and the detector's doors: defaults shown, changes validated, no silent nonsense."""

from __future__ import annotations

import dataclasses
import inspect
import math
import re
import warnings

import cv2
import numpy as np
import pytest

import sogdd
from sogdd.cli.main import main
from sogdd.params import (
    DETECT_FIELDS,
    MEASURE_FIELDS,
    PRESETS,
    SIGMA2_RANGE,
    Params,
    max_levels,
    preset_table,
    resolve_params,
)
from sogdd.synthetic import pattern_image


@pytest.fixture(scope="module")
def image():
    return pattern_image((120, 160), seed=3)[0]


def _one_line_error(call, *needles):
    with pytest.raises(ValueError) as exc:
        call()
    text = str(exc.value)
    assert "\n" not in text
    for n in needles:
        assert n in text, (n, text)
    return text


# ---- the parameter object ------------------------------------------------------------------------------


def test_repr_shows_every_value():
    p = Params.preset("authors")
    text = repr(p)
    for f in dataclasses.fields(Params):
        assert f"{f.name}={getattr(p, f.name)!r}" in text


def test_preset_and_replace_validate_and_agree_with_resolve_params():
    for name in PRESETS:
        assert Params.preset(name) == PRESETS[name] == resolve_params(name)
    p = Params.preset("hr").replace(window=5, max_corners=50)
    assert p == resolve_params("hr", window=5, max_corners=50) == resolve_params(Params.preset("hr"), window=5,
                                                                                   max_corners=50)
    assert (p.window, p.max_corners, p.sigma2) == (5, 50, 1.5)
    _one_line_error(lambda: p.replace(window=4), "window must be an odd integer")
    _one_line_error(lambda: p.replace(bogus=1), "unknown parameter(s): bogus")
    _one_line_error(lambda: Params(window=4), "window must be")  # made directly: validated too
    _one_line_error(lambda: Params.preset("nope"), "unknown preset 'nope'")
    assert Params.preset("paper").replace(subpixel=False).subpixel == "none"


def test_a_params_object_gives_the_same_corners_as_the_keywords(image):
    p = Params.preset("hr").replace(window=5, max_corners=40)
    by_object = sogdd.detect_corners(image, p)
    by_keywords = sogdd.detect_corners(image, preset="hr", window=5, max_corners=40)
    np.testing.assert_array_equal(by_object.xy, by_keywords.xy)
    np.testing.assert_array_equal(by_object.response, by_keywords.response)
    # keywords on top of an object change it like replace() does
    np.testing.assert_array_equal(sogdd.detect_corners(image, Params.preset("hr"), window=5, max_corners=40).xy,
                                  by_keywords.xy)
    np.testing.assert_array_equal(sogdd.corner_response(image, Params.preset("authors").replace(sigma2=2.0)),
                                  sogdd.corner_response(image, preset="authors", sigma2=2.0))
    det = sogdd.SOGDD(p)
    np.testing.assert_array_equal(det.detect_corners(image).xy, by_keywords.xy)
    assert det.params == dataclasses.replace(p, channel_order="bgr")


# ---- the defaults in help() -------------------------------------------------------------------------------


def _doc_table(func) -> str:
    lines = inspect.getdoc(func).splitlines()
    start = next(i for i, x in enumerate(lines) if x.startswith("parameter ")) - 1
    end = next(i for i in range(start + 3, len(lines)) if lines[i].startswith("===="))
    return "\n".join(lines[start : end + 1])


@pytest.mark.parametrize("func, names", [(sogdd.detect_corners, DETECT_FIELDS),
                                         (sogdd.corner_response, MEASURE_FIELDS)])
def test_the_docstring_tables_are_the_presets(func, names):
    """The table in each docstring is what preset_table() makes of PRESETS today: regenerate and compare."""
    assert _doc_table(func) == preset_table(names, indent="")
    keywords = [n for n, prm in inspect.signature(func).parameters.items() if prm.kind is prm.KEYWORD_ONLY
                and n not in ("mask", "device")]
    assert tuple(keywords) == names  # every keyword in the table, in the signature's order
    for n in names:  # and documented in Parameters
        assert re.search(rf"^{n} : ", inspect.getdoc(func), re.M), n


def test_the_table_changes_with_a_preset(monkeypatch):
    monkeypatch.setitem(PRESETS, "paper", dataclasses.replace(PRESETS["paper"], sigma2=1.3))
    assert preset_table(("sigma2",), indent="") != _doc_table(sogdd.detect_corners).split("\nn_orientations")[0]
    assert "1.3" in preset_table(("sigma2",))


# ---- options that depend on each other, and changes that would reinterpret a kept value -------------------


def test_threshold_units_without_a_threshold_in_those_units(image):
    _one_line_error(lambda: sogdd.detect_corners(image, threshold_units="grey"),
                    "threshold=1e+09", "'paper' preset", "give threshold= in grey levels")
    _one_line_error(lambda: sogdd.detect_corners(image, preset="hr", threshold_units="measure",
                                                 x_junctions=False),
                    "threshold=20", "give threshold= on Upsilon")
    # given together, or without an absolute threshold, it means what it says
    assert len(sogdd.detect_corners(image, threshold_units="grey", threshold=20.0)) > 0
    assert resolve_params("authors", threshold_units="grey", authors_measure=False).threshold is None


def test_threshold_units_flag_is_one_line_and_exit_2(tmp_path, image, capsys):
    f = tmp_path / "a.png"
    cv2.imwrite(str(f), image)
    assert main(["detect", str(f), "--threshold-units", "grey", "-o", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "give threshold=" in err and not (tmp_path / "c.json").exists()


def test_x_junctions_and_gaussian_window_say_what_to_use():
    _one_line_error(lambda: resolve_params("paper", x_junctions=True),
                    "x_junctions needs threshold_units='grey'", "or x_junctions=False")
    _one_line_error(lambda: resolve_params("authors", window_shape="gaussian"),
                    "window_shape='gaussian' needs padding='response'", "window_shape='square'")
    p = resolve_params("authors", window_shape="gaussian", padding="response", authors_measure=False)
    assert p.window_shape == "gaussian"


def test_relative_thresholds_never_combine_silently(image):
    _one_line_error(lambda: sogdd.detect_corners(image, quantile=0.99), "quantile=0.99", "threshold=1e+09",
                    "give threshold=None")
    _one_line_error(lambda: sogdd.detect_corners(image, threshold_rel=0.01), "threshold_rel=0.01",
                    "give threshold=None")
    _one_line_error(lambda: sogdd.detect_corners(image, preset="authors", threshold_rel=0.01),
                    "two relative thresholds", "set the other to None")
    _one_line_error(lambda: sogdd.detect_corners(image, threshold=None, quantile=0.99, threshold_rel=0.01),
                    "two relative thresholds")
    _one_line_error(lambda: sogdd.detect_corners(image, preset="authors", threshold=5e8), "quantile=0.99",
                    "give quantile=None")
    # what the user says in one call holds: the quantile alone, or both (the larger wins)
    alone = sogdd.detect_corners(image, threshold=None, quantile=0.99)
    both = sogdd.detect_corners(image, threshold=1e9, quantile=0.99)
    assert len(alone) > 0 and len(both) <= len(alone)
    assert len(sogdd.detect_corners(image, preset="authors", threshold_rel=0.01, quantile=None)) > 0


def test_a_negative_threshold_is_refused(image):
    for t in (-1, -1e-9):
        _one_line_error(lambda t=t: sogdd.detect_corners(image, threshold=t),
                        "threshold must be a finite number >= 0")
    assert len(sogdd.detect_corners(image, threshold=0.0)) > 0


# ---- sigma2: a range from the maths, and no numpy warnings ------------------------------------------------


def test_sigma2_below_the_nyquist_limit_is_refused(image):
    lo, hi = SIGMA2_RANGE
    assert lo == pytest.approx(2 / math.pi**2)
    for s2 in (1e-12, 0.05, lo * 0.999, hi * 1.001):
        _one_line_error(lambda s2=s2: sogdd.detect_corners(image, sigma2=s2), "sigma2 must be", "Nyquist")
    # the sampled filter at the limit: its pass band peak sqrt(2)/sigma sits at the Nyquist frequency pi
    assert math.sqrt(2) / math.sqrt(lo) == pytest.approx(math.pi)


@pytest.mark.parametrize("preset", ["paper", "authors"])
def test_no_numpy_warning_reaches_the_user_at_the_smallest_scale(image, preset):
    rng = np.random.default_rng(0)
    noise = rng.integers(0, 256, (96, 96), dtype=np.uint8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for img in (image, noise, np.zeros((40, 40), np.uint8)):
            c = sogdd.detect_corners(img, preset=preset, sigma2=SIGMA2_RANGE[0])
            assert np.isfinite(c.xy).all() and np.isfinite(c.response).all()


# ---- levels and the image size ----------------------------------------------------------------------------


def test_levels_beyond_the_image_are_refused():
    img = np.zeros((512, 512), np.uint8)
    img[100:300, 150:400] = 200
    p = PRESETS["paper"]
    assert max_levels(p, (512, 512)) == 5  # 512 .. 32; 16 px < the 17 px one corner's measure spans
    _one_line_error(lambda: sogdd.detect_corners(img, levels=16), "levels=16", "512 x 512", "use levels <= 5")
    _one_line_error(lambda: sogdd.detect_corners(img, levels=6), "use levels <= 5")
    c = sogdd.detect_corners(img, levels=5)
    # no level smaller than a corner's measure: no corner larger than the top level's 17 px span scaled up
    assert c.size.max() <= p.keypoint_size() * 2**4 + 1e-9
    assert max_levels(resolve_params("paper", border=20), (512, 512)) == 4  # 2 border + 3 = 43 px > 32


# ---- the image itself -------------------------------------------------------------------------------------


def test_none_is_not_an_image():
    _one_line_error(lambda: sogdd.detect_corners(None), "got None")
    _one_line_error(lambda: sogdd.corner_response(None), "got None")


def test_x_junctions_at_a_scale_they_cannot_be_calibrated_at(image):
    _one_line_error(lambda: sogdd.detect_corners(image, preset="hr", sigma2=0.5),
                    "x_junctions cannot be calibrated", "x_junctions=False")
    assert len(sogdd.detect_corners(image, preset="hr", sigma2=0.5, x_junctions=False)) > 0


def test_the_gpu_gets_the_resolved_parameters(image, monkeypatch):
    """device="cuda" hands the GPU module the Params the door resolved (and checked)."""
    from sogdd import detector

    seen = {}

    class FakeGPU:
        @staticmethod
        def detect_corners(img, *, preset, mask):
            seen["detect"] = resolve_params(preset)
            return sogdd.Corners.empty()

        @staticmethod
        def corner_response(img, *, preset):
            seen["response"] = resolve_params(preset)
            return np.zeros(img.shape[:2])

    monkeypatch.setattr(detector, "_gpu", lambda device: FakeGPU if device == "cuda" else None)
    sogdd.detect_corners(image, "hr", device="cuda", window=5)
    sogdd.corner_response(image, Params.preset("authors"), device="cuda", sigma2=2.0)
    assert seen == {"detect": resolve_params("hr", window=5), "response": resolve_params("authors", sigma2=2.0)}
    _one_line_error(lambda: sogdd.detect_corners(np.zeros((64, 64)), device="cuda", levels=4),
                    "use levels <= 2")
