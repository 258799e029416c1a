"""Foerstner's corner point, iterated until it no longer moves (compiled).

The corner point ``q`` of a window is the least-squares solution of
``grad I(p) . (p - q) = 0`` over the window's pixels ``p`` (Foerstner and Guelch
1987), with the window centred on ``q`` itself, so ``q`` is a fixed point of
``q -> F(q)``:

    F(q) = q + A^{-1} b,   A = sum_p w_p g_p g_p^T,   b = sum_p w_p g_p g_p^T (p - q),

``g_p`` the central-difference gradient of the image bilinearly resampled on the
window's grid around ``q`` (edge pixels replicated) and
``w_p = exp(-(dx / h)^2 - (dy / h)^2)`` for offsets ``|dx|, |dy| <= h`` (the
half-window): the step of ``cv2.cornerSubPix``. OpenCV iterates ``F`` a fixed
number of times or until a step is below a tolerance (1e-3 *squared*, i.e.
0.03 px, in sogdd before 0.3): in a 3 x 3 window ``F`` often overshoots, the
iterates oscillate or wander, and where they stop depends on the input's last
bits (issue 22, item 8). Here the iteration is damped: the step is halved
whenever it turns back against the previous one (an overshoot), which turns an
oscillation into convergence while a point on its way to a corner keeps full
steps, and it stops only when ``|F(q) - q|`` is below ``tol`` (1e-5 px), in float64. A point
that does not converge in ``max_iter`` steps, or whose window matrix is singular,
keeps its start.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import JIT

__all__ = ["forstner_points"]


@numba.njit(**JIT)
def _step(img, qx, qy, hw, patch, mask):  # pragma: no cover - jit
    """``F(q) - q`` for half-window ``hw`` (``patch``: (2 hw + 3)^2 scratch), or NaN where A is singular."""
    # the window's grid is q + integers: one pair of bilinear weights for all its samples
    h, w = img.shape
    n = 2 * hw + 3
    x0 = math.floor(qx) - hw - 1
    y0 = math.floor(qy) - hw - 1
    fx = qx - math.floor(qx)
    fy = qy - math.floor(qy)
    inside = x0 >= 0 and y0 >= 0 and x0 + n < w and y0 + n < h
    for i in range(n):
        ya = y0 + i
        yb = ya + 1
        if not inside:  # edge pixels replicated (getRectSubPix's border)
            ya = min(max(ya, 0), h - 1)
            yb = min(max(yb, 0), h - 1)
        for j in range(n):
            xa = x0 + j
            xb = xa + 1
            if not inside:
                xa = min(max(xa, 0), w - 1)
                xb = min(max(xb, 0), w - 1)
            top = img[ya, xa] * (1.0 - fx) + img[ya, xb] * fx
            bot = img[yb, xa] * (1.0 - fx) + img[yb, xb] * fx
            patch[i, j] = top * (1.0 - fy) + bot * fy
    a = 0.0
    b = 0.0
    c = 0.0
    b1 = 0.0
    b2 = 0.0
    for i in range(2 * hw + 1):
        py = float(i - hw)
        for j in range(2 * hw + 1):
            px = float(j - hw)
            m = mask[i, j]
            gx = patch[i + 1, j + 2] - patch[i + 1, j]
            gy = patch[i + 2, j + 1] - patch[i, j + 1]
            gxx = gx * gx * m
            gxy = gx * gy * m
            gyy = gy * gy * m
            a += gxx
            b += gxy
            c += gyy
            b1 += gxx * px + gxy * py
            b2 += gxy * px + gyy * py
    det = a * c - b * b
    if not det > 1e-12 * (a + c) * (a + c):
        return math.nan, math.nan
    return (c * b1 - b * b2) / det, (a * b2 - b * b1) / det


@numba.njit(**JIT)
def _converge(img, x, y, hw, patch, mask, max_iter, tol):  # pragma: no cover - jit
    """(x, y, converged): the damped fixed-point iteration of ``F`` from (x, y)."""
    lam = 1.0
    px = 0.0
    py = 0.0
    for _ in range(max_iter):
        dx, dy = _step(img, x, y, hw, patch, mask)
        n = math.sqrt(dx * dx + dy * dy)
        if not n < math.inf:  # singular window matrix
            return x, y, False
        if n < tol:  # q = F(q) to within tol: converged (not a step made small by damping)
            return x + dx, y + dy, True
        if dx * px + dy * py < 0.0:  # the step turned back: an overshoot, damp it
            lam *= 0.5
        x += lam * dx
        y += lam * dy
        px = dx
        py = dy
    return x, y, False


@numba.njit(**JIT)
def _refine(img, pts, half, max_shift, max_iter, tol, out):  # pragma: no cover - jit
    """``out[i]``: the damped fixed-point iteration of ``F`` from ``pts[i]``, or ``pts[i]`` (see module)."""
    hmax = 1
    for i in range(len(half)):
        hmax = max(hmax, half[i])
    patch = np.empty((2 * hmax + 3, 2 * hmax + 3))
    mask = np.empty((2 * hmax + 1, 2 * hmax + 1))
    last = -1
    for i in range(len(pts)):
        hw = half[i]
        if hw != last:  # cornerSubPix's weights
            for r in range(2 * hw + 1):
                for s in range(2 * hw + 1):
                    mask[r, s] = math.exp(-((r - hw) / hw) ** 2 - ((s - hw) / hw) ** 2)
            last = hw
        x0, y0 = pts[i, 0], pts[i, 1]
        x, y, done = _converge(img, x0, y0, hw, patch, mask, max_iter, tol)
        # inside the window the start defines (cornerSubPix's own rule), and within max_shift
        inside = abs(x - x0) <= hw and abs(y - y0) <= hw
        if done and inside and math.sqrt((x - x0) ** 2 + (y - y0) ** 2) <= max_shift[i]:
            out[i, 0], out[i, 1] = x, y
        else:
            out[i, 0], out[i, 1] = x0, y0


def forstner_points(
    grey: np.ndarray,
    xy: np.ndarray,
    half_window: np.ndarray,
    max_shift: np.ndarray,
    *,
    max_iter: int = 100,
    tol: float = 1e-5,
) -> np.ndarray:
    """Foerstner's corner point of each start point, iterated to convergence (see the module docstring).

    ``grey``: (H, W) image (read as float32); ``xy``: (N, 2) start points;
    ``half_window`` (>= 1), ``max_shift``: (N,) per point. A point that does not
    converge (``|F(q) - q| < tol``) within ``max_iter`` steps, that would leave the
    window around its start (``|dx|`` or ``|dy|`` over its half-window, as
    ``cv2.cornerSubPix`` refuses) or move more than its ``max_shift``, or whose
    window matrix is singular, keeps its start.

    Examples
    --------
    Where ``cv2.cornerSubPix`` converges, the two agree (to its float32 coordinates):

    >>> import cv2
    >>> import numpy as np
    >>> img = np.zeros((21, 21), np.float32)
    >>> img[10:, 10:] = 100.0  # an L-corner, vertex at (9.5, 9.5), blurred
    >>> img = cv2.GaussianBlur(img, (0, 0), 1.0)
    >>> q = forstner_points(img, np.array([[11.2, 10.8]]), np.array([3]), np.array([3.0]))
    >>> ocv = cv2.cornerSubPix(img, np.float32([[[11.2, 10.8]]]), (3, 3), (-1, -1), (3, 100, 1e-12))
    >>> q.round(4).tolist(), bool(np.abs(q - ocv.reshape(1, 2)).max() < 1e-5)
    ([[9.7019, 9.7019]], True)
    """
    img = np.ascontiguousarray(grey, dtype=np.float32)
    pts = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.empty_like(pts)
    half = np.ascontiguousarray(half_window, dtype=np.int64).reshape(-1)
    if len(half) != len(pts) or (half < 1).any():
        raise ValueError("half_window must hold one integer >= 1 per point")
    shift = np.ascontiguousarray(max_shift, dtype=np.float64).reshape(-1)
    if len(shift) != len(pts):
        raise ValueError("max_shift must hold one value per point")
    if len(pts):
        _refine(img, pts, half, shift, int(max_iter), float(tol), out)
    return out
