"""The rig calibrations compared: sogdd's joint fit and OpenCV's and mrcal's, each on its own corners.

==================  ===================================================================================
name                what runs
==================  ===================================================================================
sogdd               ``sogdd.calib.detect_board`` per image, then ``sogdd.calib.rig.fit.calibrate_rig``
                    (every camera's intrinsics and pose and every frame's board pose, jointly; partial
                    boards and frames seen by only some cameras used)
opencv-stereo-fix   per camera ``cv2.calibrateCamera``, then ``cv2.stereoCalibrate`` per pair
                    (first camera, camera k) with ``CALIB_FIX_INTRINSIC``
opencv-stereo-free  the same, then ``cv2.stereoCalibrate`` with ``CALIB_USE_INTRINSIC_GUESS`` (the
                    intrinsics refined with the pose; the first camera's from its pair with the second)
opencv-multiview    ``cv2.calibrateMultiview`` (OpenCV 5) on every camera at once
mrcal               ``mrcal-calibrate-cameras`` (Debian package ``mrcal``) on OpenCV's corners, given
                    in its ``corners.vnl`` cache: mrgingham, its own detector, reads square grids only
                    (not the 9 x 6 and 9 x 13 boards here); ``LENSMODEL_OPENCV5``, outlier rejection on
==================  ===================================================================================

Every OpenCV and mrcal method reads OpenCV's corners (``cv2.findChessboardCorners`` +
``cv2.cornerSubPix`` 11 x 11, :func:`.comparators.opencv_classic`), complete boards only (it
finds no other), put in one orientation (:func:`orient_grid`) so that a corner's
label is the same physical corner in every camera. The lens model is OpenCV's
``k1, k2, p1, p2, k3`` for every method (:data:`MODEL`): sogdd's ``"pinhole"``, which
fits ``k3`` (the rendered cameras have ``k3 = 0``; every method pays for the free
``k3`` alike). A method's time is its calibration's wall time, detection apart.
A method that is not installed, or that fails, is skipped with a one-line note.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import re
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from ...calib import detect_board
from ...calib.targets.board import Board
from .comparators import opencv_classic

__all__ = ["RigEstimate", "RIG_METHODS", "MODEL", "rig_available", "rig_method_names", "orient_grid",
           "opencv_corners", "sogdd_boards", "run_rig_method", "from_rig_calibration"]

#: the lens model every method fits: OpenCV's k1, k2, p1, p2, k3 (sogdd's "pinhole")
MODEL = "k1, k2, p1, p2, k3"
_CRIT = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)

Corners = dict[str, list]  # camera name -> per frame (N, 2) array in grid order, or None


@dataclass
class RigEstimate:
    """One method's rig: per camera ``(K, dist)`` and pose ``x_k = R x_first + T``, with what it cost.

    ``frames_used`` per camera: the frames whose board that camera's fit used;
    ``rms`` per camera (px) where the method says; ``rig`` sogdd's
    :class:`~sogdd.calib.rig.RigCalibration` (for its uncertainties), else None;
    ``pair_first`` per camera ``k``: the first camera's ``(K, dist)`` as the pair
    (first, k) was fitted with, where pairs were fitted apart and each refined it.
    """

    method: str
    K: dict[str, np.ndarray]
    dist: dict[str, np.ndarray]
    R: dict[str, np.ndarray]
    T: dict[str, np.ndarray]
    sizes: dict[str, tuple[int, int]]
    seconds: float = float("nan")
    rms: dict[str, float] = field(default_factory=dict)
    frames_used: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    rig: object | None = None
    uncertainty: dict[str, list[float]] = field(default_factory=dict)
    pair_first: dict[str, tuple] = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        return list(self.K)


# ---------------------------------------------------------------------------------------------
# corners


def orient_grid(image: np.ndarray, points: np.ndarray, pattern: tuple[int, int]) -> np.ndarray:
    """A complete grid's corners (N, 2) in OpenCV's order, turned so that corner 0 is the same board corner
    in every view.

    OpenCV's order may start at either end of a board (the grid read turned by a half
    turn). When ``cols + rows`` is odd the board's colours tell the ends apart: the
    square between corners ``(0, 0)`` and ``(1, 1)`` is dark (as ``ChessboardTarget``
    draws it) and the one between the last two rows' last corners light; the order is
    reversed when the image says otherwise. When ``cols + rows`` is even the board is
    the same after a half turn and only the image can decide: corner 0 is the end
    nearer the image's top left (the first-to-last diagonal points down-right), which
    holds in every camera of a rig whose cameras are not rolled against each other
    by more than the diagonal's slack.

    Examples
    --------
    >>> lab = np.array([(i, j) for j in range(2) for i in range(3)], dtype=float)
    >>> img = np.full((40, 60), 200, np.uint8); img[20:30, 20:30] = 30  # the square by corner 0
    >>> pts = lab * 10 + 20  # corners at 20, 30, 40 (x) and 20, 30 (y)
    >>> orient_grid(img, pts[::-1], (3, 2))[0].tolist()  # read from the other end: turned back
    [20.0, 20.0]
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    cols, rows = pattern
    if (cols + rows) % 2 == 1 and cols >= 2 and rows >= 2:
        g = pts.reshape(rows, cols, 2)
        first = _mean_level(image, g[:2, :2].reshape(-1, 2).mean(axis=0))
        last = _mean_level(image, g[-2:, -2:].reshape(-1, 2).mean(axis=0))
        return pts if first <= last else pts[::-1].copy()
    d = pts[-1] - pts[0]
    return pts if d[0] + d[1] >= 0 else pts[::-1].copy()


