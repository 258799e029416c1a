"""The camera model compiled (numba), for per-sample loops: the same equations as :mod:`.models`."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._jit import JIT

__all__ = ["fisheye_theta_point", "undistort_point"]


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


@njit(**JIT)
def fisheye_theta_point(td, th, k1, k2, k3, k4):
    """The fisheye's ray angle of the distorted angle ``td`` by Newton's method from ``th`` (NaN if it
    does not converge or the model folds): :func:`.models.fisheye_theta` for one sample."""
    for _ in range(100):
        t2 = th * th
        f = th * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - td
        df = 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
        if not df > 0:
            break
        step = f / df
        th -= step
        # quadratic convergence, as in undistort_point: a step below 1e-12 leaves an error far below it
        if abs(step) < 1e-12:
            return th
        if not abs(th) < 1e3:
            break
    return np.nan
