"""The SODDC matrix and its det/trace corner measure (eqs. 23-25), tiled and compiled.

For every pixel the K x K second-order directional derivative correlation
(SODDC) matrix is the unnormalised window sum of outer products of the
absolute SOGDD responses (eq. 24)::

    Lambda = sum_{window} |l| |l|^T,     l = (l_1, ..., l_K)

and the corner measure is (eq. 25)::

    Upsilon = det(Lambda) / (trace(Lambda) + varsigma),   varsigma = 2.22e-16

The image is processed in row tiles, so memory stays bounded on large images.
Each tile is filtered with the three steerable basis kernels
(:func:`sogdd.measure.filters.basis_tile`), then compiled tile code
(:mod:`sogdd.measure.square_tiles`) steers the responses to K orientations,
forms the window sums directly (no running sums, so no
cancellation) and takes the determinant with a symmetric Gaussian elimination
vectorised across pixels. Everything is float64: with K = 8 the determinant
passes 1e40 on strong corners.

Detection with an absolute threshold needs Upsilon only where it can reach
that threshold: ``soddc_measure(..., floor=T)`` first proves most pixels below
T with a Fischer bound built from six window sums, then evaluates the rest
exactly (see :func:`soddc_measure`).
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numba
import numpy as np

from .._jit import JIT, elimination, thread_count, window_rows
from ..image.rows import exact_grey
from .bound import bound_mask, bound_tables, need_from_keep, neighbour_need, spread_masks
from .filters import basis_tile, kernel_radius, orientations, steerable_basis, steering_coefficients
from .general_tiles import tile_general
from .square_tiles import AUTHORS_EPS, VARSIGMA, det_trace, pair_index, tile_square
from .window import is_square, take_reflected, window_offsets

__all__ = [
    "AUTHORS_EPS", "VARSIGMA", "MeasureSpec", "authors_apply", "authors_limit", "authors_measure", "soddc_at",
    "abs_max", "prune_pays", "soddc_from_responses", "soddc_measure", "supports_floor",
]


@dataclass(frozen=True)
class MeasureSpec:
    """Everything the measure depends on, resolved once.

    Parameters
    ----------
    sigma2 : float
        Filter scale sigma^2.
    n_orientations : int
        K, the number of orientations theta_k = (k - 1) pi / K.
    halfwidths : tuple of int
        The window's half-width on each row offset (:func:`sogdd.measure.window.window_halfwidths`).
    radius_rule : {"paper", "authors"}
        Kernel radius rule (:func:`sogdd.measure.filters.kernel_radius`).
    zero_mean : bool
        Subtract each kernel's mean (the authors' code).
    padding : {"response", "image"}
        ``"response"``: filter the reflected image, then reflect the responses for
        the window sums (scipy ``mode="reflect"`` at both stages). ``"image"``:
        reflect the image once, wide enough for both stages (the authors'
        ``numpy.pad(..., "symmetric")``).
    authors_measure : bool
        Clamp tiny negative det to 0 and map non-finite values to -inf (authors).
    weights : tuple of float
        1-D weights of a separable window over a square (``w(dy) w(dx)``: the
        Gaussian window of :mod:`sogdd.measure.gaussian_window`); empty for equal weights.

    Attributes
    ----------
    radius : int
        The kernel radius. ``coef`` : (K, 3) steering coefficients of the basis.

    Examples
    --------
    >>> from sogdd.measure.window import window_halfwidths
    >>> spec = MeasureSpec(1.2, 8, window_halfwidths("square", 7))
    >>> spec.radius, spec.coef.shape
    (5, (8, 3))
    """

    sigma2: float
    n_orientations: int
    halfwidths: tuple[int, ...]
    radius_rule: str = "paper"
    zero_mean: bool = False
    padding: str = "response"
    authors_measure: bool = False
    weights: tuple[float, ...] = ()
    radius: int = field(init=False, repr=False, compare=False)
    coef: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "halfwidths", tuple(int(h) for h in self.halfwidths))
        object.__setattr__(self, "weights", tuple(float(w) for w in self.weights))
        object.__setattr__(self, "radius", kernel_radius(self.sigma2, self.radius_rule))
        object.__setattr__(self, "coef", steering_coefficients(orientations(self.n_orientations)))

    @property
    def window_radius(self) -> int:
        """R, the window's half-height."""
        return (len(self.halfwidths) - 1) // 2


