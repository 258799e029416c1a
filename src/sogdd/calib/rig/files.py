"""A rig's files: rig.yaml (OpenCV FileStorage), rig.json, and each camera's own files in ``NAME/``.

``rig.yaml`` holds, for each camera ``NAME``, the nodes OpenCV's tools use (``camera_matrix_NAME``,
``distortion_coefficients_NAME``, ``image_size_NAME``, ``model_NAME``) and its pose ``R_NAME``
(3x3) and ``T_NAME`` (3x1): :math:`x_{NAME} = R_{NAME}\\,x_{first} + T_{NAME}`, ``T`` in the
unit of the board's square, the first camera identity and zero. A two-camera rig also has
``R``, ``T``, ``E``, ``F`` as ``cv2.stereoCalibrate`` names them (the second camera's pose in
the first's frame, the essential and fundamental matrices) and ``R1``, ``R2``, ``P1``,
``P2``, ``Q`` as ``cv2.stereoRectify`` does (:func:`~sogdd.calib.rig.stereo.stereo_pair`).
``rig.json`` holds the same with every standard deviation, and every figure the report shows
(:func:`rig_dict`), each computed where the report's is. Each camera's folder holds
the one-camera files (:func:`sogdd.calib.files.write_calibration`): its camera.yaml,
camera.json, views.csv and corners.csv, its views named by its image files.

Every file goes through the package's atomic writer (:mod:`sogdd.formats.safe_write`);
rig.yaml is read back by ``cv2.FileStorage`` before it is renamed into place.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import cv2
import numpy as np

from ..._version import __version__
from ...formats.safe_write import atomic_write, check_not_inputs, write_text
from ..detection import ViewRecord
from ..files import FILES, open_storage, write_calibration
from .report import rectified_pair
from .result import RigCalibration
from .stereo import stereo_pair
from .verdict import rig_verdict, uncertainty_summary

__all__ = ["RIG_FILES", "STEREO_KEYS", "check_camera_names", "read_rig", "rig_dict", "write_camera_nodes",
           "write_rig", "write_rig_json", "write_rig_yaml"]

#: the files :func:`write_rig` writes beside the cameras' folders
RIG_FILES = ("rig.yaml", "rig.json")
#: the two-camera nodes: ``cv2.stereoCalibrate``'s then ``cv2.stereoRectify``'s
STEREO_KEYS = ("R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q")
_NAME = re.compile(r"[A-Za-z0-9_-]+")
#: folder names of the rig's output a camera's folder may not take (the report's figures)
_RESERVED = ("report",)


def check_camera_names(names: Iterable[str]) -> tuple[str, ...]:
    """The cameras' names, checked: each a FileStorage key suffix and a folder name (one-line ``ValueError``).

    A name is letters, digits, ``_`` and ``-``; names differ also ignoring case
    (the folders would collide on a case-insensitive disk); ``report`` is the
    report's folder.

    Examples
    --------
    >>> check_camera_names(["left", "right"])
    ('left', 'right')
    >>> check_camera_names(["left", "cam 2"])
    Traceback (most recent call last):
    ...
    ValueError: camera name 'cam 2': use letters, digits, _ and - only (it names FileStorage nodes and a folder)
    """
    out = tuple(names)
    seen: dict[str, str] = {}
    for n in out:
        if not isinstance(n, str) or not _NAME.fullmatch(n):
            raise ValueError(f"camera name {n!r}: use letters, digits, _ and - only (it names FileStorage "
                             "nodes and a folder)")
        if n.lower() in _RESERVED:
            raise ValueError(f"camera name {n!r}: that is the report's folder; choose another name")
        if n.lower() in seen:
            raise ValueError(f"camera names {seen[n.lower()]!r} and {n!r}: each camera needs its own name "
                             "(ignoring case: they name folders)")
        seen[n.lower()] = n
    return out


def _num(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _plain(obj):
    """``obj`` as JSON-able data: arrays as lists, dataclasses as dicts, non-finite floats as None."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return _plain({f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)})
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return _num(obj)
    return obj if obj is None or isinstance(obj, str) else str(obj)


