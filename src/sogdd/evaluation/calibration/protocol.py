"""The calibration evaluation: every method on rendered sequences and on real photos, one JSON result.

Rendered sequences (:mod:`.sequences`)
--------------------------------------
Each view is rendered once without noise; each of ``draws`` noise draws adds
its own noise (seeded by sequence, view and draw) and every method runs on it.
Per method and sequence, pooled over the draws:

- ``boards``: views where the method returned a board, of all views (x draws);
- ``recall``: correctly labelled true corners inside the frame, of all of them;
- ``wrong_labels`` and ``flipped_views`` (:mod:`.metrics`);
- ``corner``: the corner error's mean, RMS, p95 and max (px);
- ``calibration`` (board methods with >= 3 boards per draw): the camera from
  ``sogdd.calib.calibrate`` on the method's boards (pinhole, ``k3`` fixed at 0
  as in the true camera), per draw: ``projection difference`` to the true
  camera (``sogdd.calib.projection_difference``: mean over the image of the
  distance between where the two cameras put the same ray, px), ``focal
  error`` ``|fx - fx_true|`` (px) and RMS reprojection; averaged over the draws
  (one sequence alone is a noisy judge);
- ``ms_per_frame``: median wall time of the method's call per frame.

Real photos (``$SOGDD_DATA/calibration/chessboard_*``, 6 x 4 inner corners)
----------------------------------------------------------------------------
Per method and set: boards found; the label distance (each detected corner
paired with the nearest hand label within 5 px, one global offset, the median
of detected minus label over the set, removed, then the mean distance); RMS
reprojection of a calibration of the set's boards (per image size with >= 3
boards); for ``chessboard_sony`` also ``fx`` against BoofCV's ``intrinsic.xml``.
mrgingham reads only square grids and is not run on them.
"""

from __future__ import annotations

import os
import re
import time
import zlib
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
from scipy.spatial import cKDTree

from .comparators import METHODS, Detection, available
from .metrics import ViewScore, error_stats, score_view
from .render import add_noise, in_frame, render_scene
from .sequences import Sequence

__all__ = ["run_sequences", "run_real", "REAL_SETS", "calibrate_boards"]

REAL_SETS = ("chessboard_sony", "chessboard_border", "chessboard_hard")
_REAL_PATTERN = (6, 4)
_REAL_CAPTURE = 5.0
_MIN_VIEWS = 3


def _seed(*parts: object) -> int:
    return zlib.crc32("/".join(str(p) for p in parts).encode())


def calibrate_boards(boards: list, image_size: tuple[int, int], square: float) -> tuple[object | None, str]:
    """``sogdd.calib.calibrate`` on (points, labels) boards, ``k3`` fixed: (Calibration or None, note)."""
    from sogdd.calib import Board, calibrate

    usable = [Board(p, lab) for p, lab in boards if len(p) >= 6]
    if len(usable) < _MIN_VIEWS:
        return None, f"{len(usable)} boards: too few to calibrate"
    try:
        cal = calibrate(usable, image_size, square=square, flags=cv2.CALIB_FIX_K3, cross_validate=False,
                        min_views=_MIN_VIEWS)
    except (ValueError, cv2.error) as exc:
        return None, f"calibration failed: {str(exc).splitlines()[0]}"
    return cal, ""


def _run_method(name: str, image: np.ndarray, pattern) -> tuple[Detection, float]:
    t0 = time.perf_counter()
    det = METHODS[name].detect(image, pattern)
    return det, time.perf_counter() - t0


