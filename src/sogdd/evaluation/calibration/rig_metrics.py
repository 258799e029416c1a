"""The rig evaluation: every method on rendered rigs with exact ground truth, the uncertainty's calibration
over independent sessions, and a real three-camera set.

Rendered rigs (:mod:`.rigs`), per method and rig
-------------------------------------------------
- ``rotation_deg``: per camera ``k`` after the first, the angle of
  :math:`\\hat R_k R_k^T` (degrees);
- ``translation_mm`` :math:`\\lVert \\hat T_k - T_k \\rVert` and ``translation_pct``, the
  same as a percentage of the baseline :math:`\\lVert T_k \\rVert`;
- ``fx, fy, cx, cy``: each camera's absolute intrinsic errors (px);
- ``projection_difference``: each camera's mean distance between where it and the
  true camera put the same rays over the image (:func:`sogdd.calib.projection_difference`, px);
- ``epipolar``: per pair (first camera, camera k), the RMS vertical disparity (px) of the
  *true* corners of held-out frames (board poses of their own, projected through the
  true cameras, in both images) after rectification by the method's calibration
  (``cv2.stereoRectify`` on its ``K, dist, R, T``; each point undistorted exactly,
  :func:`sogdd.calib.cameras.undistort`, rotated by ``R1``/``R2`` and projected by
  ``P1``/``P2``; a method that fits each pair apart, each with its own first camera,
  is scored with that pair's); 0 for a perfect calibration. A vertical pair (``stereoRectify``
  puts the baseline along ``y``) is scored on its horizontal disparity.
- ``seconds``: the calibration's wall time (detection apart).

Calibration of the uncertainty (``--sessions N``)
-------------------------------------------------
``N`` independent sessions of one rig (:func:`.rigs.render_rig_session`: new poses,
grey levels and noise each), each calibrated by sogdd. For each camera's ``fx`` and
``cx``, each other camera's baseline :math:`\\lVert T_k \\rVert`, and the projection of a fixed
ray (the ray through the pixel ``(0.8 W, 0.2 H)`` of the true camera ``k``, expressed
in the true first camera's frame, projected through each session's camera ``k`` with
its estimated pose: :func:`sogdd.calib.rig.uncertainty.ray_uncertainty`), the
**ratio** of the empirical standard deviation over the sessions to the predicted
one (the RMS over sessions of sogdd's per-session standard deviation; for the ray,
:math:`\\sqrt{\\operatorname{tr}}` of the pixel covariances, both axes together). A
calibrated uncertainty gives 1; with ``N`` sessions the empirical figure itself
scatters by about :math:`1/\\sqrt{2(N - 1)}` (16 % for 20). The bias of the
mean (estimate minus truth) is reported in the same predicted standard deviations.

Real rig (``calibration/rig3_ecocheck``)
----------------------------------------
Three cameras (left, middle, right), frames matched by the number in the file names,
a 9 x 13 inner-corner ECoCheck chessboard; no ground truth. Per method: every
camera's RMS reprojection and frames used, and the baselines, from a fit on all
frames; and the epipolar RMS after rectification of each pair with the first camera,
two-fold (fit on the even frames, score the odd ones' corners, and the other way
round), scored on OpenCV's corners of the held-out frames for every method (the
same points for all) and on each method's own detector's.
"""

from __future__ import annotations

import json
import math
import time
import zlib
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from ...calib.cameras import projection_difference, undistort
from ...formats.safe_write import write_text
from .rig_comparators import (
    MODEL,
    RIG_METHODS,
    RigEstimate,
    opencv_corners,
    orient_grid,
    rig_available,
    run_rig_method,
    sogdd_boards,
)
from .rigs import RigSpec, board_in_camera, render_rig_session, rig_poses

__all__ = ["pose_errors", "intrinsic_errors", "epipolar_rms", "heldout_corners", "score_estimate",
           "run_rendered_rigs", "run_sessions", "run_real_rig", "rig_availability", "rigs_markdown",
           "write_rigs", "RAY_PIXEL"]

_JSON, _MD = "rigs.json", "rigs.md"
#: the fixed ray of the uncertainty study: through this fraction (x, y) of the true camera's image
RAY_PIXEL = (0.8, 0.2)
#: how many held-out frames the epipolar error is scored on
HELDOUT = 10