def _mean_level(image: np.ndarray, p: np.ndarray) -> float:
    h, w = image.shape[:2]
    x, y = int(round(p[0])), int(round(p[1]))
    patch = image[max(0, y - 1):min(h, y + 2), max(0, x - 1):min(w, x + 2)]
    return float(patch.mean()) if patch.size else 0.0


def opencv_corners(images: Mapping[str, Sequence[np.ndarray]],
                   pattern: tuple[int, int]) -> tuple[Corners, float]:
    """OpenCV's complete boards per camera and frame (None where it found none), oriented; the seconds taken."""
    t0 = time.perf_counter()
    out: Corners = {}
    for name, imgs in images.items():
        found = []
        for img in imgs:
            grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            det = opencv_classic(grey, pattern)
            found.append(orient_grid(grey, det.points, pattern) if det.found else None)
        out[name] = found
    return out, time.perf_counter() - t0


def sogdd_boards(images: Mapping[str, Sequence[np.ndarray]], pattern: tuple[int, int]
                 ) -> tuple[dict[str, list[Board | None]], float]:
    """``sogdd.calib.detect_board`` per camera and frame (None where it found none); the seconds taken."""
    t0 = time.perf_counter()
    out = {name: [detect_board(img, pattern) for img in imgs] for name, imgs in images.items()}
    return out, time.perf_counter() - t0


def _grid_object(pattern: tuple[int, int], square: float) -> np.ndarray:
    cols, rows = pattern
    j, i = np.mgrid[0:rows, 0:cols]
    return np.stack([i.ravel(), j.ravel(), np.zeros(cols * rows)], axis=1) * float(square)


# ---------------------------------------------------------------------------------------------
# the methods


