"""ROS ``camera_info`` YAML, as ``camera_calibration_parsers`` reads and writes it (``sensor_msgs/CameraInfo``).

Fields, in the order ROS writes them: ``image_width``, ``image_height``, ``camera_name``,
``camera_matrix`` (``rows: 3``, ``cols: 3``, ``data`` row by row: ``K``),
``distortion_model``, ``distortion_coefficients`` (``rows: 1``, ``cols: N``, ``data``: ``D``),
``rectification_matrix`` (3 x 3, ``R``), ``projection_matrix`` (3 x 4, ``P``). Pixel centres at
integers, as sogdd's.

================  =======================  ==========================================
sogdd model       ``distortion_model``     ``D``
================  =======================  ==========================================
pinhole4          ``plumb_bob``            k1, k2, p1, p2 (four values)
pinhole           ``plumb_bob``            k1, k2, p1, p2, k3
rational          ``rational_polynomial``  k1, k2, p1, p2, k3, k4, k5, k6
fisheye           ``equidistant``          k1, k2, k3, k4
omnidir           refused                  ROS has no unified omnidirectional model
================  =======================  ==========================================

One camera: one file, ``R`` the identity and ``P = [K | 0]``. A stereo pair: ``left.yaml``
and ``right.yaml`` in a folder (the first camera left), ``R`` and ``P`` from
``cv2.stereoRectify`` (``alpha = 0``, ``CALIB_ZERO_DISPARITY``; ``cv2.fisheye.stereoRectify``
for two fisheyes: :func:`~sogdd.calib.rig.stereo.stereo_pair`), so
``P_right[0, 3] = -f' B`` (``B`` the baseline in the calibration's unit; ROS wants metres).
The pair's pose comes back from them: with :math:`x_{r,i} = R_i x_i` and
:math:`P_2[:, 3] = f' t'`, :math:`R = R_2^T R_1` and
:math:`T = R_2^T (P_2[0, 3] / P_2[0, 0],\\; P_2[1, 3] / P_2[1, 1],\\; 0)`. A rig of three or more
cameras is refused (``camera_info`` holds no pose but a pair's rectification).
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..rig.stereo import stereo_pair
from .format import ExchangeFormat, load_yaml, write_files, yaml_float
from .stored import StoredCamera, StoredRig

__all__ = ["FORMAT", "MODELS", "camera_info_text", "read", "read_file", "sniff", "write"]

#: sogdd model -> ROS ``distortion_model``
MODELS = {"pinhole4": "plumb_bob", "pinhole": "plumb_bob", "rational": "rational_polynomial",
          "fisheye": "equidistant"}
#: (``distortion_model``, number of coefficients) -> sogdd model
_BACK = {("plumb_bob", 4): "pinhole4", ("plumb_bob", 5): "pinhole", ("rational_polynomial", 8): "rational",
         ("equidistant", 4): "fisheye"}
_PAIR = ("left.yaml", "right.yaml")
_PLAIN = re.compile(r"[A-Za-z0-9_/-]+")


def _matrix(key: str, m: np.ndarray) -> str:
    m = np.atleast_2d(m)
    data = ", ".join(yaml_float(v) for v in m.ravel())
    return f"{key}:\n  rows: {m.shape[0]}\n  cols: {m.shape[1]}\n  data: [{data}]\n"


def camera_info_text(cam: StoredCamera, R: np.ndarray | None = None, P: np.ndarray | None = None) -> str:
    """One camera's ``camera_info`` YAML (``R`` the identity and ``P = [K | 0]`` by default).

    Examples
    --------
    >>> cam = StoredCamera("left", "pinhole4", [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]], [-0.1, 0, 0, 0],
    ...                    (640, 480))
    >>> print(camera_info_text(cam))  # doctest: +ELLIPSIS
    image_width: 640
    image_height: 480
    camera_name: left
    camera_matrix:
      rows: 3
      cols: 3
      data: [500.0, 0.0, 320.0, 0.0, 500.0, 240.0, 0.0, 0.0, 1.0]
    distortion_model: plumb_bob
    distortion_coefficients:
      rows: 1
      cols: 4
      data: [-0.1, 0.0, 0.0, 0.0]
    rectification_matrix:
    ...
    """
    if cam.model not in MODELS:
        raise ValueError(f"camera {cam.name!r}: ROS camera_info has no {cam.model} model (its models are "
                         "plumb_bob, rational_polynomial and equidistant)")
    R = np.eye(3) if R is None else np.asarray(R, np.float64)
    P = np.c_[cam.K, np.zeros(3)] if P is None else np.asarray(P, np.float64)
    name = cam.name if _PLAIN.fullmatch(cam.name) else json.dumps(cam.name)
    return (f"image_width: {cam.image_size[0]}\nimage_height: {cam.image_size[1]}\ncamera_name: {name}\n"
            + _matrix("camera_matrix", cam.K) + f"distortion_model: {MODELS[cam.model]}\n"
            + _matrix("distortion_coefficients", cam.dist.reshape(1, -1))
            + _matrix("rectification_matrix", R) + _matrix("projection_matrix", P))


def write(rig: StoredRig, path: Path, inputs: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """Write one camera as ``path`` (a ``.yaml`` file, or ``NAME.yaml`` in the folder ``path``), a pair as
    ``path/left.yaml`` and ``path/right.yaml`` (module doc); the files written."""
    path = Path(path)
    if len(rig.cameras) == 1:
        cam = rig.cameras[0]
        target = path if path.suffix.lower() in (".yaml", ".yml") else path / f"{cam.name}.yaml"
        return write_files({target: camera_info_text(cam)}, inputs)
    if len(rig.cameras) != 2:
        raise ValueError(f"ROS camera_info holds one camera or a stereo pair; this rig has {len(rig.cameras)} "
                         "cameras (convert a pair of them, or use kalibr, mrcal or colmap)")
    if path.suffix.lower() in (".yaml", ".yml"):
        raise ValueError(f"{path}: a stereo pair is two files, left.yaml and right.yaml: give a folder")
    for cam in rig.cameras:
        camera_info_text(cam)  # refuses a model ROS cannot hold before anything is written
    pair = stereo_pair(rig.relative())  # type: ignore[arg-type]  # it reads the cameras' K, dist, model, R, T
    left, right = rig.cameras
    return write_files({path / _PAIR[0]: camera_info_text(left, pair.R1, pair.P1),
                        path / _PAIR[1]: camera_info_text(right, pair.R2, pair.P2)}, inputs)


def _field(d: dict, key: str, shape: tuple[int, int] | None, where: Path) -> np.ndarray:
    node = d.get(key)
    try:
        data = np.array([float(v) for v in node["data"]], dtype=np.float64)
        rows, cols = int(node["rows"]), int(node["cols"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{where}: {key} must have rows, cols and data (numbers)") from None
    if data.size != rows * cols or (shape is not None and (rows, cols) != shape):
        raise ValueError(f"{where}: {key} is {rows} x {cols} with {data.size} values"
                         + (f"; ROS's is {shape[0]} x {shape[1]}" if shape else ""))
    return data.reshape(rows, cols)


def read_file(path: Path) -> tuple[StoredCamera, np.ndarray, np.ndarray]:
    """One ``camera_info`` file: the camera (identity pose) and its ``R`` (3 x 3) and ``P`` (3 x 4)."""
    d = load_yaml(path)
    if not isinstance(d, dict) or "camera_matrix" not in d:
        raise ValueError(f"{path}: not a ROS camera_info file (no camera_matrix)")
    K = _field(d, "camera_matrix", (3, 3), path)
    D = _field(d, "distortion_coefficients", None, path).ravel() if "distortion_coefficients" in d \
        else np.zeros(0)
    kind = str(d.get("distortion_model", "plumb_bob"))
    if kind == "plumb_bob" and len(D) == 0:
        D = np.zeros(4)
    model = _BACK.get((kind, len(D)))
    if model is None:
        raise ValueError(f"{path}: distortion_model {kind} with {len(D)} coefficients has no sogdd model "
                         f"(sogdd reads {', '.join(f'{k} ({n})' for k, n in _BACK)})")
    R = _field(d, "rectification_matrix", (3, 3), path) if "rectification_matrix" in d else np.eye(3)
    P = _field(d, "projection_matrix", (3, 4), path) if "projection_matrix" in d else np.c_[K, np.zeros(3)]
    try:
        size = (int(d["image_width"]), int(d["image_height"]))
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{path}: image_width and image_height must be integers") from None
    name = str(d.get("camera_name") or path.stem)
    try:
        return StoredCamera(name, model, K, D, size), R, P
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def read(path: Path) -> StoredRig:
    """One ``camera_info`` file, or a folder holding ``left.yaml`` and ``right.yaml`` (a pair, its pose
    from the rectification: module doc)."""
    path = Path(path)
    if path.is_dir() and not all((path / n).is_file() for n in _PAIR):
        path = _single(path)
    if not path.is_dir():
        return StoredRig((read_file(path)[0],))
    (left, R1, _), (right, R2, P2) = (read_file(path / n) for n in _PAIR)
    R = R2.T @ R1
    T = R2.T @ np.array([P2[0, 3] / P2[0, 0], P2[1, 3] / P2[1, 1], P2[2, 3]])
    if left.name == right.name:
        left, right = left.with_pose(left.R, left.T, "left"), right.with_pose(right.R, right.T, "right")
    return StoredRig((left, right.with_pose(R, T)))


def _single(folder: Path) -> Path:
    """The one ``camera_info`` file of a folder; a one-line ``ValueError`` for none or several."""
    found = [p for p in sorted(folder.glob("*.y*ml")) if sniff(p)]
    if len(found) != 1:
        raise ValueError(f"{folder}: {len(found)} camera_info files; ROS's folder holds one, or left.yaml and "
                         "right.yaml")
    return found[0]


def sniff(path: Path) -> bool:
    """A ``.yaml`` file with ``camera_matrix`` and ``distortion_model`` keys at the top level, or a folder
    with ``left.yaml`` and ``right.yaml`` that are, or with one that is."""
    path = Path(path)
    if path.is_dir():
        if all((path / n).is_file() for n in _PAIR):
            return all(sniff(path / n) for n in _PAIR)
        return sum(sniff(p) for p in path.glob("*.y*ml")) == 1
    if path.suffix.lower() not in (".yaml", ".yml") or not path.is_file():
        return False
    try:
        text = path.read_text(encoding="utf-8", errors="replace")[:65536]
    except OSError:
        return False
    return "!!opencv-matrix" not in text and all(re.search(rf"^{k}\s*:", text, re.M)
                                                    for k in ("camera_matrix", "distortion_model"))


#: the record
FORMAT = ExchangeFormat(name="ros", summary="ROS camera_info YAML (one camera, or a stereo pair as left.yaml "
                        "and right.yaml)", sniff=sniff, read=read, write=write, needs="pyyaml (to read)")
