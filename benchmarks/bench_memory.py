"""Peak memory of one calibration view per image pixel: what ``sogdd calibrate`` holds per worker.

Each frame is a 9 x 6 chessboard warped into a ``W x H`` frame (blurred 1 px, noise 2 grey levels), written
as an 8-bit grey PNG and as a colour JPEG (a phone's photo). Each file goes through the calibration's
detection of one view (:func:`sogdd.calib.detection.detect_view`: reading, the grey image, the board
search, the corners' precision, the thumbnail) in a fresh process, after a small frame has compiled
everything; the peak is the process's high-water mark (``VmHWM``, reset through ``/proc/self/clear_refs``
just before the call) less its resident set before it, so it counts what numpy, OpenCV and numba allocate
alike (tracemalloc sees numpy's only). Prints, per frame size and file kind, the peak in MB and in bytes
per image pixel, and the seconds::

    SOGDD_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/bench_memory.py --mp 2 8 32

``--bomb`` adds a flat 16000 x 16000 PNG (a quarter of a MB on disk), read with ``max_pixels`` raised.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

CHILD = r"""
import json, sys, time
from pathlib import Path
from sogdd.calib import parse_board
from sogdd.calib.detection import detect_view

def status(key):
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) * 1024

path, warm, limit = sys.argv[1], sys.argv[2], int(sys.argv[3])
spec = parse_board("chessboard:9x6")
opts = {"max_pixels": limit}
detect_view(warm, spec, opts)  # compiles
Path("/proc/self/clear_refs").write_text("5")  # the high-water mark back to the resident set
before = status("VmRSS")
t = time.perf_counter()
r = detect_view(path, spec, opts)
seconds = time.perf_counter() - t
print(json.dumps({"peak": status("VmHWM") - before, "seconds": seconds, "size": r.size, "error": r.error,
                  "corners": [len(b) for b in r.boards]}))
"""


def board_frame(width: int, height: int, *, seed: int = 0) -> np.ndarray:
    """A 9 x 6 inner-corner chessboard filling most of a ``width x height`` frame, uint8 grey."""
    sq = 64
    board = (np.indices((7, 10)).sum(axis=0) % 2) * 180.0 + 40.0
    img = np.pad(np.kron(board, np.ones((sq, sq), np.float32)), sq, constant_values=220.0).astype(np.float32)
    src = np.float32([[0, 0], [img.shape[1], 0], [img.shape[1], img.shape[0]], [0, img.shape[0]]])
    w, h = 0.8 * width, 0.8 * width * img.shape[0] / img.shape[1]
    if h > 0.8 * height:
        w, h = w * 0.8 * height / h, 0.8 * height
    cx, cy = width / 2, height / 2
    dst = np.float32([[cx - 0.55 * w, cy - 0.5 * h], [cx + 0.45 * w, cy - 0.45 * h],
                      [cx + 0.5 * w, cy + 0.5 * h], [cx - 0.5 * w, cy + 0.48 * h]])
    out = cv2.warpPerspective(img, cv2.getPerspectiveTransform(src, dst), (width, height),
                              flags=cv2.INTER_LINEAR, borderValue=128.0)
    out = cv2.GaussianBlur(out, (0, 0), 1.0)
    out += np.random.default_rng(seed).normal(0, 2.0, out.shape).astype(np.float32)
    return np.clip(out, 0, 255).astype(np.uint8)


def measure(path: Path, warm: Path, limit: int) -> dict:
    proc = subprocess.run([sys.executable, "-c", CHILD, str(path), str(warm), str(limit)], capture_output=True,
                          text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mp", type=float, nargs="+", default=[2, 8, 32], help="frame sizes, megapixels (4:3)")
    ap.add_argument("--bomb", action="store_true", help="also a flat 16000 x 16000 PNG")
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp())
    warm = folder / "warm.png"
    cv2.imwrite(str(warm), board_frame(640, 480))
    runs = []
    for mp in args.mp:
        w = int(round((mp * 1e6 * 4 / 3) ** 0.5))
        h = int(round(w * 3 / 4))
        grey = board_frame(w, h)
        png, jpg = folder / f"{w}x{h}.png", folder / f"{w}x{h}.jpg"
        cv2.imwrite(str(png), grey)
        cv2.imwrite(str(jpg), cv2.merge([grey, (grey * 0.9).astype(np.uint8), grey // 2 + 100]),
                    [cv2.IMWRITE_JPEG_QUALITY, 92])
        runs += [(f"{w}x{h} grey PNG", png, w * h), (f"{w}x{h} colour JPEG", jpg, w * h)]
    if args.bomb:
        bomb = folder / "bomb.png"
        cv2.imwrite(str(bomb), np.full((16000, 16000), 128, np.uint8), [cv2.IMWRITE_PNG_COMPRESSION, 9])
        runs.append((f"16000x16000 flat PNG ({bomb.stat().st_size // 1024} KB)", bomb, 16000 ** 2))
    print(f"{'frame':<34}{'peak MB':>10}{'B/pixel':>10}{'s':>8}  corners")
    for name, path, n in runs:
        t = time.perf_counter()
        r = measure(path, warm, 2**31)
        print(f"{name:<34}{r['peak'] / 1e6:>10.0f}{r['peak'] / n:>10.1f}{r['seconds']:>8.1f}  {r['corners']}"
              f"{' ' + r['error'] if r['error'] else ''}  ({time.perf_counter() - t:.0f} s in all)", flush=True)


if __name__ == "__main__":
    main()