def from_rig_calibration(rig, method: str = "sogdd", seconds: float = float("nan")) -> RigEstimate:
    """A :class:`RigEstimate` of sogdd's :class:`~sogdd.calib.rig.RigCalibration`."""
    est = RigEstimate(method, {}, {}, {}, {}, {}, seconds, rig=rig)
    for c in rig.cameras:
        est.K[c.name] = np.asarray(c.K, dtype=np.float64)
        est.dist[c.name] = np.asarray(c.dist, dtype=np.float64).ravel()
        est.R[c.name] = np.asarray(c.R, dtype=np.float64)
        est.T[c.name] = np.asarray(c.T, dtype=np.float64).ravel()
        est.sizes[c.name] = tuple(c.image_size)
        cal = c.calibration
        est.frames_used[c.name] = int(np.sum(np.asarray(cal.view_used, bool)))
        est.rms[c.name] = float(cal.rms)
    est.notes += list(getattr(rig, "notes", ()))
    from ...calib.rig.uncertainty import projection_uncertainty

    for c in rig.cameras:
        try:
            _, sigma = projection_uncertainty(rig, c.name, uncertainty_pixels(c.image_size))
            est.uncertainty[c.name] = [float(v) for v in sigma]
        except ValueError:
            pass
    return est


def uncertainty_pixels(size: tuple[int, int]) -> np.ndarray:
    """Where the methods' projection uncertainties are compared: the frame's centre and (0.8 W, 0.2 H)."""
    w, h = size
    return np.array([[(w - 1) / 2, (h - 1) / 2], [0.8 * w, 0.2 * h]])


# mrcal's own uncertainty of a far point's projection (its worst direction), by its Python module
_MRCAL_UNCERTAINTY = """
import json, sys
import numpy as np
import mrcal
out = []
for path, q in json.loads(sys.argv[1]):
    m = mrcal.cameramodel(path)
    v = mrcal.unproject(np.array(q, float), *m.intrinsics(), normalize=True)
    out.append([float(x) for x in np.atleast_1d(mrcal.projection_uncertainty(
        v, model=m, atinfinity=True, what="worstdirection-stdev"))])
print(json.dumps(out))
"""


def _mrcal_uncertainty(paths: list[str], sizes: list[tuple[int, int]]) -> list[list[float]] | None:
    """mrcal's projection uncertainty at :func:`uncertainty_pixels` per model, or None where it fails."""
    import json

    args = json.dumps([[p, uncertainty_pixels(s).tolist()] for p, s in zip(paths, sizes)])
    try:
        run = subprocess.run(["/usr/bin/python3", "-c", _MRCAL_UNCERTAINTY, args], capture_output=True,
                             text=True, timeout=600, check=False)
        return json.loads(run.stdout) if run.returncode == 0 else None
    except (subprocess.SubprocessError, OSError, ValueError):
        return None


def _sogdd(boards: dict, sizes: dict, pattern, square: float, **_) -> RigEstimate:
    from ...calib.rig.fit import calibrate_rig

    t0 = time.perf_counter()
    rig = calibrate_rig(boards, sizes, square=square, models="pinhole", pattern=pattern)
    return from_rig_calibration(rig, "sogdd", time.perf_counter() - t0)


def _mono(corners: list, size, obj) -> tuple[np.ndarray, np.ndarray, float, int]:
    pts = [c for c in corners if c is not None]
    if len(pts) < 3:
        raise ValueError(f"{len(pts)} complete boards: too few for cv2.calibrateCamera")
    o = [obj.astype(np.float32)] * len(pts)
    ip = [p.astype(np.float32).reshape(-1, 1, 2) for p in pts]
    rms, K, d, _, _ = cv2.calibrateCamera(o, ip, size, None, None, criteria=_CRIT)
    return K, d.ravel()[:5], float(rms), len(pts)


