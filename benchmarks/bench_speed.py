"""Speed and memory of sogdd against OpenCV, on the same images in the same process.

Images are crops and mosaics of real photos (Strecha fountain-P11 from the
shared data, ``--data`` or ``SOGDD_DATA``) at 1, 4 and 16 megapixels; without
the data, rendered test patterns with noise are used and the output says so.

Every case is timed once per round, round-robin, for ``--repeat`` rounds, so each
round has its own ``cv2.SIFT_create().detect`` time on the same image: the table
gives the median wall time in milliseconds per megapixel, the median of the
per-round ratios to SIFT and their range (min-max), which shows how much the
shared machine moved during the run. With the data, a 6.3 MP facade photo
(Herz-Jesus-P8 ``0000.jpg``, whole: ashlar walls, carvings and cobblestones,
where pruning helps least among the multiview photos) is added. At 1 MP the
authors' pipeline written directly (``authors_code_detect``) gives the
reference for the ``authors`` preset's speed-up; the ``hr`` preset is timed
when :data:`sogdd.params.PRESETS` has one.
``detect_corners`` with an absolute threshold (the paper preset) evaluates the
measure exactly only where a bound cannot rule out T_h (see ``soddc_measure``);
the fraction of pixels it evaluates is printed, the row "detect on the full map"
is the same detection without that pruning, and ``--stress`` adds a 4 MP mosaic
of the small, high-contrast repeatability images, where pruning helps least.
The direct implementation of eqs. 22-25 (``sogdd.measure.oracle``) needs an
H x W x K x K array, so it runs at 1 MP only. Peak memory is measured in a
child process detecting on a 24 MP image.

Run: ``python benchmarks/bench_speed.py [--data ../shared/data] [--sizes 1,4,16] [--stress] [--repeat 5]``
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np

import sogdd
from sogdd.measure.oracle import reference_measure


def _data_root(arg: str | None) -> Path | None:
    for c in [arg, os.environ.get("SOGDD_DATA"), "../shared/data"]:
        if c and Path(c).is_dir():
            return Path(c)
    return None


def make_image(mp: int, root: Path | None) -> tuple[np.ndarray, str]:
    """A grey uint8 image of about ``mp`` megapixels, square, from real photos if possible."""
    side = int(round(np.sqrt(mp * 1e6) / 512)) * 512
    if root is not None:
        photos = sorted((root / "multiview" / "fountain-P11" / "images").glob("*.jpg"))
        if photos:
            tiles = []
            t = min(side, 2048)
            n = side // t
            for i in range(n * n):
                img = cv2.imread(str(photos[i % len(photos)]), cv2.IMREAD_GRAYSCALE)
                y0, x0 = (img.shape[0] - t) // 2, (img.shape[1] - t) // 2
                tiles.append(img[y0 : y0 + t, x0 : x0 + t])
            rows = [np.hstack(tiles[r * n : (r + 1) * n]) for r in range(n)]
            return np.vstack(rows), "fountain-P11 crops"
    from sogdd.synthetic import pattern_image

    img, _ = pattern_image((side, side), seed=0, noise=3.0)
    return img, "rendered test pattern (no shared data found)"


def make_stress_image(root: Path | None) -> tuple[np.ndarray, str] | None:
    """A 2048 x 2048 mosaic of the 512 x 512 repeatability images (dense, high-contrast texture)."""
    if root is None:
        return None
    kinds = (".bmp", ".png", ".jpg")
    photos = sorted(p for p in (root / "repeatability").glob("*") if p.suffix.lower() in kinds)
    tiles = [cv2.resize(cv2.imread(str(p), cv2.IMREAD_GRAYSCALE), (512, 512)) for p in photos[:16]]
    if not tiles:
        return None
    tiles = [tiles[i % len(tiles)] for i in range(16)]
    return np.vstack([np.hstack(tiles[r * 4 : (r + 1) * 4]) for r in range(4)]), "repeatability mosaic"


def make_facade_image(root: Path | None) -> tuple[np.ndarray, str] | None:
    """The whole Herz-Jesus-P8 ``0000.jpg`` (3072 x 2048): a textured church facade and cobblestones."""
    if root is None:
        return None
    path = root / "multiview" / "Herz-Jesus-P8" / "images" / "0000.jpg"
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    return None if img is None else (img, "facade, Herz-Jesus-P8 0000.jpg")


def authors_code_detect(img: np.ndarray) -> np.ndarray:
    """The authors' pipeline at their defaults, written directly in numpy (not their code).

    2-D convolutions with the K = 4 sampled kernels on the symmetric-padded
    image, the 21-pixel disk window sums of ``|l| |l|^T``, ``numpy.linalg.det``
    (all in :func:`sogdd.measure.oracle.reference_measure`), the 0.99 quantile of the
    positive responses and a 3 x 3 maximum filter on the map without its 9-pixel
    border. The speed reference of the ``authors`` preset.
    """
    from scipy import ndimage

    p = sogdd.resolve_params("authors")
    ups = reference_measure(img.astype(np.float64), p.measure_spec())
    b = p.border
    inner = ups[b:-b, b:-b]
    pos = inner[inner > 0]
    thr = np.quantile(pos, p.quantile)
    peaks = (inner > thr) & (inner == ndimage.maximum_filter(inner, size=3))
    return np.argwhere(peaks) + b


def exact_fraction(img: np.ndarray) -> float:
    """Fraction of pixels where the paper preset's detection evaluates the measure exactly."""
    from sogdd.measure.soddc import soddc_measure

    spec = sogdd.resolve_params("paper").measure_spec()
    return float(np.isfinite(soddc_measure(img.astype(np.float64), spec, floor=1e9)).mean())


