"""sogdd's own files as an exchange format: ``camera.yaml`` / ``camera.json``, ``rig.yaml`` / ``rig.json``,
or an output folder holding them (``sogdd calibrate --out``).

Read through :func:`sogdd.calib.files.read_camera` and :func:`sogdd.calib.rig.read_rig` (a
``rig.json`` by its ``cameras`` list, :func:`~sogdd.calib.rig.files.rig_dict`'s), with the
uncertainties the files hold (:class:`~.stored.StoredCamera` ``std``, ``rms``, ``pose_std``;
:attr:`~.stored.StoredRig.square`): camera.json's ``std``, camera.yaml's ``std_intrinsics``,
rig.json's per camera; a rig.yaml takes them from the rig.json, or each ``NAME/camera.yaml``,
beside it (its pose's only from rig.json). This is the one reader of sogdd's own files as they are
stored (``sogdd convert``, ``sogdd check``). Written
(``--to sogdd``) as the OpenCV FileStorage nodes those readers read, and nothing of a fit's
diagnostics (a converted camera has none): one camera as ``camera.yaml`` (``model``,
``image_width``, ``image_height``, ``camera_matrix``, ``distortion_coefficients``), a rig as
``rig.yaml`` (``cameras``; per camera ``model_NAME``, ``camera_matrix_NAME``,
``distortion_coefficients_NAME``, ``image_size_NAME``, ``R_NAME``, ``T_NAME``, in the first
camera's frame). ``path`` is that file, or a folder to hold it.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np

from ...formats.safe_write import atomic_write, check_not_inputs
from ..files import open_storage, read_camera
from ..rig.files import check_camera_names, read_rig, write_camera_nodes
from .format import ExchangeFormat
from .stored import StoredCamera, StoredRig

__all__ = ["FORMAT", "read", "sniff", "write"]

_FILES = ("rig.yaml", "rig.json", "camera.yaml", "camera.json")


def _storage(tmp: Path, rig: StoredRig) -> None:
    fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_FORMAT_YAML)
    if not fs.isOpened():
        raise OSError(f"{tmp}: cannot be written")
    if len(rig.cameras) == 1:
        cam = rig.cameras[0]
        fs.write("model", cam.model)
        fs.write("image_width", cam.image_size[0])
        fs.write("image_height", cam.image_size[1])
        fs.write("camera_matrix", np.asarray(cam.K, np.float64))
        fs.write("distortion_coefficients", np.asarray(cam.dist, np.float64).reshape(1, -1))
    else:
        fs.startWriteStruct("cameras", cv2.FileNode_SEQ)
        for n in rig.names:
            fs.write("", n)
        fs.endWriteStruct()
        for c in rig.cameras:
            write_camera_nodes(fs, c)
    fs.release()


def write(rig: StoredRig, path: Path, inputs: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """One camera as ``camera.yaml``, a rig as ``rig.yaml`` (module doc): ``path`` itself when it ends in
    ``.yaml``, else that file in the folder ``path``; the file written (never one of ``inputs``, nor a
    file of ``sogdd calibrate``'s output folder)."""
    path = Path(path)
    if len(rig.cameras) > 1:
        check_camera_names(rig.names)
        rig = rig.relative()
    target = path if path.suffix.lower() in (".yaml", ".yml") else \
        path / ("camera.yaml" if len(rig.cameras) == 1 else "rig.yaml")
    check_not_inputs([("output", target)], inputs)
    if target.exists() and any((target.parent / n).is_file() for n in ("camera.json", "rig.json")):
        raise ValueError(f"{target}: part of a sogdd calibrate output folder, whose other files would no "
                         "longer agree with it; write it elsewhere")
    target.parent.mkdir(parents=True, exist_ok=True)
    return [atomic_write(target, lambda tmp: _storage(tmp, rig))]


def _one(d: dict, name: str, where: Path, std=None, pose_std=None) -> StoredCamera:
    try:
        return StoredCamera(name, d["model"], d["camera_matrix"], np.ravel(d["distortion_coefficients"]),
                            d.get("image_size") or (d["image_width"], d["image_height"]), d.get("R", np.eye(3)),
                            np.ravel(d.get("T", np.zeros(3))), std, _rms(d.get("rms")), pose_std)
    except (KeyError, TypeError) as exc:
        raise ValueError(f"{where}: camera {name!r} lacks {exc}") from None
    except ValueError as exc:
        raise ValueError(f"{where}: camera {name!r}: {exc}") from None


def _positive(v) -> float | None:
    """A positive finite number, or None."""
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and v > 0 else None


def _rms(v) -> float:
    """A stored RMS, NaN unknown (FileStorage reads a missing one as 0)."""
    v = _positive(v)
    return math.nan if v is None else v


def _json(path: Path) -> dict:
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a sogdd camera.json or rig.json ({exc})") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: not a sogdd camera.json or rig.json")
    return d