def rig_dict(rig: RigCalibration) -> dict:
    """The rig as plain JSON-able data (what ``rig.json`` holds; non-finite numbers as None).

    ``cameras``: per camera ``name``, ``model``, ``camera_matrix``,
    ``distortion_coefficients`` (OpenCV's order), ``distortion`` (by name),
    ``image_size`` ``[w, h]``, ``R`` (3x3), ``T`` (3), ``baseline`` (:math:`\\lVert T \\rVert`),
    ``rotation_deg`` (the angle of ``R``, :attr:`RigCamera.rotation_deg
    <sogdd.calib.rig.result.RigCamera.rotation_deg>`), ``rms`` (px, its corners),
    ``views_used`` of ``views`` (one per frame), ``std`` (``fx``, ``fy``, ``cx``, ``cy``,
    each coefficient, ``T``, ``baseline``, ``rotation_deg``), ``projection_uncertainty_px``
    (``centre`` and ``worst``: a far point's, 1 sigma,
    :func:`~sogdd.calib.rig.verdict.uncertainty_summary`) and, for each camera but the
    reference, ``rectified`` (``frame``, ``shared_corners`` and ``vertical_disparity_px``
    of the pair rectified with the reference, :func:`~sogdd.calib.rig.report.rectified_pair`;
    None when they share no corner); then ``rms``, ``sigma`` (the corner noise, px),
    ``square``, ``frames_used``, ``frames`` (``name``, ``used``, the board's ``rvec`` and
    ``tvec`` in the first camera's frame, ``rms``: each camera's RMS in it, px), ``notes``,
    ``verdict`` (``level``, ``text``: :func:`~sogdd.calib.rig.verdict.rig_verdict`; None, and
    no uncertainty, for a rig without the fit's ``layout``, built by hand),
    ``model_selection`` where the models were chosen, ``connectivity`` (``groups``: the
    cameras the used views tie together; ``pairs``: each pair that shares frames, with its
    ``frames`` and ``corners``, :mod:`~sogdd.calib.rig.connectivity`) from the fit, and
    ``stereo`` (:data:`STEREO_KEYS`) for two cameras.

    Examples
    --------
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> d = rig_dict(demo_rig())
    >>> [c["name"] for c in d["cameras"]], sorted(d["cameras"][1]["std"])[:4], sorted(d["stereo"])[:3]
    (['left', 'right'], ['T', 'baseline', 'cx', 'cy'], ['E', 'F', 'P1'])
    >>> right = d["cameras"][1]
    >>> round(right["rotation_deg"], 6) == round(demo_rig().camera("right").rotation_deg, 6)
    True
    >>> sorted(right["rectified"]), d["cameras"][0]["rectified"] is None
    (['frame', 'shared_corners', 'vertical_disparity_px'], True)
    >>> d["connectivity"]["groups"], d["connectivity"]["pairs"][0]["cameras"]
    ([['left', 'right']], ['left', 'right'])
    """
    # the uncertainty and the verdict read the covariance through the fit's layout, which a rig built by hand
    # (not by calibrate_rig) may lack: it then has neither
    fitted = all(f"{n}.intrinsics" in rig.layout for n in rig.names)
    cams = []
    for k, c in enumerate(rig.cameras):
        centre, worst = uncertainty_summary(rig, c.name) if fitted else (float("nan"), float("nan"))
        cams.append({
            "name": c.name, "model": c.model,
            "camera_matrix": _plain(c.K), "distortion_coefficients": _plain(np.ravel(c.dist)),
            "distortion": _plain(c.calibration.coefficients()),
            "image_size": [int(c.image_size[0]), int(c.image_size[1])],
            "R": _plain(c.R), "T": _plain(np.ravel(c.T)), "baseline": _num(c.baseline),
            "rotation_deg": _num(c.rotation_deg), "rms": _num(c.calibration.rms),
            "views_used": c.calibration.n_used, "views": len(c.calibration.names),
            "std": _plain(c.std), "projection_uncertainty_px": {"centre": _num(centre), "worst": _num(worst)},
            "rectified": None if k == 0 else _rectified(rig, c.name),
        })
    view_rms = {c.name: c.calibration.view_rms for c in rig.cameras}
    out = {
        "cameras": cams,
        "reference": rig.cameras[0].name,
        "pose_convention": f"x_NAME = R x_{rig.cameras[0].name} + T, T in the square's unit",
        "rms": _num(rig.rms), "sigma": _num(rig.sigma), "square": float(rig.square),
        "frames_used": int(np.sum(rig.frame_used)),
        "frames": [{"name": f, "used": bool(u), "rvec": _plain(rv), "tvec": _plain(tv),
                    "rms": {n: _num(r[i]) for n, r in view_rms.items()}}
                   for i, (f, u, rv, tv) in enumerate(zip(rig.frames, rig.frame_used, rig.rvecs, rig.tvecs))],
        "notes": list(rig.notes),
        "verdict": [{"level": level, "text": text} for level, text in rig_verdict(rig)] if fitted else None,
    }
    if rig.model_selection is not None:
        out["model_selection"] = _plain(rig.model_selection)
    if rig.connectivity is not None:
        con = rig.connectivity
        out["connectivity"] = {
            "groups": [list(g) for g in con.components],
            "pairs": [{"cameras": [a, b], "frames": int(con.frames[i, j]), "corners": int(con.corners[i, j])}
                      for i, a in enumerate(con.names) for j, b in enumerate(con.names)
                      if i < j and con.frames[i, j] > 0]}
    if len(rig.cameras) == 2:
        pair = stereo_pair(rig)
        out["stereo"] = {k: _plain(getattr(pair, k)) for k in STEREO_KEYS}
    out["sogdd_version"] = __version__
    return out