#: ``(top, r0, r1, planes)``: a tile's filter responses (``soddc_measure``'s ``on_planes``)
PlanesHook = Callable[[int, int, int, np.ndarray], None]


def _tiled(
    H: int,
    W: int,
    domain,
    margin: int,
    coef: np.ndarray,
    halfwidths: np.ndarray,
    *,
    parts: bool = False,
    floor: float | None = None,
    tile_rows: int = 128,
    threads: int | None = None,
    weights: np.ndarray | None = None,
    on_planes: PlanesHook | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the compiled tile function over row tiles, in threads.

    ``domain(r0, r1)`` returns the filter-response planes of one tile with
    ``margin`` extra rows and columns on each side (at least the window
    half-height R; R + 1 for ``floor``). With ``parts`` the raw det and trace
    maps are returned too; with ``floor`` the pruned kernel runs. ``weights``: the 1-D
    weights of a separable square window (:mod:`sogdd.measure.gaussian_window`). ``on_planes(top, r0,
    r1, planes)`` is called with each tile's planes (rows ``top = r0 - margin ..``), from
    the tiles' threads.
    """
    halfw = np.ascontiguousarray(halfwidths, dtype=np.int64)
    R = (len(halfw) - 1) // 2
    nr = 2 * R + 1
    square = is_square(halfw)
    coef = np.ascontiguousarray(coef, dtype=np.float64)
    # with ``parts`` the caller wants det and trace only: Upsilon goes to per-tile scratch, not a third map
    out = None if parts else np.empty((H, W), dtype=np.float64)
    det = np.empty((H, W)) if parts else np.empty((1, 1))
    tr = np.empty((H, W)) if parts else np.empty((1, 1))
    if floor is not None:  # tiles of >= 3 rows, so an edge pixel's 3 x 3 patch lies in its tile
        tile_rows = max(tile_rows, 3)
    starts = list(range(0, H, tile_rows))
    if floor is not None and len(starts) > 1 and H - starts[-1] < 3:
        starts.pop()
    ends = starts[1:] + [H]
    tables = bound_tables(coef) if floor is not None else None
    none = np.zeros((0, 0), np.uint8)
    # None, not an empty array: the box window's kernels are then compiled without the weighted code
    wts = None if weights is None else np.ascontiguousarray(weights, dtype=np.float64)
    kdim, wdim = elimination(coef.shape[0]), window_rows(nr)  # what numba compiles (square_tiles)

    def run(r0: int, r1: int) -> None:
        planes = domain(r0, r1)
        if on_planes is not None:
            on_planes(r0 - margin, r0, r1, planes)
        o = np.empty((r1 - r0, W)) if out is None else out[r0:r1]
        d, t = (det[r0:r1], tr[r0:r1]) if parts else (det, tr)
        if not square:
            tile_general(planes, margin - R, coef, halfw, parts, o, d, t, 256, kdim)
            return
        h = r1 - r0
        if tables is None:
            tile_square(planes, margin - R, coef, nr, none, none, none, parts, o, d, t, 256, 32, 0, h, True,
                        wts, kdim, wdim)
            return
        # pass 1: the pixels whose bound reaches the floor; pass 2: the 3 x 3 patches around
        # those found at or above it (sub-pixel refinement reads them), when not evaluated yet
        keep = np.empty((h + 2, W + 2), np.uint8)
        bound_mask(planes, nr, *tables, float(floor), keep, 256, wts, wdim)
        need = np.empty((h, W), np.uint8)
        colneed = np.empty((h, W + 2 * R), np.uint8)
        rowneed = np.empty((h + 2 * R, W + 2 * R), np.uint8)
        need_from_keep(keep, need)
        spread_masks(need, R, colneed, rowneed, 0, h)
        tile_square(planes, margin - R, coef, nr, need, colneed, rowneed, parts, o, d, t, 256, 32, 0, h, True,
                    wts, kdim, wdim)
        lo, hi = neighbour_need(o, float(floor), r0, H, need)
        if lo < hi:
            spread_masks(need, R, colneed, rowneed, lo, hi)
            tile_square(planes, margin - R, coef, nr, need, colneed, rowneed, parts, o, d, t, 256, 32,
                        lo, hi, False, wts, kdim, wdim)

    n = threads or thread_count()
    if n == 1 or len(starts) == 1:
        for r0, r1 in zip(starts, ends):
            run(r0, r1)
    else:
        with ThreadPoolExecutor(n) as pool:
            list(pool.map(run, starts, ends))
    return (out, det, tr) if parts else out


#: The Fischer bound costs six window sums per pixel, the exact kernel K(K+1)/2 and an
#: elimination, so the bound pays only for enough orientations and a high enough threshold.
#: Measured on the 6.3 MP facade photo (``benchmarks/bench_speed.py``'s), 2 threads, ms full /
#: pruned: at a threshold of 20 grey levels K = 4 box 89 / 123, K = 4 Gaussian (hr) 157 / 197,
#: K = 6 box 127 / 152, K = 6 Gaussian 273 / 307, K = 8 box 194 / 216, K = 8 Gaussian 456 / 451;
#: at the paper preset's T_h (K = 8 box) 198 / 150. (Before the unrolled elimination the full
#: kernel was slower and pruning paid at 20 grey levels from K = 6 on.)
PRUNE_MIN_ORIENTATIONS = 6

#: Below this many pixels in one call (an image, or one band of a banded detection) the bound does
#: not pay either: on a 640 x 480 crop of a photo at the paper preset the full map took 10.8 ms and
#: the pruned one 8.2, on the rendered demo pattern 10.7 against 13.1 (2 threads), while the bound's
#: compiled code costs about 2.5 s to compile on its first use (``benchmarks/bench_compile.py``),
#: which a first small image would otherwise pay (``sogdd demo``).
PRUNE_MIN_PIXELS = 1 << 19


def prune_pays(spec: MeasureSpec, pixels: int | None = None) -> bool:
    """Whether pruning below a floor is worth its bound for this spec and a map of ``pixels`` pixels.

    :data:`PRUNE_MIN_ORIENTATIONS` orientations and, where ``pixels`` is given,
    :data:`PRUNE_MIN_PIXELS` pixels. Pruning never changes a result (see
    :func:`soddc_measure`), only its cost.

    Examples
    --------
    >>> import sogdd
    >>> spec = sogdd.resolve_params("paper").measure_spec()
    >>> prune_pays(spec), prune_pays(spec, 640 * 480), prune_pays(spec, 3072 * 2048)
    (True, False, True)
    """
    big = pixels is None or pixels >= PRUNE_MIN_PIXELS
    return spec.n_orientations >= PRUNE_MIN_ORIENTATIONS and big


def supports_floor(spec: MeasureSpec) -> bool:
    """Whether :func:`soddc_measure` can prune below a floor for this spec (square windows)."""
    return not spec.authors_measure and is_square(spec.halfwidths)


def soddc_measure(
    image: np.ndarray,
    spec: MeasureSpec,
    *,
    floor: float | None = None,
    tile_rows: int = 128,
    threads: int | None = None,
    raw: bool = False,
    prune: bool | None = None,
    on_planes: PlanesHook | None = None,
) -> np.ndarray:
    """The measure Upsilon (eq. 25) of a grey 0-255 image (float64, or uint8 read exactly), H x W float64.

    Inputs are assumed valid (see :func:`sogdd.corner_response` for the checked
    public entry point). With ``raw`` and the authors' measure the maps
    ``(det, trace)`` are returned instead, before :func:`authors_measure`
    (whose clamp needs ``max|det|`` over the whole image).

    With ``floor`` (> 0, square windows, see :func:`supports_floor`) only what
    peak selection above ``floor`` needs is computed: Upsilon is exact, bit for
    bit as without ``floor``, at every pixel where a Fischer bound on
    det(Lambda) reaches ``floor`` (so at every pixel at or above it), in the
    3 x 3 patch that :func:`sogdd.select.refine.refine_quadratic` reads around each
    pixel at or above ``floor``, and at a few more (where nearby runs are
    merged); every pixel that holds ``-inf`` is provably below ``floor``. Local
    maxima above ``floor`` (any radius: a pixel left out is below every peak),
    their values and their 3 x 3 patches are then those of the full map, at a
    fraction of the cost on photographs (most pixels are proven below ``T_h``
    by six window sums instead of K(K+1)/2 and an elimination). ``prune``:
    whether to run the bound; by default where it pays (:func:`prune_pays`, for this spec and
    ``H * W`` pixels).
    Without it the full map is returned, which meets the same contract.
    ``on_planes(top, r0, r1, planes)``: called from the tiles' threads with the
    filter responses of each tile of rows ``r0 .. r1 - 1``: ``(3, rows, W + 2M)``
    planes of image rows ``top ..`` and columns ``-M ..`` (the X-junction stage reads them).

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> from sogdd.measure.window import window_halfwidths
    >>> img = pattern_image((120, 160))[0].astype(float)
    >>> spec = MeasureSpec(1.2, 8, window_halfwidths("square", 7))
    >>> full = soddc_measure(img, spec)
    >>> pruned = soddc_measure(img, spec, floor=1e9, prune=True)  # small: pruned on request
    >>> bool(np.all((pruned == full) | (pruned == -np.inf)))
    True
    >>> bool(np.all(full[pruned == -np.inf] < 1e9))
    True
    """
    img = exact_grey(image)  # uint8 is read as it is: no float64 copy
    H, W = img.shape
    R = spec.window_radius
    if floor is not None and not (floor > 0 and supports_floor(spec)):
        raise ValueError("floor needs a positive value, a square window and the paper's measure")
    if min(H, W) < 3 or not (prune_pays(spec, H * W) if prune is None else prune):
        floor = None  # the full map meets the floor's contract (and 3 x 3 patches need 3 rows)
    basis = steerable_basis(spec.sigma2, spec.radius, zero_mean=spec.zero_mean)
    # one margin for both kernels, so the filter responses are computed identically
    M = R + 1

    def domain(r0: int, r1: int) -> np.ndarray:
        return basis_tile(img, r0, r1, M, basis, reflect_image=spec.padding == "image")

    res = _tiled(
        H, W, domain, M, spec.coef, np.asarray(spec.halfwidths),
        parts=spec.authors_measure, floor=floor, tile_rows=tile_rows, threads=threads,
        weights=np.asarray(spec.weights) if spec.weights else None, on_planes=on_planes,
    )
    if spec.authors_measure:
        return (res[1], res[2]) if raw else authors_measure(res[1], res[2], out=res[1])
    return res


def soddc_from_responses(
    responses: np.ndarray, halfwidths: np.ndarray, *, tile_rows: int = 128, threads: int | None = None
) -> np.ndarray:
    """det / (tr + varsigma) of the window sums of ``|l| |l|^T`` for any K responses.

    For filter banks that are not steerable (the anisotropic kernels of the
    Zhang & Sun baselines). ``responses`` is (K, H, W), signed or absolute;
    they are reflected (half-sample) at the image border for the window sums.
    """
    resp = np.ascontiguousarray(responses, dtype=np.float64)
    K, H, W = resp.shape
    halfw = _check_halfwidths(halfwidths)
    R = (len(halfw) - 1) // 2

    def domain(r0: int, r1: int) -> np.ndarray:
        return np.ascontiguousarray(take_reflected(take_reflected(resp, 1, r0 - R, r1 + R), 2, -R, W + R))

    return _tiled(H, W, domain, R, np.eye(K), halfw, tile_rows=tile_rows, threads=threads)


def _check_halfwidths(halfwidths) -> np.ndarray:
    halfw = np.asarray(halfwidths, dtype=np.int64)
    if halfw.ndim != 1 or len(halfw) % 2 != 1 or (halfw < 0).any():
        raise ValueError("halfwidths must be an odd-length array of non-negative half-widths")
    return halfw


def soddc_at(responses: np.ndarray, halfwidths, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The measure of :func:`soddc_from_responses`, only at the pixels ``(rows, cols)``.

    For detectors that need the measure at a few candidates only (the coarser
    scales of Zhang & Sun 2020). The same elimination as the map; values agree
    with it to rounding (the window sums are formed in another order).

    Examples
    --------
    >>> resp = np.random.default_rng(0).normal(size=(4, 12, 10))
    >>> full = soddc_from_responses(resp, (2, 2, 2, 2, 2))
    >>> at = soddc_at(resp, (2, 2, 2, 2, 2), np.array([0, 6]), np.array([9, 3]))
    >>> bool(np.allclose(at, full[[0, 6], [9, 3]], rtol=1e-12))
    True
    """
    resp = np.asarray(responses, dtype=np.float64)
    K, H, W = resp.shape
    off = window_offsets(_check_halfwidths(halfwidths))
    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    n = len(rows)
    if n == 0:
        return np.zeros(0)
    R = int(np.abs(off).max())
    pad = np.abs(take_reflected(take_reflected(resp, 1, -R, H + R), 2, -R, W + R))
    v = pad[:, rows[:, None] + R + off[:, 0], cols[:, None] + R + off[:, 1]]  # (K, n, offsets)
    lam = np.einsum("inw,jnw->ijn", v, v)
    pi, pj, diag = pair_index(K)
    acc = np.ascontiguousarray(lam[pi, pj])  # packed upper triangle, (P, n)
    det, tr, f = np.empty(n), np.empty(n), np.empty(n)
    det_trace(acc, diag, det, tr, f, n, elimination(K))
    return det / (tr + VARSIGMA)


def authors_measure(det: np.ndarray, tr: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """The authors' post-processing: tiny negative det -> 0, non-finite -> -inf.

    ``det`` in ``[-eps * max|det|, 0)`` becomes 0 (``max|det|`` is NaN if any det
    is), then ``Upsilon = det / (tr + eps)``, ``-inf`` where that is not finite.
    Two compiled passes instead of numpy temporaries, with the same values.
    ``out`` may be ``det`` itself (element-wise, in place: no extra map).
    """
    d = np.ascontiguousarray(det, dtype=np.float64).reshape(-1)
    big, nan = abs_max(d)
    return authors_apply(det, tr, authors_limit(big, nan), out=out)


def authors_limit(big: float, nan: bool) -> float:
    """The clamp limit ``-eps * max|det|`` (NaN when a det is NaN: nothing is clamped then)."""
    return -AUTHORS_EPS * (np.nan if nan else float(big))


def authors_apply(det: np.ndarray, tr: np.ndarray, lim: float, out: np.ndarray | None = None) -> np.ndarray:
    """``det`` in ``[lim, 0)`` -> 0, then ``det / (tr + eps)``, ``-inf`` where not finite.

    The second half of :func:`authors_measure`, for a ``lim`` known from elsewhere
    (:mod:`sogdd.select.bands` takes ``max|det|`` over bands of the image).
    """
    d = np.ascontiguousarray(det, dtype=np.float64)
    if out is None or out.shape != d.shape or out.dtype != np.float64 or not out.flags.c_contiguous:
        out = np.empty(d.shape)
    trf = np.ascontiguousarray(tr, dtype=np.float64).reshape(-1)
    _authors_post(d.reshape(-1), trf, AUTHORS_EPS, float(lim), out.reshape(-1))
    return out


@numba.njit(**JIT)
def abs_max(det):  # pragma: no cover - jit
    """max|det| over the finite-or-inf values, and whether any det is NaN."""
    big = 0.0
    nan = False
    for i in range(det.shape[0]):
        a = abs(det[i])
        if a != a:
            nan = True
        elif a > big:
            big = a
    return big, nan


@numba.njit(**JIT)
def _authors_post(det, tr, eps, lim, out):  # pragma: no cover - jit
    for i in range(det.shape[0]):
        d = det[i]
        if d < 0 and d >= lim:
            d = 0.0
        u = d / (tr[i] + eps)
        out[i] = u if np.isfinite(u) else -np.inf
