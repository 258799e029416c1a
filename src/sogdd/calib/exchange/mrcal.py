"""mrcal's ``.cameramodel``: a Python literal dict, what ``mrcal.cameramodel`` reads and writes.

Keys: ``lensmodel``, ``intrinsics`` (``fx, fy, cx, cy``, then the coefficients in the lens model's
order), ``imagersize`` ``[w, h]`` and ``extrinsics``, mrcal's ``rt_cam_ref``: a Rodrigues vector
and a translation taking the reference frame to the camera's, :math:`x_{cam} = R(r)\\,x_{ref} + t`,
which is sogdd's ``(R, T)`` as it stands. mrcal counts pixels as sogdd does (centres at integers).

================  =====================  ==============================================
sogdd model       ``lensmodel``          ``intrinsics`` after fx, fy, cx, cy
================  =====================  ==============================================
pinhole4          LENSMODEL_OPENCV4      k1, k2, p1, p2
pinhole           LENSMODEL_OPENCV5      k1, k2, p1, p2, k3
rational          LENSMODEL_OPENCV8      k1, k2, p1, p2, k3, k4, k5, k6
fisheye           refused                mrcal has no OpenCV equidistant fisheye model
omnidir           refused                mrcal has no unified omnidirectional model
================  =====================  ==============================================

mrcal's coefficient order is OpenCV's (it calls them ``distortion0`` ...): the same vector.
``LENSMODEL_PINHOLE`` reads as pinhole4 with no distortion; mrcal's other models (splined,
CAHVOR(E), stereographic, OpenCV12) have no sogdd model and are refused. Any skew is refused
(mrcal's OpenCV models have none).

One camera: the file ``path`` (``.cameramodel``). A rig: a folder of
``camera-0.cameramodel``, ``camera-1.cameramodel``, ... as ``mrcal-calibrate-cameras`` names
them, in the rig's order, each opening with a comment ``# sogdd camera: NAME`` that gives the
name back (a file without one is named by its file name).
"""

from __future__ import annotations

import ast
import os
import re
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np

from .format import ExchangeFormat, no_skew, write_files
from .stored import StoredCamera, StoredRig

__all__ = ["FORMAT", "LENSMODELS", "cameramodel_text", "read", "read_file", "sniff", "write"]

#: sogdd model -> mrcal lens model
LENSMODELS = {"pinhole4": "LENSMODEL_OPENCV4", "pinhole": "LENSMODEL_OPENCV5", "rational": "LENSMODEL_OPENCV8"}
_WHY = {"fisheye": "mrcal has no OpenCV equidistant fisheye model (its wide-angle models are splined "
                   "stereographic and CAHVORE: calibrate in mrcal)",
        "omnidir": "mrcal has no unified omnidirectional (Mei) model"}
_NAME = re.compile(r"^# sogdd camera: (.*)$", re.M)


def _list(values) -> str:
    return "[ " + ", ".join(repr(float(v)) for v in values) + ",]"


def cameramodel_text(cam: StoredCamera) -> str:
    """One camera as a ``.cameramodel`` (module doc), the extrinsics its pose.

    Examples
    --------
    >>> cam = StoredCamera("left", "pinhole4", [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]], [-0.1, 0, 0, 0],
    ...                    (640, 480))
    >>> print(cameramodel_text(cam).splitlines()[3])
        'intrinsics': [ 500.0, 500.0, 320.0, 240.0, -0.1, 0.0, 0.0, 0.0,],
    """
    if cam.model not in LENSMODELS:
        raise ValueError(f"camera {cam.name!r}: {_WHY.get(cam.model, f'mrcal has no {cam.model} model')}")
    if "\n" in cam.name:
        raise ValueError(f"camera name {cam.name!r}: one line, please")
    no_skew(cam, "mrcal's OpenCV models")
    K = cam.K
    rvec = cv2.Rodrigues(np.asarray(cam.R, np.float64))[0].ravel()
    return (f"# sogdd camera: {cam.name}\n{{\n    'lensmodel':  '{LENSMODELS[cam.model]}',\n"
            f"    'intrinsics': {_list([K[0, 0], K[1, 1], K[0, 2], K[1, 2], *cam.dist])},\n"
            f"    'imagersize': [ {cam.image_size[0]}, {cam.image_size[1]},],\n"
            f"    # rt_cam_ref: x_cam = R(r) x_ref + t\n    'extrinsics': {_list([*rvec, *cam.T])},\n}}\n")