def timed_rounds(cases: dict, repeat: int) -> dict[str, np.ndarray]:
    """Wall times of every case, ``repeat`` rounds of one call each (round-robin), after a warm-up.

    The slow direct implementations run in the first round only.
    """
    slow = {n for n in cases if "direct" in n or n.startswith("baseline")}
    for name, fn in cases.items():
        if name not in slow:
            fn()  # warm-up (JIT compilation, allocations)
    times: dict[str, list[float]] = {n: [] for n in cases}
    for r in range(repeat):
        for name, fn in cases.items():
            if name in slow and r > 0:
                continue
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {n: np.array(t) for n, t in times.items()}


def peak_rss_mb(mp: int, root: Path | None) -> float:
    """Peak resident memory of a child process that detects on an ``mp``-MP image."""
    # VmHWM (not ru_maxrss, which Linux carries over from the parent across exec)
    code = f"""
import sys
sys.path.insert(0, {str(Path(__file__).parent)!r})
import numpy as np, cv2, sogdd
from bench_speed import make_image, _data_root
def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM"):
            return float(line.split()[1]) / 1024
img, _ = make_image(4, _data_root({str(root) if root else None!r}))
w = int(np.sqrt({mp} * 1e6 * 1.5)); h = int({mp} * 1e6 / w)
big = cv2.resize(img, (w, h), interpolation=cv2.INTER_LINEAR)
sogdd.detect_corners(big[:64, :64])
base = hwm()
c = sogdd.detect_corners(big)
print(hwm(), base, len(c))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    peak, base, _ = out.stdout.split()
    return float(peak), float(base)


def _detect_full_map(img: np.ndarray):
    """The paper preset's detection on the full Upsilon map (no pruning), for comparison."""
    from sogdd.select.peaks import select_peaks
    from sogdd.select.refine import refine_gradient, refine_quadratic

    resp = sogdd.corner_response(img)
    rows, cols = select_peaks(resp, threshold=1e9)
    xy = np.stack([cols, rows], axis=1).astype(np.float64) + refine_quadratic(resp, rows, cols)
    return refine_gradient(img.astype(np.float64), xy)


