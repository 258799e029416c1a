"""Ground-truth cameras (Strecha's format) and the pose errors of a reconstruction.

The model is aligned to the GT by a similarity fitted to the camera centres
(Umeyama, least squares); rotation and position errors are then per camera.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["GTCamera", "align_similarity", "camera_errors", "read_strecha_cameras"]


@dataclass(frozen=True)
class GTCamera:
    """A ground-truth camera: ``K``, world-to-camera rotation ``R``, centre ``C``, image size."""

    K: np.ndarray
    R: np.ndarray
    C: np.ndarray
    size: tuple[int, int]


def read_strecha_cameras(folder: str | Path) -> dict[str, GTCamera]:
    """Read Strecha-format cameras: ``{image name: GTCamera}``.

    Each ``NAME.camera`` file holds K (3 lines), the radial distortion
    (``0 0 0``), a rotation (3 lines), the camera centre C, and ``width height``.
    The rotation is camera-to-world (Strecha's convention, ``P = K [R^T | -R^T C]``);
    it is stored transposed here, as world-to-camera.
    """
    out = {}
    for f in sorted(Path(folder).glob("*.camera")):
        v = np.array(f.read_text().split(), dtype=np.float64)
        if v.size < 26:
            raise ValueError(f"{f}: expected 26 numbers, got {v.size}")
        k = v[0:9].reshape(3, 3)
        r_c2w = v[12:21].reshape(3, 3)
        out[f.name[: -len(".camera")]] = GTCamera(k, r_c2w.T, v[21:24].copy(), (int(v[24]), int(v[25])))
    if not out:
        raise ValueError(f"{folder}: no *.camera files")
    return out


def align_similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares similarity ``dst ~ s R src + t`` (Umeyama 1991): returns ``(s, R, t)``."""
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    if len(src) < 3:
        raise ValueError("need at least 3 points to fit a similarity")
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    cov = b.T @ a / len(src)
    u, d, vt = np.linalg.svd(cov)
    e = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        e[2, 2] = -1
    r = u @ e @ vt
    var = (a**2).sum() / len(src)
    s = float(np.trace(np.diag(d) @ e) / var) if var > 0 else 1.0
    return s, r, md - s * r @ ms


def _rot_angle_deg(r: np.ndarray) -> float:
    # atan2 of the sine and cosine parts stays accurate near 0 where arccos does not
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return float(np.degrees(np.arctan2(np.linalg.norm(w) / 2.0, (np.trace(r) - 1.0) / 2.0)))


def camera_errors(est: dict[str, tuple[np.ndarray, np.ndarray]], gt: dict[str, GTCamera]) -> dict:
    """Align estimated cameras to GT and measure them.

    Parameters
    ----------
    est : dict
        ``{image name: (R_world_to_cam, centre)}`` of the reconstruction.
    gt : dict
        ``{image name: GTCamera}``.

    Returns
    -------
    dict
        ``per_camera`` (name -> rotation error in degrees, position error in GT
        units), their means and medians, the scale, and the number of cameras
        used. The similarity is fitted to all common camera centres.
    """
    names = [n for n in est if n in gt]
    if len(names) < 3:
        return {"aligned": False, "reason": f"only {len(names)} cameras in common with the GT", "n": len(names)}
    src = np.array([est[n][1] for n in names])
    dst = np.array([gt[n].C for n in names])
    s, r, t = align_similarity(src, dst)
    per = {}
    for n in names:
        r_est, c_est = est[n]
        c_al = s * r @ c_est + t
        # world-to-camera rotation of the estimate, expressed in the GT frame
        r_al = r_est @ r.T
        per[n] = {"rotation_deg": _rot_angle_deg(r_al @ gt[n].R.T),
                  "position": float(np.linalg.norm(c_al - gt[n].C))}
    rot = np.array([v["rotation_deg"] for v in per.values()])
    pos = np.array([v["position"] for v in per.values()])
    return {"aligned": True, "n": len(names), "scale": s, "per_camera": per,
            "rotation_deg_mean": float(rot.mean()), "rotation_deg_median": float(np.median(rot)),
            "position_mean": float(pos.mean()), "position_median": float(np.median(pos))}