def _seed(*parts: object) -> int:
    return zlib.crc32("/".join(str(p) for p in parts).encode())


def _angle_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    c = (np.trace(np.asarray(Ra) @ np.asarray(Rb).T) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def pose_errors(est: RigEstimate, spec: RigSpec) -> dict[str, dict]:
    """Per camera after the first: ``rotation_deg``, ``translation_mm`` and ``translation_pct`` of the baseline.

    Examples
    --------
    >>> from sogdd.evaluation.calibration.rigs import QUICK_RIGS
    >>> spec = QUICK_RIGS["quick"]
    >>> e = pose_errors(perfect_estimate(spec), spec)["right"]
    >>> e["rotation_deg"], e["translation_mm"]
    (0.0, 0.0)
    """
    out = {}
    for c in spec.cameras[1:]:
        dT = float(np.linalg.norm(est.T[c.name] - c.T))
        out[c.name] = {"rotation_deg": _angle_deg(est.R[c.name], c.R), "translation_mm": dT,
                       "translation_pct": 100.0 * dT / float(np.linalg.norm(c.T))}
    return out


def intrinsic_errors(est: RigEstimate, spec: RigSpec) -> dict[str, dict]:
    """Per camera: ``fx, fy, cx, cy`` absolute errors (px) and ``projection_difference`` (mean, px)."""
    out = {}
    for c in spec.cameras:
        K, Kt = est.K[c.name], c.camera.K
        diff = projection_difference((np.asarray(Kt), np.asarray(c.camera.dist)), (K, est.dist[c.name]),
                                     c.camera.size)
        out[c.name] = {"fx": abs(K[0, 0] - Kt[0, 0]), "fy": abs(K[1, 1] - Kt[1, 1]),
                       "cx": abs(K[0, 2] - Kt[0, 2]), "cy": abs(K[1, 2] - Kt[1, 2]),
                       "projection_difference": float(diff.mean)}
    return out


def _rectified(px: np.ndarray, K, dist, Rr, P) -> np.ndarray:
    xy, ok = undistort(px, K, dist)
    ray = np.c_[xy, np.ones(len(xy))] @ np.asarray(Rr).T
    q = ray @ np.asarray(P)[:, :3].T
    out = q[:, :2] / q[:, 2:3]
    out[~ok] = np.nan
    return out


def epipolar_rms(est: RigEstimate, first: str, other: str, pts_first: np.ndarray,
                 pts_other: np.ndarray) -> float:
    """RMS disparity across the epipolar lines (px) of matched points after rectifying by ``est`` (module doc).

    Examples
    --------
    >>> from sogdd.evaluation.calibration.rigs import QUICK_RIGS
    >>> spec = QUICK_RIGS["quick"]
    >>> a, b = heldout_corners(spec, 2, seed=0)["right"]
    >>> round(epipolar_rms(perfect_estimate(spec), "left", "right", a, b), 9)
    0.0
    """
    K0, d0 = est.pair_first.get(other, (est.K[first], est.dist[first]))
    K1, d1 = est.K[other], est.dist[other]
    R1, R2, P1, P2 = cv2.stereoRectify(K0, d0, K1, d1, tuple(est.sizes[first]), est.R[other],
                                       est.T[other].reshape(3, 1), alpha=0)[:4]
    a = _rectified(np.asarray(pts_first, np.float64).reshape(-1, 2), K0, d0, R1, P1)
    b = _rectified(np.asarray(pts_other, np.float64).reshape(-1, 2), K1, d1, R2, P2)
    axis = 0 if abs(P2[1, 3]) > abs(P2[0, 3]) else 1  # a vertical pair's epipolar lines are columns
    d = a[:, axis] - b[:, axis]
    d = d[np.isfinite(d)]
    return float(np.sqrt(np.mean(d ** 2))) if len(d) else float("nan")


def heldout_corners(spec: RigSpec, n_frames: int = HELDOUT, seed: int = 0) -> dict[str, tuple]:
    """Per camera after the first: the true corners ``(first, camera k)`` of held-out frames seen by both."""
    obj = spec.target.object_points()
    poses = rig_poses(spec, n_frames, _seed("heldout", spec.name, seed))
    first = spec.cameras[0]
    out = {}
    for c in spec.cameras[1:]:
        a, b = [], []
        for rvec, tvec, _ in poses:
            pa = first.camera.project(obj, rvec, tvec)
            pb = c.camera.project(obj, *board_in_camera(c, rvec, tvec))
            ok = _inside(pa, first.camera.size) & _inside(pb, c.camera.size)
            a.append(pa[ok])
            b.append(pb[ok])
        out[c.name] = (np.concatenate(a), np.concatenate(b))
    return out


def _inside(p: np.ndarray, size) -> np.ndarray:
    w, h = size
    with np.errstate(invalid="ignore"):
        return np.all(np.isfinite(p), axis=1) & (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 0] <= w - 1) & \
            (p[:, 1] <= h - 1)


