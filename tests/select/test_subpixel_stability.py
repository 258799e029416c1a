"""Sub-pixel stability: one photo as uint8 and as float32 (issue 22, item 8); a known bug, a strict xfail.

``img`` and ``img.astype(np.float32) / 255`` differ by ~7.6e-6 grey levels once
converted back to the 0-255 scale, yet hr moves one corner of this photo by
0.996 px. Measured causes (the shared images, paper and hr):

* ``cv2.cornerSubPix`` with hr's 3 x 3 windows (half-window 1) often does not
  converge in its 30 iterations (7 % of the moved hr points of 28 shared
  images), and its last iterate is then a chaotic function of the input: this
  corner's is 0.996 px from its start with uint8 input, 1.064 px with float32;
* the refusal of a move at ``max_shift`` (here 1 px) turns that into a jump of the
  whole move (kept at 0.996, refused at 1.064);
* further: the switch of the quadratic peak fit between ``log`` and linear
  values when a 3 x 3 patch holds a non-positive value (paper), ties of Upsilon
  between neighbouring pixels, cornerSubPix's 1e-3 px stopping step.

A refusal that fades in (continuous in the move) alone does not help on the
109 shared images (hr corners moved > 0.1 px between uint8 and float32: 1569
before and after) and breaks hr's one point per corner (two peaks of one vertex stop
merging). The fix needs a refinement that converges; when it lands this test
passes and, strict, fails until the mark goes.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import sogdd


@pytest.mark.xfail(strict=True, reason="issue 22 item 8: a non-converged cornerSubPix iterate near the 1 px "
                   "refusal moves one hr corner by 0.996 px between uint8 and float32 input")
def test_uint8_and_float32_photo_give_the_same_hr_corners(data_dir):
    path = data_dir / "calibration" / "chessboard_sony" / "frame07.jpg"
    if not path.is_file():
        pytest.skip(f"{path} is not in the shared data")
    img = sogdd.read_image(path)
    a = sogdd.detect_corners(img, preset="hr")
    b = sogdd.detect_corners(img.astype(np.float32) / 255, preset="hr")
    assert len(a) == len(b) > 100
    d, _ = cKDTree(b.xy).query(a.xy)
    assert d.max() < 1e-3, f"a corner moved {d.max():.3f} px at {a.xy[np.argmax(d)]}"
