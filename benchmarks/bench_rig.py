"""The rig fit's speed: a rendered 2-camera session, or a synthetic ring of N cameras, after detection.

Two benchmarks, both of ``sogdd.calib.rig.fit.calibrate_rig`` on corners already found:

**The rendered pair** (default; target <= 10 s on 2 cores). One session of the rendered
``parallel`` rig (:mod:`sogdd.evaluation.calibration.rigs`: two 1280 x 960 cameras,
baseline 120 mm, 9 x 6 board; 20 frames, 2 of them cut by one camera's frame and 2
seen by one camera only) is rendered once and detected once (``sogdd.calib.detect_board``;
OpenCV's ``findChessboardCorners`` + ``cornerSubPix`` for the anchor). Then, in the
same process, each is timed after one warm-up run as the median of ``--repeats`` runs,
with the fastest and slowest:

- ``calibrate_rig`` (pinhole model, rejection on);
- OpenCV's ``calibrateCamera`` per camera + ``stereoCalibrate`` (``CALIB_FIX_INTRINSIC``),
  the anchor: what the same machine does in the classic pipeline.

**The ring** (``--ring N``; target <= 60 s and <= 2 GB for 20 cameras x 200 frames on
2 cores, growing about linearly with the frames). :func:`ring_rig`: ``N`` cameras on a
circle looking at its centre and a 9 x 6 board carried once around inside it, facing
outwards, over ``--frames`` frames; each camera sees the board whole where it passes in
front of it, neighbours see it in the same frames. The corners are the board projected
through each known camera plus Gaussian noise of 0.1 px (no rendering, no detection).
One fit (pinhole, rejection on, the per-camera starts included; their share is shown
apart) is timed in a fresh process, and its peak memory is the process's maximum resident set
(``resource.getrusage``) less the resident set before the fit; the recovered focal
lengths, baselines and rotations are compared with the truth. ``--sweep`` runs the
table of cameras x frames, each row in a process of its own.

Limit the threads as CI does (``OMP_NUM_THREADS=2`` etc.) to measure "on 2 cores".

Usage::

    python benchmarks/bench_rig.py [--frames 20] [--repeats 5]
    python benchmarks/bench_rig.py --ring 20 --frames 200
    python benchmarks/bench_rig.py --sweep
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import time

import cv2
import numpy as np

from sogdd.calib.cameras import project
from sogdd.calib.rig import fit as _fit
from sogdd.calib.rig.demo import SyntheticRig
from sogdd.calib.rig.fit import calibrate_rig
from sogdd.calib.targets.board import Board

#: the ring's sweep, (cameras, frames): the frames at 20 cameras, then the cameras at 200 frames
SWEEP = ((20, 50), (20, 100), (20, 200), (20, 400), (5, 200), (10, 200), (50, 200))


def _timed(call, repeats: int) -> tuple[float, float, float]:
    call()  # warm-up: imports, numba, caches
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times), max(times)


# --------------------------------------------------------------------------------------------------
# the ring


def _look_at(centre: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The rotation world -> camera of a camera at ``centre`` looking at ``target``, image ``y`` down
    (world ``z`` up)."""
    z = target - centre
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z])


def _ring_cameras(n: int, radius: float, rng) -> list:
    """``(R, t, K, dist)`` per camera, world -> camera: on a circle, looking at its centre (a little off)."""
    out = []
    for c in range(n):
        a = 2 * np.pi * c / n
        centre = radius * np.array([np.cos(a), np.sin(a), 0.0]) + [0.0, 0.0, rng.uniform(-1, 1)]
        R = _look_at(centre, rng.uniform(-1.5, 1.5, 3) * [1, 1, 0.5])
        f = rng.uniform(850, 950)
        K = np.array([[f, 0, 640 + rng.uniform(-10, 10)], [0, f * rng.uniform(0.998, 1.002),
                                                           480 + rng.uniform(-10, 10)], [0, 0, 1]])
        dist = np.array([rng.uniform(-0.15, -0.05), rng.uniform(0.0, 0.03), rng.normal(0, 5e-4),
                         rng.normal(0, 5e-4), 0.0])
        out.append((R, -R @ centre, K, dist))
    return out