def perfect_estimate(spec: RigSpec) -> RigEstimate:
    """The true rig as an estimate (every error 0): a check of the metrics."""
    est = RigEstimate("truth", {}, {}, {}, {}, {})
    for c in spec.cameras:
        est.K[c.name] = np.asarray(c.camera.K, np.float64)
        est.dist[c.name] = np.asarray(c.camera.dist, np.float64)
        est.R[c.name], est.T[c.name] = c.R.copy(), c.T.copy()
        est.sizes[c.name] = c.camera.size
    return est


def _r(v, digits: int = 4):
    return None if v is None or not math.isfinite(v) else round(float(v), digits)


def score_estimate(est: RigEstimate, spec: RigSpec, heldout: dict[str, tuple]) -> dict:
    """One row: the method's errors on ``spec`` (module doc)."""
    first = spec.cameras[0].name
    poses = pose_errors(est, spec)
    intr = intrinsic_errors(est, spec)
    cams = {}
    for c in spec.cameras:
        row = {k: _r(v) for k, v in intr[c.name].items()}
        if c.name in poses:
            row.update({k: _r(v) for k, v in poses[c.name].items()})
            row["epipolar"] = _r(epipolar_rms(est, first, c.name, *heldout[c.name]))
        row["frames_used"] = est.frames_used.get(c.name)
        row["rms"] = _r(est.rms.get(c.name))
        if c.name in est.uncertainty:
            row["uncertainty"] = [_r(v) for v in est.uncertainty[c.name]]
        cams[c.name] = row
    others = [cams[c.name] for c in spec.cameras[1:]]
    return {"rig": spec.name, "method": est.method, "seconds": _r(est.seconds, 3), "cameras": cams,
            "rotation_deg": _r(max(r["rotation_deg"] for r in others)),
            "translation_mm": _r(max(r["translation_mm"] for r in others)),
            "epipolar": _r(max(np.nan if r["epipolar"] is None else r["epipolar"] for r in others)),
            "projection_difference": _r(max(r["projection_difference"] for r in cams.values())),
            "notes": est.notes}


def rig_availability(methods: list[str]) -> tuple[list[str], list[str]]:
    """The rig methods that can run, and a note for each one skipped."""
    run, notes = [], []
    for m in methods:
        ok, note = rig_available(m)
        (run.append(m) if ok else notes.append(note))
    return run, notes


def _inputs(images: dict, pattern, methods: list[str]) -> tuple[dict | None, dict | None, dict]:
    need = {RIG_METHODS[m].reads for m in methods}
    boards, corners, det = None, None, {}
    if "sogdd" in need:
        boards, det["sogdd"] = sogdd_boards(images, pattern)
    if "opencv" in need:
        corners, det["opencv"] = opencv_corners(images, pattern)
    return boards, corners, det


def run_rendered_rigs(specs: list[RigSpec], methods: list[str], *, seed: int = 0, n_frames: int | None = None,
                      progress: Callable[[str], None] | None = None) -> tuple[list[dict], list[str]]:
    """Every method on one session (``seed``) of each rig: one row per (rig, method), and notes."""
    rows, notes = [], []
    for spec in specs:
        session = render_rig_session(spec, n_frames, seed)
        images = {n: session.images(n) for n in spec.names}
        sizes = {c.name: c.camera.size for c in spec.cameras}
        boards, corners, det = _inputs(images, spec.target.pattern_size, methods)
        heldout = heldout_corners(spec, HELDOUT, seed)
        for m in methods:
            est, note = run_rig_method(m, boards=boards, corners=corners, sizes=sizes,
                                       pattern=spec.target.pattern_size, square=spec.target.square)
            if est is None:
                notes.append(f"{spec.name}: {note}")
                continue
            row = score_estimate(est, spec, heldout)
            row.update(frames=len(session.frames), detect_seconds=_r(det[RIG_METHODS[m].reads], 2))
            rows.append(row)
            if progress:
                progress(f"{spec.name}: {m}")
    return rows, notes