def _stereo(corners: Corners, sizes: dict, pattern, square: float, free: bool, **_) -> RigEstimate:
    names = list(corners)
    obj = _grid_object(pattern, square)
    t0 = time.perf_counter()
    est = RigEstimate("opencv-stereo-free" if free else "opencv-stereo-fix", {}, {}, {}, {}, dict(sizes))
    mono = {}
    for n in names:
        K, d, rms, used = _mono(corners[n], sizes[n], obj)
        mono[n] = (K, d)
        est.rms[n], est.frames_used[n] = rms, used
    first = names[0]
    est.K[first], est.dist[first] = mono[first]
    est.R[first], est.T[first] = np.eye(3), np.zeros(3)
    flags = cv2.CALIB_USE_INTRINSIC_GUESS if free else cv2.CALIB_FIX_INTRINSIC
    for k, n in enumerate(names[1:]):
        both = [f for f, (a, b) in enumerate(zip(corners[first], corners[n]))
                if a is not None and b is not None]
        if len(both) < 3:
            raise ValueError(f"{first} and {n} share {len(both)} complete boards: too few for "
                             "cv2.stereoCalibrate")
        o = [obj.astype(np.float32)] * len(both)
        p0 = [corners[first][f].astype(np.float32).reshape(-1, 1, 2) for f in both]
        p1 = [corners[n][f].astype(np.float32).reshape(-1, 1, 2) for f in both]
        K0, d0 = mono[first]
        K1, d1 = mono[n]
        rms, K0, d0, K1, d1, R, T, _, _ = cv2.stereoCalibrate(o, p0, p1, K0.copy(), d0.copy(), K1.copy(),
                                                              d1.copy(), sizes[first], flags=flags,
                                                              criteria=_CRIT)
        if free:  # each pair refined the first camera its own way: its rectification needs that one
            est.pair_first[n] = (K0, d0.ravel()[:5])
            if k == 0:
                est.K[first], est.dist[first] = K0, d0.ravel()[:5]
        est.K[n], est.dist[n] = K1, d1.ravel()[:5]
        est.R[n], est.T[n] = R, T.ravel()
        est.frames_used[n] = len(both)
        est.rms[n] = float(rms)
    est.seconds = time.perf_counter() - t0
    if len(names) > 2:
        est.notes.append(f"{est.method}: one cv2.stereoCalibrate per pair ({first}, camera k)")
    return est


def _multiview(corners: Corners, sizes: dict, pattern, square: float, **_) -> RigEstimate:
    names = list(corners)
    n_frames = len(corners[names[0]])
    obj = _grid_object(pattern, square)
    # calibrateMultiview divides the board by its squared extent and then calls the board collinear when
    # that is far from 1 (a board in mm): give it a board of extent 1, and scale T back
    extent = float(np.linalg.norm(obj.max(axis=0) - obj.min(axis=0)))
    mask = np.array([[c is not None for c in corners[n]] for n in names], dtype=np.uint8)
    keep = np.flatnonzero(mask.sum(axis=0) >= 1)
    if not np.all(mask.sum(axis=1) >= 3):
        raise ValueError("cv2.calibrateMultiview needs >= 3 complete boards per camera")
    npts = len(obj)
    ip = [[(corners[n][f] if corners[n][f] is not None else np.full((npts, 2), -1.0)).astype(np.float32)
           for f in keep] for n in names]
    t0 = time.perf_counter()
    out = cv2.calibrateMultiview([(obj / extent).astype(np.float32)] * len(keep), ip,
                                 [tuple(int(v) for v in sizes[n]) for n in names], mask[:, keep],
                                 np.full(len(names), cv2.CALIB_MODEL_PINHOLE, np.uint8), None, None, None, None,
                                 np.zeros(len(names), np.int32), criteria=_CRIT)
    rms, Ks, ds, Rs, Ts = out[:5]
    est = RigEstimate("opencv-multiview", {}, {}, {}, {}, dict(sizes), time.perf_counter() - t0)
    for k, n in enumerate(names):
        est.K[n] = np.asarray(Ks[k], dtype=np.float64)
        est.dist[n] = np.asarray(ds[k], dtype=np.float64).ravel()[:5]
        est.R[n] = cv2.Rodrigues(np.asarray(Rs[k], dtype=np.float64).reshape(3))[0]
        est.T[n] = np.asarray(Ts[k], dtype=np.float64).ravel() * extent
        est.frames_used[n] = int(mask[k].sum())
        est.rms[n] = float(rms)
    del n_frames
    return est


