"""The OpenCV calls of a calibration: one fit of a camera to views, one view's pose given the camera."""

from __future__ import annotations

import cv2
import numpy as np

from .cameras import MODELS
from .targets.board import Board

__all__ = ["fit_camera", "fit_camera_checked", "solve_pose"]



def fit_camera(obj: list[np.ndarray], img: list[np.ndarray], size: tuple[int, int], model: str, flags: int):
    """One OpenCV calibration: ``(K, dist, rvecs (V, 3), tvecs (V, 3), std (array or None))``."""
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    if model == "fisheye":
        f = flags | cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
        o = [p.reshape(1, -1, 3) for p in obj]
        i = [p.reshape(1, -1, 2) for p in img]
        _, K, D, rv, tv = cv2.fisheye.calibrate(o, i, size, np.eye(3), np.zeros(4), flags=f, criteria=crit)
        std = None
    else:
        f = flags | (cv2.CALIB_RATIONAL_MODEL if model == "rational" else 0)
        nd = len(MODELS[model])
        o = [p.astype(np.float64).reshape(-1, 1, 3) for p in obj]
        i = [p.astype(np.float64).reshape(-1, 1, 2) for p in img]
        _, K, D, rv, tv, std, _, _ = cv2.calibrateCameraExtended(
            o, i, size, np.eye(3), np.zeros(nd), flags=f, criteria=crit)
        D = D.ravel()[:nd]
        std = std.ravel()
    rv = np.array([np.asarray(r, dtype=np.float64).ravel() for r in rv])
    tv = np.array([np.asarray(t, dtype=np.float64).ravel() for t in tv])
    return K, np.asarray(D, dtype=np.float64).ravel(), rv, tv, std


def fit_camera_checked(obj, img, size, model, flags, what: str):
    """:func:`fit_camera`, with OpenCV's failure as a one-line ``ValueError`` naming ``what``."""
    try:
        return fit_camera(obj, img, size, model, flags)
    except cv2.error as exc:
        msg = " ".join(str(exc).split())
        raise ValueError(f"OpenCV could not calibrate {what} ({model} model): {msg[-160:]}") from None


def solve_pose(board: Board, square: float, K, dist, model):
    """A view's pose given the intrinsics (solvePnP), or None."""
    obj = board.object_points(square)
    img = board.image_points
    try:
        if model == "fisheye":
            ok, rv, tv = cv2.fisheye.solvePnP(obj.reshape(-1, 1, 3), img.reshape(-1, 1, 2), K, dist)
        else:
            ok, rv, tv = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    except cv2.error:
        return None
    return (rv.ravel(), tv.ravel()) if ok else None