# ---------------------------------------------------------------------------------------------
# the uncertainty's calibration


def _fixed_rays(spec: RigSpec) -> dict[str, np.ndarray]:
    """Per camera: the ray through ``RAY_PIXEL`` of its true image, in the true first camera's frame."""
    out = {}
    for c in spec.cameras:
        w, h = c.camera.size
        d = c.camera.rays(np.array([[RAY_PIXEL[0] * w, RAY_PIXEL[1] * h]]))[0]
        out[c.name] = c.R.T @ d
    return out


def _session_values(rig, spec: RigSpec, rays: dict) -> dict[str, tuple]:
    """``quantity -> (estimate (k,), predicted covariance (k, k), truth (k,))`` of one session's rig."""
    from ...calib.rig.uncertainty import ray_uncertainty

    out = {}
    for c in spec.cameras:
        cam = rig.camera(c.name)
        K, Kt = np.asarray(cam.K), c.camera.K
        out[f"{c.name}.fx"] = (np.array([K[0, 0]]), np.array([[cam.std["fx"] ** 2]]), np.array([Kt[0, 0]]))
        out[f"{c.name}.cx"] = (np.array([K[0, 2]]), np.array([[cam.std["cx"] ** 2]]), np.array([Kt[0, 2]]))
        if c is not spec.cameras[0]:
            out[f"{c.name}.baseline"] = (np.array([cam.baseline]), np.array([[cam.std["baseline"] ** 2]]),
                                         np.array([float(np.linalg.norm(c.T))]))
        q, cov, _ = ray_uncertainty(rig, c.name, rays[c.name])
        w, h = c.camera.size
        out[f"{c.name}.ray"] = (np.asarray(q, float), np.asarray(cov, float),
                                np.array([RAY_PIXEL[0] * w, RAY_PIXEL[1] * h]))
    return out


def calibration_ratios(values: dict[str, list]) -> dict[str, dict]:
    """Per quantity, from a list of ``(estimate, covariance, truth)`` over sessions: the empirical and
    predicted standard deviations, their ratio and the bias (module doc).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> vals = [(np.array([rng.normal(0, 2.0)]), np.array([[4.0]]), np.array([0.0])) for _ in range(400)]
    >>> r = calibration_ratios({"fx": vals})["fx"]
    >>> 0.9 < r["ratio"] < 1.1, r["sessions"]
    (True, 400)
    """
    out = {}
    for q, vals in values.items():
        est = np.array([v[0] for v in vals], dtype=np.float64)
        cov = np.array([v[1] for v in vals], dtype=np.float64)
        truth = np.asarray(vals[0][2], dtype=np.float64)
        n = len(est)
        emp = float(np.sqrt(np.sum(np.var(est, axis=0, ddof=1)))) if n > 1 else float("nan")
        pred = float(np.sqrt(np.mean(np.trace(cov, axis1=1, axis2=2))))
        bias = float(np.linalg.norm(est.mean(axis=0) - truth))
        out[q] = {"sessions": n, "empirical_std": _r(emp, 5), "predicted_std": _r(pred, 5),
                  "ratio": _r(emp / pred if pred > 0 else float("nan"), 3),
                  "bias_in_predicted_std": _r(bias / pred if pred > 0 else float("nan"), 3)}
    return out


