"""The GPU path: the corner measure and detection on a CUDA device (``device="cuda"``).

Install with ``pip install 'sogdd[gpu]'`` (numba-cuda with the CUDA 12 runtime
libraries); CPU users need nothing of it. :func:`sogdd.corner_response` and
:func:`sogdd.detect_corners` call :func:`corner_response` and
:func:`detect_corners` here when given ``device="cuda"``.

The measure is the CPU one (eqs. 22-25): the same three separable steerable
basis kernels, the same half-sample symmetric reflection (``padding="response"``
or ``"image"``), |responses| at K orientations, window sums of
``|l| |l|^T`` over a square, disk or Gaussian-weighted window and ``det / (tr +
varsigma)``, in float64, by one fused kernel per image tile
(:mod:`sogdd.gpu.device_code`); it agrees with the CPU map to rounding (the sums
are taken in another order). Peaks above an absolute threshold are found on the
device and only they come back, with their 3 x 3 neighbourhoods; they are
finished on the host by the CPU's own selection stage (:func:`sogdd.select.stage.select_corners`,
which reads the device's maxima or its map instead of measuring): quadratic and
gradient refinement on those few points, and for ``hr`` the X-junction stage and
the adaptive refinement, which read the whole grey image (copied back from the
device for a device input), then the same merge of points that refinement
brought together (:func:`sogdd.select.refine.first_distinct`, before the
``max_corners`` cut, refilled from the next peaks: their patches are gathered
on the device as they are asked for).
``threshold_rel`` and ``quantile`` need the whole map: it is copied back and
peaks are selected on the host. With ``levels > 1`` the pyramid's levels are
resized on the host (:mod:`sogdd.image.pyramid`, as on the CPU) and each is detected
on the device. Not supported here (``ValueError``): settings whose tile does not
fit in 48 KiB of shared memory (very large sigma2, windows or K).

Inputs: numpy arrays (any the CPU path takes), or grey device arrays with
``__cuda_array_interface__`` or DLPack (torch, CuPy, numba), which are read in
place. Device inputs give device outputs: :func:`corner_response` returns a numba
device array, which ``torch.as_tensor(out, device="cuda")`` or
``cupy.asarray(out)`` wrap without a copy. The ``*_batch`` functions take a list
of images or an (N, H, W) stack; same-sized images share one launch.
"""

from __future__ import annotations

import math

import numpy as np
from numba import cuda

from ..corners import Corners
from ..image.pyramid import pyramid_levels
from ..image.validate import check_mask
from ..measure.filters import steerable_basis
from ..measure.soddc import AUTHORS_EPS
from ..params import Params, resolve_params
from ..select.assemble import merge_levels
from ..select.peaks import inside_allowed
from ..select.refine import refine_gradient
from ..select.stage import select_corners
from . import device_code as ck
from .input import GreyStack, cuda_runtime_available, require_cuda, to_grey_stacks

__all__ = ["available", "corner_response", "corner_response_batch", "detect_corners", "detect_corners_batch"]

_PATCH = 16  # half-size of the image patches the gradient refinement reads around a device corner


def available() -> bool:
    """Whether a CUDA device (or numba's CUDA simulator) is usable.

    Examples
    --------
    >>> from sogdd import gpu
    >>> gpu.available() in (True, False)
    True
    """
    return cuda_runtime_available()


def _measure(dev, spec):
    """Upsilon of a (N, H, W) float64 device stack, as a device array (one fused launch)."""
    K, R, rk = spec.n_orientations, spec.window_radius, spec.radius
    nf = 4 if spec.zero_mean else 3
    T = ck.tile_size(K, R, rk, nf)
    if T is None:
        raise ValueError(
            f"device='cuda' does not support K={K} with a {2 * R + 1}-row window and kernel radius {rk} "
            "(the tile does not fit in shared memory); use device='cpu'"
        )
    b = steerable_basis(spec.sigma2, rk, zero_mean=spec.zero_mean)
    fx, fy = [b.d2, b.d1, b.gauss], [b.gauss, b.d1, b.d2]  # along x (columns), along y (rows)
    if spec.zero_mean:
        fx.append(np.ones(2 * rk + 1))
        fy.append(np.ones(2 * rk + 1))
    # d1 is odd, the Gaussian, d2 and the box are even: the kernel pairs taps by this parity
    odd = np.array([0, 1, 0, 0][:nf] * 2, np.uint8)
    weighted = bool(spec.weights)
    wts = np.asarray(spec.weights) if weighted else np.ones(2 * R + 1)
    args = [cuda.to_device(np.ascontiguousarray(a, dtype=t)) for a, t in (
        (fx, np.float64), (fy, np.float64), (odd, np.uint8), (b.means, np.float64),
        (spec.coef, np.float64), (np.asarray(spec.halfwidths), np.int64), (wts, np.float64))]
    N, H, W = dev.shape
    parts = bool(spec.authors_measure)
    out = cuda.device_array((N, H, W))
    tr = cuda.device_array((N, H, W) if parts else (1, 1, 1))
    kern = ck.measure_kernel(K, R, rk, nf, T, spec.padding == "image", parts, weighted)
    kern[(math.ceil(W / T), math.ceil(H / T), N), (T, T)](dev, *args, out, tr)
    if not parts:
        return out
    big = cuda.to_device(np.zeros(N))
    ck.abs_max_kernel[(min(64, math.ceil(H * W / 256)), 1, N), 256](out, big)
    ups = cuda.device_array((N, H, W))
    ck.authors_kernel[(math.ceil(W / 32), math.ceil(H / 8), N), (32, 8, 1)](out, tr, big, AUTHORS_EPS, ups)
    return ups


