"""The renderer's compiled sampling: exact undistortion per sample, the board plane, box-filtered reflectance.

See :mod:`.render` for the maths. ``c`` packs the camera and pose:
``fx, fy, cx, cy, skew, k1, k2, p1, p2, k3, R (row-major), t, n . t, fisheye`` (a fisheye's
``k1..k4`` in the places of ``k1, k2, p1, p2``; ``fisheye`` is 1.0 or 0.0). ``b`` packs a board:
``square, cols, rows, margin, dark, light, background[, edge, dots, dot]`` (the last three:
the outer squares' width in cells, the dots per side of a white square's dot matrix, 0 for none,
and a dot's side in cells; 1, 0, 0 when absent).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..._jit import JIT
from ...calib.cameras import Camera
from ...calib.cameras.compiled import fisheye_theta_point, undistort_point

__all__ = ["dot_printed", "render_samples", "sample_coords"]


def _cam_args(camera: Camera, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    K = camera.K
    n = R[:, 2]  # the board's normal in the camera frame
    dist = np.zeros(5)
    dist[:len(camera.dist)] = camera.dist
    fisheye = 1.0 if getattr(camera, "model", "pinhole") == "fisheye" else 0.0
    return np.concatenate([[K[0, 0], K[1, 1], K[0, 2], K[1, 2], K[0, 1]], dist, R.ravel(), t,
                           [float(n @ t), fisheye]])


def render_samples(camera: Camera, R: np.ndarray, t: np.ndarray, s: int, board: np.ndarray,
                   behind: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Each pixel: the mean of its ``s x s`` box-filtered samples, (H, W) float64 (board: target, levels).

    ``behind``: ``(R, t, board)`` of a second board seen where the first is not (it takes the
    first board's background's place; it must not come between the camera and the first board).
    """
    w, h = camera.size
    out = np.empty((h, w), dtype=np.float64)
    if behind is None:
        c2, b2 = np.zeros(0), np.zeros(0)
    else:
        c2, b2 = _cam_args(camera, behind[0], behind[1]), np.asarray(behind[2], dtype=np.float64)
    _render_kernel(_cam_args(camera, R, t), np.asarray(board, dtype=np.float64), c2, b2, s, out)
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
def _board_uv_dir(dx, dy, dz, c):
    """Board coordinates of the ray along (dx, dy, dz), any direction (a fisheye's rays reach 90 degrees)."""
    n0, n1, n2 = c[12], c[15], c[18]
    den = n0 * dx + n1 * dy + n2 * dz
    lam = c[22] / den
    if not (lam > 0) or not np.isfinite(lam):
        return np.nan, np.nan
    px, py, pz = lam * dx - c[19], lam * dy - c[20], lam * dz - c[21]
    return c[10] * px + c[13] * py + c[16] * pz, c[11] * px + c[14] * py + c[17] * pz


@njit(**JIT)
def _overlap(x, r, lo, hi):
    a = max(x - r, lo)
    b = min(x + r, hi)
    return max(b - a, 0.0) / (2 * r)


@njit(**JIT)
def _parity_cover(x, r, sq, n, lo, hi):
    """Box-filtered indicators of the even and of the odd squares along one axis (squares 0..n, cut to
    ``[lo, hi]``: the outer squares' width is ``edge`` cells)."""
    a0 = int(math.floor(x / sq)) + 1
    even = 0.0
    odd = 0.0
    for a in range(a0 - 1, a0 + 2):
        if a < 0 or a > n:
            continue
        f = _overlap(x, r, max((a - 1) * sq, lo), min(a * sq, hi))
        if a % 2 == 0:
            even += f
        else:
            odd += f
    return even, odd


