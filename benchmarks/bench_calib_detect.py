"""Time of chessboard detection + refinement (``sogdd.calib.detect_boards``) on a large frame.

A 20 x 20 inner-corner board (21 x 21 squares) warped by a homography into a
4000 x 3000 (12 MP) frame, blurred (sigma 1 px) with noise (sigma 2 grey levels);
the first call compiles and is not counted. Prints the median wall and CPU time
(all threads) of ``--repeat`` calls, the X-corner search's, and the corners found
with their error. On a loaded machine the CPU time is the steadier figure.

    SOGDD_NUM_THREADS=2 NUMBA_NUM_THREADS=2 python benchmarks/bench_calib_detect.py

``--accuracy N`` measures instead the corner error (mean, max, boards found, wrong
labels) on N rendered views (``sogdd.evaluation.calibration.render``, tilts up to
40 degrees, k1 = -0.12) per cell size (6-8 to 45-60 px) and blur (0.8, 1.2, 2.5);
with ``--compare`` also hr's points and OpenCV's two detectors. ``--photos DATA``
runs the real photos of ``DATA/calibration/chessboard_*`` (6 x 4 inner corners):
boards found, distance to the hand labels after one global offset per set, and
the RMS reprojection error of ``cv2.calibrateCamera`` on the full boards.

``--folder GLOB --pattern CxR`` times instead, photo by photo, ``detect_board(img, (C, R))`` (one board
per image, as ``sogdd calibrate`` searches by default) and ``detect_boards(img, (C, R))`` (every board) against
OpenCV's ``findChessboardCorners`` + ``cornerSubPix`` (11 x 11 window, the usual anchor) in the same
process on the same grey images, both warmed up on the first photo and run ``--repeat`` times in turn
per photo, each timed run after an untimed one of the same method (the photo's time: the median of its
runs). Per image size it prints the median over the photos and their spread (interquartile range, min,
max), the ratio of the medians, and the boards each found (a board of ``C x R`` corners for sogdd):

    python benchmarks/bench_calib_detect.py --folder 'DATA/calibration/opencv_stereo/left*.jpg' --pattern 9x6

``--sweep N --seed S [--max-pixels P]`` times the same two on N views of the randomized sweep
(``sogdd eval calibration --sweep``; every factor drawn at random, each view with its own pattern),
grouped by frame size. OpenCV's classic detector can take minutes on a large frame where it finds
nothing: ``--max-pixels`` bounds the frames drawn.
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


def wrong_labels(labels: np.ndarray, truth: np.ndarray) -> int:
    """Corners whose label the best integer map ``truth = A label + t`` (a rotation and a shift) gets wrong."""
    X = np.c_[labels, np.ones(len(labels))]
    sol = np.rint(np.linalg.lstsq(X, truth, rcond=None)[0])
    if round(abs(np.linalg.det(sol[:2]))) != 1:
        return len(labels)
    return int(np.count_nonzero(np.abs(X @ sol - truth).sum(axis=1)))


def comparators(views: list, pattern: tuple[int, int]) -> list[str]:
    """The same views through hr's points (nearest to each true corner within 1.5 px), OpenCV's
    findChessboardCorners + cornerSubPix 11 x 11 and findChessboardCornersSB (EXHAUSTIVE | ACCURACY)."""
    from scipy.spatial import cKDTree

    import sogdd

    out = {"hr points": [], "classic+cornerSubPix": [], "SB": []}
    found = dict.fromkeys(out, 0)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    sb = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
    for v in views:
        c = sogdd.detect_corners(v.image.astype(np.float32) / 255, preset="hr")
        d, _ = cKDTree(c.xy).query(v.corners[v.inside])
        out["hr points"].append(d[d < 1.5])
        found["hr points"] += 1
        ok, cc = cv2.findChessboardCorners(v.image, pattern)
        if ok:
            cc = cv2.cornerSubPix(v.image, cc, (5, 5), (-1, -1), crit)
            out["classic+cornerSubPix"].append(cKDTree(v.corners).query(cc.reshape(-1, 2))[0])
            found["classic+cornerSubPix"] += 1
        ok, cc = cv2.findChessboardCornersSB(v.image, pattern, flags=sb)
        if ok:
            out["SB"].append(cKDTree(v.corners).query(cc.reshape(-1, 2))[0])
            found["SB"] += 1
    text = []
    for m, e in out.items():
        err = f", mean {np.concatenate(e).mean():.4f} max {np.concatenate(e).max():.3f}" if e else ""
        text.append(f"{m}: {found[m]}/{len(views)}{err}")
    return text


def photos(root: str) -> None:
    """Real photos: boards found, distance to the hand labels after one global offset, calibration RMS."""
    import glob
    import os

    from scipy.spatial import cKDTree

    from sogdd.calib.targets.chessboard import detect_board

    lab = np.array([(i, j) for j in range(4) for i in range(6)])
    sb = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
    for name in ("chessboard_sony", "chessboard_border", "chessboard_hard"):
        files = sorted(glob.glob(os.path.join(root, "calibration", name, "*.jpg")))
        if not files:
            print(f"{name}: not found under {root}")
            continue
        found: dict[str, list] = {"sogdd": [], "SB": [], "classic+cornerSubPix": []}
        for f in files:
            img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
            b = detect_board(img, (6, 4))
            found["sogdd"].append(None if b is None else (f, b.image_points, b.labels))
            ok, c = cv2.findChessboardCornersSB(img, (6, 4), flags=sb)
            found["SB"].append((f, c.reshape(-1, 2).astype(float), lab) if ok else None)
            ok, c = cv2.findChessboardCorners(img, (6, 4))
            if ok:
                c = cv2.cornerSubPix(img, c, (5, 5), (-1, -1), (3, 30, 0.001))
            found["classic+cornerSubPix"].append((f, c.reshape(-1, 2).astype(float), lab) if ok else None)
        shape = {cv2.imread(f).shape[:2] for f in files}
        for m, rows in found.items():
            got = [r for r in rows if r is not None]
            d = np.concatenate([r[1][cKDTree(r[1]).query(np.loadtxt(r[0][:-4] + ".txt", comments="#"))[1]]
                                - np.loadtxt(r[0][:-4] + ".txt", comments="#") for r in got])
            off = d.mean(axis=0)
            dist = np.hypot(*(d - off).T)
            rms = float("nan")
            full = [r for r in got if len(r[1]) == 24]
            if len(shape) == 1 and len(full) >= 3:
                h, w = next(iter(shape))
                obj = [np.c_[r[2], np.zeros(len(r[2]))].astype(np.float32) for r in full]
                rms = cv2.calibrateCamera(obj, [r[1].astype(np.float32) for r in full], (w, h), None, None)[0]
            print(f"{name} {m}: {len(got)}/{len(files)} boards, offset {np.round(off, 3).tolist()}, hand-label "
                  f"distance mean {dist.mean():.3f} max {dist.max():.3f}, calibration RMS {rms:.4f}")


def accuracy(n_views: int, fractions: list[float], compare: bool = False) -> None:
    """Corner error of detect_boards on rendered views (calib-eval's renderer): per cell size and blur."""
    from scipy.spatial import cKDTree

    import sogdd.calib.targets.refine as refine
    from sogdd.calib.targets.chessboard import detect_boards
    from sogdd.evaluation.calibration.render import Camera, ChessboardTarget, random_sequence, render_view

    cam = Camera(np.array([[700.0, 0, 319.5], [0, 700.0, 239.5], [0, 0, 1]]), (-0.12, 0.03, 0.001, -0.001),
                 (640, 480))
    for cells, target in (((6, 8), ChessboardTarget(20, 14, 0.01)), ((10, 16), ChessboardTarget(14, 10, 0.02)),
                          ((25, 35), ChessboardTarget(9, 6, 0.03)), ((45, 60), ChessboardTarget(6, 4, 0.04))):
        poses = random_sequence(cam, target, n_views, seed=1, cell_px=cells, tilt_max=40.0)
        for blur, noise in ((0.8, 2.0), (1.2, 3.0), (2.5, 4.0)):
            views = [render_view(cam, target, r, t, blur=blur, noise=noise, rng=k)
                     for k, (r, t) in enumerate(poses)]
            row = []
            for frac in fractions:
                refine.WINDOW_FRACTION = frac
                errs, found, wrong = [], 0, 0
                for v in views:
                    b = max(detect_boards(v.image, (target.cols, target.rows)), key=len, default=None)
                    if b is None:
                        continue
                    found += 1
                    d, k = cKDTree(v.corners).query(b.image_points)
                    wrong += wrong_labels(b.labels, v.labels[k])
                    errs.append(d)
                e = np.concatenate(errs) if errs else np.array([np.nan])
                row.append(f"w {frac}: {found}/{len(views)} boards, {len(e)} corners, {wrong} wrong, "
                           f"mean {np.mean(e):.4f} max {np.max(e):.3f}")
            if compare:
                row += comparators(views, (target.cols, target.rows))
            print(f"cells {cells[0]}-{cells[1]} px, blur {blur}, noise {noise}: " + "; ".join(row), flush=True)


def _pattern(text: str) -> tuple[int, int]:
    try:
        c, r = (int(v) for v in text.lower().split("x"))
    except ValueError:
        msg = f"pattern must be COLSxROWS of inner corners, e.g. 9x6, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if min(c, r) < 2:
        raise argparse.ArgumentTypeError(f"pattern must be at least 2x2 inner corners, got {text!r}")
    return c, r


def _spread(ms: list[float]) -> str:
    q1, q2, q3 = np.percentile(ms, [25, 50, 75])
    return f"median {q2:7.1f} ms (IQR {q1:.1f}-{q3:.1f}, min {min(ms):.1f}, max {max(ms):.1f})"


def _methods() -> dict:
    """The detectors timed: ``fn(grey, pattern) -> found the whole pattern``; OpenCV's last (the anchor).

    sogdd's twice: ``detect_board``, one board per image (the view's; what ``sogdd calibrate`` runs by
    default: the search stops once a complete board settles the view), and ``detect_boards``, every
    board in the image (screens and reflections too)."""
    from sogdd.calib import detect_board, detect_boards

    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)

    def view(img: np.ndarray, pattern: tuple[int, int]) -> bool:
        b = detect_board(img, pattern)
        return b is not None and len(b) == pattern[0] * pattern[1]

    def ours(img: np.ndarray, pattern: tuple[int, int]) -> bool:
        return any(len(b) == pattern[0] * pattern[1] for b in detect_boards(img, pattern))

    def opencv(img: np.ndarray, pattern: tuple[int, int]) -> bool:
        ok, c = cv2.findChessboardCorners(img, pattern)
        if ok:
            cv2.cornerSubPix(img, c, (5, 5), (-1, -1), crit)
        return bool(ok)

    return {"sogdd detect_board (one board per image)": view, "sogdd detect_boards (every board)": ours,
            "OpenCV findChessboardCorners+cornerSubPix 11x11": opencv}