def _rectified(rig: RigCalibration, name: str) -> dict | None:
    """Camera ``name`` rectified with the reference, as the report shows it (None: no shared corner)."""
    check = rectified_pair(rig, name)
    if check is None:
        return None
    return {"frame": rig.frames[check.frame], "shared_corners": len(check.shared),
            "vertical_disparity_px": _num(check.disparity)}


def write_camera_nodes(fs: cv2.FileStorage, camera) -> None:
    """One camera's nodes of ``rig.yaml`` (module doc) into an open FileStorage: ``model_NAME``,
    ``camera_matrix_NAME``, ``distortion_coefficients_NAME``, ``image_size_NAME``, ``R_NAME`` and ``T_NAME``
    (``x_cam = R x_ref + T``), from any record with those attributes (``name``, ``model``, ``K``,
    ``dist``, ``image_size``, ``R``, ``T``): a rig's camera or an exchange format's."""
    n = camera.name
    fs.write(f"model_{n}", camera.model)
    fs.write(f"camera_matrix_{n}", np.asarray(camera.K, dtype=np.float64))
    fs.write(f"distortion_coefficients_{n}", np.asarray(camera.dist, dtype=np.float64).reshape(1, -1))
    fs.startWriteStruct(f"image_size_{n}", cv2.FileNode_SEQ | cv2.FileNode_FLOW)
    for v in camera.image_size:
        fs.write("", int(v))
    fs.endWriteStruct()
    fs.write(f"R_{n}", np.asarray(camera.R, dtype=np.float64).reshape(3, 3))
    fs.write(f"T_{n}", np.asarray(camera.T, dtype=np.float64).reshape(3, 1))


def write_rig_yaml(rig: RigCalibration, path: str | os.PathLike) -> Path:
    """Write the rig as OpenCV FileStorage YAML (``cv2.FileStorage(path, READ)`` reads it; module doc).

    Nodes: ``cameras`` (the names, a sequence, the reference first); per camera
    ``NAME``: ``model_NAME``, ``camera_matrix_NAME`` (3x3),
    ``distortion_coefficients_NAME`` (1xN, OpenCV's order for the model),
    ``image_size_NAME`` (``[w, h]``, as OpenCV writes a ``cv::Size``), ``R_NAME``
    (3x3), ``T_NAME`` (3x1), ``rms_NAME``; for two cameras :data:`STEREO_KEYS`;
    then ``rms``, ``sigma``, ``square``, ``frames_used``, ``frames_total``,
    ``sogdd_version``.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> with tempfile.TemporaryDirectory() as d:
    ...     fs = cv2.FileStorage(str(write_rig_yaml(demo_rig(), Path(d) / "rig.yaml")), cv2.FILE_STORAGE_READ)
    ...     shapes = [fs.getNode(k).mat().shape for k in ("R_right", "T_right", "P2")]
    >>> shapes
    [(3, 3), (3, 1), (3, 4)]
    """
    path = Path(path)
    check_camera_names(rig.names)
    pair = stereo_pair(rig) if len(rig.cameras) == 2 else None

    def write(tmp: Path) -> None:
        # the format by name: the temporary file's suffix is not .yaml
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_FORMAT_YAML)
        if not fs.isOpened():
            raise OSError(f"{path}: cannot be written")
        fs.startWriteStruct("cameras", cv2.FileNode_SEQ)
        for n in rig.names:
            fs.write("", n)
        fs.endWriteStruct()
        for c in rig.cameras:
            write_camera_nodes(fs, c)
            fs.write(f"rms_{c.name}", float(c.calibration.rms))
        if pair is not None:
            for k in STEREO_KEYS:
                m = np.asarray(getattr(pair, k), dtype=np.float64)
                fs.write(k, m.reshape(3, 1) if k == "T" else m)
        fs.write("rms", float(rig.rms))
        fs.write("sigma", float(rig.sigma))
        fs.write("square", float(rig.square))
        fs.write("frames_used", int(np.sum(rig.frame_used)))
        fs.write("frames_total", len(rig.frames))
        fs.write("sogdd_version", __version__)
        fs.release()
        back = read_rig(tmp)
        if list(back["cameras"]) != list(rig.names) or not all(
                np.allclose(back["cameras"][c.name]["camera_matrix"], c.K) for c in rig.cameras):
            raise OSError(f"{path}: the written file does not read back (disk full?)")

    atomic_write(path, write)
    return path