def _ring_board(k: int, frames: int, rng, pattern) -> tuple[np.ndarray, np.ndarray]:
    """Frame ``k``'s board pose (board -> world): once around the ring, facing outwards, tilted."""
    cols, rows = pattern
    a = 2 * np.pi * (k + rng.uniform(-0.3, 0.3)) / frames
    out = np.array([np.cos(a), np.sin(a), 0.0])
    # the board's z axis points away from the cameras it faces (Board's convention): inwards
    z = -out
    x = np.cross(z, [0.0, 0.0, 1.0])
    Rb = np.stack([x, np.cross(z, x), z], axis=1)
    axis = rng.normal(size=3)
    Rb = Rb @ cv2.Rodrigues(axis / np.linalg.norm(axis) * np.deg2rad(rng.uniform(0, 30)))[0]
    centre = rng.uniform(8, 13) * out + [0.0, 0.0, rng.uniform(-2, 2)]
    return Rb, centre - Rb @ np.array([(cols - 1) / 2, (rows - 1) / 2, 0.0])


def ring_rig(cameras: int = 20, frames: int = 200, noise: float = 0.1, seed: int = 0, *,
             radius: float = 30.0, pattern: tuple[int, int] = (9, 6), size: tuple[int, int] = (1280, 960),
             max_angle: float = 65.0) -> SyntheticRig:
    """A ring of ``cameras`` cameras ``radius`` squares from its centre and ``frames`` boards inside it.

    Camera ``c`` sits at angle :math:`2 \\pi c / N` on the circle (height within 1 square),
    looking at the centre (within 1.5 squares), ``fx`` 850-950 px, OpenCV's pinhole
    distortion (``k1`` -0.15 to -0.05, ``k2`` 0-0.03, small ``p1, p2``), images ``size``. Frame
    ``k``'s board is 8-13 squares from the centre at angle :math:`2 \\pi k / F` (jittered),
    its front turned outwards and tilted by up to 30 degrees. A camera sees the board when
    every corner lies 4 px inside its image and its front is turned at most ``max_angle``
    degrees from the camera; its corners are the board projected by
    :func:`sogdd.calib.cameras.project` plus Gaussian noise of ``noise`` px.

    Returns
    -------
    SyntheticRig
        ``R, T``: each camera's pose in ``cam0``'s frame (:math:`x_c = R x_{cam0} + T`); ``rvecs,
        tvecs``: each board's pose in ``cam0``'s frame.

    Examples
    --------
    >>> d = ring_rig(cameras=6, frames=12, seed=1)
    >>> seen = np.array([[b is not None for b in d.boards[n]] for n in d.names])
    >>> bool(seen.any(axis=0).all()), bool(seen[0].any() and seen[0][seen[1]].any())
    (True, True)
    """
    rng = np.random.default_rng(seed)
    names = tuple(f"cam{c}" for c in range(cameras))
    cams = _ring_cameras(cameras, radius, rng)
    cols, rows = pattern
    lab = np.array([(i, j) for j in range(rows) for i in range(cols)])
    obj = np.c_[lab, np.zeros(len(lab))].astype(float)
    w, h = size
    boards: dict = {n: [] for n in names}
    rv_all, tv_all = [], []
    R0, t0 = cams[0][:2]
    for k in range(frames):
        Rb, tb = _ring_board(k, frames, rng, pattern)
        for n, (R, t, K, D) in zip(names, cams):
            pc = (obj @ Rb.T + tb) @ R.T + t
            px = project(pc, K, D, "pinhole")
            facing = (R @ Rb)[2, 2] > np.cos(np.deg2rad(max_angle))
            inside = facing and (pc[:, 2] > 0).all() and np.all((px > 3) & (px < [w - 4, h - 4]))
            boards[n].append(Board(px + rng.normal(0, noise, px.shape), lab, size=pattern) if inside else None)
        rv_all.append(cv2.Rodrigues(R0 @ Rb)[0].ravel())
        tv_all.append(R0 @ tb + t0)
    Rs = [R @ R0.T for R, *_ in cams]
    Ts = [t - Rc @ t0 for (_, t, *_), Rc in zip(cams, Rs)]
    return SyntheticRig(names, boards, dict.fromkeys(names, size), [c[2] for c in cams], [c[3] for c in cams],
                        dict.fromkeys(names, "pinhole"), Rs, Ts, np.array(rv_all), np.array(tv_all), pattern)


