"""A calibration's files: camera.yaml (OpenCV FileStorage), camera.json, views.csv and corners.csv.

Every file is written to a temporary name beside its target and renamed into
place only once complete (camera.yaml is read back by ``cv2.FileStorage``
first), so a failed write raises and never leaves a half-written file under
the final name; a target that is one of the inputs is refused before anything
is written.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

import cv2
import numpy as np

from .._version import __version__
from ..formats.safe_write import atomic_write, check_not_inputs, write_text
from .detection import ViewRecord, view_records
from .guidance import guidance
from .model_selection import ModelSelection
from .result import Calibration
from .weighting import view_precision

__all__ = [
    "FILES",
    "calibration_dict",
    "open_storage",
    "read_camera",
    "selection_dict",
    "write_calibration",
    "write_camera_json",
    "write_camera_yaml",
    "write_corners_csv",
    "write_views_csv",
]

#: the files :func:`write_calibration` writes
FILES = ("camera.yaml", "camera.json", "views.csv", "corners.csv")


def _num(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def calibration_dict(cal: Calibration, views: Sequence[ViewRecord] | None = None) -> dict:
    """The calibration as plain JSON-able data (non-finite numbers as None).

    With ``views`` (every input's fate, :attr:`sogdd.calib.ImageCalibration.views`),
    ``views`` lists them all (``view``, ``file``, ``status``, ``reason``) and
    ``rejected_views`` holds every one not used, the images that could not be
    read too; without it, the views of ``cal``.

    ``pixel_grid`` is :attr:`~sogdd.calib.Calibration.pixel_grid`: ``"image"``, or ``"sensor"`` when the
    images' EXIF orientations differed and none was applied (a note in ``notes`` says which).

    ``projection_uncertainty_px`` holds the far-point projection uncertainty at the image's centre and its
    worst, 1 sigma (``{"centre", "worst"}``, :meth:`~sogdd.calib.result.Calibration.projection_uncertainty`,
    as each camera of a rig.json; None without a covariance).

    ``guidance`` says where the next views should put the board (:meth:`~sogdd.calib.guidance.Guidance.as_dict`:
    ``regions``, the frame's 3 x 3 regions with their share of the corners and their worst uncertainty;
    ``tilts``; ``advice``, empty when nothing is needed).

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> d = calibration_dict(demo_calibration())
    >>> d["model"], d["image_width"], len(d["camera_matrix"]), sorted(d["distortion"])[:2]
    ('pinhole', 640, 3, ['k1', 'k2'])
    """
    cv = cal.cross_validation
    centre, worst = cal.projection_uncertainty()
    return {
        "model": cal.model,
        "image_width": int(cal.image_size[0]),
        "image_height": int(cal.image_size[1]),
        "pixel_grid": cal.pixel_grid,
        "camera_matrix": [[float(v) for v in row] for row in cal.K],
        "distortion_coefficients": [float(v) for v in cal.dist],
        "distortion": cal.coefficients(),
        "std": {k: _num(v) for k, v in cal.std.items()},
        "projection_uncertainty_px": {"centre": _num(centre), "worst": _num(worst)},
        "rms": _num(cal.rms),
        "square": cal.square,
        "views_total": len(cal.names),
        "views_used": cal.n_used,
        "corners_used": cal.n_corners_used,
        "cross_validation": None if cv is None else {
            "mean": _num(cv.mean), "max": _num(cv.max), "mean_within": _num(cv.mean_within),
            "max_within": _num(cv.max_within), "rms_a": _num(cv.rms_a), "rms_b": _num(cv.rms_b),
            "views_a": [cal.names[v] for v in cv.views_a], "views_b": [cal.names[v] for v in cv.views_b],
            "camera_matrix_a": cv.K_a.tolist(), "distortion_a": cv.dist_a.tolist(),
            "camera_matrix_b": cv.K_b.tolist(), "distortion_b": cv.dist_b.tolist(),
        },
        "model_selection": selection_dict(cal.model_selection),
        "thresholds": {k: _num(v) for k, v in cal.thresholds.items()},
        "typical_precision": _num(cal.typical_precision),
        "guidance": guidance(cal).as_dict(),
        "rejected_views": {n: r for n, r, u in zip(cal.names, cal.reasons, cal.view_used) if not u}
        if views is None else {v.name: v.reason or v.status for v in views if v.status != "used"},
        **({} if views is None else {"views": [{"view": v.name, "file": v.file, "status": v.status,
                                                "reason": v.reason} for v in views]}),
        "notes": list(cal.notes),
        "sogdd_version": __version__,
    }


def selection_dict(sel: ModelSelection | None) -> dict | None:
    """The model selection as plain JSON-able data (None without one): ``chosen``, ``rule``,
    ``folds`` (each fold's held-out views), ``notes`` and ``table``, one row per candidate
    (:class:`~sogdd.calib.model_selection.CandidateScore`'s fields; non-finite numbers as None).

    Examples
    --------
    >>> from sogdd.calib.model_selection import CandidateScore, ModelSelection
    >>> row = CandidateScore("pinhole4", 4, 0.1, 0.12, 0.01, 0.0, 0.0, True)
    >>> d = selection_dict(ModelSelection("pinhole4", (row,), ((0, 2), (1, 3)), "the rule"))
    >>> d["chosen"], d["table"][0]["cv_rms"], d["folds"]
    ('pinhole4', 0.12, [[0, 2], [1, 3]])
    """
    if sel is None:
        return None
    rows = [{"model": r.model, "n_coefficients": r.n_coefficients, "fit_rms": _num(r.fit_rms),
             "cv_rms": _num(r.cv_rms), "cv_se": _num(r.cv_se), "difference": _num(r.difference),
             "difference_se": _num(r.difference_se), "within_noise": r.within_noise, "note": r.note}
            for r in sel.table]
    return {"chosen": sel.chosen, "rule": sel.rule, "folds": [list(f) for f in sel.folds],
            "notes": list(sel.notes), "table": rows}


# --------------------------------------------------------------------------------------------------
# the four files


def write_camera_yaml(cal: Calibration, path: str | os.PathLike) -> Path:
    """Write the camera as OpenCV FileStorage YAML (``cv2.FileStorage(path, READ)`` reads it).

    Nodes: ``model``, ``image_width``, ``image_height``, ``camera_matrix`` (3x3),
    ``distortion_coefficients`` (1xN, OpenCV's order for the model),
    ``distortion_names``, ``std_intrinsics`` (fx, fy, cx, cy, then the
    coefficients), ``rms``, ``views_used``, ``views_total``, ``corners_used``,
    ``square``, ``cross_validation_mean``/``_max`` over the image and
    ``cross_validation_mean_within``/``_max_within`` inside the hull of the
    used corners (px, -1 without a cross-validation),
    ``sogdd_version``. The file is read back before it is renamed into place.
    """
    path = Path(path)

    def write(tmp: Path) -> None:
        # the format by name: the temporary file's suffix is not .yaml
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_FORMAT_YAML)
        if not fs.isOpened():
            raise OSError(f"{path}: cannot be written")
        cv = cal.cross_validation
        fs.write("model", cal.model)
        fs.write("image_width", int(cal.image_size[0]))
        fs.write("image_height", int(cal.image_size[1]))
        fs.write("camera_matrix", np.asarray(cal.K, dtype=np.float64))
        fs.write("distortion_coefficients", np.asarray(cal.dist, dtype=np.float64).reshape(1, -1))
        fs.write("distortion_names", " ".join(cal.coefficients()))
        fs.write("std_intrinsics", np.array(list(cal.std.values()), dtype=np.float64).reshape(1, -1))
        fs.write("rms", float(cal.rms))
        fs.write("views_used", cal.n_used)
        fs.write("views_total", len(cal.names))
        fs.write("corners_used", cal.n_corners_used)
        fs.write("square", float(cal.square))
        fs.write("cross_validation_mean", -1.0 if cv is None else float(cv.mean))
        fs.write("cross_validation_max", -1.0 if cv is None else float(cv.max))
        fs.write("cross_validation_mean_within", -1.0 if cv is None else float(cv.mean_within))
        fs.write("cross_validation_max_within", -1.0 if cv is None else float(cv.max_within))
        fs.write("sogdd_version", __version__)
        fs.release()
        back = read_camera(tmp)
        n = len(back["distortion_coefficients"])
        if not np.allclose(back["camera_matrix"], cal.K) or n != len(cal.dist):
            raise OSError(f"{path}: the written file does not read back (disk full?)")

    atomic_write(path, write)
    return path


def open_storage(path: Path) -> cv2.FileStorage:
    """``path`` opened for reading by ``cv2.FileStorage``, or a one-line ``ValueError`` saying why not."""
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # a parse error reaches Python as SystemError from the constructor
        raise ValueError(f"{path}: not an OpenCV FileStorage file") from None
    if not fs.isOpened():
        raise ValueError(f"{path}: cannot be read")
    return fs


def read_camera(path: str | os.PathLike) -> dict:
    """Read a ``camera.yaml`` (through ``cv2.FileStorage``) or ``camera.json``.

    Returns a dict with ``model``, ``image_width``, ``image_height``,
    ``camera_matrix`` (3x3 ndarray), ``distortion_coefficients`` (1-D ndarray)
    and ``rms``. Raises ``ValueError`` for a file that is not such a camera.
    """
    p = Path(path)
    if p.suffix.lower() == ".json":
        try:
            d = json.loads(p.read_text(encoding="utf-8"))
            K, D = np.array(d["camera_matrix"], float), np.array(d["distortion_coefficients"], float)
            return {"model": d["model"], "image_width": d["image_width"], "image_height": d["image_height"],
                    "camera_matrix": K, "distortion_coefficients": D, "rms": d.get("rms")}
        except (KeyError, TypeError, json.JSONDecodeError) as exc:
            raise ValueError(f"{p}: not a sogdd camera.json ({exc})") from None
    fs = open_storage(p)
    K, D = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
    if K is None or D is None or K.shape != (3, 3):
        raise ValueError(f"{p}: no camera_matrix / distortion_coefficients")
    out = {"model": fs.getNode("model").string() or "pinhole",
           "image_width": int(fs.getNode("image_width").real()),
           "image_height": int(fs.getNode("image_height").real()),
           "camera_matrix": K, "distortion_coefficients": D.ravel(), "rms": fs.getNode("rms").real()}
    fs.release()
    return out


def write_camera_json(cal: Calibration, path: str | os.PathLike, *,
                      views: Sequence[ViewRecord] | None = None) -> Path:
    """Write :func:`calibration_dict` as indented JSON."""
    path = Path(path)
    write_text(path, json.dumps(calibration_dict(cal, views), indent=2) + "\n")
    return path


def _csv(rows: list[list]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    return buf.getvalue()


def _fmt(v: float, digits: int = 4) -> str:
    return f"{v:.{digits}f}" if math.isfinite(v) else ""


def _sig(v: float) -> str:
    """A precision in px to 3 significant digits (they span 0.002 to 1 px); empty when unknown."""
    return f"{v:.3g}" if math.isfinite(v) else ""


def write_views_csv(cal: Calibration, path: str | os.PathLike, *,
                    views: Sequence[ViewRecord] | None = None) -> Path:
    """``view,corners_found,corners_used,rms,used,reason,status,precision_px,weight,source,reasons``: a row
    per view.

    ``rms`` is over the used corners (all corners of a rejected view, from its
    pose re-estimated with the final camera; empty without a pose); ``used`` is
    1 or 0 and ``reason`` says why a view was not used (a smeared view: by how
    much its corners are less precise than the set's,
    :func:`~sogdd.calib.weighting.smeared_views`); ``status`` is ``used``,
    ``rejected``, ``ignored`` (a board of another kind or size; a board beside
    the image's view, its corners counted in ``corners_found``), ``no board`` or
    ``unreadable``. ``precision_px`` is the view's median corner precision
    (:func:`~sogdd.calib.weighting.view_precision`, px), ``weight`` its corners'
    median weight in the fit relative to the set's typical corner
    (:func:`~sogdd.calib.weighting.corner_weights`: 1 typical, 0.5 a view twice
    as imprecise; a rejected view's what it would have had); both empty where
    unknown (no precision measured; ``weight`` also for an unweighted fit).
    ``source`` names the detector that proposed the view's board
    (``Board.source``: ``sogdd``, ``opencv`` or ``opencv-sb`` for a chessboard,
    whose corners sogdd measured and checked whatever the source; ``charuco``),
    empty without a board. ``reasons`` says why a video's frame was chosen
    (:attr:`~sogdd.calib.detection.ViewRecord.choice`), empty for an image. With ``views``
    (every input's fate, :attr:`sogdd.calib.ImageCalibration.views`)
    every input is a row, the images that could not be read too; without it,
    the views of ``cal``.
    """
    if views is None:
        views = view_records(cal)
    rows: list[list] = [["view", "corners_found", "corners_used", "rms", "used", "reason", "status",
                         "precision_px", "weight", "source", "reasons"]]
    for row in views:
        v = row.view
        if v is None:
            rows.append([row.name, row.corners or 0, 0, "", 0, row.reason, row.status, "", "", "", row.choice])
            continue
        b, used = cal.boards[v], cal.corner_used[v]
        w = cal.corner_weights(v)
        rows.append([row.name, 0 if b is None else len(b), 0 if used is None else int(used.sum()),
                     _fmt(cal.view_rms[v]), int(bool(cal.view_used[v])), row.reason, row.status,
                     _sig(view_precision(b)), "" if w is None or len(w) == 0 else _fmt(float(np.median(w)), 3),
                     "" if b is None else b.source, row.choice])
    path = Path(path)
    write_text(path, _csv(rows))
    return path


def write_corners_csv(cal: Calibration, path: str | os.PathLike) -> Path:
    """``view,i,j,x,y,residual,used,sigma_px,source``: one row per corner found.

    ``i, j`` the integer board label, ``x, y`` the position (OpenCV's pixel
    convention: pixel centres at integers), ``residual`` the reprojection
    error in px (empty without a pose), ``used`` 1 if the calibration used it,
    ``sigma_px`` its measured 1-sigma precision (``Board.precision``, px; empty
    where unknown), ``source`` the detector that proposed its board (``Board.source``).
    """
    rows: list[list] = [["view", "i", "j", "x", "y", "residual", "used", "sigma_px", "source"]]
    for v, name in enumerate(cal.names):
        b = cal.boards[v]
        if b is None:
            continue
        res = cal.residuals[v]
        r = np.full(len(b), np.nan) if res is None else np.hypot(res[:, 0], res[:, 1])
        sigma = np.full(len(b), np.nan) if b.precision is None else b.precision
        for c in range(len(b)):
            i, j = b.labels[c]
            x, y = b.image_points[c]
            rows.append([name, int(i), int(j), _fmt(x), _fmt(y), _fmt(r[c]), int(bool(cal.corner_used[v][c])),
                         _sig(sigma[c]), b.source])
    path = Path(path)
    write_text(path, _csv(rows))
    return path


def write_calibration(cal: Calibration, out_dir: str | os.PathLike, *,
                      inputs: Iterable[str | os.PathLike] = (),
                      views: Sequence[ViewRecord] | None = None) -> dict[str, Path]:
    """Write camera.yaml, camera.json, views.csv and corners.csv into ``out_dir`` (created if needed).

    Parameters
    ----------
    cal : Calibration
    out_dir : path
    inputs : paths
        Files that must never be overwritten (the images): a target that is one
        of them raises ``ValueError`` before anything is written.
    views : sequence of ViewRecord, optional
        Every input's fate, for views.csv and camera.json (:func:`write_views_csv`).

    Returns
    -------
    dict
        File name -> path written.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.demo import demo_calibration
    >>> with tempfile.TemporaryDirectory() as d:
    ...     files = write_calibration(demo_calibration(), d)
    ...     cam = read_camera(files["camera.yaml"])
    >>> sorted(files), round(float(cam["camera_matrix"][0, 0]))
    (['camera.json', 'camera.yaml', 'corners.csv', 'views.csv'], 600)
    """
    out = Path(out_dir)
    targets = {name: out / name for name in FILES}
    check_not_inputs([("output", t) for t in targets.values()], inputs)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    write_camera_yaml(cal, targets["camera.yaml"])
    write_camera_json(cal, targets["camera.json"], views=views)
    write_views_csv(cal, targets["views.csv"], views=views)
    write_corners_csv(cal, targets["corners.csv"])
    return targets
