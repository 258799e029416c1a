"""Time of chessboard detection + refinement (``sogdd.calib.detect_boards``) on a large frame.

A 20 x 20 inner-corner board (21 x 21 squares) warped by a homography into a
4000 x 3000 (12 MP) frame, blurred (sigma 1 px) with noise (sigma 2 grey levels);
the first call compiles and is not counted. Prints the median of ``--repeat``
calls, the stages' share, and the corners found.

    SOGDD_NUM_THREADS=2 NUMBA_NUM_THREADS=2 python benchmarks/bench_calib_detect.py
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np


def frame(width: int, height: int, n: int, *, blur: float = 1.0, noise: float = 2.0, seed: int = 0):
    """A board of ``n x n`` inner corners in a ``width x height`` frame, and its true corners."""
    sq = 64
    board = (np.indices((n + 1, n + 1)).sum(axis=0) % 2) * 180.0 + 40.0
    img = np.pad(np.kron(board, np.ones((sq, sq))), sq, constant_values=220.0)
    s = 0.8 * min(width, height) / img.shape[0]
    src = np.float32([[0, 0], [img.shape[1], 0], [img.shape[1], img.shape[0]], [0, img.shape[0]]]) - 0.5
    cx, cy = width / 2, height / 2
    h = img.shape[0] * s / 2
    dst = np.float32([[cx - 1.1 * h, cy - h], [cx + 0.9 * h, cy - 0.9 * h], [cx + h, cy + h],
                      [cx - h, cy + 0.95 * h]])
    H = cv2.getPerspectiveTransform(src, dst)
    out = cv2.warpPerspective(img, H, (width, height), flags=cv2.INTER_AREA, borderValue=128.0)
    if blur:
        out = cv2.GaussianBlur(out, (0, 0), blur)
    out = out + np.random.default_rng(seed).normal(0, noise, out.shape)
    g = (np.indices((n, n))[::-1].reshape(2, -1).T + 1) * sq + sq - 0.5
    truth = cv2.perspectiveTransform(g[None].astype(np.float64), H)[0]
    return np.clip(out, 0, 255).astype(np.uint8), truth


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=4000)
    ap.add_argument("--height", type=int, default=3000)
    ap.add_argument("--corners", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    from scipy.spatial import cKDTree

    from sogdd.calib.detect import detect_boards
    from sogdd.calib.xcorners import find_xcorners

    img, truth = frame(a.width, a.height, a.corners)
    detect_boards(img[:600, :800])  # compile
    times, t_x = [], []
    for _ in range(a.repeat):
        t0 = time.perf_counter()
        find_xcorners(img)
        t_x.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        boards = detect_boards(img, (a.corners, a.corners))
        times.append(time.perf_counter() - t0)
    b = boards[0] if boards else None
    found = 0 if b is None else len(b)
    err = cKDTree(truth).query(b.image_points)[0] if b is not None else np.array([np.nan])
    print(f"{a.width}x{a.height}, {a.corners}x{a.corners} board: detect_boards {np.median(times):.3f} s "
          f"(median of {a.repeat}; X-corner search {np.median(t_x):.3f} s), "
          f"{found} of {a.corners ** 2} corners, "
          f"error vs the warp mean {np.mean(err):.4f} px max {np.max(err):.4f} px")


if __name__ == "__main__":
    main()