def _device_peaks(resp, thr: float, radius: int, border: int):
    """Per image: rows, cols, values and 3 x 3 patches of the local maxima above ``thr``, raster order."""
    N, H, W = resp.shape
    cap = max(1024, H * W // 256)
    while True:
        count = cuda.to_device(np.zeros(N, np.int32))
        rows = cuda.device_array((N, cap), np.int32)
        cols = cuda.device_array((N, cap), np.int32)
        vals = cuda.device_array((N, cap))
        patches = cuda.device_array((N, cap, 3, 3))
        ck.peaks_kernel[(math.ceil(W / 32), math.ceil(H / 8), N), (32, 8, 1)](
            resp, thr, radius, border, count, rows, cols, vals, patches)
        counts = count.copy_to_host()
        if counts.max() <= cap:
            break
        cap = int(counts.max())  # rare: more peaks than expected; run again with room for all
    found = []
    for j, c in enumerate(counts):
        r = rows[j, :c].copy_to_host().astype(np.int64)
        x = cols[j, :c].copy_to_host().astype(np.int64)
        order = np.lexsort((x, r))  # the device appends in any order; the host scan is raster
        found.append((r[order], x[order], vals[j, :c].copy_to_host()[order],
                      patches[j, :c].copy_to_host()[order]))
    return found


def _gradient_on_device(dev, j: int, rows, cols, xy) -> np.ndarray:
    """:func:`sogdd.select.refine.refine_gradient` from image patches gathered on the device.

    The patches (edges replicated, as OpenCV reads past the image) are laid out in
    a mosaic on the host; a refinement that stays within ``_PATCH - 5`` px of its
    start reads the same pixels as on the full image (and one that goes further is
    refused, as it leaves its 7 x 7 window, unless it comes back).
    """
    n = len(rows)
    S = 2 * _PATCH + 1
    d_rows = cuda.to_device(rows.astype(np.int64))
    d_cols = cuda.to_device(cols.astype(np.int64))
    out = cuda.device_array((n, S, S))
    ck.gather_patches_kernel[(1, S, n), (S, 1, 1)](
        dev, j, d_rows, d_cols, _PATCH, out)
    patches = out.copy_to_host()
    g = math.ceil(math.sqrt(n))
    mosaic = np.zeros((S * math.ceil(n / g), S * g))
    oy, ox = (np.arange(n) // g) * S, (np.arange(n) % g) * S
    for i in range(n):
        mosaic[oy[i] : oy[i] + S, ox[i] : ox[i] + S] = patches[i]
    shift = np.stack([ox + _PATCH - cols, oy + _PATCH - rows], axis=1).astype(np.float64)
    return refine_gradient(mosaic, xy + shift) - shift


class _StackMeasure:
    """The measure of a device stack: its maxima found on the device once, for every image."""

    def __init__(self, resp) -> None:
        self.resp = resp
        self._peaks: dict = {}

    def peaks(self, j: int, threshold: float, radius: int, border: int):
        key = (threshold, radius, border)
        if key not in self._peaks:
            self._peaks[key] = _device_peaks(self.resp, threshold, radius, border)
        return self._peaks[key][j]


class _DeviceMeasure:
    """One image of a device stack, read by :func:`sogdd.select.stage.select_corners`."""

    def __init__(self, stack: _StackMeasure, j: int, dev, on_device_gradient: bool) -> None:
        self.stack, self.j, self.dev, self.on_device_gradient = stack, j, dev, on_device_gradient
        self.shape = tuple(stack.resp.shape[1:])

    def peaks(self, threshold: float, nms_radius: int, border: int):
        if min(self.shape) < 3:  # no 3 x 3 patches: the map is read on the host
            return None
        return self.stack.peaks(self.j, threshold, nms_radius, border)

    def whole(self) -> np.ndarray:
        return self.stack.resp[self.j].copy_to_host()

    def gradient(self, rows, cols, xy):
        # asked for the strongest peaks first, then for more where merged duplicates left the cut short
        if not self.on_device_gradient or len(rows) == 0:
            return None
        return _gradient_on_device(self.dev, self.j, rows, cols, xy)


def _detect_stack(s: GreyStack, p: Params, masks: list, clip: bool = True) -> list[Corners]:
    """Corners of every image of one device stack; ``clip``: drop those that refinement moved out of the
    mask or border (the pyramid does it at full resolution instead)."""
    resp = _measure(s.dev, p.measure_spec())
    N, H, W = resp.shape
    # the host grey image: refinement reads it where it is at hand; X-junctions, the adaptive
    # refinement and the host's selection on the whole map need it whole (copied back for a device input)
    whole = p.threshold_rel is not None or p.quantile is not None or H < 3 or W < 3
    grey = s.host
    if grey is None and (whole or p.x_junctions or p.subpixel == "adaptive"):
        grey = s.dev.copy_to_host()
    stack = _StackMeasure(resp)
    out = [select_corners(None if grey is None else grey[j], p, masks[j],
                          device=_DeviceMeasure(stack, j, s.dev, grey is None)) for j in range(N)]
    return [c.subset(inside_allowed(c.xy, masks[j], p.border, (H, W))) if clip else c
            for j, c in enumerate(out)]


def _params(preset: str, params: dict) -> Params:
    p = resolve_params(preset, **params)
    require_cuda()
    return p


def corner_response(image, *, preset: str = "paper", **params):
    """The corner measure Upsilon (eq. 25) of one image, computed on the GPU.

    Parameters
    ----------
    image : ndarray or device array
        A host image as :func:`sogdd.corner_response` takes, or a grey (H, W)
        device array (torch, CuPy, numba; uint8, uint16, float32 or float64).
    preset : {"paper", "authors", "hr"}
        Starting parameter set; keyword arguments override it.

    Returns
    -------
    ndarray or numba device array
        Upsilon = det(Lambda) / (tr(Lambda) + varsigma), H x W float64; on the
        device for a device input, else on the host.

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img, _ = pattern_image((120, 160))
    >>> R = corner_response(img)  # needs a GPU  # doctest: +SKIP
    """
    p = _params(preset, params)
    s = to_grey_stacks(image, p, batch=False)[0]
    out = _measure(s.dev, p.measure_spec())[0]
    return out if s.on_device else out.copy_to_host()


def corner_response_batch(images, *, preset: str = "paper", **params) -> list:
    """Upsilon of each image of a list or (N, H, W) stack; same-sized images share one launch.

    Returns a list of maps (host or device, as :func:`corner_response`), or one
    (N, H, W) device array for a device stack.
    """
    p = _params(preset, params)
    stacks = to_grey_stacks(images, p, batch=True)
    spec = p.measure_spec()
    if len(stacks) == 1 and stacks[0].on_device and len(stacks[0].index) > 1:
        return _measure(stacks[0].dev, spec)
    res: list = [None] * sum(len(s.index) for s in stacks)
    for s in stacks:
        out = _measure(s.dev, spec)
        host = None if s.on_device else out.copy_to_host()
        for j, i in enumerate(s.index):
            res[i] = out[j] if host is None else host[j]
    return res


def detect_corners(image, *, preset: str = "paper", mask=None, **params) -> Corners:
    """Detect corners on the GPU: local maxima of Upsilon above the threshold, as :func:`sogdd.detect_corners`.

    Only the corners (and their 3 x 3 neighbourhoods) come back from the device.

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img, _ = pattern_image((240, 320))
    >>> c = detect_corners(img)  # needs a GPU  # doctest: +SKIP
    """
    return _detect(image, preset, [mask], params, batch=False)[0]


def detect_corners_batch(images, *, preset: str = "paper", masks=None, **params) -> list[Corners]:
    """Corners of each image of a list or (N, H, W) stack, in input order; ``masks`` one per image or None."""
    return _detect(images, preset, masks, params, batch=True)


def _detect(images, preset: str, masks, params: dict, *, batch: bool) -> list[Corners]:
    p = _params(preset, params)
    stacks = to_grey_stacks(images, p, batch=batch)
    n = sum(len(s.index) for s in stacks)
    if masks is None:
        masks = [None] * n
    if len(masks) != n:
        raise ValueError(f"got {len(masks)} masks for {n} images")
    res: list = [None] * n
    for s in stacks:
        shape = tuple(s.dev.shape[1:])
        ms = [check_mask(masks[i], shape) for i in s.index]
        for i, c in zip(s.index, _detect_stack(s, p, ms) if p.levels == 1 else _detect_levels(s, p, ms)):
            res[i] = c
    return res


def _detect_levels(s: GreyStack, p: Params, masks: list) -> list[Corners]:
    """The image pyramid (:mod:`sogdd.image.pyramid`): levels resized on the host, detected on the device."""
    grey = s.host if s.host is not None else s.dev.copy_to_host()

    def level(g: np.ndarray, mk) -> Corners:
        g = np.ascontiguousarray(g[None], dtype=np.float64)
        # mask and border hold for the full-resolution positions (the pyramid checks them), as on the CPU
        return _detect_stack(GreyStack(cuda.to_device(g), [0], g, False), p, [mk], clip=False)[0]

    out = []
    for j in range(len(s.index)):
        levels = pyramid_levels(grey[j], p.levels, p.scale_factor, border=p.border, mask=masks[j])
        found = [(lv, level(lv.grey, lv.mask)) for lv in levels]
        out.append(merge_levels(found, p, masks[j], grey[j].shape))
    return out