def write(rig: StoredRig, path: Path, inputs: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """One camera as ``path`` (a ``.cameramodel``, or ``path/camera-0.cameramodel``); a rig as
    ``path/camera-K.cameramodel``; the files written."""
    path = Path(path)
    texts = [cameramodel_text(c) for c in rig.cameras]  # all refusals before anything is written
    if path.suffix.lower() == ".cameramodel":
        if len(texts) > 1:
            raise ValueError(f"{path}: a rig of {len(texts)} cameras is one .cameramodel per camera: give a "
                             "folder")
        return write_files({path: texts[0]}, inputs)
    return write_files({path / f"camera-{k}.cameramodel": t for k, t in enumerate(texts)}, inputs)


def read_file(path: Path) -> StoredCamera:
    """One ``.cameramodel``: the camera with its extrinsics as its pose."""
    path = Path(path)
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        d = ast.literal_eval(text.strip())
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        raise ValueError(f"{path}: not an mrcal .cameramodel (not a Python literal dict)") from None
    if not isinstance(d, dict) or "lensmodel" not in d or "intrinsics" not in d:
        raise ValueError(f"{path}: not an mrcal .cameramodel (no lensmodel and intrinsics)")
    lensmodel = str(d["lensmodel"])
    n = {"LENSMODEL_PINHOLE": 0, "LENSMODEL_OPENCV4": 4, "LENSMODEL_OPENCV5": 5,
         "LENSMODEL_OPENCV8": 8}.get(lensmodel)
    if n is None:
        raise ValueError(f"{path}: {lensmodel} has no sogdd model (sogdd reads LENSMODEL_PINHOLE and "
                         "LENSMODEL_OPENCV4, 5 and 8)")
    try:
        intr = np.array([float(v) for v in d["intrinsics"]], dtype=np.float64)
        rt = np.array([float(v) for v in d.get("extrinsics", [0.0] * 6)], dtype=np.float64)
        w, h = (int(v) for v in d["imagersize"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{path}: intrinsics, extrinsics and imagersize must be numbers") from None
    if len(intr) != 4 + n or len(rt) != 6:
        raise ValueError(f"{path}: {lensmodel} has {4 + n} intrinsics and 6 extrinsics; the file has "
                         f"{len(intr)} and {len(rt)}")
    model = "pinhole4" if n == 0 else next(m for m, lm in LENSMODELS.items() if lm == lensmodel)
    dist = np.zeros(4) if n == 0 else intr[4:]
    m = _NAME.search(text.split("{", 1)[0])
    K = [[intr[0], 0, intr[2]], [0, intr[1], intr[3]], [0, 0, 1]]
    try:
        return StoredCamera(m.group(1) if m else path.stem, model, K, dist, (w, h),
                            cv2.Rodrigues(rt[:3].reshape(3, 1))[0], rt[3:])
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _order(p: Path) -> tuple:
    return tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.stem))


def read(path: Path) -> StoredRig:
    """A ``.cameramodel`` (one camera), or a folder's ``*.cameramodel`` (a rig, in the numbers' order)."""
    path = Path(path)
    if not path.is_dir():
        return StoredRig((read_file(path),))
    files = sorted(path.glob("*.cameramodel"), key=_order)
    if not files:
        raise ValueError(f"{path}: no .cameramodel in the folder")
    try:
        return StoredRig(tuple(read_file(p) for p in files))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def sniff(path: Path) -> bool:
    """A ``.cameramodel`` file, or a folder holding some."""
    path = Path(path)
    if path.is_dir():
        return any(path.glob("*.cameramodel"))
    return path.suffix.lower() == ".cameramodel"


#: the record
FORMAT = ExchangeFormat(name="mrcal", summary="mrcal's .cameramodel (LENSMODEL_OPENCV4/5/8; a rig as "
                        "camera-K.cameramodel files with their extrinsics)", sniff=sniff, read=read,
                        write=write)
