"""OpenCV's calibration tutorial, ``cornerSubPix`` replaced by ``sogdd.calib.refine_corners``: the RMS of each.

The snippet of OpenCV's tutorial (``findChessboardCorners`` -> ``cornerSubPix`` ->
``calibrateCamera``, its criteria ``(EPS + MAX_ITER, 30, 0.001)`` and ``winSize
(11, 11)``) runs on a rendered sequence (``sogdd.evaluation.calibration.render``:
the tutorial's 7 x 6 inner corners through a 640 x 480 camera with a 60 degree
field of view and k1, k2, p1, p2, tilts up to 40 degrees, blur, illumination
falloff and noise), once per refinement:

- ``none``: ``findChessboardCorners``'s corners as they are;
- ``cornerSubPix``: the tutorial;
- ``refine_corners (11, 11)``: the same call with ``refine_corners`` in its place;
- ``refine_corners (-1, -1)``: the window from each corner's cell (its default).

Prints per refinement the views found, ``calibrateCamera``'s RMS reprojection
error, the corners' mean and max distance to the true corners, and the
calibrated camera's difference to the true one (``projection_difference``, mean
over the image, and ``|fx - fx_true|``).

    python benchmarks/bench_refine_tutorial.py
    python benchmarks/bench_refine_tutorial.py --views 25 --blur 1.5 --seed 3
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np

PATTERN = (7, 6)  # the tutorial's inner corners
CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)  # the tutorial's


def views(n: int, blur: float, noise: float, seed: int, cells: tuple[float, float]):
    """``n`` rendered views of the tutorial's board, and the camera that saw them."""
    from sogdd.evaluation.calibration.render import ChessboardTarget, random_sequence, render_view
    from sogdd.evaluation.calibration.sequences import camera_for

    cam = camera_for(640, 480)
    target = ChessboardTarget(*PATTERN, 0.025)
    poses = random_sequence(cam, target, n, seed=seed, cell_px=cells)
    return cam, [render_view(cam, target, r, t, blur=blur, noise=noise, falloff=0.3, rng=seed + k)
                 for k, (r, t) in enumerate(poses)]


def tutorial(images, refine):
    """The tutorial's loop and calibration, ``refine(gray, corners)`` in place of ``cornerSubPix``."""
    objp = np.zeros((PATTERN[0] * PATTERN[1], 3), np.float32)
    objp[:, :2] = np.mgrid[0:PATTERN[0], 0:PATTERN[1]].T.reshape(-1, 2)
    objpoints, imgpoints, found = [], [], []
    for k, gray in enumerate(images):
        ret, corners = cv2.findChessboardCorners(gray, PATTERN, None)
        if ret:
            objpoints.append(objp)
            imgpoints.append(refine(gray, corners))
            found.append(k)
    rms, mtx, dist, _, _ = cv2.calibrateCamera(objpoints, imgpoints, images[0].shape[::-1], None, None)
    return found, imgpoints, rms, mtx, dist


def corner_errors(found, imgpoints, truth):
    out = []
    for k, pts in zip(found, imgpoints):
        pts = pts.reshape(-1, 2).astype(np.float64)
        d = np.hypot(*(pts[:, None] - truth[k][None]).transpose(2, 0, 1))
        out.append(d.min(axis=1))  # each found corner to its true one (the nearest: cells are >= 15 px)
    return np.concatenate(out)


def main() -> None:
    from sogdd.calib import projection_difference, refine_corners

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", type=int, default=15)
    ap.add_argument("--blur", type=float, default=1.0, help="Gaussian blur sigma (px)")
    ap.add_argument("--noise", type=float, default=2.0, help="Gaussian noise sigma (grey levels)")
    ap.add_argument("--cells", type=float, nargs=2, default=(20.0, 40.0), help="cell size range (px)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    cam, vs = views(args.views, args.blur, args.noise, args.seed, tuple(args.cells))
    images, truth = [v.image for v in vs], [v.corners for v in vs]
    methods = {
        "none": lambda g, c: c,
        "cornerSubPix (11, 11)": lambda g, c: cv2.cornerSubPix(g, c, (11, 11), (-1, -1), CRITERIA),
        "refine_corners (11, 11)": lambda g, c: refine_corners(g, c, (11, 11), (-1, -1), CRITERIA),
        "refine_corners (-1, -1)": lambda g, c: refine_corners(g, c, (-1, -1), (-1, -1), CRITERIA),
    }
    print(f"{args.views} views, 640 x 480, {PATTERN[0]} x {PATTERN[1]} inner corners, cells {args.cells[0]:g}-"
          f"{args.cells[1]:g} px, blur {args.blur:g} px, noise {args.noise:g}, falloff 0.3, seed {args.seed}")
    print(f"{'refinement':<24} {'views':>5} {'RMS px':>8} {'corner mean':>11} {'max':>7} {'proj diff':>9} "
          f"{'|dfx|':>6}")
    for name, refine in methods.items():
        found, pts, rms, K, dist = tutorial(images, refine)
        e = corner_errors(found, pts, truth)
        diff = projection_difference((K, dist.ravel()), (cam.K, np.asarray(cam.dist)), cam.size).mean
        print(f"{name:<24} {len(found):>5} {rms:>8.4f} {e.mean():>11.4f} {e.max():>7.3f} {diff:>9.3f} "
              f"{abs(K[0, 0] - cam.fx):>6.2f}")


if __name__ == "__main__":
    main()