def _mrcal(corners: Corners, sizes: dict, pattern, square: float, **_) -> RigEstimate:
    names = list(corners)
    w, h = sizes[names[0]]
    if any(tuple(sizes[n]) != (w, h) for n in names):
        raise ValueError("mrcal-calibrate-cameras takes one --imagersize for cameras without image files")
    cols, rows = pattern
    focal = [0.5 * sizes[n][0] / np.tan(np.radians(30.0)) for n in names]  # a 60-degree guess, as a user would
    with tempfile.TemporaryDirectory(prefix="sogdd-mrcal-") as tmp:
        lines = ["# filename x y level"]
        for n in names:
            for f, c in enumerate(corners[n]):
                fname = f"{n}-{f:04d}.png"
                if c is None:
                    lines.append(f"{fname} - - -")
                else:
                    lines += [f"{fname} {x:.6f} {y:.6f} 0" for x, y in c]
        cache = os.path.join(tmp, "corners.vnl")
        with open(cache, "w") as fh:
            fh.write("\n".join(lines) + "\n")
        cmd = ["mrcal-calibrate-cameras", "--corners-cache", cache, "--lensmodel", "LENSMODEL_OPENCV5",
               "--focal", ",".join(f"{v:.1f}" for v in focal), "--imagersize", str(w), str(h),
               "--object-spacing", repr(float(square)), "--object-width-n", str(cols),
               "--object-height-n", str(rows), "--outdir", tmp] + [f"{n}-*.png" for n in names]
        t0 = time.perf_counter()
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=1800, check=False, cwd=tmp)
        seconds = time.perf_counter() - t0
        if run.returncode != 0:
            tail = (run.stderr or run.stdout).strip().splitlines()
            raise RuntimeError(f"mrcal-calibrate-cameras failed: {tail[-1] if tail else run.returncode}")
        est = RigEstimate("mrcal", {}, {}, {}, {}, dict(sizes), seconds)
        est.notes.append("mrcal: OpenCV's corners in its corners.vnl (mrgingham reads square grids only)")
        for k, n in enumerate(names):
            model = read_cameramodel(os.path.join(tmp, f"camera-{k}.cameramodel"))
            intr = np.asarray(model["intrinsics"], dtype=np.float64)
            est.K[n] = np.array([[intr[0], 0, intr[2]], [0, intr[1], intr[3]], [0, 0, 1]])
            est.dist[n] = intr[4:9]
            rt = np.asarray(model.get("extrinsics", np.zeros(6)), dtype=np.float64)
            est.R[n], est.T[n] = cv2.Rodrigues(rt[:3])[0], rt[3:]
            est.frames_used[n] = sum(c is not None for c in corners[n])
        unc = _mrcal_uncertainty([os.path.join(tmp, f"camera-{k}.cameramodel") for k in range(len(names))],
                                 [tuple(sizes[n]) for n in names])
        if unc is None:
            est.notes.append("mrcal: its projection uncertainty could not be computed")
        else:
            est.uncertainty = dict(zip(names, unc))
    return est


def read_cameramodel(path: str) -> dict:
    """``lensmodel``, ``intrinsics``, ``extrinsics`` and ``imagersize`` of an mrcal ``.cameramodel`` file.

    The file is a Python literal with ``#`` comments; its base-85 ``optimization_inputs``
    may hold ``#`` too, so each wanted key is read on its own.

    Examples
    --------
    >>> import tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "c.cameramodel")
    >>> _ = open(p, "w").write("{\\n 'lensmodel': 'LENSMODEL_OPENCV4', # x\\n 'intrinsics': [ 1.5, 2,],\\n"
    ...                        " 'extrinsics': [0, 0, 0, 1, 2, 3,], 'optimization_inputs': b'#'}")
    >>> read_cameramodel(p)["intrinsics"], read_cameramodel(p)["lensmodel"]
    ([1.5, 2], 'LENSMODEL_OPENCV4')
    """
    with open(path) as fh:
        text = fh.read()
    out: dict = {}
    for key in ("intrinsics", "extrinsics", "imagersize"):
        m = re.search(rf"'{key}'\s*:\s*(\[[^\]]*\])", text)
        if m:
            out[key] = ast.literal_eval(m.group(1))
    m = re.search(r"'lensmodel'\s*:\s*'([^']*)'", text)
    if m:
        out["lensmodel"] = m.group(1)
    if "intrinsics" not in out:
        raise ValueError(f"{path}: no intrinsics")
    return out