class _Pool:
    """One method's scores on one sequence, over views and draws."""

    def __init__(self) -> None:
        self.scores: list[ViewScore] = []
        self.times: list[float] = []
        self.boards: dict[int, list] = {}

    def summary(self, seq: Sequence, kind: str) -> dict:
        s = self.scores
        errors = np.concatenate([v.errors for v in s]) if s else np.zeros(0)
        out = {
            "frames": len(s),
            "recall": round(sum(v.recalled for v in s) / max(1, sum(v.n_inside for v in s)), 4),
            "corner": error_stats(errors),
            "ms_per_frame": round(1000 * float(np.median(self.times)), 1) if self.times else None,
        }
        if kind == "board":
            out["boards"] = sum(v.found for v in s)
            out["wrong_labels"] = sum(v.n_wrong for v in s)
            out["flipped_views"] = sum(v.flipped for v in s)
            out["calibration"] = self._calibrations(seq)
        return out

    def _calibrations(self, seq: Sequence) -> dict:
        from sogdd.calib import projection_difference

        cam = seq.camera
        truth = (np.asarray(cam.K), np.asarray(cam.dist))
        rows, notes = [], []
        for draw, boards in sorted(self.boards.items()):
            cal, note = calibrate_boards(boards, cam.size, seq.target.square)
            if cal is None:
                notes.append(f"draw {draw}: {note}")
                continue
            diff = projection_difference(truth, cal, cam.size)
            rows.append((diff.mean, abs(cal.K[0, 0] - cam.fx), cal.rms, int(np.sum(cal.view_used))))
        if not rows:
            return {"draws": 0, "notes": notes}
        a = np.array(rows, dtype=np.float64)
        return {"draws": len(rows), "projection_difference": round(float(a[:, 0].mean()), 4),
                "projection_difference_per_draw": [round(float(v), 4) for v in a[:, 0]],
                "focal_error": round(float(a[:, 1].mean()), 4), "rms": round(float(a[:, 2].mean()), 4),
                "views_used": round(float(a[:, 3].mean()), 1), "notes": notes}


def run_sequences(seqs: list[Sequence], methods: list[str], *, draws: int = 1, views: int | None = None,
                  progress: Callable[[str], None] | None = None) -> list[dict]:
    """Run ``methods`` on every view (the first ``views`` of each) and noise draw of ``seqs``.

    One row per (sequence, method). With ``views``, a ``partial`` sequence keeps
    its cut views (the last ones) in proportion.
    """
    rows = []
    for seq in seqs:
        if hasattr(seq, "run"):  # the stress scenes carry their own cameras and boards, and are not calibrated
            rows += seq.run(methods, draws=draws, views=views, progress=progress)
            continue
        pools = {m: _Pool() for m in methods}
        pattern = seq.target.pattern_size
        obj = seq.target.object_points()
        chosen = _chosen(seq, views)
        for done, (v, (rvec, tvec)) in enumerate(chosen):
            clean = render_scene(seq.camera, seq.target, rvec, tvec, blur=seq.blur, falloff=seq.falloff)
            truth = seq.camera.project(obj, rvec, tvec)
            inside = in_frame(truth, seq.camera.size, 4.0)
            for d in range(draws):
                image = add_noise(clean, seq.noise, _seed(seq.name, seq.seed, v, d))
                for m in methods:
                    det, dt = _run_method(m, image, pattern)
                    pool = pools[m]
                    pool.times.append(dt)
                    pool.scores.append(score_view(det.points, det.labels, truth, seq.target.labels(), inside))
                    if det.found:
                        pool.boards.setdefault(d, []).append((det.points, det.labels))
                    else:
                        pool.boards.setdefault(d, [])
            if progress:
                progress(f"{seq.name}: view {done + 1}/{len(chosen)}")
        for m in methods:
            row = {"sequence": seq.name, "method": m, "kind": METHODS[m].kind,
                   "views": len(chosen), "draws": draws}
            row.update(pools[m].summary(seq, METHODS[m].kind))
            rows.append(row)
    return rows


def _chosen(seq: Sequence, views: int | None) -> list[tuple[int, tuple[np.ndarray, np.ndarray]]]:
    """``(index, pose)`` of the views to run: all, or ``views`` of them, full and cut ones in proportion."""
    poses = list(enumerate(seq.poses()))
    if views is None or views >= len(poses):
        return poses
    n_cut = int(round(seq.partial * seq.n_views))
    full, cut = poses[:len(poses) - n_cut], poses[len(poses) - n_cut:]
    k_cut = int(round(views * n_cut / len(poses)))
    return full[:views - k_cut] + cut[:k_cut]


# ---------------------------------------------------------------------------------------------
# real photos