def _rig_json(d: dict, path: Path) -> StoredRig:
    try:
        cams = d["cameras"]
        return StoredRig(tuple(_one(c, c["name"], path, c.get("std"), c.get("std")) for c in cams),
                         _positive(d.get("square")))
    except (KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not a sogdd rig.json ({exc})") from None


def _nodes(path: Path, *names: str) -> list:
    """FileStorage nodes of ``path`` as matrices or numbers (None where missing)."""
    fs = open_storage(path)
    try:
        nodes = [fs.getNode(n) for n in names]
        return [None if n.empty() else n.mat() if n.isMap() else n.real() for n in nodes]
    finally:
        fs.release()


def _rig_yaml(path: Path) -> StoredRig:
    d = read_rig(path)
    stds: dict = {}
    beside = path.with_name("rig.json")  # the standard deviations rig.yaml does not hold
    if beside.is_file():
        try:
            stds = {c["name"]: c.get("std") for c in _json(beside)["cameras"]}
        except (ValueError, KeyError, TypeError):
            stds = {}
    cams = []
    for name, c in d["cameras"].items():
        std, own = stds.get(name), path.parent / name / "camera.yaml"
        if not std and own.is_file():
            try:
                std = _nodes(own, "std_intrinsics")[0]
            except ValueError:  # a camera.yaml beside that cannot be read holds no standard deviation
                std = None
        cams.append(_one({**c, "rms": _nodes(path, f"rms_{name}")[0]}, name, path, std, stds.get(name)))
    return StoredRig(tuple(cams), _positive(d["square"]))


def read(path: Path) -> StoredRig:
    """A sogdd camera or rig file, or the output folder holding one (a rig's files first), with the
    uncertainties the files hold (module doc). A one-line ``ValueError`` for a missing file or one
    that is no such calibration.

    Examples
    --------
    >>> import tempfile
    >>> from sogdd.calib.demo import demo_calibration
    >>> from sogdd.calib.files import write_calibration
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = write_calibration(demo_calibration(), d)
    ...     rig = read(Path(d) / "camera.yaml")
    >>> rig.names, rig.cameras[0].image_size, bool(rig.cameras[0].std["fx"] > 0), rig.square
    (('camera',), (640, 480), True, 1.0)
    """
    path = Path(path)
    if path.is_dir():
        found = [path / n for n in _FILES if (path / n).is_file()]
        if not found:
            raise ValueError(f"{path}: no {', '.join(_FILES)} in the folder")
        path = found[0]
    elif not path.is_file():
        raise ValueError(f"{path}: no such file" if not path.exists() else f"{path}: not a file")
    if path.suffix.lower() == ".json":
        d = _json(path)
        if "cameras" in d:
            return _rig_json(d, path)
        std, square = d.get("std"), d.get("square")
    else:
        rig, std, square = _nodes(path, "cameras", "std_intrinsics", "square")
        if rig is not None:
            return _rig_yaml(path)
    return StoredRig((_one(read_camera(path), "camera", path, std),), _positive(square))


def sniff(path: Path) -> bool:
    """An output folder holding one of sogdd's camera or rig files, a ``.json`` with sogdd's
    ``camera_matrix`` or ``cameras``, or an OpenCV FileStorage ``.yaml`` (``%YAML`` and ``!!opencv-matrix``)."""
    path = Path(path)
    if path.is_dir():
        return any((path / n).is_file() for n in _FILES)
    if not path.is_file():
        return False
    try:
        head = path.read_text(encoding="utf-8", errors="replace")[:65536]
    except OSError:
        return False
    if path.suffix.lower() == ".json":
        return '"camera_matrix"' in head or '"cameras"' in head
    return path.suffix.lower() in (".yaml", ".yml") and head.startswith("%YAML") and "!!opencv-matrix" in head


#: the record
FORMAT = ExchangeFormat(name="sogdd", summary="sogdd's own camera.yaml / rig.yaml (OpenCV FileStorage), "
                        "camera.json / rig.json, or an output folder", sniff=sniff, read=read, write=write)