def folder(pattern_glob: str, pattern: tuple[int, int], repeat: int) -> None:
    """Per-photo time of detect_boards against findChessboardCorners + cornerSubPix 11 x 11 (module doc)."""
    import glob
    import os

    files = sorted(glob.glob(os.path.expanduser(pattern_glob)))
    images = [(f, cv2.imread(f, cv2.IMREAD_GRAYSCALE)) for f in files]
    images = [(f, g) for f, g in images if g is not None]
    if not images:
        raise SystemExit(f"no readable image matches {pattern_glob!r}")
    methods = _methods()
    for fn in methods.values():  # compile, load, warm the caches
        fn(images[0][1], pattern)
    by_size = _time_views([("{}x{}".format(*g.shape[::-1]), g, pattern) for _, g in images], methods,
                          max(1, repeat))
    print(f"{pattern_glob}, pattern {pattern[0]}x{pattern[1]}: {len(images)} photos, median of {repeat} runs "
          "per photo")
    _report(by_size, "photos")


#: the frame sizes (MP) by which ``--sweep`` groups its views
SWEEP_BINS = (0.5, 1.0, 2.0, 4.0, 8.0)


def sweep(n: int, seed: int, max_pixels: int, repeat: int) -> None:
    """The same timing on ``n`` views of the randomized sweep (``sogdd eval calibration --sweep``),
    grouped by frame size (:data:`SWEEP_BINS`); each view with its own board's pattern."""
    from sogdd.evaluation.calibration.sweep import sweep_view

    views = [sweep_view(seed, k, max_pixels=max_pixels) for k in range(n)]
    methods = _methods()
    for fn in methods.values():
        fn(views[0].image, views[0].pattern)
    items = []
    for v in views:
        mp = v.image.size / 1e6
        k = int(np.searchsorted(SWEEP_BINS, mp, side="right"))
        lo = 0.0 if k == 0 else SWEEP_BINS[k - 1]
        group = f"{lo:g}-{SWEEP_BINS[k]:g} MP" if k < len(SWEEP_BINS) else f">= {lo:g} MP"
        items.append((group, v.image, v.pattern))
    items.sort(key=lambda it: it[1].size)
    by_group = _time_views(items, methods, max(1, repeat))
    print(f"sweep seed {seed}: {n} views (at most {max_pixels / 1e6:g} MP), median of {repeat} runs per view")
    _report(by_group, "views")


