"""The renderer's compiled sampling: exact undistortion per sample, the board plane, box-filtered reflectance.

See :mod:`.render` for the maths. ``c`` packs the camera and pose:
``fx, fy, cx, cy, skew, k1, k2, p1, p2, k3, R (row-major), t, n . t``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..._jit import JIT
from ...calib.cameras import Camera
from ...calib.cameras.compiled import undistort_point

__all__ = ["render_samples", "sample_coords"]


def _cam_args(camera: Camera, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    K = camera.K
    n = R[:, 2]  # the board's normal in the camera frame
    return np.concatenate([[K[0, 0], K[1, 1], K[0, 2], K[1, 2], K[0, 1]], camera.dist, R.ravel(), t,
                           [float(n @ t)]])


def render_samples(camera: Camera, R: np.ndarray, t: np.ndarray, s: int, board: np.ndarray) -> np.ndarray:
    """Each pixel: the mean of its ``s x s`` box-filtered samples, (H, W) float64 (board: target, levels)."""
    w, h = camera.size
    out = np.empty((h, w), dtype=np.float64)
    _render_kernel(_cam_args(camera, R, t), board, s, out)
    return out


def sample_coords(camera: Camera, R: np.ndarray, t: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Board coordinates (u, v) of every sample, (H s, W s) each; NaN where the ray misses the board plane."""
    w, h = camera.size
    u = np.empty((h * s, w * s), dtype=np.float64)
    v = np.empty((h * s, w * s), dtype=np.float64)
    _coords_kernel(_cam_args(camera, R, t), s, u, v)
    return u, v

@njit(**JIT)
def _board_uv(xn, yn, c):
    """Board coordinates of the ray (xn, yn, 1): intersection with the plane n . X = n . t."""
    n0, n1, n2 = c[12], c[15], c[18]  # R[:, 2]
    den = n0 * xn + n1 * yn + n2
    lam = c[22] / den
    if not (lam > 0) or not np.isfinite(lam):
        return np.nan, np.nan
    px, py, pz = lam * xn - c[19], lam * yn - c[20], lam - c[21]
    # R^T (X - t): rows of R^T are the columns of R
    return c[10] * px + c[13] * py + c[16] * pz, c[11] * px + c[14] * py + c[17] * pz


@njit(**JIT)
def _overlap(x, r, lo, hi):
    a = max(x - r, lo)
    b = min(x + r, hi)
    return max(b - a, 0.0) / (2 * r)


@njit(**JIT)
def _parity_cover(x, r, sq, n):
    """Box-filtered indicators of the even and of the odd squares along one axis (squares 0..n)."""
    a0 = int(math.floor(x / sq)) + 1
    even = 0.0
    odd = 0.0
    for a in range(a0 - 1, a0 + 2):
        if a < 0 or a > n:
            continue
        f = _overlap(x, r, (a - 1) * sq, a * sq)
        if a % 2 == 0:
            even += f
        else:
            odd += f
    return even, odd


@njit(**JIT)
def _reflectance(u, v, ru, rv, b):
    sq, cols, rows, margin, dark, light, bg = b[0], int(b[1]), int(b[2]), b[3], b[4], b[5], b[6]
    if not np.isfinite(u):
        return bg
    ru = min(max(ru, 1e-9), 0.5 * sq)
    rv = min(max(rv, 1e-9), 0.5 * sq)
    pu = _overlap(u, ru, -sq - margin, cols * sq + margin)
    pv = _overlap(v, rv, -sq - margin, rows * sq + margin)
    eu, ou = _parity_cover(u, ru, sq, cols)
    ev, ov = _parity_cover(v, rv, sq, rows)
    return bg + (light - bg) * pu * pv - (light - dark) * (eu * ev + ou * ov)


@njit(**JIT)
def _row_samples(c, row, sub, s, w, us, vs):
    """(u, v) of every sample of sub-row ``sub`` of pixel row ``row``, (w s,) each, warm-started Newton."""
    fx, fy, cx, cy, skew = c[0], c[1], c[2], c[3], c[4]
    k1, k2, p1, p2, k3 = c[5], c[6], c[7], c[8], c[9]
    py = row - 0.5 + (sub + 0.5) / s
    yd = (py - cy) / fy
    x0 = np.nan  # the previous two solutions: their linear extrapolation starts Newton's method
    y0 = np.nan
    x1 = np.nan
    y1 = np.nan
    for k in range(w * s):
        px = -0.5 + (k + 0.5) / s
        xd = (px - cx - skew * yd) / fx
        if np.isfinite(x0) and np.isfinite(x1):
            x, y = 2 * x1 - x0, 2 * y1 - y0
        elif np.isfinite(x1):
            x, y = x1, y1
        else:
            x, y = xd, yd
        x, y = undistort_point(xd, yd, x, y, k1, k2, p1, p2, k3)
        x0, y0, x1, y1 = x1, y1, x, y
        if np.isfinite(x):
            us[k], vs[k] = _board_uv(x, y, c)
        else:
            us[k], vs[k] = np.nan, np.nan


@njit(parallel=True, cache=True, error_model="numpy")
def _render_kernel(c, b, s, out):
    h, w = out.shape
    for row in prange(h):
        us = np.empty((s, w * s))
        vs = np.empty((s, w * s))
        for sub in range(s):
            _row_samples(c, row, sub, s, w, us[sub], vs[sub])
        for col in range(w):
            k0 = col * s
            # the pixel's Jacobian d(u, v)/d(x, y) from its corner samples (1 px = s - 1 sample steps * s/(s-1))
            step = (s - 1) / s
            dux = 0.5 * ((us[0, k0 + s - 1] - us[0, k0]) + (us[s - 1, k0 + s - 1] - us[s - 1, k0])) / step
            dvx = 0.5 * ((vs[0, k0 + s - 1] - vs[0, k0]) + (vs[s - 1, k0 + s - 1] - vs[s - 1, k0])) / step
            duy = 0.5 * ((us[s - 1, k0] - us[0, k0]) + (us[s - 1, k0 + s - 1] - us[0, k0 + s - 1])) / step
            dvy = 0.5 * ((vs[s - 1, k0] - vs[0, k0]) + (vs[s - 1, k0 + s - 1] - vs[0, k0 + s - 1])) / step
            half = 0.5 / s
            ru = half * math.sqrt(dux * dux + duy * duy)
            rv = half * math.sqrt(dvx * dvx + dvy * dvy)
            if not np.isfinite(ru):
                ru = 0.0
            if not np.isfinite(rv):
                rv = 0.0
            acc = 0.0
            for sub in range(s):
                for k in range(s):
                    acc += _reflectance(us[sub, k0 + k], vs[sub, k0 + k], ru, rv, b)
            out[row, col] = acc / (s * s)


@njit(parallel=True, cache=True, error_model="numpy")
def _coords_kernel(c, s, u, v):
    hs, ws = u.shape
    w = ws // s
    for r in prange(hs):
        _row_samples(c, r // s, r % s, s, w, u[r], v[r])
