"""COLMAP cameras and rigs, through pycolmap: a model folder's ``cameras.txt`` and ``rigs.txt``.

Written by ``pycolmap.Reconstruction.write_text`` (``cameras.txt``, ``rigs.txt`` and the empty
``frames.txt``, ``images.txt``, ``points3D.txt`` COLMAP expects beside them), read by
``pycolmap.Reconstruction`` (text or binary). Camera ``k + 1`` is the rig's camera ``k``; one rig
holds them all, the first the reference sensor, each other's ``sensor_from_rig`` its pose
:math:`x_{cam} = R\\,x_{ref} + T` (a quaternion and a translation in COLMAP's text).

COLMAP puts pixel centres at half-integers: its principal point is sogdd's plus 0.5
(``cx + 0.5``, ``cy + 0.5``), so that a point projects to COLMAP's pixel = sogdd's + 0.5.

================  ===================  ==========================================
sogdd model       COLMAP model         params
================  ===================  ==========================================
pinhole4          ``OPENCV``           fx, fy, cx, cy, k1, k2, p1, p2
pinhole           ``FULL_OPENCV``      fx, fy, cx, cy, k1, k2, p1, p2, k3, 0, 0, 0
rational          ``FULL_OPENCV``      fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6
fisheye           ``OPENCV_FISHEYE``   fx, fy, cx, cy, k1, k2, k3, k4
omnidir           refused              COLMAP has no unified omnidirectional model
================  ===================  ==========================================

Read back, ``FULL_OPENCV`` is the pinhole model where ``k4 = k5 = k6 = 0`` (the same camera) and
the rational one otherwise; COLMAP's ``SIMPLE_PINHOLE``, ``PINHOLE``, ``SIMPLE_RADIAL`` and
``RADIAL`` are pinhole4 with the coefficients they have (the others 0). Any skew is refused (COLMAP's
models have none). A folder of several cameras is read as one rig only if one rig holds them all.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from .format import ExchangeFormat, no_skew, write_files
from .stored import StoredCamera, StoredRig

__all__ = ["FORMAT", "MODELS", "colmap_params", "read", "require_pycolmap", "sniff", "write"]

#: sogdd model -> COLMAP camera model
MODELS = {"pinhole4": "OPENCV", "pinhole": "FULL_OPENCV", "rational": "FULL_OPENCV",
          "fisheye": "OPENCV_FISHEYE"}
#: COLMAP model -> (sogdd model, indices of the coefficients among k1, k2, p1, p2 (pinhole4's))
_SIMPLE = {"SIMPLE_PINHOLE": (), "PINHOLE": (), "SIMPLE_RADIAL": (0,), "RADIAL": (0, 1)}


def require_pycolmap():
    """pycolmap, or a one-line ``ValueError`` saying how to install it."""
    try:
        import pycolmap
    except ImportError:
        raise ValueError("COLMAP files need pycolmap: pip install 'sogdd[formats]' (or pip install pycolmap)") \
            from None
    return pycolmap


def colmap_params(cam: StoredCamera) -> tuple[str, list[float]]:
    """The COLMAP model and its parameters for a camera (module doc: principal point + 0.5).

    Examples
    --------
    >>> cam = StoredCamera("c", "pinhole4", [[500.0, 0, 320], [0, 510, 240], [0, 0, 1]], [-0.1, 0, 0, 0],
    ...                    (640, 480))
    >>> colmap_params(cam)
    ('OPENCV', [500.0, 510.0, 320.5, 240.5, -0.1, 0.0, 0.0, 0.0])
    """
    if cam.model not in MODELS:
        raise ValueError(f"camera {cam.name!r}: COLMAP has no {cam.model} model (sogdd writes "
                         "OPENCV, FULL_OPENCV and OPENCV_FISHEYE)")
    no_skew(cam, "COLMAP")
    K = cam.K
    dist = [float(v) for v in cam.dist] + ([0.0, 0.0, 0.0] if cam.model == "pinhole" else [])
    return MODELS[cam.model], [float(K[0, 0]), float(K[1, 1]), float(K[0, 2]) + 0.5, float(K[1, 2]) + 0.5,
                               *dist]


def write(rig: StoredRig, path: Path, inputs: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """Write the rig's cameras and their poses as a COLMAP text model in the folder ``path``; the files.

    A folder holding a reconstruction (images, frames or points, which the model's empty files would
    replace) is refused."""
    path = Path(path)
    params = [colmap_params(c) for c in rig.cameras]  # refusals first
    held = _reconstruction(path)
    if held:
        raise ValueError(f"{path}: holds a COLMAP reconstruction ({held}), which the cameras' files would "
                         "replace; write them into a new folder")
    pycolmap = require_pycolmap()
    rig = rig.relative()
    rec = pycolmap.Reconstruction()
    prig = pycolmap.Rig(rig_id=1)
    for k, (cam, (model, p)) in enumerate(zip(rig.cameras, params)):
        rec.add_camera(pycolmap.Camera(model=model, width=cam.image_size[0], height=cam.image_size[1], params=p,
                                       camera_id=k + 1))
        sensor = pycolmap.sensor_t(type=pycolmap.SensorType.CAMERA, id=k + 1)
        if k == 0:
            prig.add_ref_sensor(sensor)
        else:
            prig.add_sensor(sensor, pycolmap.Rigid3d(pycolmap.Rotation3d(np.asarray(cam.R, np.float64)),
                                                     np.asarray(cam.T, np.float64)))
    rec.add_rig(prig)
    with tempfile.TemporaryDirectory(prefix="sogdd-colmap-") as tmp:
        rec.write_text(tmp)
        files = {path / p.name: p.read_text(encoding="utf-8") for p in sorted(Path(tmp).iterdir())}
    return write_files(files, inputs)


def _reconstruction(folder: Path) -> str:
    """The files of ``folder`` holding images, frames or points (writing would empty them); "" if none."""
    held = []
    for n in ("images", "frames", "points3D"):
        txt, binary = folder / f"{n}.txt", folder / f"{n}.bin"
        if txt.is_file() and any(ln.strip() and not ln.lstrip().startswith("#")
                                 for ln in txt.read_text(encoding="utf-8", errors="replace").splitlines()):
            held.append(txt.name)
        if binary.is_file() and binary.stat().st_size > 8:  # more than its count
            held.append(binary.name)
    return ", ".join(held)


def _camera(cam, name: str) -> StoredCamera:
    model = cam.model.name
    p = np.asarray(cam.params, dtype=np.float64)
    if model in _SIMPLE:
        idx = _SIMPLE[model]
        n_focal = 1 if model.startswith("SIMPLE") or model == "RADIAL" else 2
        fx, fy = (p[0], p[0]) if n_focal == 1 else (p[0], p[1])
        cx, cy = p[n_focal], p[n_focal + 1]
        dist = np.zeros(4)
        dist[list(idx)] = p[n_focal + 2:]
        sogdd = "pinhole4"
    elif model in ("OPENCV", "FULL_OPENCV", "OPENCV_FISHEYE"):
        fx, fy, cx, cy = p[:4]
        dist = p[4:]
        sogdd = {"OPENCV": "pinhole4", "OPENCV_FISHEYE": "fisheye"}.get(model, "rational")
        if model == "FULL_OPENCV" and not np.any(dist[5:]):
            sogdd, dist = "pinhole", dist[:5]
    else:
        raise ValueError(f"camera {cam.camera_id}: COLMAP's {model} has no sogdd model (sogdd reads OPENCV, "
                         f"FULL_OPENCV, OPENCV_FISHEYE, {', '.join(_SIMPLE)})")
    return StoredCamera(name, sogdd, [[fx, 0, cx - 0.5], [0, fy, cy - 0.5], [0, 0, 1]], dist,
                        (int(cam.width), int(cam.height)))


def _complete(folder: Path, tmp: Path) -> Path:
    """``folder``, or where it lacks the images and points COLMAP reads beside its cameras (a camera file
    alone), a copy of its cameras in ``tmp`` with none of them."""
    for ext, empty in ((".txt", b""), (".bin", bytes(8))):  # a binary file of none: its count, 0 (uint64)
        cams = folder / f"cameras{ext}"
        if cams.is_file():
            if all((folder / f"{n}{ext}").is_file() for n in ("images", "points3D")):
                return folder
            (tmp / cams.name).write_bytes(cams.read_bytes())
            for n in ("images", "points3D"):
                (tmp / f"{n}{ext}").write_bytes(empty)
            return tmp
    return folder


def read(path: Path) -> StoredRig:
    """A COLMAP model folder (or its ``cameras.txt`` / ``cameras.bin``): its cameras and their rig's poses."""
    path = Path(path)
    if path.is_file():
        path = path.parent
    pycolmap = require_pycolmap()
    with tempfile.TemporaryDirectory(prefix="sogdd-colmap-") as tmp:
        try:
            rec = pycolmap.Reconstruction(str(_complete(path, Path(tmp))))
        except Exception as exc:  # pycolmap raises its own (C++) errors for a folder that is not a model
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ValueError(f"{path}: not a COLMAP model ({first})") from None
    ids = sorted(rec.cameras)
    if not ids:
        raise ValueError(f"{path}: a COLMAP model without cameras")
    try:
        cams = {i: _camera(rec.cameras[i], f"camera{i}") for i in ids}
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    if len(ids) == 1:
        return StoredRig((cams[ids[0]],))
    holding = [r for r in rec.rigs.values()
               if {s.id for s in r.sensor_ids() if s.type == pycolmap.SensorType.CAMERA} >= set(ids)]
    if not holding:
        raise ValueError(f"{path}: {len(ids)} cameras and no rig holding them all: their poses are unknown")
    prig = holding[0]
    ref = prig.ref_sensor_id.id
    out = [cams[ref]]
    for i in ids:
        if i == ref:
            continue
        pose = prig.sensor_from_rig(pycolmap.sensor_t(type=pycolmap.SensorType.CAMERA, id=i))
        if pose is None:
            raise ValueError(f"{path}: camera {i} has no pose in its rig")
        out.append(cams[i].with_pose(pose.rotation.matrix(), np.asarray(pose.translation)))
    return StoredRig(tuple(out))


def sniff(path: Path) -> bool:
    """A folder holding ``cameras.txt`` or ``cameras.bin``, or one of those files."""
    path = Path(path)
    if path.is_dir():
        return (path / "cameras.txt").is_file() or (path / "cameras.bin").is_file()
    return path.name in ("cameras.txt", "cameras.bin")


#: the record
FORMAT = ExchangeFormat(name="colmap", summary="COLMAP cameras and rig (cameras.txt, rigs.txt; through "
                        "pycolmap)", sniff=sniff, read=read, write=write, needs="pycolmap")
