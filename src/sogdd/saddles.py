"""X-junctions as saddle points, and one grey-level scale for corners and X-junctions.

Why a second stage
------------------
On an X-junction (a checkerboard's inner corner) the four wedges cancel:
``g_xx = g_yy = 0`` at the junction, so the absolute SOGDD responses there are
``|l_k| = |sin 2 theta_k| |g_xy|``, one pattern over the K orientations, and
the SODDC matrix is nearly of rank one. Upsilon has a *local minimum* on the
junction with a ring of maxima about 2 px around it, and the reported corners
land off the junction. The junction is instead the saddle point of the smoothed
image ``G_sigma * I``: the gradient vanishes and ``det H < 0``.

The stage (Chen and Zhang 2005, "A new sub-pixel detector for X-corners in
camera calibration targets"; a Foerstner-style saddle fit):

1. ``g_xx, g_xy, g_yy`` of ``G_sigma * I`` at the detector's scale (the
   steerable basis);
2. candidates: 3x3 maxima of the saddle strength
   ``s = sigma^2 sqrt(max(0, g_xy^2 - g_xx g_yy))`` (a scale-normalised second
   derivative, linear in the image contrast), found in one compiled pass
   (:mod:`sogdd._saddle_kernels`);
3. the saddle point: Newton steps ``delta = -H^{-1} grad`` on bilinearly
   interpolated derivatives (the gradient ``g_x, g_y`` evaluated from the image at
   the four pixels each step reads; only candidates need it). A candidate is kept
   only when the last of four iterates is within one pixel of it: an L-corner's
   apex also has ``det H < 0`` but a large gradient, so its step leaves the pixel.

Bands
-----
Every step is local, so :func:`find_saddles` runs in bands of rows with three
float64 maps of ``band_rows + 2 halo`` rows, never image-sized ones, and gives
the same points for any band height: the derivatives of a crop of full rows
are those of the image, bit for bit, on every row at least ``radius`` rows from
a crop edge that is not the image's (OpenCV's separable filter computes each
pixel from the same values in the same order; tested); the maxima read rows
+-1, and each Newton step reads the maps on two rows and the image ``radius``
rows beyond them. A point whose step needs a row outside the band's maps (it
wandered more than ``halo`` rows; almost always refused in the end) continues
afterwards on crops filtered around the rows it reads, so its path is the
whole image's path.

Grey-level units
----------------
Both measures are put on the scale of *grey levels of corner contrast*: an
ideal right-angle L-corner of contrast ``c`` (rendered at 16x supersampling)
has corner strength ``c``, and an ideal X-junction of contrast ``c`` has
saddle strength ``c``. Upsilon grows as ``contrast^(2K-2)``, so its strength
is ``100 (Upsilon / Upsilon_L100)^(1 / (2K - 2))`` with ``Upsilon_L100`` the
L-corner's peak at contrast 100. A threshold ``T`` then keeps corners at
least as strong as a right-angle corner of contrast ``T``, on a dim photo as on
a bright one, and scaling an image's contrast by ``a`` scales every strength
by ``a`` exactly.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from ._grey_rows import float_rows
from ._saddle_kernels import gradient_bilinear, strength_maxima
from .corners import Corners
from .filters import kernel_radius, steerable_basis
from .peaks import inside_allowed, one_per_point
from .response import MeasureSpec, soddc_measure
from .synthetic import Polygon, render_polygons

__all__ = [
    "CALIBRATION_CONTRAST",
    "X_RING_RADIUS",
    "add_x_junctions",
    "corner_unit",
    "find_saddles",
    "grey_strength",
    "measure_threshold",
    "near_any",
    "newton_step",
    "saddle_unit",
    "second_derivatives",
    "strength_floor",
]

#: the contrast (grey levels) of the calibration corner and junction
CALIBRATION_CONTRAST = 100.0
#: Upsilon peaks closer than this (px) to a reported X-junction belong to its ring and are dropped
#: (the hr study's choice, docs/hr.md)
X_RING_RADIUS = 2.0
_BORDER = cv2.BORDER_REFLECT  # half-sample symmetric, as every other stage
#: pixels per band of :func:`find_saddles` (OpenCV filters a crop under ~2 MP on one thread only)
BAND_PIXELS = 1 << 21
#: saddle points closer than this (px) are one saddle, reached from tied candidates (a plateau of
#: the strength, e.g. the pixels around a junction on a symmetric JPEG block corner; their iterates
#: meet within ~1e-4 px)
SADDLE_MERGE = 0.1
#: rows beyond a band where its maps are kept: a Newton iterate that reads farther (rare) continues
#: on crops filtered around it (``_finish``)
HALO = 16


def second_derivatives(grey: np.ndarray, sigma2: float, radius: int,
                       out: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """``(g_xx, g_xy, g_yy)`` of ``G_sigma * I``: sampled Gaussian derivatives, reflect border.

    They are the steerable basis of :mod:`sogdd.filters`
    (``l_theta = c^2 g_xx + 2 s c g_xy + s^2 g_yy``). ``out``: a (3, >= H, W)
    float64 buffer to write them into (bands reuse one: fresh image-sized
    allocations cost page faults every time).
    """
    b = steerable_basis(sigma2, radius)
    img = np.ascontiguousarray(grey, dtype=np.float64)
    h = img.shape[0]

    def f(i: int, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
        dst = None if out is None else out[i, :h]
        return cv2.sepFilter2D(img, cv2.CV_64F, kx, ky, dst=dst, borderType=_BORDER)

    return f(0, b.d2, b.gauss), f(1, b.d1, b.d1), f(2, b.gauss, b.d2)


def bilinear_rows(maps, off: int, H: int, W: int, x: np.ndarray, y: np.ndarray) -> list[np.ndarray]:
    """Each map at sub-pixel points of an H x W image (bilinear, edge-clamped), float64 arithmetic.

    The maps may hold only image rows ``off ..`` (a band), as long as they cover
    the two rows each point reads.
    """
    x0, x1 = _rows_of(x, W)  # the same clamp along either axis
    y0, y1 = _rows_of(y, H)
    fx, fy = np.clip(x, 0.0, W - 1.0) - x0, np.clip(y, 0.0, H - 1.0) - y0
    r0, r1 = y0 - off, y1 - off
    return [((m[r0, x0] * (1 - fx) + m[r0, x1] * fx) * (1 - fy) + (m[r1, x0] * (1 - fx) + m[r1, x1] * fx) * fy)
            for m in maps]


def newton_step(maps, map_off: int, img: np.ndarray, img_off: int, shape: tuple[int, int], x: np.ndarray,
                y: np.ndarray, basis) -> tuple[np.ndarray, np.ndarray]:
    """One step ``delta = -H^{-1} grad`` from each point: the Hessian from ``maps`` (``g_xx, g_xy, g_yy`` on
    image rows ``map_off ..``), the gradient from ``img`` (image rows ``img_off ..``).

    A singular Hessian is no saddle: the point is sent 9 px away, so that it is refused.
    """
    H, W = shape
    a, b, c = bilinear_rows(maps, map_off, H, W, x, y)
    px, py = gradient_bilinear(img, img_off, H, W, x, y, basis.gauss, basis.d1)
    det = a * c - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        dx = -(c * px - b * py) / det
        dy = -(a * py - b * px) / det
    return x + np.where(np.isfinite(dx), dx, 9.0), y + np.where(np.isfinite(dy), dy, 9.0)


def strength_floor(sigma2: float, min_strength: float) -> float:
    """The ``N = g_xy^2 - g_xx g_yy`` that candidates must exceed: ``s > min_strength`` in ``N`` units."""
    t = max(float(min_strength), 0.0) / float(sigma2)
    return t * t


def _rows_of(y: np.ndarray, H: int) -> tuple[np.ndarray, np.ndarray]:
    """The two rows (or columns, with the width) :func:`bilinear_rows` reads at ``y``, edge-clamped."""
    yc = np.clip(y, 0.0, H - 1.0)
    y0 = np.minimum(np.floor(yc).astype(np.int64), H - 2 if H > 1 else 0)
    return y0, np.minimum(y0 + 1, H - 1)


def _steps_in_band(maps, ea: int, eb: int, crop: np.ndarray, c0: int, shape: tuple[int, int], x: np.ndarray,
                   y: np.ndarray, basis, iterations: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newton steps while each point reads rows ``ea .. eb - 1`` only; ``(x, y, steps done)``."""
    x, y = x.copy(), y.copy()
    steps = np.zeros(len(x), dtype=np.int64)
    act = np.arange(len(x))
    for _ in range(int(iterations)):
        lo, hi = _rows_of(y[act], shape[0])
        act = act[(lo >= ea) & (hi < eb)]  # a point that would read outside continues in _finish
        x[act], y[act] = newton_step(maps, ea, crop, c0, shape, x[act], y[act], basis)
        steps[act] += 1
    return x, y, steps