def _report(by_group: dict, what: str) -> None:
    for group, row in by_group.items():
        print(f"  {group}, {len(next(iter(row.values())))} {what}:")
        med = {}
        for m, got in row.items():
            ms = [t for t, _ in got]
            med[m] = float(np.median(ms))
            print(f"    {m:48s} {_spread(ms)}, boards {sum(f for _, f in got)}/{len(got)}")
        *ours, anchor = med.values()
        print("    ratio of the medians (sogdd / OpenCV): "
              + ", ".join(f"{a / max(anchor, 1e-9):.2f}" for a in ours))


def _time_views(items: list[tuple[str, np.ndarray, tuple[int, int]]], methods: dict, repeat: int) -> dict:
    """``{group: {method: [(median ms of the view's runs, found), ...]}}`` for ``(group, grey, pattern)``
    items; the methods in turn on each view, so that a load that comes and goes meets both. Each timed run
    follows an untimed run of the same method on the same view: a calibration runs one detector over its
    views, and a run that follows another method's pays for what that one left in the caches and the
    allocator (sogdd's ``detect_board`` right after its ``detect_boards``: 5.2 ms instead of 3.4 on Sony's
    photos)."""
    by_group: dict[str, dict[str, list]] = {}
    for group, img, pattern in items:
        row = by_group.setdefault(group, {m: [] for m in methods})
        times: dict[str, list[float]] = {m: [] for m in methods}
        found = {}
        for _ in range(repeat):
            for m, fn in methods.items():
                fn(img, pattern)  # untimed: the method's own run before it (docstring)
                t0 = time.perf_counter()
                found[m] = fn(img, pattern)
                times[m].append(1e3 * (time.perf_counter() - t0))
        for m in methods:
            row[m].append((float(np.median(times[m])), found[m]))
    return by_group


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=4000)
    ap.add_argument("--height", type=int, default=3000)
    ap.add_argument("--corners", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--accuracy", type=int, default=0, metavar="N",
                    help="instead: corner error on N rendered views per cell size and blur")
    ap.add_argument("--compare", action="store_true", help="--accuracy: also hr's points, OpenCV's classic, SB")
    ap.add_argument("--photos", metavar="DATA", help="instead: the photos of DATA/calibration/chessboard_*")
    ap.add_argument("--fractions", type=float, nargs="+", default=None,
                    help="window fractions (of the cell) to compare in --accuracy; default: the library's")
    ap.add_argument("--folder", metavar="GLOB",
                    help="instead: per-photo time of detect_boards and OpenCV's detector on these photos")
    ap.add_argument("--pattern", type=_pattern, metavar="CxR", help="--folder: inner corners, e.g. 9x6")
    ap.add_argument("--sweep", type=int, default=0, metavar="N",
                    help="instead: the same timing on N views of the randomized sweep, by frame size")
    ap.add_argument("--seed", type=int, default=5, help="--sweep: the sweep's seed")
    ap.add_argument("--max-pixels", type=int, default=12_000_000, help="--sweep: the largest frame drawn")
    a = ap.parse_args()
    if a.sweep:
        sweep(a.sweep, a.seed, a.max_pixels, a.repeat)
        return
    if a.folder:
        if a.pattern is None:
            ap.error("--folder needs --pattern CxR")
        folder(a.folder, a.pattern, a.repeat)
        return
    if a.accuracy:
        import sogdd.calib.targets.refine as refine

        accuracy(a.accuracy, a.fractions or [refine.WINDOW_FRACTION], a.compare)
        return
    if a.photos:
        photos(a.photos)
        return
    from scipy.spatial import cKDTree

    from sogdd.calib.targets.chessboard import detect_boards
    from sogdd.calib.targets.chessboard.xcorners import find_xcorners

    img, truth = frame(a.width, a.height, a.corners)
    detect_boards(frame(800, 600, 6)[0])  # compile
    times, t_x, cpu = [], [], []
    for _ in range(a.repeat):
        t0 = time.perf_counter()
        find_xcorners(img)
        t_x.append(time.perf_counter() - t0)
        t0, c0 = time.perf_counter(), time.process_time()
        boards = detect_boards(img, (a.corners, a.corners))
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    b = boards[0] if boards else None
    found = 0 if b is None else len(b)
    err = cKDTree(truth).query(b.image_points)[0] if b is not None else np.array([np.nan])
    print(f"{a.width}x{a.height}, {a.corners}x{a.corners} board: detect_boards {np.median(times):.3f} s "
          f"(median of {a.repeat}; CPU time {np.median(cpu):.3f} s; X-corner search {np.median(t_x):.3f} s), "
          f"{found} of {a.corners ** 2} corners, "
          f"error vs the warp mean {np.mean(err):.4f} px max {np.max(err):.4f} px")


if __name__ == "__main__":
    main()
