"""The hr2 study's orientation candidate: a keypoint angle from SOGDD's own responses (added in stop 20).

The SOGDD response steered to theta at the point, psi_theta * I = cos^2 g_xx +
2 sin cos g_xy + sin^2 g_yy (eq. 22's kernel at ``hr``'s sigma, steerable from
three Gaussian second derivatives), is largest and smallest along two orthogonal
axes: the point's SOGDD principal axes (at a corner, its bisector and the normal
to it). They give four candidate directions; the one closest to the intensity
centroid of SIFT's orientation window (sigma_w = 0.75 * size; ORB's rule, for a
Gaussian window sigma_w^2 times the gradient of the window-smoothed image) is
the angle. The centroid alone is coarse; the SOGDD axes fix the angle, and the
centroid only picks one of the four. The angle follows ``cv2.KeyPoint.angle``'s
convention (degrees, image coordinates, y down), and OpenCV's SIFT computes the
descriptor at it. Only the descriptor stage changes: points, sizes and
strengths are the detector's.
"""

from __future__ import annotations

import cv2
import numpy as np

from sogdd.descriptors import _sift_compute  # the package's own SIFT-at-given-angles (no core change)

__all__ = ["sogdd_orientations", "describe_at_angles"]


def _second_derivatives(grey: np.ndarray, sigma2: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = float(np.sqrt(sigma2))
    r = int(np.ceil(4.0 * s))
    t = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-t * t / (2 * sigma2))
    g /= g.sum()
    g1 = -t / sigma2 * g
    g2 = (t * t / sigma2 - 1.0) / sigma2 * g
    f = grey.astype(np.float32)
    gxx = cv2.sepFilter2D(f, cv2.CV_32F, g2, g, borderType=cv2.BORDER_REFLECT)
    gyy = cv2.sepFilter2D(f, cv2.CV_32F, g, g2, borderType=cv2.BORDER_REFLECT)
    gxy = cv2.sepFilter2D(f, cv2.CV_32F, g1, g1, borderType=cv2.BORDER_REFLECT)
    return gxx, gxy, gyy


def sogdd_orientations(grey: np.ndarray, xy: np.ndarray, size: np.ndarray, sigma2: float = 1.5,
                       snap: bool = True) -> np.ndarray:
    """Angles (degrees, ``cv2.KeyPoint`` convention) of the points ``xy`` from SOGDD's responses.

    ``size``: the descriptor diameters (the centroid's window is SIFT's: sigma_w = 0.75 size).
    ``snap=False``: the centroid's direction itself (ORB's rule alone, the control for the SOGDD axes).

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((64, 64), np.uint8); img[32:, 32:] = 200  # an L corner opening down-right
    >>> a = sogdd_orientations(img, np.array([[32.0, 32.0]]), np.array([8.0]))
    >>> bool(abs(a[0] - 45.0) < 3.0)
    True
    """
    xy = np.asarray(xy, np.float64).reshape(-1, 2)
    size = np.asarray(size, np.float64).reshape(-1)
    out = np.zeros(len(xy))
    if not len(xy):
        return out
    g = grey.astype(np.float32)
    gxx, gxy, gyy = _second_derivatives(g, sigma2)
    h, w = g.shape
    xi = np.clip(np.round(xy[:, 0]).astype(int), 0, w - 1)
    yi = np.clip(np.round(xy[:, 1]).astype(int), 0, h - 1)
    a, b, c = (p[yi, xi].astype(np.float64) for p in (gxx, gxy, gyy))
    # psi_theta * I = (a + c)/2 + (a - c)/2 cos 2theta + b sin 2theta: extreme at phi and phi + 90 deg
    phi = 0.5 * np.arctan2(2.0 * b, a - c)
    cand = phi[:, None] + np.arange(4)[None, :] * (np.pi / 2)
    for s in np.unique(size):
        sel = np.flatnonzero(size == s)
        sm = cv2.GaussianBlur(g, (0, 0), 0.75 * float(s), borderType=cv2.BORDER_REFLECT)
        gx = cv2.Sobel(sm, cv2.CV_32F, 1, 0, ksize=1)[yi[sel], xi[sel]].astype(np.float64)
        gy = cv2.Sobel(sm, cv2.CV_32F, 0, 1, ksize=1)[yi[sel], xi[sel]].astype(np.float64)
        beta = np.arctan2(gy, gx)  # the centroid's direction
        d = np.abs(np.angle(np.exp(1j * (cand[sel] - beta[:, None]))))
        best = cand[sel, np.argmin(d, axis=1)] if snap else beta
        out[sel] = np.rad2deg(best) % 360.0
    return out


def describe_at_angles(grey_u8: np.ndarray, xy: np.ndarray, size: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """OpenCV SIFT descriptors (float32, OpenCV's scale) at the given angles."""
    return _sift_compute(grey_u8, np.asarray(xy, np.float64), np.asarray(size, np.float64),
                         np.asarray(angles, np.float64))
