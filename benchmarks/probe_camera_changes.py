"""Complete boards on the real calibration sets under changes a camera can make, sogdd against OpenCV.

Each photo of a set is changed as another camera or setting would show it (half and a third of the size,
twice the size, a quarter turn, JPEG quality 20, a sixth of the light, noise of 10 grey levels, a blur of
2 px, vignetting to 0.3 at the corners, and a response of ``I^2.5``, as a linear sensor's output is against
an sRGB one), and ``sogdd.calib.detect_board`` and OpenCV's ``findChessboardCorners`` (adaptive threshold,
normalised) look for the set's board. Prints, per set and change, the complete boards ``sogdd/OpenCV``:

    python benchmarks/probe_camera_changes.py --data "$SOGDD_DATA/calibration"
"""

from __future__ import annotations

import argparse
import glob
import os

import cv2
import numpy as np

from sogdd.calib import detect_board

#: (glob under the data folder, inner corners)
SETS = [("opencv_stereo/left*.jpg", (9, 6)), ("chessboard_sony/*.jpg", (6, 4)), ("hik_mono_1440/*.png", (9, 6)),
        ("fisheye_chessboard/*.jpg", (4, 6)), ("rig3_ecocheck/left/*.jpg", (9, 13)),
        ("chessboard_border/*.jpg", (6, 4))]


def _vignetted(g: np.ndarray) -> np.ndarray:
    h, w = g.shape
    y, x = np.mgrid[:h, :w]
    r = ((x - w / 2) ** 2 + (y - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
    return np.clip(g * (1 - 0.7 * r), 0, 255).astype(np.uint8)


#: each change of a grey photo ``g`` (``rng`` for the noise)
CHANGES = {
    "none": lambda g, rng: g,
    "half": lambda g, rng: cv2.resize(g, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA),
    "third": lambda g, rng: cv2.resize(g, None, fx=0.34, fy=0.34, interpolation=cv2.INTER_AREA),
    "x2": lambda g, rng: cv2.resize(g, None, fx=2, fy=2, interpolation=cv2.INTER_CUBIC),
    "rot90": lambda g, rng: np.ascontiguousarray(np.rot90(g)),
    "jpeg20": lambda g, rng: cv2.imdecode(cv2.imencode(".jpg", g, [cv2.IMWRITE_JPEG_QUALITY, 20])[1],
                                          cv2.IMREAD_GRAYSCALE),
    "dark": lambda g, rng: np.clip(g * 0.15, 0, 255).astype(np.uint8),
    "gamma": lambda g, rng: (255 * (g / 255.0) ** 2.5).astype(np.uint8),
    "noise": lambda g, rng: np.clip(g + rng.normal(0, 10, g.shape), 0, 255).astype(np.uint8),
    "blur": lambda g, rng: cv2.GaussianBlur(g, (0, 0), 2.0),
    "vignetting": lambda g, rng: _vignetted(g),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.path.join(os.environ.get("SOGDD_DATA", ""), "calibration"))
    ap.add_argument("--changes", nargs="*", default=list(CHANGES), choices=list(CHANGES))
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    for pattern_glob, pattern in SETS:
        files = sorted(glob.glob(os.path.join(args.data, pattern_glob)))
        if not files:
            continue
        row = []
        for name in args.changes:
            ours = theirs = 0
            for f in files:
                g = CHANGES[name](cv2.imread(f, cv2.IMREAD_GRAYSCALE), rng)
                b = detect_board(g, pattern)
                ours += b is not None and len(b) == pattern[0] * pattern[1]
                theirs += bool(cv2.findChessboardCorners(g, pattern, flags=flags)[0])
            row.append(f"{name} {ours}/{theirs}")
        print(f"{pattern_glob} ({len(files)} photos): " + ", ".join(row), flush=True)


if __name__ == "__main__":
    main()
