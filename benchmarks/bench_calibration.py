"""Time per frame of chessboard detection + refinement against OpenCV's, on the same rendered frames.

Frames from the calibration renderer (``sogdd.evaluation.calibration``): a
20 x 20 inner-corner board through a pinhole camera with k1, k2, p1, p2, tilted
up to 40 degrees, 4000 x 3000 (12 MP) by default, blur 1.0 px, noise 2 grey
levels. Each method (``sogdd.evaluation.calibration.comparators``: ``sogdd`` is
``sogdd.calib.detect_board`` with its refinement; ``opencv-sb`` is
``findChessboardCornersSB`` with EXHAUSTIVE | ACCURACY) is called once on a
small frame to compile and warm up, then ``--repeat`` times on each frame.
Prints per method the median time per frame with its spread (min, max and the
quartiles over all calls), boards found and the mean corner error.

    SOGDD_NUM_THREADS=2 NUMBA_NUM_THREADS=2 python benchmarks/bench_calibration.py
    python benchmarks/bench_calibration.py --width 1280 --height 960 --frames 2 --repeat 2   # a quick look
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def frames(width: int, height: int, corners: int, n: int, seed: int):
    """``n`` rendered views of a ``corners x corners`` board spanning about 60 % of the frame's height."""
    from sogdd.evaluation.calibration import ChessboardTarget, random_sequence, render_view
    from sogdd.evaluation.calibration.sequences import camera_for

    cam = camera_for(width, height)
    target = ChessboardTarget(corners, corners, 0.02)
    cell = 0.6 * height / (corners + 3)
    poses = random_sequence(cam, target, n, seed=seed, cell_px=(0.8 * cell, cell))
    return [render_view(cam, target, r, t, blur=1.0, noise=2.0, falloff=0.2, rng=seed + k)
            for k, (r, t) in enumerate(poses)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=4000)
    ap.add_argument("--height", type=int, default=3000)
    ap.add_argument("--corners", type=int, default=20, help="inner corners per side")
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--methods", default="sogdd,opencv-sb", help="comma-separated comparator names")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    from sogdd.evaluation.calibration.comparators import METHODS, available, method_names
    from sogdd.evaluation.calibration.metrics import score_view

    names = method_names(a.methods)
    t0 = time.perf_counter()
    views = frames(a.width, a.height, a.corners, a.frames, a.seed)
    print(f"{a.frames} frames {a.width}x{a.height}, {a.corners}x{a.corners} board, rendered in "
          f"{time.perf_counter() - t0:.1f} s")
    pattern = (a.corners, a.corners)
    for name in names:
        ok, note = available(name)
        if not ok:
            print(f"{name:>14}: {note}")
            continue
        detect = METHODS[name].detect
        small = views[0].image[: a.height // 3, : a.width // 3]
        detect(small, pattern)  # compile, warm up
        times, found, errs = [], 0, []
        for v in views:
            for r in range(a.repeat):
                t1 = time.perf_counter()
                det = detect(v.image, pattern)
                times.append(time.perf_counter() - t1)
                if r == 0:
                    found += det.found
                    s = score_view(det.points, det.labels, v.corners, v.labels, v.inside)
                    errs.append(s.errors)
        t = np.array(times)
        q1, med, q3 = np.percentile(t, [25, 50, 75])
        e = np.concatenate(errs) if errs else np.zeros(0)
        err = f"{e.mean():.4f}" if len(e) else "n/a"
        print(f"{name:>14}: median {med:.3f} s/frame (min {t.min():.3f}, IQR {q1:.3f}-{q3:.3f}, "
              f"max {t.max():.3f}; {len(t)} calls), boards {found} of {len(views)}, corner mean {err} px")


if __name__ == "__main__":
    main()
