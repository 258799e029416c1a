"""Shared fixtures of the feature-file tests: a rendered image and a writer."""

import cv2
import pytest

from sogdd.synthetic import pattern_image


@pytest.fixture(scope="module")
def image():
    return pattern_image((120, 160), seed=2)[0]


@pytest.fixture
def write_image():
    """``write_image(path, img)`` writes an image file (folders made) and returns its path as text."""

    def write(path, img):
        path.parent.mkdir(parents=True, exist_ok=True)
        assert cv2.imwrite(str(path), img)
        return str(path)

    return write