@njit(**JIT)
def _parity_cover_plain(x, r, sq, n):
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
def _reflectance_plain(u, v, ru, rv, b):
    """The full board without dots over its own background: the renderer's original code, kept apart
    so that the renders it made stay bit-identical (inlined, the general code rounds differently)."""
    sq, cols, rows, margin, dark, light, bg = b[0], int(b[1]), int(b[2]), b[3], b[4], b[5], b[6]
    if not np.isfinite(u):
        return bg
    ru = min(max(ru, 1e-9), 0.5 * sq)
    rv = min(max(rv, 1e-9), 0.5 * sq)
    pu = _overlap(u, ru, -sq - margin, cols * sq + margin)
    pv = _overlap(v, rv, -sq - margin, rows * sq + margin)
    eu, ou = _parity_cover_plain(u, ru, sq, cols)
    ev, ov = _parity_cover_plain(v, rv, sq, rows)
    return bg + (light - bg) * pu * pv - (light - dark) * (eu * ev + ou * ov)


@njit(**JIT)
def dot_printed(a, b, kx, ky):
    """Whether dot (kx, ky) of white square (a, b) is printed: a fixed hash, about 6 in 11 printed, so
    that neighbouring squares' codes differ."""
    return (a * 1103 + b * 2371 + kx * 313 + ky * 97 + a * b * 7 + kx * ky * 29) % 11 < 6


@njit(**JIT)
def _dot_cover(u, v, ru, rv, sq, cols, rows, g, dot):
    """Box-filtered coverage of the dots: a g x g matrix of squares of side ``dot`` cells in every white
    square with inner corners on all four sides, kept 0.2 of a cell clear of the square's edges."""
    a0 = int(math.floor(u / sq)) + 1
    b0 = int(math.floor(v / sq)) + 1
    d = dot * sq
    pitch = (0.6 * sq - d) / max(g - 1, 1)
    first = 0.2 * sq + 0.5 * d  # the first dot's centre from the square's low edge
    acc = 0.0
    for a in range(max(a0 - 1, 1), min(a0 + 1, cols - 1) + 1):
        for b in range(max(b0 - 1, 1), min(b0 + 1, rows - 1) + 1):
            if (a + b) % 2 == 0:  # dark square
                continue
            for kx in range(g):
                cu = (a - 1) * sq + first + kx * pitch
                fu = _overlap(u, ru, cu - 0.5 * d, cu + 0.5 * d)
                if fu == 0.0:
                    continue
                for ky in range(g):
                    if dot_printed(a, b, kx, ky):
                        cv = (b - 1) * sq + first + ky * pitch
                        acc += fu * _overlap(v, rv, cv - 0.5 * d, cv + 0.5 * d)
    return acc


@njit(**JIT)
def _reflectance(u, v, ru, rv, b, bg):
    """The board's reflectance box-filtered over the sample's footprint, over a background of ``bg``."""
    sq, cols, rows, margin, dark, light = b[0], int(b[1]), int(b[2]), b[3], b[4], b[5]
    if not np.isfinite(u):
        return bg
    ru = min(max(ru, 1e-9), 0.5 * sq)
    rv = min(max(rv, 1e-9), 0.5 * sq)
    edge = b[7] if len(b) > 7 else 1.0
    # the squares span [-edge sq, (n - 1 + edge) sq]
    lo = -edge * sq
    hu = (cols - 1 + edge) * sq
    hv = (rows - 1 + edge) * sq
    pu = _overlap(u, ru, lo - margin, hu + margin)
    pv = _overlap(v, rv, lo - margin, hv + margin)
    eu, ou = _parity_cover(u, ru, sq, cols, lo, hu)
    ev, ov = _parity_cover(v, rv, sq, rows, lo, hv)
    out = bg + (light - bg) * pu * pv - (light - dark) * (eu * ev + ou * ov)
    if len(b) > 8 and b[8] > 0:
        out -= (light - dark) * _dot_cover(u, v, ru, rv, sq, cols, rows, int(b[8]), b[9])
    return out