def _labels_file(path: Path) -> np.ndarray:
    vals = [ln.split() for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    return np.array([[float(a), float(b)] for a, b, *_ in vals], dtype=np.float64).reshape(-1, 2)


def _boofcv_fx(path: Path) -> float | None:
    if not path.exists():
        return None
    m = re.search(r'property="fx">\s*<double>([-0-9.eE]+)</double>', path.read_text())
    return float(m.group(1)) if m else None


def real_frames(root: Path, name: str) -> list[tuple[Path, np.ndarray]]:
    """The set's images and their hand labels, sorted by name."""
    folder = root / name
    out = []
    for img in sorted(folder.glob("*.jpg")):
        lab = img.with_suffix(".txt")
        if lab.exists():
            out.append((img, _labels_file(lab)))
    return out


def run_real(root: Path, methods: list[str], *, sets: tuple[str, ...] = REAL_SETS,
             progress: Callable[[str], None] | None = None) -> list[dict]:
    """Every method on the real photo sets under ``root`` (module doc): one row per (set, method)."""
    rows = []
    for name in sets:
        frames = real_frames(root, name)
        if not frames:
            continue
        images = [(p, cv2.imread(str(p), cv2.IMREAD_GRAYSCALE), lab) for p, lab in frames]
        for m in methods:
            if METHODS[m].square_only:
                continue
            rows.append(_real_row(name, m, images, root))
            if progress:
                progress(f"{name}: {m}")
    return rows


def _real_row(name: str, m: str, images: list, root: Path) -> dict:
    kind = METHODS[m].kind
    found, deltas, times = 0, [], []
    by_size: dict[tuple[int, int], list] = {}
    for _path, img, lab in images:
        det, dt = _run_method(m, img, _REAL_PATTERN)
        times.append(dt)
        if kind == "board" and det.found:
            found += 1
            by_size.setdefault((img.shape[1], img.shape[0]), []).append((det.points, det.labels))
        if len(det.points) and len(lab):
            dist, idx = cKDTree(lab).query(det.points)
            ok = dist < _REAL_CAPTURE
            deltas.append(det.points[ok] - lab[idx[ok]])
    d = np.concatenate(deltas) if deltas else np.zeros((0, 2))
    offset = np.median(d, axis=0) if len(d) else np.full(2, np.nan)
    dist = np.linalg.norm(d - offset, axis=1) if len(d) else np.zeros(0)
    row = {"set": name, "method": m, "kind": kind, "images": len(images), "matched": int(len(d)),
           "offset": [round(float(v), 3) for v in offset],
           "label_distance": round(float(dist.mean()), 4) if len(dist) else None,
           "ms_per_frame": round(1000 * float(np.median(times)), 1)}
    if kind == "board":
        row["boards"] = found
        row.update(_real_calibration(name, by_size, root))
    return row


def _real_calibration(name: str, by_size: dict, root: Path) -> dict:
    rms, fx, notes = [], None, []
    square = 33.0
    for size, boards in sorted(by_size.items()):
        cal, note = calibrate_boards(boards, size, square)
        if cal is None:
            notes.append(f"{size[0]}x{size[1]}: {note}")
            continue
        rms.append((len(boards), cal.rms))
        if name == "chessboard_sony":
            fx = float(cal.K[0, 0])
    out: dict = {"notes": notes}
    if rms:
        n = np.array([r[0] for r in rms], dtype=np.float64)
        out["rms"] = round(float(np.sum(n * np.array([r[1] for r in rms])) / n.sum()), 4)
    if name == "chessboard_sony":
        out["fx"] = None if fx is None else round(fx, 2)
        out["fx_reference"] = _boofcv_fx(root / name / "intrinsic.xml")
    return out


def data_root(explicit: str | None = None) -> Path | None:
    """The calibration photos' folder: ``explicit``, else ``$SOGDD_DATA/calibration``; None when absent."""
    if explicit:
        return Path(explicit)
    base = os.environ.get("SOGDD_DATA")
    if base and (Path(base) / "calibration").is_dir():
        return Path(base) / "calibration"
    return None


def availability(methods: list[str]) -> tuple[list[str], list[str]]:
    """The methods that can run, and a note for each one skipped."""
    run, notes = [], []
    for m in methods:
        ok, note = available(m)
        (run.append(m) if ok else notes.append(note))
    return run, notes
