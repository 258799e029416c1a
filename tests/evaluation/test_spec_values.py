"""Spec values keep the text where it is a documented value."""

import pytest

from sogdd.evaluation.specs import parse_spec, parse_specs
from sogdd.params import CHOICES


@pytest.mark.parametrize("key", sorted(CHOICES))
def test_every_documented_text_value_survives_parsing(key):
    for value in CHOICES[key]:
        spec = parse_spec(f"sogdd:{key}={value}")
        assert spec.params == {key: value}, (key, value)


def test_subpixel_none_builds_and_none_still_means_none_elsewhere():
    (spec,) = parse_specs(["sogdd:subpixel=none"], [])  # was refused: subpixel=None
    assert spec.params == {"subpixel": "none"} and spec.label == "sogdd:subpixel=none"
    assert parse_spec("sogdd:threshold=none").params == {"threshold": None}
    assert parse_spec("sogdd:subpixel=off").params == {"subpixel": False}
    assert parse_spec("sogdd:subpixel=None").params == {"subpixel": "none"}