@njit(**JIT)
def _row_samples_fisheye(c, row, sub, s, w, us, vs):
    """:func:`_row_samples` for the fisheye: the ray at angle theta (Newton on theta_d(theta)) along the
    pixel's azimuth, exact at any angle."""
    fx, fy, cx, cy, skew = c[0], c[1], c[2], c[3], c[4]
    k1, k2, k3, k4 = c[5], c[6], c[7], c[8]
    py = row - 0.5 + (sub + 0.5) / s
    yd = (py - cy) / fy
    for k in range(w * s):
        px = -0.5 + (k + 0.5) / s
        xd = (px - cx - skew * yd) / fx
        td = math.sqrt(xd * xd + yd * yd)
        # theta_d(theta) ~ theta, and for the equidistant model (k = 0) the start is the exact root
        th = fisheye_theta_point(td, td, k1, k2, k3, k4)
        if not (th < math.pi):
            us[k], vs[k] = np.nan, np.nan
            continue
        sc = math.sin(th) / td if td > 0 else 1.0
        us[k], vs[k] = _board_uv_dir(xd * sc, yd * sc, math.cos(th), c)


@njit(**JIT)
def _row_samples(c, row, sub, s, w, us, vs):
    """(u, v) of every sample of sub-row ``sub`` of pixel row ``row``, (w s,) each, warm-started Newton."""
    if c[23] > 0:
        _row_samples_fisheye(c, row, sub, s, w, us, vs)
        return
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


@njit(cache=True, nogil=True, error_model="numpy")  # no fused multiply-adds: renders stay bit-identical
def _footprint(us, vs, k0, s):
    """Half-widths (ru, rv) along u and v of a sample's box, from the pixel's Jacobian d(u, v)/d(x, y)
    estimated from its corner samples (1 px = s - 1 sample steps * s/(s-1))."""
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
    return ru, rv


@njit(cache=True, nogil=True, error_model="numpy")
def _pixel_plain(us, vs, k0, s, b):
    """The mean of a pixel's samples of one full board without dots (:func:`_reflectance_plain`)."""
    ru, rv = _footprint(us, vs, k0, s)
    acc = 0.0
    for sub in range(s):
        for k in range(s):
            acc += _reflectance_plain(us[sub, k0 + k], vs[sub, k0 + k], ru, rv, b)
    return acc / (s * s)


@njit(cache=True, nogil=True, error_model="numpy")
def _pixel(us, vs, us2, vs2, k0, s, b, b2, two):
    """The mean of a pixel's samples: board ``b`` over board ``b2`` (when ``two``) over the background."""
    ru, rv = _footprint(us, vs, k0, s)
    ru2, rv2 = _footprint(us2, vs2, k0, s) if two else (0.0, 0.0)
    acc = 0.0
    for sub in range(s):
        for k in range(s):
            bg = b[6]
            if two:
                # the second board shows where the first board's paper does not cover
                bg = _reflectance(us2[sub, k0 + k], vs2[sub, k0 + k], ru2, rv2, b2, b2[6])
            acc += _reflectance(us[sub, k0 + k], vs[sub, k0 + k], ru, rv, b, bg)
    return acc / (s * s)


@njit(parallel=True, cache=True, error_model="numpy")
def _render_kernel(c, b, c2, b2, s, out):
    h, w = out.shape
    two = len(b2) > 0
    plain = not two and (len(b) <= 7 or (b[7] == 1.0 and b[8] == 0))
    for row in prange(h):
        us = np.empty((s, w * s))
        vs = np.empty((s, w * s))
        us2 = np.empty((s, w * s if two else 0))
        vs2 = np.empty((s, w * s if two else 0))
        for sub in range(s):
            _row_samples(c, row, sub, s, w, us[sub], vs[sub])
            if two:
                _row_samples(c2, row, sub, s, w, us2[sub], vs2[sub])
        for col in range(w):
            if plain:
                out[row, col] = _pixel_plain(us, vs, col * s, s, b)
            else:
                out[row, col] = _pixel(us, vs, us2, vs2, col * s, s, b, b2, two)


@njit(parallel=True, cache=True, error_model="numpy")
def _coords_kernel(c, s, u, v):
    hs, ws = u.shape
    w = ws // s
    for r in prange(hs):
        _row_samples(c, r // s, r % s, s, w, u[r], v[r])
