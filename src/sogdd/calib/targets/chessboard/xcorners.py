"""X-corner candidates: saddle points of the smoothed image with their two edge lines.

A chessboard's inner corner is an X-junction: two edge lines cross and the four
wedges alternate dark and light. Near the junction ``p`` the smoothed image is,
to second order, ``I(p + d) ~ m + d^T H d / 2`` (the gradient vanishes), with a
Hessian ``H`` of ``det H < 0``. For a junction of two blurred steps
``I = m + c s(n1 . d) s(n2 . d)`` (``s`` odd), ``H = c s'(0)^2 (n1 n2^T + n2 n1^T)``,
so

- the **edge lines** are the two zero-curvature directions ``d^T H d = 0``: with
  the eigenvalues ``l+ > 0 > l-`` and the eigenvector ``e+`` of ``l+`` they lie at
  ``alpha +- phi`` with ``alpha`` the angle of ``e+`` and ``tan phi = sqrt(l+ / -l-)``;
- the **light axis** ``alpha`` bisects the two light wedges (there ``d^T H d > 0``,
  the image is above its mean); at the next corner along either edge line the
  wedges' colours swap and the light axis turns by 90 degrees.

The candidates are :func:`saddles`: the Gaussian derivatives of each level are
filtered once (:func:`derivative_maps`, OpenCV's separable filters), and the 3 x 3
maxima of the saddle strength ``sigma^2 sqrt(g_xy^2 - g_xx g_yy)`` above the
noise-relative threshold are followed by Newton steps to their saddle on the
same maps (L-corners and edges, which leave their pixel, rejected); the Hessian
at the saddle is interpolated from them, and the strength is converted to grey
levels of contrast (an ideal X-junction of contrast ``c`` has strength ``c``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import cv2
import numba
import numpy as np

from sogdd._jit import EXACT_JIT
from sogdd.params import PRESETS
from sogdd.select.refine import one_per_point

from ..grey import to_grey

__all__ = ["XCorners", "find_xcorners"]


#: the saddle search's scale ``sigma^2`` (px^2): the ``hr`` preset's ``sigma2``, read from it so the two agree
SIGMA2 = float(PRESETS["hr"].sigma2)
#: images above this many pixels are searched at a reduced scale by default (the refinement works at full scale)
SEARCH_PIXELS = 2_000_000
#: the saddle strength that noise alone reaches, in multiples of :func:`noise_strength`: the largest of the
#: 3 x 3 saddle maxima of pure Gaussian noise, white or blurred by sigma 0.5-1.5 px, is 3.9-4.3 times it
NOISE_FACTOR = 4.0
#: the search's floor without ``min_strength``: this share of the image's range (1st to 99th percentile of
#: its grey levels), 6-10 grey levels on the real sets, whose range is 112-255
CONTRAST_SHARE = 0.04
#: pixels per band of the candidate search's filtered maps (five float32 maps of a band: 40 MB)
BAND_PIXELS = 1 << 21
#: about this many pixels are sampled for the image's statistics (its noise, its range)
SAMPLES = 1 << 16
#: Newton steps from each candidate pixel to its saddle (the ``hr`` search's number)
NEWTON_STEPS = 4
#: saddle points closer than this (px) are one saddle, reached from tied candidates (a plateau of strength)
SADDLE_MERGE = 0.1
#: the pyramid's coarsest level keeps at least this many pixels along the image's shorter side
MIN_LEVEL_SIDE = 100


@dataclass(frozen=True)
class XCorners:
    """X-corner candidates of one image.

    Attributes
    ----------
    xy : (N, 2) float64
        Saddle points, ``x`` = column, ``y`` = row, pixel centres at integers.
    strength : (N,) float64
        Saddle strength in grey levels of contrast (a sharp junction between
        levels ``a`` and ``b`` has strength ``|b - a|``; a blur of ``b`` px lowers
        it by about ``1.5 / (1.5 + b^2)``).
    light : (N,) float64
        Angle in ``[0, pi)`` of the axis bisecting the two light wedges.
    spread : (N,) float64
        Half-angle ``phi`` between the edge lines and the light axis, in
        ``(0, pi/2)``; ``pi/4`` for perpendicular edges.
    noise : float
        The noise of the search that found them (:func:`noise_strength`, as
        the search used it; NaN when they come from elsewhere).
    """

    xy: np.ndarray
    strength: np.ndarray
    light: np.ndarray
    spread: np.ndarray
    noise: float = math.nan

    def __len__(self) -> int:
        return len(self.xy)

    @property
    def edges(self) -> np.ndarray:
        """(N, 2) angles in ``[0, pi)`` of the two edge lines, ``light - spread`` and ``light + spread``."""
        return np.mod(np.stack([self.light - self.spread, self.light + self.spread], axis=1), np.pi)

    @cached_property
    def by_x(self) -> np.ndarray:
        """The candidates' indices sorted by ``x`` (the lattice's search for a label's candidates), once."""
        return np.argsort(self.xy[:, 0], kind="stable")

    def subset(self, keep: np.ndarray) -> XCorners:
        """The candidates selected by a mask or index array."""
        return XCorners(self.xy[keep], self.strength[keep], self.light[keep], self.spread[keep])


