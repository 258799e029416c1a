"""A flexible numpy/OpenCV prototype of the SOGDD family, for the hr study only.

Every variant of the study is one :class:`Cfg`. The response is computed the
slow, obvious way, so that any combination can be tried:

1. the steerable basis ``g_xx, g_xy, g_yy`` of :mod:`sogdd.measure.filters` (separable,
   ``cv2.sepFilter2D``, reflect border), optionally zero-mean;
2. ``K`` responses ``l_k = c^2 g_xx + 2 s c g_xy + s^2 g_yy`` (eq. 23),
   absolute or signed, scale-normalised by ``sigma^2`` so they are grey levels;
3. the ``K (K + 1) / 2`` window *means* of ``a_i a_j`` with a box, disk or
   Gaussian window;
4. a measure of the K x K matrix ``M``, put on the grey-level scale ``g``
   (``g(c I) = c g(I)``):

   ``dettr``      ``(det M / tr M)^(1/(2K-2))``  (eq. 25, up to the window area)
   ``detroot``    ``det(M)^(1/(2K))``
   ``scalefree``  ``det M / (tr M / K)^K`` (dimensionless, in [0, 1])
   ``mineig``     ``sqrt(lambda_min(M))``
   ``gram``       ``sqrt(tr M / K) * det(C)^(1/(2K))``, C = M's correlation matrix

5. peaks (3x3 maxima), an X-junction (saddle) stage, sub-pixel refinement.

``paper_measure`` returns eq. 25 exactly as ``sogdd.corner_response`` defines it
(unnormalised window sums), to check this prototype against the package.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache

import cv2
import numpy as np

from sogdd.corners import Corners
from sogdd.measure.filters import kernel_radius, steerable_basis
from sogdd.select.peaks import select_peaks
from sogdd.select.refine import refine_quadratic

VARSIGMA = 2.22e-16
_B = cv2.BORDER_REFLECT  # half-sample symmetric = scipy "reflect"


@dataclass(frozen=True)
class Cfg:
    """One point of the design space (defaults: the paper preset's choices)."""

    sigma2: float = 1.2
    K: int = 8
    window: str = "box"  # box | disk | gauss
    size: int = 7  # odd window size; gauss: sigma_w = size / 4
    measure: str = "dettr"
    signed: bool = False
    zero_mean: bool = False
    radius_mult: float = 4.0  # kernel radius = ceil(radius_mult * sigma)
    scales: int = 1  # 1, or 2: max over sigma and 2 sigma (scale-normalised) per pixel
    levels: int = 1  # image pyramid (factor 2, INTER_AREA), points of every level ranked together
    dedup: float = 0.0  # drop a coarse point within dedup coarse pixels of a finer one (0: keep all)
    saddle: bool = False  # X-junction stage
    saddle_rho: float = 3.0  # ring suppression radius (px) around an accepted saddle
    saddle_measure: str = "det"  # det: sigma^2 sqrt(-det H); min: sigma^2 min(|l1|, |l2|) (opposite signs)
    subpix: str = "grad"  # none | quad | grad | grad_adapt
    threshold: float | None = None  # grey levels on g
    max_corners: int | None = None

    def label(self) -> str:
        base = Cfg()
        return ",".join(f"{k}={v}" for k, v in self.__dict__.items() if getattr(base, k) != v) or "paper-like"


# -- filtering ----------------------------------------------------------------
def basis(img: np.ndarray, sigma2: float, radius: int, zero_mean: bool) -> tuple[np.ndarray, ...]:
    """``(g_x, g_y, g_xx, g_xy, g_yy)`` of the image at scale sigma2 (reflect border)."""
    b = steerable_basis(sigma2, radius, zero_mean=zero_mean)
    f = lambda kx, ky: cv2.sepFilter2D(img, cv2.CV_64F, kx, ky, borderType=_B)  # noqa: E731
    gx, gy = f(b.d1, b.gauss), f(b.gauss, b.d1)
    gxx, gxy, gyy = f(b.d2, b.gauss), f(b.d1, b.d1), f(b.gauss, b.d2)
    if zero_mean:
        n = 2 * radius + 1
        box = cv2.boxFilter(img, cv2.CV_64F, (n, n), normalize=False, borderType=_B)
        m = b.means
        gxx, gxy, gyy = gxx - m[0] * box, gxy - m[1] * box, gyy - m[2] * box
    return gx, gy, gxx, gxy, gyy


def window_kernel(shape: str, size: int) -> np.ndarray:
    """Window weights summing to 1 (disk: ``dy^2 + dx^2 <= (R + 1/2)^2``, as the package)."""
    R = size // 2
    t = np.arange(-R, R + 1)
    yy, xx = np.meshgrid(t, t, indexing="ij")
    if shape == "box":
        w = np.ones((size, size))
    elif shape == "disk":
        w = (yy**2 + xx**2 <= (R + 0.5) ** 2).astype(np.float64)
    elif shape == "gauss":
        sw = size / 4.0
        R = int(math.ceil(3 * sw))
        t = np.arange(-R, R + 1)
        yy, xx = np.meshgrid(t, t, indexing="ij")
        w = np.exp(-(xx**2 + yy**2) / (2 * sw * sw))
    else:
        raise ValueError(shape)
    return w / w.sum()


def responses(img: np.ndarray, cfg: Cfg, sigma2: float | None = None):
    s2 = cfg.sigma2 if sigma2 is None else sigma2
    r = max(1, int(math.ceil(cfg.radius_mult * math.sqrt(s2) - 1e-12)))
    gx, gy, gxx, gxy, gyy = basis(img, s2, r, cfg.zero_mean)
    th = np.arange(cfg.K) * np.pi / cfg.K
    c, s = np.cos(th), np.sin(th)
    ls = np.stack([c[k] ** 2 * gxx + 2 * s[k] * c[k] * gxy + s[k] ** 2 * gyy for k in range(cfg.K)])
    return ls, (gx, gy, gxx, gxy, gyy)


def _wfilter(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    if np.all(w == w.flat[0]):  # box: running sums
        return cv2.boxFilter(x, cv2.CV_64F, w.shape[::-1], normalize=False, borderType=_B) * w.flat[0]
    u, s, vt = np.linalg.svd(w)
    if s[1] < 1e-12 * s[0]:  # separable (Gaussian)
        return cv2.sepFilter2D(x, cv2.CV_64F, vt[0] * np.sqrt(s[0]), u[:, 0] * np.sqrt(s[0]), borderType=_B)
    return cv2.filter2D(x, cv2.CV_64F, w, borderType=_B)


def window_means(a: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(K, K, H, W) window means of a_i a_j (symmetric; the same array object on both sides)."""
    K = len(a)
    out = np.empty((K, K) + a.shape[1:])
    for i in range(K):
        for j in range(i, K):
            out[i, j] = _wfilter(a[i] * a[j], w)
            if j != i:
                out[j, i] = out[i, j]
    return out


def det_planes(M: np.ndarray) -> np.ndarray:
    """det of (K, K, H, W) symmetric PSD matrices by elimination across pixel planes (no pivoting).

    A zero pivot means a singular matrix (PSD), so its determinant is 0.
    """
    A = M.copy()
    K = A.shape[0]
    det = np.ones(A.shape[2:])
    for k in range(K):
        piv = A[k, k]
        det *= piv
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(np.abs(piv) > 1e-280, 1.0 / piv, 0.0)  # (near-)singular: det 0
        for i in range(k + 1, K):
            f = A[i, k] * inv
            for j in range(k + 1, K):
                A[i, j] -= f * A[k, j]
    return det


def measure_grey(M: np.ndarray, measure: str) -> np.ndarray:
    """The grey-level measure g of the (K, K, H, W) matrices (module doc)."""
    K = M.shape[0]
    tr = np.maximum(sum(M[k, k] for k in range(K)), 0.0)  # running box sums round to -1e-14 on flat areas
    if measure in ("dettr", "detroot", "scalefree"):
        det = np.maximum(det_planes(M), 0.0)
        if measure == "dettr":
            return (det / (tr + VARSIGMA)) ** (1.0 / (2 * K - 2))
        if measure == "detroot":
            return det ** (1.0 / (2 * K))
        return det / np.maximum(tr / K, 1e-300) ** K
    if measure == "mineig":
        A = np.ascontiguousarray(np.moveaxis(M, (0, 1), (-2, -1)))
        return np.sqrt(np.maximum(np.linalg.eigvalsh(A)[..., 0], 0.0))
    if measure == "gram":
        # flat pixels (a zero diagonal) have no direction: their correlation det is 0
        diag = np.stack([M[k, k] for k in range(K)])
        ok = np.all(diag > 1e-12 * np.maximum(tr, 1e-300), axis=0)
        d = np.sqrt(np.where(ok, diag, 1.0))
        C = M / (d[:, None] * d[None, :])
        return np.where(ok, np.sqrt(tr / K) * np.maximum(det_planes(C), 0.0) ** (1.0 / (2 * K)), 0.0)
    raise ValueError(measure)


def grey_map(img: np.ndarray, cfg: Cfg) -> tuple[np.ndarray, tuple]:
    """The measure in grey levels of corner contrast (see :func:`calibration`), and the derivatives."""
    g, d = raw_grey_map(img, cfg)
    return g * calibration(cfg)[0], d


def raw_grey_map(img: np.ndarray, cfg: Cfg) -> tuple[np.ndarray, tuple]:
    """The measure g (linear in contrast) and the scale-sigma derivatives (for the saddle stage)."""
    w = window_kernel(cfg.window, cfg.size)
    out, derivs = None, None
    for i in range(cfg.scales):
        s2 = cfg.sigma2 * 4.0**i
        ls, d = responses(img, cfg, s2)
        a = ls * s2  # scale-normalised: a step of height h gives O(h) whatever sigma
        if not cfg.signed:
            a = np.abs(a)
        g = measure_grey(window_means(a, w), cfg.measure)
        if out is None:
            out, derivs = g, d
        else:
            out = np.maximum(out, g)
    return out, derivs


def paper_measure(img: np.ndarray, cfg: Cfg) -> np.ndarray:
    """Eq. 25 with unnormalised window sums: must equal ``sogdd.corner_response``."""
    ls, _ = responses(img, cfg)
    a = ls if cfg.signed else np.abs(ls)
    w = window_kernel(cfg.window, cfg.size)
    w = w / w.max()  # 0/1 weights: plain sums
    M = window_means(a, w)
    return det_planes(M) / (sum(M[k, k] for k in range(len(M))) + VARSIGMA)


# -- X-junctions ----------------------------------------------------------------
def _bilinear(m: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    # float64 bilinear sampling, edge-clamped (the arithmetic of the core's former bilinear_rows)
    H, W = m.shape
    xc, yc = np.clip(x, 0.0, W - 1.0), np.clip(y, 0.0, H - 1.0)
    x0 = np.minimum(np.floor(xc).astype(np.int64), W - 2 if W > 1 else 0)
    y0 = np.minimum(np.floor(yc).astype(np.int64), H - 2 if H > 1 else 0)
    x1, y1 = np.minimum(x0 + 1, W - 1), np.minimum(y0 + 1, H - 1)
    fx, fy = xc - x0, yc - y0
    return (m[y0, x0] * (1 - fx) + m[y0, x1] * fx) * (1 - fy) + (m[y1, x0] * (1 - fx) + m[y1, x1] * fx) * fy


def saddles(derivs: tuple, sigma2: float, iters: int = 4, measure: str = "det"
            ) -> tuple[np.ndarray, np.ndarray]:
    """Saddle points of the smoothed image: ``(xy, strength)``, strength in grey levels.

    Candidates are 3x3 maxima of ``s = sigma^2 sqrt(max(0, -det H))``; from each,
    Newton steps ``delta = -H^{-1} grad`` on bilinearly interpolated derivative maps
    (Chen and Zhang 2005; a Foerstner-style saddle fit) must converge within one pixel
    of the candidate, else it is not a saddle (an L-corner's apex has a large gradient).
    """
    gx, gy, gxx, gxy, gyy = derivs
    neg = gxy * gxy - gxx * gyy
    if measure == "min":  # the weaker of two opposite curvatures: |l_min| = sqrt(disc) - |tr| / 2
        half_tr = 0.5 * (gxx + gyy)
        disc = np.sqrt(np.maximum(half_tr * half_tr + neg, 0.0))
        s = sigma2 * np.where(neg > 0, disc - np.abs(half_tr), 0.0)
    else:
        s = sigma2 * np.sqrt(np.maximum(neg, 0.0))
    dil = cv2.dilate(s, np.ones((3, 3), np.uint8))
    rows, cols = np.nonzero((s == dil) & (s > 0))
    if len(rows) == 0:
        return np.zeros((0, 2)), np.zeros(0)
    x0, y0 = cols.astype(np.float64), rows.astype(np.float64)
    x, y = x0.copy(), y0.copy()
    for _ in range(iters):
        a, b, c = _bilinear(gxx, x, y), _bilinear(gxy, x, y), _bilinear(gyy, x, y)
        px, py = _bilinear(gx, x, y), _bilinear(gy, x, y)
        det = a * c - b * b
        with np.errstate(divide="ignore", invalid="ignore"):
            dx = -(c * px - b * py) / det
            dy = -(a * py - b * px) / det
        x, y = x + np.nan_to_num(dx, nan=9.0), y + np.nan_to_num(dy, nan=9.0)
    ok = (np.abs(x - x0) <= 1.0) & (np.abs(y - y0) <= 1.0) & (neg[rows, cols] > 0)
    return np.stack([x[ok], y[ok]], axis=1), s[rows, cols][ok]


@lru_cache(maxsize=64)
def calibration(cfg: Cfg) -> tuple[float, float]:
    """Gains putting the corner measure and the saddle strength on one grey-level scale.

    An ideal right-angle L-corner and an ideal X-junction, both of contrast 100 grey
    levels, rendered at 16x supersampling: the corner gain makes the L-corner's peak
    measure 100, the saddle gain makes the X-junction's saddle strength 100. So a
    threshold T reports corners at least as strong as a right-angle corner of contrast T.
    """
    from sogdd.synthetic import Polygon, render_polygons

    n, c, big = 64, 31.5, 200.0
    quad = np.array([[c, c], [c + big, c], [c + big, c + big], [c, c + big]])
    L = render_polygons((n, n), [Polygon(quad, 150.0)], background=50.0)
    X = render_polygons((n, n), [Polygon(quad, 150.0), Polygon(2 * c - quad, 150.0)], background=50.0)
    base = replace(cfg, scales=1)
    gL, _ = raw_grey_map(L, base)
    _, d = raw_grey_map(X, base)
    _, st = saddles(d, cfg.sigma2, measure=cfg.saddle_measure)
    return 100.0 / float(gL.max()), (100.0 / float(st.max()) if len(st) else 1.0)


# -- detection -------------------------------------------------------------------
def _adaptive_subpix(grey: np.ndarray, xy: np.ndarray, max_half: int = 3) -> np.ndarray:
    """cornerSubPix with a half window of min(max_half, floor(d_nn / 2)) (d_nn: nearest other point)."""
    if len(xy) == 0:
        return xy
    out = xy.copy()
    if len(xy) > 1:
        from scipy.spatial import cKDTree

        dnn = cKDTree(xy).query(xy, k=2)[0][:, 1]
    else:
        dnn = np.full(1, np.inf)
    half = np.clip(np.floor(dnn / 2), 1, max_half).astype(int)
    g32 = np.ascontiguousarray(grey, np.float32)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 1e-3)
    h, w = grey.shape
    for hw in np.unique(half):
        sel = np.flatnonzero(half == hw)
        if h < 2 * hw + 3 or w < 2 * hw + 3:
            continue
        sel = sel[(xy[sel, 0] >= 0) & (xy[sel, 0] <= w - 1) & (xy[sel, 1] >= 0) & (xy[sel, 1] <= h - 1)]
        if len(sel) == 0:
            continue
        p = xy[sel].astype(np.float32).reshape(-1, 1, 2).copy()
        q = cv2.cornerSubPix(g32, p, (int(hw), int(hw)), (-1, -1), crit).reshape(-1, 2).astype(np.float64)
        bad = ~np.isfinite(q).all(axis=1) | (np.linalg.norm(q - xy[sel], axis=1) > hw)
        q[bad] = xy[sel][bad]
        out[sel] = q
    return out


def _candidates(grey: np.ndarray, cfg: Cfg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Peaks of g above the threshold (quadratic sub-pixel), X-junction stage: ``(xy, strength, is_x)``."""
    g, derivs = grey_map(grey, cfg)
    rows, cols = select_peaks(g, threshold=cfg.threshold, nms_radius=1, max_corners=None)
    xy = np.stack([cols, rows], axis=1).astype(np.float64)
    resp = g[rows, cols]
    if cfg.subpix in ("quad", "grad", "grad_adapt") and len(rows):
        xy += refine_quadratic(g, rows, cols)
    is_x = np.zeros(len(xy), bool)
    if cfg.saddle:
        sxy, sst = saddles(derivs, cfg.sigma2, measure=cfg.saddle_measure)
        sst = sst * calibration(cfg)[1]
        if cfg.threshold is not None:
            keep = sst >= cfg.threshold
            sxy, sst = sxy[keep], sst[keep]
        if len(sxy) and len(xy):
            from scipy.spatial import cKDTree

            near = cKDTree(sxy).query(xy, k=1)[0] <= cfg.saddle_rho
            xy, resp = xy[~near], resp[~near]
        xy, resp = np.concatenate([xy, sxy]), np.concatenate([resp, sst])
        is_x = np.r_[np.zeros(len(xy) - len(sxy), bool), np.ones(len(sxy), bool)]
    return xy, resp, is_x


def _refine(grey: np.ndarray, xy: np.ndarray, is_x: np.ndarray, cfg: Cfg) -> np.ndarray:
    xy = xy.copy()
    c = ~is_x
    if cfg.subpix == "grad" and c.any():
        from sogdd.select.refine import refine_gradient

        xy[c] = refine_gradient(grey, xy[c])
    elif cfg.subpix == "grad_adapt" and c.any():
        xy[c] = _adaptive_subpix(grey, xy)[c]
    return xy


def detect(image: np.ndarray, cfg: Cfg) -> Corners:
    """Detect with a prototype configuration: strongest first, response = grey-level strength.

    Order: per pyramid level, peaks of g (threshold) and the X-junction stage (saddles
    added, ring peaks dropped); levels merged (a coarse point within ``dedup`` coarse
    pixels of a finer one is dropped), ranked and cut to ``max_corners``; then sub-pixel
    refinement of the kept points only, on their own level.
    """
    grey = np.asarray(image, dtype=np.float64)
    h, w = grey.shape
    imgs, parts = [], []
    for lev in range(cfg.levels):
        if lev == 0:
            gl, sx, sy = grey, 1.0, 1.0
        else:
            lw, lh = int(round(w / 2**lev)), int(round(h / 2**lev))
            if min(lw, lh) < 16:
                break
            gl = cv2.resize(grey, (lw, lh), interpolation=cv2.INTER_AREA)
            sx, sy = w / lw, h / lh
        xy, resp, is_x = _candidates(gl, cfg)
        full = np.stack([(xy[:, 0] + 0.5) * sx - 0.5, (xy[:, 1] + 0.5) * sy - 0.5], axis=1)
        if lev and cfg.dedup > 0 and parts:
            from scipy.spatial import cKDTree

            finer = np.concatenate([p[1] for p in parts])
            if len(finer) and len(full):
                far = cKDTree(finer).query(full, k=1)[0] > cfg.dedup * sx
                xy, resp, is_x, full = xy[far], resp[far], is_x[far], full[far]
        imgs.append((gl, sx, sy))
        parts.append((xy, full, resp, is_x, np.full(len(xy), lev)))
    xy = np.concatenate([p[0] for p in parts])
    resp = np.concatenate([p[2] for p in parts])
    is_x = np.concatenate([p[3] for p in parts])
    lev = np.concatenate([p[4] for p in parts])
    order = np.argsort(-resp, kind="stable")
    if cfg.max_corners is not None:
        order = order[: cfg.max_corners]
    xy, resp, is_x, lev = xy[order], resp[order], is_x[order], lev[order]
    out = np.zeros_like(xy)
    for L, (gl, sx, sy) in enumerate(imgs):
        m = lev == L
        if m.any():
            q = _refine(gl, xy[m], is_x[m], cfg)
            out[m] = np.stack([(q[:, 0] + 0.5) * sx - 0.5, (q[:, 1] + 0.5) * sy - 0.5], axis=1)
    r = kernel_radius(cfg.sigma2)
    return Corners(out, resp, float(cfg.size + 2 * r) * 2.0**lev, lev)


class ProtoDetector:
    """``detect_corners(image, mask=None)`` and ``permissive()`` around a :class:`Cfg`."""

    family = "sogdd"

    def __init__(self, cfg: Cfg) -> None:
        self.cfg = cfg

    def detect_corners(self, image, mask=None) -> Corners:
        from sogdd.image.grey import to_gray255
        from sogdd.image.validate import validate_image

        return detect(to_gray255(validate_image(image)), self.cfg)

    def permissive(self) -> ProtoDetector:
        return ProtoDetector(replace(self.cfg, threshold=None, max_corners=None))

    def top(self, n: int) -> ProtoDetector:
        """Threshold off, the ``n`` strongest points (refined after the cut: same points, faster)."""
        return ProtoDetector(replace(self.cfg, threshold=None, max_corners=n))
