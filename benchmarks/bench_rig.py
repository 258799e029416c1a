"""The rig fit's speed: a 2-camera rig of 20 frames at 1280 x 960, after detection (target <= 10 s on 2 cores).

One session of the rendered ``parallel`` rig (:mod:`sogdd.evaluation.calibration.rigs`:
two 1280 x 960 cameras, baseline 120 mm, 9 x 6 board; 20 frames, 2 of them cut by
one camera's frame and 2 seen by one camera only) is rendered once and detected once
(``sogdd.calib.detect_board``; OpenCV's ``findChessboardCorners`` + ``cornerSubPix``
for the anchor). Then, in the same process, each is timed after one warm-up run as the
median of ``--repeats`` runs, with the fastest and slowest:

- ``sogdd.calib.rig.fit.calibrate_rig`` (pinhole model, rejection on);
- OpenCV's ``calibrateCamera`` per camera + ``stereoCalibrate`` (``CALIB_FIX_INTRINSIC``),
  the anchor: what the same machine does in the classic pipeline.

Limit the threads as CI does (``OMP_NUM_THREADS=2`` etc.) to measure "on 2 cores".

Usage::

    python benchmarks/bench_rig.py [--frames 20] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

from sogdd.calib.rig.fit import calibrate_rig
from sogdd.evaluation.calibration.rig_comparators import opencv_corners, run_rig_method, sogdd_boards
from sogdd.evaluation.calibration.rigs import RIGS, render_rig_session


def _timed(call, repeats: int) -> tuple[float, float, float]:
    call()  # warm-up: imports, numba, caches
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times), max(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    spec = RIGS["parallel"]
    t0 = time.perf_counter()
    session = render_rig_session(spec, args.frames, args.seed)
    images = {n: session.images(n) for n in spec.names}
    print(f"rendered {args.frames} frames x {len(spec.names)} cameras in {time.perf_counter() - t0:.1f} s")
    boards, t_sogdd = sogdd_boards(images, spec.target.pattern_size)
    corners, t_cv = opencv_corners(images, spec.target.pattern_size)
    print(f"detection: sogdd {t_sogdd:.1f} s, OpenCV {t_cv:.1f} s (not timed below)")
    sizes = {c.name: c.camera.size for c in spec.cameras}
    kw = dict(square=spec.target.square, pattern=spec.target.pattern_size)

    def sogdd_fit():
        return calibrate_rig(boards, sizes, models="pinhole", **kw)

    def opencv_fit():
        est, note = run_rig_method("opencv-stereo-fix", boards=None, corners=corners, sizes=sizes, **kw)
        if est is None:
            raise SystemExit(note)
        return est

    rig = sogdd_fit()
    used = sum(int(c.calibration.view_used.sum()) for c in rig.cameras)
    print(f"sogdd's fit uses {used} views of {args.frames * len(spec.names)}; RMS {rig.rms:.3f} px")
    print("| fit | median (s) | min (s) | max (s) |")
    print("|---|---:|---:|---:|")
    for name, call in (("sogdd calibrate_rig", sogdd_fit), ("OpenCV calibrateCamera + stereoCalibrate",
                                                           opencv_fit)):
        med, lo, hi = _timed(call, args.repeats)
        print(f"| {name} | {med:.3f} | {lo:.3f} | {hi:.3f} |")


if __name__ == "__main__":
    main()