@dataclass(frozen=True)
class RigMethod:
    """A compared rig method: its name, what it reads ("sogdd" boards or "opencv" corners), its call, needs."""

    name: str
    reads: str
    run: Callable[..., RigEstimate]
    needs: str = ""


RIG_METHODS: dict[str, RigMethod] = {m.name: m for m in (
    RigMethod("sogdd", "sogdd", _sogdd, "sogdd.calib.rig.fit.calibrate_rig"),
    RigMethod("opencv-stereo-fix", "opencv", lambda **kw: _stereo(free=False, **kw)),
    RigMethod("opencv-stereo-free", "opencv", lambda **kw: _stereo(free=True, **kw)),
    RigMethod("opencv-multiview", "opencv", _multiview, "OpenCV >= 5 (cv2.calibrateMultiview)"),
    RigMethod("mrcal", "opencv", _mrcal, "apt-get install mrcal"),
)}

_PROBES: dict[str, Callable[[], bool]] = {
    "sogdd": lambda: importlib.util.find_spec("sogdd.calib.rig.fit") is not None,
    "opencv-multiview": lambda: hasattr(cv2, "calibrateMultiview"),
    "mrcal": lambda: shutil.which("mrcal-calibrate-cameras") is not None,
}


def rig_available(name: str) -> tuple[bool, str]:
    """Whether rig method ``name`` can run here, and a note saying why not ("" when it can).

    Examples
    --------
    >>> rig_available("opencv-stereo-fix")
    (True, '')
    """
    probe = _PROBES.get(name)
    if probe is None or probe():
        return True, ""
    return False, f"{name} skipped: not installed ({RIG_METHODS[name].needs})"


def rig_method_names(spec: str | None = None) -> list[str]:
    """Rig method names from a comma-separated ``spec`` (None or "all": every method).

    Examples
    --------
    >>> rig_method_names("sogdd, mrcal")
    ['sogdd', 'mrcal']
    """
    if spec is None or spec.strip() == "all":
        return list(RIG_METHODS)
    names = [n.strip() for n in spec.split(",") if n.strip()]
    bad = [n for n in names if n not in RIG_METHODS]
    if bad or not names:
        raise ValueError(f"unknown rig method(s) {', '.join(bad) or '(none)'}; known: {', '.join(RIG_METHODS)}")
    return names


def run_rig_method(name: str, *, boards: dict | None, corners: Corners | None, sizes: dict,
                   pattern: tuple[int, int], square: float) -> tuple[RigEstimate | None, str]:
    """Run rig method ``name`` on its input (sogdd's boards or OpenCV's corners): (estimate, "") or (None,
    a one-line note saying why it did not run or failed)."""
    ok, note = rig_available(name)
    if not ok:
        return None, note
    m = RIG_METHODS[name]
    data = boards if m.reads == "sogdd" else corners
    try:
        if m.reads == "sogdd":
            est = m.run(boards=data, sizes=sizes, pattern=pattern, square=square)
        else:
            est = m.run(corners=data, sizes=sizes, pattern=pattern, square=square)
    except (ValueError, RuntimeError, ImportError, cv2.error, subprocess.SubprocessError, OSError) as exc:
        text = str(exc).strip().splitlines()
        return None, f"{name} failed: {text[-1] if text else type(exc).__name__}"
    return est, ""
