"""Kalibr's camera chain YAML (``camchain.yaml``, what ``kalibr_calibrate_cameras`` writes and its tools read).

One block per camera, ``cam0``, ``cam1``, ..., in the rig's order, keys as Kalibr's writer
(``yaml.dump``) orders them: ``T_cn_cnm1`` (cam1 on: the 4 x 4 transform from the previous
camera's frame to this one's, :math:`x_{n} = T\\,x_{n-1}`), ``cam_overlaps``,
``camera_model``, ``distortion_coeffs``, ``distortion_model``, ``intrinsics``, ``resolution``
``[w, h]``, ``rostopic`` (``/NAME/image_raw``: the camera's name goes out and comes back in it).
Pixel centres at integers, as sogdd's.

================  ================  =========================  =====================
sogdd model       ``camera_model``  ``intrinsics``             ``distortion_model``
================  ================  =========================  =====================
pinhole4          ``pinhole``       fu, fv, pu, pv             ``radtan`` k1, k2, p1, p2
pinhole (k3 = 0)  ``pinhole``       fu, fv, pu, pv             ``radtan`` (read back as pinhole4)
fisheye           ``pinhole``       fu, fv, pu, pv             ``equidistant`` k1, k2, k3, k4
omnidir           ``omni``          xi, fu, fv, pu, pv         ``radtan`` k1, k2, p1, p2
================  ================  =========================  =====================

Refused: a pinhole camera with ``k3 != 0`` and the rational model (Kalibr's radtan has no
``k3`` and no rational terms), and any skew (its intrinsics have none). Kalibr's
``equidistant`` is OpenCV's fisheye (Kannala-Brandt: :math:`\\theta_d = \\theta(1 + k_1\\theta^2
+ \\dots + k_4\\theta^8)`) and its ``omni`` + ``radtan`` is ``cv2.omnidir``'s model, coefficient
for coefficient. Kalibr's translations are in metres: sogdd's are in the unit of the square
(``sogdd convert --scale``).

The pose chain: sogdd's :math:`x_n = R_n x_0 + T_n` gives
:math:`T_{c_n c_{n-1}} = [R_n R_{n-1}^T \\mid T_n - R_n R_{n-1}^T T_{n-1}]`, and back
:math:`R_n = R_{rel} R_{n-1}`, :math:`T_n = R_{rel} T_{n-1} + t_{rel}`.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from .format import ExchangeFormat, load_yaml, no_skew, write_files, yaml_float
from .stored import StoredCamera, StoredRig

__all__ = ["FORMAT", "camchain_text", "read", "sniff", "write"]

_TOPIC = re.compile(r"^/?([^/]+)/image_raw$")


def _list(values) -> str:
    return "[" + ", ".join(yaml_float(v) for v in values) + "]"


def _block(cam: StoredCamera) -> list[str]:
    """The keys of one camera after ``T_cn_cnm1`` and ``cam_overlaps``."""
    no_skew(cam, "Kalibr")
    fu, fv, pu, pv = cam.K[0, 0], cam.K[1, 1], cam.K[0, 2], cam.K[1, 2]
    d = cam.dist
    if cam.model == "pinhole4" or (cam.model == "pinhole" and d[4] == 0):
        model, intr, kind, coeffs = "pinhole", [fu, fv, pu, pv], "radtan", d[:4]
    elif cam.model == "fisheye":
        model, intr, kind, coeffs = "pinhole", [fu, fv, pu, pv], "equidistant", d
    elif cam.model == "omnidir":
        model, intr, kind, coeffs = "omni", [d[0], fu, fv, pu, pv], "radtan", d[1:]
    elif cam.model == "pinhole":
        raise ValueError(f"camera {cam.name!r}: Kalibr's radtan has no k3 (k3 = {float(d[4])!r}); "
                         "calibrate with --model pinhole4 for Kalibr")
    else:
        raise ValueError(f"camera {cam.name!r}: Kalibr has no {cam.model} model (its distortions are radtan, "
                         "equidistant, fov and none)")
    return [f"  camera_model: {model}", f"  distortion_coeffs: {_list(coeffs)}", f"  distortion_model: {kind}",
            f"  intrinsics: {_list(intr)}", f"  resolution: [{cam.image_size[0]}, {cam.image_size[1]}]",
            f"  rostopic: /{cam.name}/image_raw"]


def camchain_text(rig: StoredRig) -> str:
    """The rig as Kalibr's camchain YAML (module doc).

    Examples
    --------
    >>> cam = StoredCamera("cam0", "pinhole4", [[500.0, 0, 320], [0, 500, 240], [0, 0, 1]], [-0.1, 0, 0, 0],
    ...                    (640, 480))
    >>> print(camchain_text(StoredRig((cam,))))
    cam0:
      cam_overlaps: []
      camera_model: pinhole
      distortion_coeffs: [-0.1, 0.0, 0.0, 0.0]
      distortion_model: radtan
      intrinsics: [500.0, 500.0, 320.0, 240.0]
      resolution: [640, 480]
      rostopic: /cam0/image_raw
    <BLANKLINE>
    """
    lines = []
    n = len(rig.cameras)
    for k, cam in enumerate(rig.cameras):
        if "/" in cam.name or not cam.name.strip() or cam.name != cam.name.strip():
            raise ValueError(f"camera name {cam.name!r}: Kalibr's rostopic /NAME/image_raw needs a name "
                             "without '/' or surrounding spaces")
        block = _block(cam)
        lines.append(f"cam{k}:")
        if k > 0:
            prev = rig.cameras[k - 1]
            R = cam.R @ prev.R.T
            t = cam.T - R @ prev.T
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = R, t
            lines.append("  T_cn_cnm1:")
            lines += [f"  - {_list(row)}" for row in T]
        overlaps = [j for j in (k - 1, k + 1) if 0 <= j < n]
        lines.append(f"  cam_overlaps: [{', '.join(map(str, overlaps))}]")
        lines += block
    return "\n".join(lines) + "\n"


def write(rig: StoredRig, path: Path, inputs: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """Write the rig as ``path`` (a ``.yaml`` file) or ``path/camchain.yaml``; the file written."""
    path = Path(path)
    target = path if path.suffix.lower() in (".yaml", ".yml") else path / "camchain.yaml"
    return write_files({target: camchain_text(rig)}, inputs)


def _numbers(block: dict, key: str, n: int | None, where: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in block[key]], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{where}: {key} must be a list of numbers") from None
    if n is not None and len(v) != n:
        raise ValueError(f"{where}: {key} has {len(v)} values, Kalibr's has {n}")
    return v


def _camera(block: dict, key: str, where: str) -> StoredCamera:
    here = f"{where}: {key}"
    if not isinstance(block, dict):
        raise ValueError(f"{here} is not a camera block")
    model, kind = str(block.get("camera_model", "")), str(block.get("distortion_model", "none"))
    intr = _numbers(block, "intrinsics", 5 if model == "omni" else 4, here)
    coeffs = _numbers(block, "distortion_coeffs", None, here) if "distortion_coeffs" in block else np.zeros(0)
    xi, (fu, fv, pu, pv) = (intr[0], intr[1:]) if model == "omni" else (None, intr)
    if kind == "none" and not np.any(coeffs):
        kind, coeffs = "radtan", np.zeros(4)
    if model not in ("pinhole", "omni") or kind not in ("radtan", "equidistant") or len(coeffs) != 4 \
            or (model == "omni" and kind != "radtan"):
        raise ValueError(f"{here}: camera_model {model} with distortion_model {kind} "
                         f"({len(coeffs)} coefficients) has no sogdd model (sogdd reads pinhole-radtan, "
                         "pinhole-equidistant and omni-radtan)")
    sogdd = "omnidir" if model == "omni" else "fisheye" if kind == "equidistant" else "pinhole4"
    dist = np.r_[xi, coeffs] if model == "omni" else coeffs
    try:
        w, h = (int(v) for v in block["resolution"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{here}: resolution must be [width, height]") from None
    m = _TOPIC.match(str(block.get("rostopic", "")))
    try:
        K = [[fu, 0, pu], [0, fv, pv], [0, 0, 1]]
        return StoredCamera(m.group(1) if m else key, sogdd, K, dist, (w, h))
    except ValueError as exc:
        raise ValueError(f"{here}: {exc}") from None


def read(path: Path) -> StoredRig:
    """A camchain YAML: its cameras ``cam0``, ``cam1``, ... and their poses chained from ``T_cn_cnm1``."""
    path = Path(path)
    if path.is_dir():
        path = path / "camchain.yaml"
    d = load_yaml(path)
    keys = sorted((k for k in d if re.fullmatch(r"cam\d+", str(k))), key=lambda k: int(k[3:])) \
        if isinstance(d, dict) else []
    if not keys:
        raise ValueError(f"{path}: not a Kalibr camchain (no cam0)")
    if keys != [f"cam{k}" for k in range(len(keys))]:
        raise ValueError(f"{path}: the cameras must be cam0 to cam{len(keys) - 1}, got {', '.join(keys)}")
    cams: list[StoredCamera] = []
    for key in keys:
        cam = _camera(d[key], key, str(path))
        if cams:
            try:
                T = np.array(d[key]["T_cn_cnm1"], dtype=np.float64)
            except (KeyError, TypeError, ValueError):
                raise ValueError(f"{path}: {key} has no T_cn_cnm1 (a 4 x 4 matrix)") from None
            if T.shape != (4, 4):
                raise ValueError(f"{path}: {key}'s T_cn_cnm1 is not 4 x 4")
            prev = cams[-1]
            try:
                cam = cam.with_pose(T[:3, :3] @ prev.R, T[:3, :3] @ prev.T + T[:3, 3])
            except ValueError as exc:
                raise ValueError(f"{path}: {key}'s T_cn_cnm1: {exc}") from None
        cams.append(cam)
    try:
        return StoredRig(tuple(cams))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def sniff(path: Path) -> bool:
    """A ``.yaml`` file (or a folder's ``camchain.yaml``) with a top-level ``cam0:`` and a ``camera_model``."""
    path = Path(path)
    if path.is_dir():
        path = path / "camchain.yaml"
    if path.suffix.lower() not in (".yaml", ".yml") or not path.is_file():
        return False
    try:
        text = path.read_text(encoding="utf-8", errors="replace")[:65536]
    except OSError:
        return False
    return bool(re.search(r"^cam0\s*:", text, re.M)) and "camera_model" in text


#: the record
FORMAT = ExchangeFormat(name="kalibr", summary="Kalibr's camera chain YAML (camchain.yaml: cam0, cam1, ... "
                        "with T_cn_cnm1)", sniff=sniff, read=read, write=write, needs="pyyaml (to read)")