def run_sessions(spec: RigSpec, n_sessions: int, *, n_frames: int | None = None, first_seed: int = 1000,
                 progress: Callable[[str], None] | None = None) -> dict:
    """sogdd on ``n_sessions`` independent sessions of ``spec``: the calibration ratios (module doc)."""
    from ...calib.rig.fit import calibrate_rig

    if int(n_sessions) < 2:
        raise ValueError(f"--sessions must be >= 2 (a spread needs two sessions), got {n_sessions}")
    rays = _fixed_rays(spec)
    values: dict[str, list] = {}
    notes, seconds = [], []
    sizes = {c.name: c.camera.size for c in spec.cameras}
    for s in range(int(n_sessions)):
        session = render_rig_session(spec, n_frames, first_seed + s)
        boards, _ = sogdd_boards({n: session.images(n) for n in spec.names}, spec.target.pattern_size)
        t0 = time.perf_counter()
        try:
            rig = calibrate_rig(boards, sizes, square=spec.target.square, models="pinhole",
                                pattern=spec.target.pattern_size)
        except ValueError as exc:
            notes.append(f"session {first_seed + s}: {str(exc).splitlines()[0]}")
            continue
        seconds.append(time.perf_counter() - t0)
        for q, v in _session_values(rig, spec, rays).items():
            values.setdefault(q, []).append(v)
        if progress:
            progress(f"{spec.name}: session {s + 1}/{n_sessions}")
    return {"rig": spec.name, "sessions": int(n_sessions), "frames": n_frames or spec.n_frames,
            "ray_pixel": list(RAY_PIXEL), "ratios": calibration_ratios(values) if values else {},
            "seconds_per_fit": _r(float(np.median(seconds)) if seconds else float("nan"), 3), "notes": notes}


# ---------------------------------------------------------------------------------------------
# the real rig


def _grid_order(board, pattern: tuple[int, int]) -> np.ndarray | None:
    """A complete sogdd board's corners in grid order (rows of ``cols``), or None."""
    if board is None or board.size is None:
        return None
    lab = board.labels - board.labels.min(axis=0)
    cols = int(lab[:, 0].max()) + 1
    rows = int(lab[:, 1].max()) + 1
    if cols * rows != len(board) or sorted((cols, rows)) != sorted(pattern):
        return None
    out = np.full((rows * cols, 2), np.nan)
    out[lab[:, 1] * cols + lab[:, 0]] = board.image_points
    return out


def _oriented(image: np.ndarray, board, pattern: tuple[int, int]) -> np.ndarray | None:
    g = _grid_order(board, pattern)
    return None if g is None else orient_grid(image, g, pattern)


def _real_pairs(pts: dict[str, list], names: list[str], frames: list[int]) -> dict[str, tuple]:
    out = {}
    for n in names[1:]:
        a = [pts[names[0]][f] for f in frames if pts[names[0]][f] is not None and pts[n][f] is not None]
        b = [pts[n][f] for f in frames if pts[names[0]][f] is not None and pts[n][f] is not None]
        out[n] = (np.concatenate(a), np.concatenate(b)) if a else (np.zeros((0, 2)), np.zeros((0, 2)))
    return out


def _masked(data: dict | None, keep: set[int]) -> dict | None:
    if data is None:
        return None
    return {n: [v if f in keep else None for f, v in enumerate(vals)] for n, vals in data.items()}


def _two_fold(m: str, data: dict, names: list[str], F: int, notes: list[str], label: str) -> dict:
    """Method ``m``'s epipolar RMS per camera pair, fit on half the frames and scored on the other half."""
    folds = [set(range(0, F, 2)), set(range(1, F, 2))]
    kw = dict(sizes=data["sizes"], pattern=data["pattern"], square=data["square"])
    sums: dict[str, dict[str, list]] = {"opencv": {}, "own": {}}
    for fit, test in ((folds[0], folds[1]), (folds[1], folds[0])):
        half, note = run_rig_method(m, boards=_masked(data["boards"], fit),
                                    corners=_masked(data["corners"], fit), **kw)
        if half is None:
            notes.append(f"{label}: {m} on half the frames: {note}")
            continue
        for key, pts in (("opencv", data["corners"]), ("own", data["own"][RIG_METHODS[m].reads])):
            for n, (a, b) in _real_pairs(pts, names, sorted(test)).items():
                if len(a):
                    e = epipolar_rms(half, names[0], n, a, b)
                    sums[key].setdefault(n, []).append((e ** 2 * len(a), len(a)))
    return {f"epipolar_{key}_corners": {n: _r(math.sqrt(sum(v for v, _ in vals) / sum(c for _, c in vals)))
                                        for n, vals in per.items()} for key, per in sums.items()}