def read_rig(path: str | os.PathLike) -> dict:
    """Read a ``rig.yaml`` (through ``cv2.FileStorage``) into plain arrays.

    Returns
    -------
    dict
        ``cameras``: name -> ``{"model", "camera_matrix" (3x3), "distortion_coefficients"
        (1-D), "image_size" ((w, h)), "R" (3x3), "T" (3,)}``, in the rig's order (the
        reference first); ``stereo``: :data:`STEREO_KEYS` -> array (``T`` (3,)), for
        two cameras only; ``rms``, ``sigma``, ``square``.

    Raises
    ------
    ValueError
        A file that is not a rig.yaml (one line).

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> with tempfile.TemporaryDirectory() as d:
    ...     rig = read_rig(write_rig_yaml(demo_rig(), Path(d) / "rig.yaml"))
    >>> list(rig["cameras"]), rig["cameras"]["right"]["T"].shape, rig["cameras"]["left"]["image_size"]
    (['left', 'right'], (3,), (640, 480))
    """
    p = Path(path)
    fs = open_storage(p)
    try:
        node = fs.getNode("cameras")
        if not node.isSeq() or node.size() == 0:
            raise ValueError(f"{p}: not a sogdd rig.yaml (no cameras)")
        cams = {}
        for i in range(node.size()):
            n = node.at(i).string()
            K, D = fs.getNode(f"camera_matrix_{n}").mat(), fs.getNode(f"distortion_coefficients_{n}").mat()
            R, T = fs.getNode(f"R_{n}").mat(), fs.getNode(f"T_{n}").mat()
            size = fs.getNode(f"image_size_{n}")
            if any(m is None for m in (K, D, R, T)) or K.shape != (3, 3) or R.shape != (3, 3) \
                    or T.size != 3 or size.size() != 2:
                raise ValueError(f"{p}: camera {n}'s nodes are missing or malformed")
            cams[n] = {"model": fs.getNode(f"model_{n}").string() or "pinhole", "camera_matrix": K,
                       "distortion_coefficients": D.ravel(), "R": R, "T": T.ravel(),
                       "image_size": (int(size.at(0).real()), int(size.at(1).real()))}
        out: dict = {"cameras": cams, "rms": fs.getNode("rms").real(), "sigma": fs.getNode("sigma").real(),
                     "square": fs.getNode("square").real()}
        if not fs.getNode("E").empty():
            out["stereo"] = {k: fs.getNode(k).mat() for k in STEREO_KEYS}
            out["stereo"]["T"] = out["stereo"]["T"].ravel()
        return out
    finally:
        fs.release()


def write_rig_json(rig: RigCalibration, path: str | os.PathLike) -> Path:
    """Write :func:`rig_dict` as indented JSON."""
    path = Path(path)
    write_text(path, json.dumps(rig_dict(rig), indent=2) + "\n")
    return path


def write_rig(rig: RigCalibration, out_dir: str | os.PathLike, *, inputs: Iterable[str | os.PathLike] = (),
              views: Mapping[str, Sequence[ViewRecord]] | None = None) -> dict[str, Path]:
    """Write rig.yaml, rig.json and each camera's ``NAME/`` files into ``out_dir`` (created if needed).

    Parameters
    ----------
    rig : RigCalibration
    out_dir : path
    inputs : paths
        Files that must never be overwritten (the images): a target that is one
        of them raises ``ValueError`` before that camera's files are written.
    views : mapping of camera name to sequence of ViewRecord, optional
        Per camera, every input's fate, for its views.csv and camera.json.

    Returns
    -------
    dict
        Name relative to ``out_dir`` (``rig.yaml``, ``left/camera.yaml``, ...) -> path written.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> with tempfile.TemporaryDirectory() as d:
    ...     files = write_rig(demo_rig(), d)
    >>> sorted(files)[:4]
    ['left/camera.json', 'left/camera.yaml', 'left/corners.csv', 'left/views.csv']
    """
    out = Path(out_dir)
    check_camera_names(rig.names)
    inputs = list(inputs)
    check_not_inputs([("output", out / n) for n in RIG_FILES], inputs)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    files = {"rig.yaml": write_rig_yaml(rig, out / "rig.yaml"),
             "rig.json": write_rig_json(rig, out / "rig.json")}
    for c in rig.cameras:
        own = write_calibration(c.calibration, out / c.name, inputs=inputs,
                                views=None if views is None else views.get(c.name))
        files.update({f"{c.name}/{n}": own[n] for n in FILES})
    return files