def build_cases(img: np.ndarray, mp: int, with_baselines: bool) -> dict:
    """The timed callables for one image."""
    sift = cv2.SIFT_create()
    fast = cv2.FastFeatureDetector_create()
    f32 = img.astype(np.float32)
    cases = {
        "sogdd paper: corner_response": lambda: sogdd.corner_response(img),
        "sogdd paper: detect_corners": lambda: sogdd.detect_corners(img),
        "sogdd paper: detect, subpixel off": lambda: sogdd.detect_corners(img, subpixel=False),
        "sogdd paper: detect on the full map": lambda: _detect_full_map(img),
        "sogdd authors: detect_corners": lambda: sogdd.detect_corners(img, preset="authors"),
        "cv2.SIFT detect": lambda: sift.detect(img, None),
        "cv2.cornerHarris": lambda: cv2.cornerHarris(f32, 3, 3, 0.04),
        "cv2.goodFeaturesToTrack": lambda: cv2.goodFeaturesToTrack(img, 5000, 0.01, 3),
        "cv2.FAST": lambda: fast.detect(img, None),
    }
    from sogdd.params import PRESETS  # (the package exports load lazily)

    if "hr" in PRESETS:
        cases["sogdd hr: detect_corners"] = lambda: sogdd.detect_corners(img, preset="hr")
    if mp == 1:
        spec = sogdd.resolve_params("paper").measure_spec()
        cases["direct eqs. 22-25 (oracle), K=8"] = lambda: reference_measure(img.astype(float), spec)
        cases["authors' pipeline, direct numpy (K=4)"] = lambda: authors_code_detect(img)
    if with_baselines and mp == 1:
        try:
            from sogdd import baselines

            for name in baselines.available():
                if name.startswith("sogdd"):
                    continue
                det = baselines.get(name)
                cases[f"baseline {name}"] = lambda det=det: det.detect_corners(img)
        except Exception as exc:  # noqa: BLE001 - the registry is optional here
            print(f"(baselines skipped: {exc})")
    return cases


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=None)
    ap.add_argument("--sizes", default="1,4,16")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--memory-mp", type=int, default=24)
    ap.add_argument("--baselines", action="store_true", help="add a row per registry baseline (1 MP)")
    ap.add_argument("--stress", action="store_true", help="add a 4 MP high-texture mosaic")
    ap.add_argument("--no-facade", action="store_true", help="leave out the 6.3 MP facade photo")
    args = ap.parse_args()
    root = _data_root(args.data)
    print(f"sogdd {sogdd.__version__}, OpenCV {cv2.__version__}, numpy {np.__version__}, "
          f"{os.cpu_count()} CPUs, SOGDD_NUM_THREADS={os.environ.get('SOGDD_NUM_THREADS', 'auto')}")
    rows = []
    images = [(mp, *make_image(mp, root)) for mp in (int(s) for s in args.sizes.split(","))]
    if args.stress:
        stress = make_stress_image(root)
        if stress is None:
            print("(--stress needs the shared data)")
        else:
            images.append((4, *stress))
    facade = make_facade_image(root)
    if facade is not None and not args.no_facade:
        images.append((6, *facade))
    for mp, img, src in images:
        real_mp = img.size / 1e6
        cases = build_cases(img, mp, args.baselines)
        times = timed_rounds(cases, args.repeat)
        sift = times["cv2.SIFT detect"]
        print(f"\n{real_mp:.1f} MP ({img.shape[1]}x{img.shape[0]}, {src}); "
              f"detection evaluates {100 * exact_fraction(img):.1f} % of pixels exactly; {args.repeat} rounds")
        print(f"{'implementation':40s} {'ms/MP':>9s} {'x SIFT':>8s} {'range':>12s}")
        for name, t in times.items():
            ratios = t / sift[: len(t)]
            ms = float(np.median(t)) / real_mp * 1000
            ratio = float(np.median(ratios))
            print(f"{name:40s} {ms:9.1f} {ratio:8.2f} {ratios.min():5.2f}-{ratios.max():<6.2f}")
            rows.append((mp, name, ms, ratio))
        if "authors' pipeline, direct numpy (K=4)" in times:
            speedup = np.median(times["authors' pipeline, direct numpy (K=4)"]) / np.median(
                times["sogdd authors: detect_corners"])
            print(f"sogdd authors preset vs the authors' pipeline written directly: {speedup:.0f}x faster")
    if args.memory_mp:
        peak, base = peak_rss_mb(args.memory_mp, root)
        print(f"\npeak RSS detecting on a {args.memory_mp} MP image: {peak:.0f} MB "
              f"(before detection: {base:.0f} MB, imports, the image and a 4 MP helper image)")


if __name__ == "__main__":
    main()