def _load_real(root: Path, name: str, methods: list[str]) -> dict | None:
    """The real rig's images, board, and every method's input (module doc); None when it is not there."""
    from ...calib.rig.frames import match_frames
    from .photo_sets import photo_sets

    sets = photo_sets(root, [name])
    if not sets or sets[0].target is None:
        return None
    names = [s.name.split("/", 1)[1] for s in sets]
    target = sets[0].target
    _, per = match_frames({n: [str(p) for p in s.images] for n, s in zip(names, sets)})
    images = {n: [cv2.imread(p, cv2.IMREAD_GRAYSCALE) for p in per[n]] for n in names}
    pattern = target.pattern
    boards, corners, _ = _inputs(images, pattern, methods)
    if corners is None:
        corners, _ = opencv_corners(images, pattern)
    own = {"opencv": corners}
    if boards is not None:
        own["sogdd"] = {n: [_oriented(images[n][f], b, pattern) for f, b in enumerate(boards[n])]
                        for n in names}
    return {"names": names, "frames": len(per[names[0]]), "pattern": pattern, "square": target.square,
            "sizes": {n: (images[n][0].shape[1], images[n][0].shape[0]) for n in names},
            "boards": boards, "corners": corners, "own": own}


def run_real_rig(root: Path, methods: list[str], *, name: str = "rig3_ecocheck",
                 progress: Callable[[str], None] | None = None) -> tuple[list[dict], list[str]]:
    """Every method on the real rig under ``root`` (module doc): one row per method, and notes."""
    data = _load_real(root, name, methods)
    if data is None:
        return [], [f"{name}: not found under {root} (or no board file)"]
    names, F = data["names"], data["frames"]
    rows, notes = [], []
    for m in methods:
        est, note = run_rig_method(m, boards=data["boards"], corners=data["corners"], sizes=data["sizes"],
                                   pattern=data["pattern"], square=data["square"])
        if est is None:
            notes.append(f"{name}: {note}")
            continue
        row = {"set": name, "method": m, "frames": F, "seconds": _r(est.seconds, 3),
               "cameras": {n: {"rms": _r(est.rms.get(n)), "frames_used": est.frames_used.get(n),
                               "baseline": _r(float(np.linalg.norm(est.T[n])), 4)} for n in names},
               "notes": est.notes}
        row.update(_two_fold(m, data, names, F, notes, name))
        rows.append(row)
        if progress:
            progress(f"{name}: {m}")
    cols, rws = data["pattern"]
    if (cols + rws) % 2 == 0:
        notes.append(f"{name}: {cols} x {rws} inner corners, symmetric under a half turn: OpenCV's grids put "
                     "in one orientation by the image (corner 0 toward the top left)")
    return rows, notes


# ---------------------------------------------------------------------------------------------
# tables and files


def _f(v, digits: int = 3) -> str:
    return "-" if v is None else f"{v:.{digits}f}" if isinstance(v, float) else str(v)