def truth_errors(rig, d: SyntheticRig) -> dict[str, float]:
    """The worst camera's relative ``fx`` error, relative baseline error (cameras other than the first)
    and rotation error (degrees) of a fitted ``rig`` against the truth ``d``."""
    fx = max(abs(cam.K[0, 0] / d.K[c][0, 0] - 1) for c, cam in enumerate(rig.cameras))
    base = max((abs(cam.baseline / np.linalg.norm(d.T[c]) - 1) for c, cam in enumerate(rig.cameras) if c),
               default=0.0)
    ang = max(float(np.degrees(np.linalg.norm(cv2.Rodrigues(cam.R @ d.R[c].T)[0])))
              for c, cam in enumerate(rig.cameras))
    return {"fx_rel": fx, "baseline_rel": base, "rotation_deg": ang}


def _maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux


def run_ring(cameras: int, frames: int, seed: int = 0) -> dict:
    """One ring fit, timed (and the part of it in each camera's own calibration, the start), with its
    memory and its errors against the truth."""
    d = ring_rig(cameras, frames, seed=seed)
    views = sum(b is not None for n in d.names for b in d.boards[n])
    corners = sum(len(b) for n in d.names for b in d.boards[n] if b is not None)
    mono, starts = _fit._mono, []

    def timed_mono(*args):
        t = time.perf_counter()
        out = mono(*args)
        starts.append(time.perf_counter() - t)
        return out

    before = _maxrss_mb()
    _fit._mono = timed_mono
    try:
        t0 = time.perf_counter()
        rig = calibrate_rig(d.boards, d.image_sizes, models="pinhole")
        dt = time.perf_counter() - t0
    finally:
        _fit._mono = mono
    peak = _maxrss_mb()
    return {"cameras": cameras, "frames": frames, "views": views, "corners": corners, "fit_s": dt,
            "start_s": sum(starts), "rss_mb": peak, "rss_growth_mb": peak - before, "rms": rig.rms,
            **truth_errors(rig, d)}


_HEADER = ("| cameras x frames | views | corners | fit (s) | of which the cameras' own calibrations (s) "
           "| peak RSS (MB) | RSS growth in the fit (MB) | RMS (px) | max fx err | max baseline err "
           "| max rotation err (deg) |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def _row(r: dict) -> str:
    return (f"| {r['cameras']} x {r['frames']} | {r['views']} | {r['corners']} | {r['fit_s']:.1f} | "
            f"{r['start_s']:.1f} | {r['rss_mb']:.0f} | {r['rss_growth_mb']:.0f} | {r['rms']:.3f} | "
            f"{r['fx_rel']:.2e} | {r['baseline_rel']:.2e} | {r['rotation_deg']:.4f} |")


def _ring_main(args) -> None:
    if args.sweep:
        print(_HEADER, flush=True)
        for n, f in SWEEP:  # a process each: the peak resident set is the process's
            out = subprocess.run([sys.executable, __file__, "--ring", str(n), "--frames", str(f), "--seed",
                                  str(args.seed), "--row"], capture_output=True, text=True, check=True)
            print(out.stdout.strip(), flush=True)
        return
    r = run_ring(args.ring, args.frames, args.seed)
    print(_row(r) if args.row else f"{_HEADER}\n{_row(r)}")


# --------------------------------------------------------------------------------------------------
# the rendered pair


def _pair_main(args) -> None:
    from sogdd.evaluation.calibration.rig_comparators import opencv_corners, run_rig_method, sogdd_boards
    from sogdd.evaluation.calibration.rigs import RIGS, render_rig_session

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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=None, help="frames (default 20; the ring: 200)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ring", type=int, default=None, metavar="N", help="a synthetic ring of N cameras")
    ap.add_argument("--sweep", action="store_true", help="the ring's table of cameras x frames")
    ap.add_argument("--row", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.ring is not None or args.sweep:
        args.frames = 200 if args.frames is None else args.frames
        _ring_main(args)
    else:
        args.frames = 20 if args.frames is None else args.frames
        _pair_main(args)


if __name__ == "__main__":
    main()
