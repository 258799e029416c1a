"""The camera model compiled (numba), for per-sample loops: the same equations as :mod:`.models`."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._jit import JIT

__all__ = ["undistort_point"]


@njit(**JIT)
def undistort_point(xd, yd, x, y, k1, k2, p1, p2, k3):
    """Newton's method on the distortion from (x, y); returns the solution (NaN if it does not converge)."""
    for _ in range(100):
        r2 = x * x + y * y
        rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        drad = k1 + r2 * (2 * k2 + 3 * k3 * r2)
        ex = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) - xd
        ey = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y - yd
        j00 = rad + 2 * x * x * drad + 2 * p1 * y + 6 * p2 * x
        j01 = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
        j11 = rad + 2 * y * y * drad + 6 * p1 * y + 2 * p2 * x
        det = j00 * j11 - j01 * j01
        dx = (j11 * ex - j01 * ey) / det
        dy = (-j01 * ex + j00 * ey) / det
        x -= dx
        y -= dy
        # Newton converges quadratically: after a step of d the error is about d^2 times the
        # distortion's curvature over its slope (< 10 for any usable lens), so d < 1e-7 leaves < 1e-13
        if abs(dx) < 1e-7 and abs(dy) < 1e-7:
            return x, y
        if not (abs(x) < 1e6 and abs(y) < 1e6):
            break
    return np.nan, np.nan