def _rendered_table(rows: list[dict]) -> list[str]:
    out = ["Rendered rigs (worst camera of each rig; errors against the exact truth):", "",
           "| rig | method | rotation (deg) | translation (mm) | epipolar (px) | proj. diff. (px) | fit (s) |",
           "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['rig']} | {r['method']} | {_f(r['rotation_deg'], 4)} | {_f(r['translation_mm'])} "
                   f"| {_f(r['epipolar'])} | {_f(r['projection_difference'])} | {_f(r['seconds'], 2)} |")
    out += ["", "Per camera:", "", "| rig | method | camera | fx | cx | rotation (deg) | translation (mm, "
            "% of baseline) | epipolar (px) | frames used |", "|---|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        for n, c in r["cameras"].items():
            tr = "-" if c.get("translation_mm") is None else \
                f"{c['translation_mm']:.3f} ({c['translation_pct']:.3f} %)"
            out.append(f"| {r['rig']} | {r['method']} | {n} | {_f(c['fx'])} | {_f(c['cx'])} | "
                       f"{_f(c.get('rotation_deg'), 4)} | {tr} | {_f(c.get('epipolar'))} | "
                       f"{c['frames_used']} |")
    return out + [""]


def _sessions_table(s: dict) -> list[str]:
    out = [f"Calibration of sogdd's uncertainty: {s['sessions']} independent sessions of rig {s['rig']} "
           f"({s['frames']} frames each); target 0.7-1.4:", "",
           "| quantity | empirical std | predicted std | ratio | bias (predicted std) |",
           "|---|---:|---:|---:|---:|"]
    for q, v in s["ratios"].items():
        out.append(f"| {q} | {_f(v['empirical_std'], 4)} | {_f(v['predicted_std'], 4)} | "
                   f"{_f(v['ratio'], 2)} | {_f(v['bias_in_predicted_std'], 2)} |")
    return out + [""]


def _real_table(rows: list[dict]) -> list[str]:
    out = ["Real rig (no ground truth; epipolar RMS two-fold, on held-out frames):", "",
           "| set | method | camera | RMS (px) | frames used | baseline | epipolar, OpenCV's corners (px) "
           "| epipolar, own corners (px) |", "|---|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        for n, c in r["cameras"].items():
            out.append(f"| {r['set']} | {r['method']} | {n} | {_f(c['rms'])} | {c['frames_used']} | "
                       f"{_f(c['baseline'], 3)} | {_f(r['epipolar_opencv_corners'].get(n))} | "
                       f"{_f(r['epipolar_own_corners'].get(n))} |")
    return out + [""]


def _uncertainty_table(rows: list[dict]) -> list[str]:
    """Each method's own projection uncertainty of a far point, where it gives one (sogdd, mrcal)."""
    found = [(r, n, c["uncertainty"]) for r in rows for n, c in r["cameras"].items() if c.get("uncertainty")]
    if not found:
        return []
    out = ["Each method's own projection uncertainty of a far point (1 sigma, worst direction, px), at the "
           "frame's centre and at (0.8 W, 0.2 H):", "",
           "| rig | method | camera | centre | (0.8 W, 0.2 H) |", "|---|---|---|---:|---:|"]
    for r, n, u in found:
        out.append(f"| {r['rig']} | {r['method']} | {n} | {_f(u[0], 4)} | {_f(u[1], 4)} |")
    return out + [""]


def rigs_markdown(res: dict) -> str:
    """The result as markdown: rendered rigs, the calibration ratios, the real rig, notes.

    Examples
    --------
    >>> print(rigs_markdown({"rendered": [], "notes": ["x skipped"]}).splitlines()[0])
    # Rig calibration
    """
    out = ["# Rig calibration", ""]
    if res.get("command"):
        out += [f"`{res['command']}` ({res.get('seconds', 0)} s); lens model {res.get('model', MODEL)}", ""]
    if res.get("rendered"):
        out += _rendered_table(res["rendered"])
        out += _uncertainty_table(res["rendered"])
    if res.get("sessions") and res["sessions"].get("ratios"):
        out += _sessions_table(res["sessions"])
    if res.get("real"):
        out += _real_table(res["real"])
    out += [f"- {n}" for n in res.get("notes", [])]
    return "\n".join(out) + "\n"


def _plain(obj):
    """numpy scalars and arrays as Python numbers and lists (the rows hold no other non-JSON type)."""
    if hasattr(obj, "tolist"):
        return obj.tolist()
    raise TypeError(f"not JSON: {type(obj).__name__}")


def write_rigs(res: dict, out: str | Path, *, merge: bool = False) -> Path:
    """Write ``rigs.json`` and ``rigs.md`` into ``out`` (``merge``: rows of other rigs and methods kept)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / _JSON
    if merge and path.is_file():
        old = json.loads(path.read_text())
        for key, ident in (("rendered", ("rig", "method")), ("real", ("set", "method"))):
            new_keys = {tuple(r[k] for k in ident) for r in res.get(key, [])}
            kept = [r for r in old.get(key, []) if tuple(r[k] for k in ident) not in new_keys]
            res[key] = kept + res.get(key, [])
        res["sessions"] = res.get("sessions") or old.get("sessions")
        res["notes"] = list(dict.fromkeys([*old.get("notes", []), *res.get("notes", [])]))
    write_text(path, json.dumps(res, indent=1, default=_plain))
    write_text(out / _MD, rigs_markdown(res))
    return path