def _finish(grey, sigma2: float, r: int, basis, x: np.ndarray, y: np.ndarray, steps: np.ndarray,
            iterations: int, band_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Newton steps of the points that left their band, until each has done ``iterations``.

    Each round sorts the points by the rows they read and filters crops of at most
    ``band_rows`` rows (plus ``r`` on each side) around groups of them, so memory stays
    that of a band however far the points went; a group ends where the next point's
    crop would not overlap its own, so a few scattered points filter a few rows each.
    """
    H, W = grey.shape
    x, y, steps = x.copy(), y.copy(), steps.copy()
    act = np.flatnonzero(steps < iterations)
    while len(act):
        lo, hi = _rows_of(y[act], H)
        order = np.argsort(lo, kind="stable")
        g0 = 0
        while g0 < len(order):
            glo = ghi = int(lo[order[g0]])
            g1 = g0
            while g1 < len(order) and (g1 == g0 or (lo[order[g1]] <= ghi + 2 * r + 1
                                                    and hi[order[g1]] < glo + band_rows)):
                ghi = max(ghi, int(hi[order[g1]]))
                g1 += 1
            sel = act[order[g0:g1]]
            c0, c1 = max(0, glo - r), min(H, ghi + 1 + r)  # rows glo .. ghi are the image's
            crop = np.ascontiguousarray(grey[c0:c1], dtype=np.float64)
            maps = [m[glo - c0 : ghi + 1 - c0] for m in second_derivatives(crop, sigma2, r)]
            x[sel], y[sel] = newton_step(maps, glo, crop, c0, (H, W), x[sel], y[sel], basis)
            g0 = g1
        steps[act] += 1
        act = act[steps[act] < iterations]
    return x, y


def find_saddles(grey, sigma2: float, radius: int | None = None, *, iterations: int = 4,
                 min_strength: float = 0.0, band_rows: int | None = None,
                 halo: int = HALO) -> tuple[np.ndarray, np.ndarray]:
    """Saddle points of the smoothed image: ``(xy (N, 2), strength (N,))``, strength ``s`` (module doc).

    Candidates with ``s <= min_strength`` are not fitted (a threshold, applied
    early). The image is processed in bands of ``band_rows`` rows (default: about
    :data:`BAND_PIXELS` pixels, at least 64 rows) with maps
    ``halo`` rows beyond them, with the same result for any band height and halo
    (module doc); ``grey`` may be a :class:`sogdd._grey_rows.GreyRows`.

    Examples
    --------
    >>> from sogdd.synthetic import Polygon, render_polygons
    >>> q = np.array([[20.3, 20.6], [60, 20.6], [60, 60], [20.3, 60]])
    >>> img = render_polygons((41, 41), [Polygon(q, 200.0), Polygon(2 * q[0] - q, 200.0)], background=50.0)
    >>> xy, s = find_saddles(img, 1.2)
    >>> np.round(xy[np.argmax(s)], 1).tolist()  # within 0.02 px of the junction
    [20.3, 20.6]
    """
    r = kernel_radius(sigma2) if radius is None else int(radius)
    H, W = grey.shape
    if band_rows is None:
        band_rows = max(64, -(-BAND_PIXELS // max(W, 1)))
    rows_per_band, halo = max(int(band_rows), 1), max(int(halo), 1)
    t_n = strength_floor(sigma2, min_strength)
    basis = steerable_basis(sigma2, r)
    parts = []
    buf = np.empty((4, min(H, rows_per_band + 2 * (halo + r)), W))  # one set of maps and crop for every band
    for a in range(0, H, rows_per_band):
        c = min(H, a + rows_per_band)
        ea, eb = max(0, a - halo), min(H, c + halo)  # rows where the band's maps are the image's
        c0, c1 = max(0, ea - r), min(H, eb + r)
        crop = float_rows(grey, c0, c1, buf[3])
        maps = [m[ea - c0 : eb - c0] for m in second_derivatives(crop, sigma2, r, out=buf[:3])]
        rows, cols, n = strength_maxima(*maps, top=ea, height=H, first=a - ea, last=c - ea, t_n=t_n)
        x0, y0 = cols.astype(np.float64), rows.astype(np.float64)
        parts.append((x0, y0, n, *_steps_in_band(maps, ea, eb, crop, c0, (H, W), x0, y0, basis, iterations)))
    x0, y0, n, x, y, steps = (np.concatenate([p[i] for p in parts]) for i in range(6))
    out = steps < int(iterations)
    if out.any():
        x[out], y[out] = _finish(grey, sigma2, r, basis, x[out], y[out], steps[out], int(iterations),
                                 rows_per_band)
    ok = (np.abs(x - x0) <= 1.0) & (np.abs(y - y0) <= 1.0)
    xy, strength = np.stack([x[ok], y[ok]], axis=1), sigma2 * np.sqrt(n[ok])
    keep = one_per_point(xy, strength, SADDLE_MERGE)  # tied candidates converge to one saddle
    return xy[keep], strength[keep]


def _calibration_images() -> tuple[np.ndarray, np.ndarray]:
    n, c, big = 64, 31.5, 200.0
    quad = np.array([[c, c], [c + big, c], [c + big, c + big], [c, c + big]])
    lo, hi = 50.0, 50.0 + CALIBRATION_CONTRAST
    L = render_polygons((n, n), [Polygon(quad, hi)], background=lo)
    X = render_polygons((n, n), [Polygon(quad, hi), Polygon(2 * c - quad, hi)], background=lo)
    return L, X


@lru_cache(maxsize=32)
def corner_unit(spec) -> float:
    """Peak Upsilon of an ideal right-angle L-corner of contrast 100 under ``spec``.

    ``spec``: a :class:`~sogdd.response.MeasureSpec` (any window, equal or Gaussian weights).
    """
    L, _ = _calibration_images()
    return float(soddc_measure(L, spec).max())


@lru_cache(maxsize=32)
def saddle_unit(sigma2: float, radius: int) -> float:
    """Peak saddle strength ``s`` of an ideal X-junction of contrast 100."""
    _, X = _calibration_images()
    _, s = find_saddles(X, sigma2, radius)
    return float(s.max())


def grey_strength(upsilon: np.ndarray, spec: MeasureSpec) -> np.ndarray:
    """Upsilon in grey levels of corner contrast: ``100 (Upsilon / Upsilon_L100)^(1/(2K-2))``.

    Examples
    --------
    >>> from sogdd.window import window_halfwidths
    >>> spec = MeasureSpec(1.2, 4, window_halfwidths("square", 7))
    >>> float(np.round(grey_strength(np.array([corner_unit(spec)]), spec)[0], 9))
    100.0
    """
    k = 2 * spec.n_orientations - 2
    u = np.maximum(np.asarray(upsilon, dtype=np.float64), 0.0) / corner_unit(spec)
    return CALIBRATION_CONTRAST * u ** (1.0 / k) if k > 0 else CALIBRATION_CONTRAST * u


def measure_threshold(grey_threshold: float, spec: MeasureSpec) -> float:
    """The Upsilon value whose grey-level strength is ``grey_threshold`` (inverse of :func:`grey_strength`)."""
    k = 2 * spec.n_orientations - 2
    t = max(float(grey_threshold), 0.0) / CALIBRATION_CONTRAST
    return corner_unit(spec) * (t**k if k > 0 else t)


def near_any(xy: np.ndarray, centres: np.ndarray, radius: float) -> np.ndarray:
    """Mask of the points of ``xy`` within ``radius`` of some point of ``centres``."""
    if len(xy) == 0 or len(centres) == 0:
        return np.zeros(len(xy), dtype=bool)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(centres).query(xy, k=1, distance_upper_bound=radius + 1e-9)
    return np.isfinite(d) & (d <= radius)


def saddle_search(grey, spec: MeasureSpec, threshold: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The saddles :func:`add_x_junctions` starts from: ``(xy, strength in grey levels)``.

    Only the image is read, so detection runs it beside the measure (``found=``).
    """
    r = kernel_radius(spec.sigma2, spec.radius_rule)
    unit = saddle_unit(spec.sigma2, r)
    raw_min = 0.0 if threshold is None else threshold * unit / CALIBRATION_CONTRAST
    xy, s = find_saddles(grey, spec.sigma2, r, min_strength=raw_min)
    return xy, CALIBRATION_CONTRAST * s / unit


def add_x_junctions(corners, grey, spec: MeasureSpec, *, threshold: float | None, rho: float, size: float,
                    border: int = 0, mask: np.ndarray | None = None,
                    found: tuple[np.ndarray, np.ndarray] | None = None):
    """Replace the ring of Upsilon peaks around each X-junction by the junction's saddle point.

    ``corners`` carry grey-level strengths (:func:`grey_strength`). Saddles of
    strength ``>= threshold`` (grey levels, :func:`saddle_unit` scale) are added;
    corners within ``rho`` px of one are dropped. Returns ``(Corners, is_x)``, strongest first,
    ``is_x`` marking the X-junctions. ``grey``: an array or a :class:`sogdd._grey_rows.GreyRows`
    (:func:`find_saddles` reads it in bands). ``found``: :func:`saddle_search`'s result for
    this ``grey``, ``spec`` and ``threshold``, if already computed.
    """
    xy, s = saddle_search(grey, spec, threshold) if found is None else found
    keep = inside_allowed(xy, mask, border, grey.shape)
    if threshold is not None:
        keep &= s >= threshold
    xy, s = xy[keep], s[keep]
    c = corners.subset(~near_any(corners.xy, xy, rho))
    out = Corners.concatenate([c, Corners(xy, s, np.full(len(s), float(size)))])
    order = np.argsort(-out.response, kind="stable")
    is_x = np.r_[np.zeros(len(c), bool), np.ones(len(s), bool)][order]
    return out.subset(order), is_x
