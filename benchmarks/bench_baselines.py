"""Speed of every registered baseline against ``cv2.SIFT_create().detect``, same images, same process.

Images: 512 x 512 and 1024 x 1024 rendered test patterns with noise (or
``--image PATH``, cropped to each size). Each figure is the median wall time of
``--repeat`` runs after one warm-up run (JIT compilation), in milliseconds per
megapixel, with the ratio to SIFT's detect time on the same image.

Run: ``python benchmarks/bench_baselines.py [--sizes 512,1024] [--repeat 3] [--only a,b]``
"""

from __future__ import annotations

import argparse
import os
import time

import cv2
import numpy as np

import sogdd
from sogdd import baselines
from sogdd.synthetic import pattern_image


def timed(fn, repeat: int) -> float:
    """Median seconds of ``repeat`` calls after one warm-up call."""
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def make_image(side: int, path: str | None) -> tuple[np.ndarray, str]:
    if path:
        img = sogdd.read_image(path)
        if img.ndim == 3:
            img = cv2.cvtColor(img[:, :, :3], cv2.COLOR_RGB2GRAY)
        if min(img.shape) >= side:
            y0, x0 = (img.shape[0] - side) // 2, (img.shape[1] - side) // 2
            return img[y0 : y0 + side, x0 : x0 + side], os.path.basename(path)
        return cv2.resize(img, (side, side), interpolation=cv2.INTER_LINEAR), os.path.basename(path)
    img, _ = pattern_image((side, side), seed=0, noise=3.0)
    return img, "rendered test pattern, noise 3"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="512,1024")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--image", default=None, help="a photo to crop instead of the rendered pattern")
    ap.add_argument("--only", default=None, help="comma-separated registry names")
    args = ap.parse_args()
    names = args.only.split(",") if args.only else baselines.available()
    print(f"sogdd {sogdd.__version__}, OpenCV {cv2.__version__}, {os.cpu_count()} CPUs")
    sift = cv2.SIFT_create()
    for side in [int(s) for s in args.sizes.split(",")]:
        img, src = make_image(side, args.image)
        mp = img.size / 1e6
        t_sift = timed(lambda img=img: sift.detect(img, None), args.repeat)
        print(f"\n{side}x{side} ({src})")
        print(f"{'detector':16s} {'points':>7s} {'ms/image':>9s} {'ms/MP':>9s} {'x SIFT':>7s}")
        print(f"{'cv2.SIFT detect':16s} {len(sift.detect(img, None)):7d} {t_sift * 1e3:9.1f} "
              f"{t_sift / mp * 1e3:9.1f} {1.0:7.2f}")
        for name in names:
            det = baselines.get(name)
            n = len(det.detect_corners(img))
            t = timed(lambda det=det, img=img: det.detect_corners(img), args.repeat)
            print(f"{name:16s} {n:7d} {t * 1e3:9.1f} {t / mp * 1e3:9.1f} {t / t_sift:7.2f}", flush=True)


if __name__ == "__main__":
    main()