def _kernels(sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = int(np.ceil(3.5 * sigma))
    t = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-t * t / (2 * sigma * sigma))
    g /= g.sum()
    d1 = -t / sigma**2 * g
    d2 = (t * t / sigma**4 - 1 / sigma**2) * g
    d2 -= d2.mean()  # no response to a constant
    return g, d1, d2


def hessian_at(grey: np.ndarray, xy: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian-derivative Hessians ``(g_xx, g_xy, g_yy)`` at ``xy``, bilinear between pixels, (N, 3)."""
    g, d1, d2 = _kernels(sigma)
    r = (len(g) - 1) // 2
    pad = np.pad(grey, r + 1, mode="reflect")
    x = np.clip(xy[:, 0], 0, grey.shape[1] - 1)
    y = np.clip(xy[:, 1], 0, grey.shape[0] - 1)
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = x - x0, y - y0
    o = np.arange(2 * r + 2)
    patches = pad[(y0[:, None] + o + 1)[:, :, None], (x0[:, None] + o + 1)[:, None, :]]  # pad: pixel + r + 1
    out = np.zeros((len(xy), 3))
    for a, b, w in ((0, 0, (1 - fx) * (1 - fy)), (0, 1, fx * (1 - fy)), (1, 0, (1 - fx) * fy), (1, 1, fx * fy)):
        p = patches[:, a : a + 2 * r + 1, b : b + 2 * r + 1]  # centred on pixel (x0 + b, y0 + a)
        out[:, 0] += w * np.einsum("nab,a,b->n", p, g, d2)
        out[:, 1] += w * np.einsum("nab,a,b->n", p, d1, d1)
        out[:, 2] += w * np.einsum("nab,a,b->n", p, d2, g)
    return out


def edge_geometry(hess: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Light axis, half-angle ``phi`` and ``det H < 0`` mask from Hessians (module doc)."""
    a, b, c = hess[:, 0], hess[:, 1], hess[:, 2]
    mean, half = (a + c) / 2, np.hypot((a - c) / 2, b)
    lp, lm = mean + half, mean - half
    saddle = (lp > 0) & (lm < 0)
    light = np.mod(0.5 * np.arctan2(2 * b, a - c), np.pi)  # the eigenvector of the larger eigenvalue
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = np.arctan(np.sqrt(np.where(saddle, lp / np.where(saddle, -lm, 1.0), 1.0)))
    return light, phi, saddle


def junction_strength(hess: np.ndarray) -> np.ndarray:
    """The saddle strength in grey levels of contrast from Hessians ``(g_xx, g_xy, g_yy)`` at :data:`SIGMA2`.

    ``sigma^2 sqrt(max(g_xy^2 - g_xx g_yy, 0)) / u``, ``u`` that of an ideal
    junction of unit contrast: what :class:`XCorners` holds as ``strength``.

    Examples
    --------
    >>> t = np.arange(60) - 30.4
    >>> img = np.where((t[:, None] > 0) == (t[None, :] > 0), 200.0, 40.0)
    >>> xy = np.array([[30.5, 30.5]])
    >>> round(float(junction_strength(hessian_at(img, xy, np.sqrt(SIGMA2)))[0]))  # contrast 160
    160
    """
    h = np.asarray(hess, dtype=np.float64).reshape(-1, 3)
    return SIGMA2 * np.sqrt(np.maximum(h[:, 1] ** 2 - h[:, 0] * h[:, 2], 0.0)) / _unit()


@lru_cache(maxsize=1)
def _unit() -> float:
    """The saddle strength ``sigma^2 sqrt(g_xy^2 - g_xx g_yy)`` (:data:`SIGMA2`) at the strongest pixel of an
    ideal X-junction of contrast 1 (levels 0 and 1, 4 x 4 supersampled, off the pixel grid)."""
    n, s = 41, 4
    t = (np.arange(n * s) + 0.5) / s - 0.5 - 20.3
    fine = ((t[:, None] > 0) == (t[None, :] - 0.4 > 0)).astype(np.float64)
    img = 100.0 * fine.reshape(n, s, n, s).mean(axis=(1, 3))
    return float(SIGMA2 * np.sqrt(_det(derivative_maps(img)).max())) / 100.0


def check_search(grey: np.ndarray, min_strength: float | None, scale: float | None, mask) -> None:
    """The X-corner search's arguments, checked at the door (one-line ``ValueError``)."""
    ok = min_strength is None or (isinstance(min_strength, (int, float, np.integer, np.floating))
                                  and not isinstance(min_strength, bool) and np.isfinite(min_strength)
                                  and min_strength >= 0)
    if not ok:
        raise ValueError(f"min_strength must be None or a finite number >= 0, got {min_strength!r}")
    if scale is not None and not (0 < scale <= 1):
        raise ValueError(f"scale must be in (0, 1], got {scale!r}")
    if mask is not None and np.shape(mask) != grey.shape:
        raise ValueError(f"mask must have the image's shape {grey.shape}, got {np.shape(mask)}")


def find_xcorners(image: np.ndarray, *, min_strength: float | None = None, scale: float | None = None,
                  mask: np.ndarray | None = None, value_range: tuple[float, float] | None = None) -> XCorners:
    """X-corner candidates: saddle points, their edge lines and grey-level strength.

    For each saddle ``p`` of ``G_sigma * I`` (:data:`SIGMA2`, the ``hr``
    preset's ``sigma^2 = 1.5``; :func:`saddles`), the Hessian ``H`` at
    ``p`` gives the light axis ``alpha`` (eigenvector of the positive eigenvalue
    ``l+``) and the edge lines at ``alpha +- phi``, ``tan phi = sqrt(l+ / -l-)``
    (the directions with ``d^T H d = 0``). The strength is the saddle strength
    divided by that of an ideal X-junction of unit contrast.

    Parameters
    ----------
    image : ndarray
        Grey or colour image (RGB), any dtype :func:`sogdd.image.validate_image`
        takes, on its scale (:func:`to_grey`): a float image on [0, 1], else
        give ``value_range``.
    min_strength : float or None
        Candidates below this strength (grey levels of contrast on the 0-255
        scale) are not fitted; None: :data:`CONTRAST_SHARE` of the image's
        range (its 1st to 99th percentile). Either way the search raises it to
        what noise alone reaches (:func:`threshold`).
    scale : float or None
        Search on the image resized by this factor (<= 1) and map the points back
        (``x = (x' + 0.5) / scale - 0.5``); None: 1 up to
        :data:`SEARCH_PIXELS` pixels, else the factor that fits that budget.
        The positions are coarse at a reduced scale: refine them
        (:func:`sogdd.calib.refine_corners`).
    mask : ndarray of bool or None
        Keep only candidates whose nearest pixel is True.
    value_range : (lo, hi) or None
        The image's range, mapped to 0-255 (``(0, 255)`` for OpenCV's float
        images of grey levels); None: the dtype's (float: [0, 1]).

    Returns
    -------
    XCorners

    Examples
    --------
    >>> t = np.arange(60) - 30.4
    >>> img = np.where((t[:, None] > 0) == (t[None, :] > 0), 200.0, 40.0)
    >>> xc = find_xcorners(img, value_range=(0, 255))
    >>> len(xc), np.round(xc.xy[0], 1).tolist()
    (1, [30.5, 30.5])
    >>> round(float(np.degrees(xc.light[0]))), round(float(np.degrees(xc.spread[0])))
    (45, 45)
    """
    grey = to_grey(image, value_range)
    check_search(grey, min_strength, scale, mask)
    return search(grey, min_strength, scale, mask)


def default_scale(shape: tuple[int, int]) -> float:
    """The search scale of an image of this shape: 1 up to :data:`SEARCH_PIXELS` pixels, else that budget."""
    return min(1.0, float(np.sqrt(SEARCH_PIXELS / (shape[0] * shape[1]))))


@lru_cache(maxsize=1)
def _filters() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Correlation kernels (float32) of the Gaussian, its first and its second derivative at :data:`SIGMA2`."""
    g, d1, d2 = _kernels(np.sqrt(SIGMA2))
    return g.astype(np.float32), (-d1).astype(np.float32), d2.astype(np.float32)  # correlation: d1 mirrored


def derivative_maps(img: np.ndarray) -> np.ndarray:
    """``(g_x, g_y, g_xx, g_xy, g_yy)`` of ``G_sigma * img`` at :data:`SIGMA2`, (5, H, W) float32.

    Separable Gaussian-derivative filters (``cv2.sepFilter2D``, the border
    reflected), the ones :func:`hessian_at` applies at points: the maps at pixel
    centres, so that their bilinear interpolation is :func:`hessian_at`.

    Examples
    --------
    >>> t = np.arange(40) - 20.0
    >>> m = derivative_maps(np.tile(3.0 * t, (40, 1)))  # a ramp of slope 3 along x
    >>> np.round(m[:, 20, 20], 3).tolist()
    [3.0, 0.0, 0.0, 0.0, 0.0]
    """
    g, d1, d2 = _filters()
    src = np.ascontiguousarray(img, dtype=np.float32)
    out = np.empty((5, *src.shape), np.float32)  # one block written in place: five fresh maps cost 3x more
    for k, (kx, ky) in enumerate(((d1, g), (g, d1), (d2, g), (d1, d1), (g, d2))):  # (along x, along y)
        cv2.sepFilter2D(src, -1, kx, ky, dst=out[k], borderType=cv2.BORDER_REFLECT)
    return out


def _bands(H: int, W: int) -> list[tuple[int, int]]:
    rows = max(64, BAND_PIXELS // max(W, 1))
    return [(a, min(H, a + rows)) for a in range(0, H, rows)]


def _band_maps(work: np.ndarray, a: int, c: int) -> tuple[np.ndarray, int]:
    """The derivative maps of image rows ``a - P .. c + P`` (``P`` the kernel radius and the Newton steps'
    reach), exact on rows ``a .. c`` (and wherever the crop is the image's), and the crop's first row."""
    pad = len(_filters()[0]) // 2 + NEWTON_STEPS
    top = max(0, a - pad)
    return derivative_maps(work[top:min(work.shape[0], c + pad)]), top


def _det(m: np.ndarray) -> np.ndarray:
    """``g_xy^2 - g_xx g_yy`` of derivative maps (:func:`derivative_maps`): the saddle strength squared,
    over ``sigma^4``."""
    out = np.empty(m.shape[1:], m.dtype)
    _det_into(m, out)
    return out


@numba.njit(**EXACT_JIT)
def _det_into(m, out):  # pragma: no cover - jit
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            out[i, j] = m[3, i, j] * m[3, i, j] - m[2, i, j] * m[4, i, j]


def noise_strength(grey: np.ndarray) -> float:
    """The image's noise, measured as the saddle search sees it: grey levels of saddle strength.

    ``N = median_x sigma^2 sqrt(|g_xy^2 - g_xx g_yy|) / u`` over every other
    pixel each way (about :data:`SAMPLES` pixels on a large image), with ``g``
    the Gaussian derivatives at :data:`SIGMA2` (:func:`derivative_maps`) and
    ``u`` the strength of an ideal junction of unit contrast: the strength
    map's typical value where there is no junction.
    A board's corners and edges cover few pixels (along a straight edge
    ``g_xy^2 = g_xx g_yy``), so the median is that of the noise and texture,
    of whatever spectrum: on Gaussian noise, white or blurred, the largest
    saddle maximum is 3.9-4.3 ``N`` (:data:`NOISE_FACTOR`), where a threshold in
    grey levels would pass noise at one sigma and miss faint boards at another.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> n1 = noise_strength(128 + 2.0 * rng.standard_normal((200, 200)))
    >>> n2 = noise_strength(128 + 8.0 * rng.standard_normal((200, 200)))
    >>> round(n2 / n1, 1)  # proportional to the noise
    4.0
    >>> noise_strength(np.full((50, 50), 100.0)) < 1e-4  # a flat image: float rounding only
    True
    """
    H, W = grey.shape
    step = _stride(grey.shape)
    parts = []
    for a, c in _bands(H, W):
        m, top = _band_maps(grey, a, c)
        parts.append(np.abs(_det(m[:, a + (-a % step) - top : c - top : step, ::step])).ravel())
    return _noise(np.concatenate(parts))


def _stride(shape: tuple[int, int]) -> int:
    """The step between the pixels a statistic of the image samples each way: every other pixel, or fewer
    on a large image, keeping about :data:`SAMPLES` (the median of as many is within 1 % of the image's)."""
    return max(2, round(float(np.sqrt(shape[0] * shape[1] / SAMPLES))))


def _noise(det: np.ndarray) -> float:
    return float(SIGMA2 * np.sqrt(np.median(det)) / _unit())


@numba.njit(**EXACT_JIT)
def _sample(m, x, y, out):  # pragma: no cover - jit
    """The maps ``m`` (K, h, w) at ``(x, y)``, bilinear, the point clamped to the maps, into ``out`` (K,)."""
    h, w = m.shape[1], m.shape[2]
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    x0 = min(int(math.floor(x)), max(w - 2, 0))
    y0 = min(int(math.floor(y)), max(h - 2, 0))
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    fx, fy = x - x0, y - y0
    for k in range(m.shape[0]):
        out[k] = ((m[k, y0, x0] * (1.0 - fx) + m[k, y0, x1] * fx) * (1.0 - fy)
                  + (m[k, y1, x0] * (1.0 - fx) + m[k, y1, x1] * fx) * fy)


@numba.njit(**EXACT_JIT)
def _newton(m, x, y, steps, hess):  # pragma: no cover - jit
    """``steps`` Newton steps ``p <- p - H^{-1} grad`` from each point (in place) on the derivative maps ``m``,
    then ``(g_xx, g_xy, g_yy)`` at the point into ``hess`` (N, 3)."""
    v = np.empty(5)
    for t in range(x.shape[0]):
        for _ in range(steps):
            _sample(m, x[t], y[t], v)
            det = v[2] * v[4] - v[3] * v[3]
            dx = -(v[4] * v[0] - v[3] * v[1]) / det
            dy = -(v[2] * v[1] - v[3] * v[0]) / det
            # a singular Hessian is no saddle: the point is sent away, so that it is refused
            x[t] += dx if math.isfinite(dx) else 9.0
            y[t] += dy if math.isfinite(dy) else 9.0
        _sample(m, x[t], y[t], v)
        hess[t, 0], hess[t, 1], hess[t, 2] = v[2], v[3], v[4]


def saddles(work: np.ndarray, floor: float, noise_cap: float = math.inf,
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Saddle points of ``G_sigma * work`` stronger than the search's threshold: ``(xy, strength, hess, N)``.

    With the derivative maps of :func:`derivative_maps` (in bands of rows of
    about :data:`BAND_PIXELS` pixels, each exact on its rows):

    1. the threshold ``t = max(floor, NOISE_FACTOR N)``, ``N`` the smaller of
       :func:`noise_strength` and ``noise_cap`` (the noise of a finer level of the
       same image: averaging pixels never adds noise, while the strength map's
       median at a coarse level, where the board and the background's texture
       fill much of a small image, measures them too);
    2. candidates: the 3 x 3 maxima (in-image neighbours) of the saddle strength
       ``s = sigma^2 sqrt(g_xy^2 - g_xx g_yy) / u`` with ``s >= t``;
    3. :data:`NEWTON_STEPS` Newton steps ``p <- p - H(p)^{-1} grad(p)`` from the
       pixel, the derivatives interpolated bilinearly; a candidate that ends more
       than a pixel away along either axis is no saddle of its own (an
       L-corner's, an edge's); points within :data:`SADDLE_MERGE` are one.

    ``strength`` is the candidate pixel's ``s`` (grey levels of contrast, the
    maximum's), ``hess`` ``(g_xx, g_xy, g_yy)`` at the saddle point.

    Examples
    --------
    >>> t = np.arange(60) - 30.4
    >>> img = np.where((t[:, None] > 0) == (t[None, :] > 0), 200.0, 40.0)
    >>> xy, s, _, _ = saddles(img, 5.0)
    >>> np.round(xy, 2).tolist(), round(float(s[0]))  # contrast 160, the junction on the pixel grid
    ([[30.5, 30.5]], 157)
    """
    H, W = work.shape
    bands = _bands(H, W)
    unit = _unit()
    m, top = _band_maps(work, *bands[0])
    det = _det(m)
    if len(bands) == 1:  # the maps once: the noise from them
        step = _stride(work.shape)
        noise = _noise(np.abs(det[::step, ::step]).ravel())
    else:
        noise = noise_strength(work)
    noise = min(noise, float(noise_cap))
    t_det = (max(float(floor), NOISE_FACTOR * noise) * unit / SIGMA2) ** 2
    xy, strength, hess = [], [], []
    for k, (a, c) in enumerate(bands):
        if k:
            m, top = _band_maps(work, a, c)
            det = _det(m)
        peak = ((det >= cv2.dilate(det, np.ones((3, 3), np.uint8))) & (det >= t_det)).view(np.uint8)
        peak[: a - top] = 0
        peak[c - top :] = 0
        pts = cv2.findNonZero(peak)
        cols, rows = pts.reshape(-1, 2).T.astype(np.int64) if pts is not None else np.zeros((2, 0), np.int64)
        x, y = cols.astype(np.float64), rows.astype(np.float64)
        h = np.empty((len(x), 3))
        _newton(m, x, y, NEWTON_STEPS, h)
        ok = (np.abs(x - cols) <= 1.0) & (np.abs(y - rows) <= 1.0)
        xy.append(np.stack([x[ok], y[ok] + top], axis=1))
        strength.append(SIGMA2 * np.sqrt(det[rows[ok], cols[ok]].astype(np.float64)) / unit)
        hess.append(h[ok])
    xy, strength, hess = np.concatenate(xy), np.concatenate(strength), np.concatenate(hess)
    keep = one_per_point(xy, strength, SADDLE_MERGE)
    return xy[keep], strength[keep], hess[keep], noise


def search_levels(shape: tuple[int, int]) -> tuple[float, ...]:
    """The scales at which the board search looks, in the order it tries them.

    A pyramid of octaves: :func:`default_scale`, then half of it, a quarter...
    while the shorter side keeps :data:`MIN_LEVEL_SIDE` pixels, and last the
    full resolution when the first level is reduced (a board of small cells in a
    large frame). Each octave halves a blur, a motion smear and a cell in pixels
    and averages the noise of four pixels into one (its sigma halves), while the
    saddle strength, in grey levels of contrast, is unchanged for a sharp
    junction: a board too blurred or too noisy at one scale is clear at a coarser
    one, and a board of 300 px cells is one of 37 px cells three octaves up.

    Examples
    --------
    >>> search_levels((480, 640))
    (1.0, 0.5, 0.25)
    >>> [round(s, 3) for s in search_levels((3000, 4000))]  # 12 MP: from the 2 MP budget down, then full
    [0.408, 0.204, 0.102, 0.051, 1.0]
    >>> search_levels((60, 80))
    (1.0,)
    """
    s0 = default_scale(shape)
    side = min(shape)
    out = [s0]
    while side * out[-1] / 2 >= MIN_LEVEL_SIDE:
        out.append(out[-1] / 2)
    if s0 < 1:
        out.append(1.0)
    return tuple(out)


def threshold(grey: np.ndarray, min_strength: float | None = None) -> float:
    """The weakest saddle strength the search keeps in ``grey`` (grey levels of contrast).

    ``max(f, NOISE_FACTOR N)``: ``N`` the image's noise as the search sees it
    (:func:`noise_strength`; noise alone stays under ``NOISE_FACTOR N``) and
    ``f`` the floor, ``min_strength`` or, when None, :data:`CONTRAST_SHARE`
    of the image's range (1st to 99th percentile): scaled with the light, so a
    dim board and a bright one are searched alike. Both follow the image; no
    grey level is fixed.

    Examples
    --------
    >>> t = np.arange(60) - 30.4
    >>> bright = np.where((t[:, None] > 0) == (t[None, :] > 0), 200.0, 40.0)
    >>> dim = 0.25 * bright
    >>> round(threshold(bright), 2), round(threshold(dim), 2)  # 4 % of the range: 160 and 40 grey levels
    (6.4, 1.6)
    >>> round(threshold(bright, 20.0), 1)
    20.0
    """
    return max(floor(grey, min_strength), NOISE_FACTOR * noise_strength(grey))


def floor(grey: np.ndarray, min_strength: float | None = None) -> float:
    """The search's floor: ``min_strength`` or, when None, :data:`CONTRAST_SHARE` of the image's range
    (1st to 99th percentile of the pixels :func:`_stride` samples)."""
    if min_strength is None:
        step = _stride(grey.shape)
        lo, hi = np.percentile(grey[::step, ::step], [1, 99])
        return CONTRAST_SHARE * float(hi - lo)
    return float(min_strength)


def search(grey: np.ndarray, min_strength: float | None, scale: float | None,
           mask: np.ndarray | None, noise_cap: float = math.inf) -> XCorners:
    """:func:`find_xcorners` on a validated grey image (float32 or float64, 0-255); ``noise_cap``: the
    noise of a finer level's search of the same image (:func:`saddles`)."""
    H, W = grey.shape
    scale = default_scale(grey.shape) if scale is None else scale
    work = np.asarray(grey, dtype=np.float32)  # the search's maps are float32: one conversion per image
    if scale < 1:
        size = (max(8, round(W * scale)), max(8, round(H * scale)))
        work = cv2.resize(work, size, interpolation=cv2.INTER_AREA)
    xy, st, hess, noise = saddles(work, floor(work, min_strength), noise_cap)
    light, phi, saddle = edge_geometry(hess)
    if scale < 1:
        fx, fy = W / work.shape[1], H / work.shape[0]
        xy = np.stack([(xy[:, 0] + 0.5) * fx - 0.5, (xy[:, 1] + 0.5) * fy - 0.5], axis=1)
    keep = saddle
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        ix = np.clip(np.rint(xy[:, 0]).astype(np.int64), 0, W - 1)
        iy = np.clip(np.rint(xy[:, 1]).astype(np.int64), 0, H - 1)
        keep &= m[iy, ix]
    order = np.argsort(-st[keep], kind="stable")
    sel = np.flatnonzero(keep)[order]
    return XCorners(xy[sel], st[sel], light[sel], phi[sel], noise)
