"""CUDA kernels of the GPU path: the fused measure, the authors' post-processing, peaks, patches.

Why numba.cuda (and not CuPy ``RawKernel`` or Triton): numba is already a
dependency and the CPU kernels are numba too, so the GPU kernel is Python with
the same arithmetic as :mod:`sogdd.measure.filters` and :mod:`sogdd.measure.soddc`, and it runs
unchanged on numba's CUDA simulator, which is how CI (no GPU) tests it. CuPy
would add a second array library and a CUDA C++ string nobody can test without a
GPU; Triton works on blocks of float32/16 tensors and has no cheap way to hold a
per-pixel packed K x K float64 matrix and eliminate it in registers.

One launch of :func:`measure_kernel` computes, for a T x T tile of output pixels
(one thread each), everything from the image to Upsilon (eqs. 22-25) in shared
memory, without writing any intermediate map to global memory:

1. the image patch the tile needs (half-sample symmetric reflection at the edges);
2. horizontal then vertical passes of the three separable basis kernels
   ``g_xx, g_xy, g_yy`` (and a box filter for zero-mean kernels), with the same
   tap order as the CPU filter (taps ``b`` and ``2r - b`` share one multiply);
3. steering to K orientations and absolute values, ``|l_k| = |sum_p c_kp g_p|``;
4. per thread, the window sums of the K(K+1)/2 products ``|l_i| |l_j|`` in
   registers (each product times ``w[dy] w[dx]`` for a separable weighted window:
   the Gaussian window of :mod:`sogdd.measure.gaussian_window`), then det and trace by
   symmetric Gaussian elimination, written as ``det / (tr + varsigma)``.

Everything is float64: det passes 1e40 at K = 8. Kernels are specialised (and
cached) per K, window half-height, kernel radius, tile size and padding mode,
because shared and local arrays need sizes known at compile time.
"""

from __future__ import annotations

import math
from functools import cache

from numba import cuda, float64

from ..measure.square_tiles import VARSIGMA

__all__ = [
    "SHARED_BYTES",
    "abs_max_kernel",
    "authors_kernel",
    "gather_patches_kernel",
    "measure_kernel",
    "peaks_kernel",
    "range_kernel",
    "tile_size",
    "to_grey_kernel",
]

# Static shared memory per block that every CUDA GPU offers without opting in.
SHARED_BYTES = 48 * 1024


def _shared_doubles(K: int, R: int, rk: int, nf: int, T: int) -> tuple[int, int]:
    """Sizes (in doubles) of the two shared buffers of a T x T tile."""
    rh = T + 2 * R  # rows (and columns) of responses the tile's windows touch
    ph = rh + 2 * rk  # rows (and columns) of image they need
    return max(ph * ph, 3 * rh * rh), max(nf * ph * rh, K * rh * rh)


def tile_size(K: int, R: int, rk: int, nf: int) -> int | None:
    """The largest tile side (16, 8 or 4) whose buffers fit in static shared memory, or None."""
    for T in (16, 8, 4):
        a, b = _shared_doubles(K, R, rk, nf, T)
        if 8 * (a + b) <= SHARED_BYTES:
            return T
    return None


@cuda.jit(device=True, inline=True)
def _reflect(i, n):  # pragma: no cover - device code
    """Half-sample symmetric reflection of index i into [0, n), any reach (sogdd.measure.window.reflect1)."""
    m = i % (2 * n)
    return m if m < n else 2 * n - 1 - m


@cache
def measure_kernel(K: int, R: int, rk: int, nf: int, T: int, image_mode: bool, parts: bool,
                   weighted: bool = False):
    """The fused measure kernel of one specialisation.

    Launch with block (T, T) and grid (ceil(W / T), ceil(H / T), N).

    Arguments: ``img`` (N, H, W) float64 grey 0-255; ``fx``, ``fy`` (nf, 2rk+1)
    filter factors along x and y; ``odd`` (2 nf,) uint8 parity of each factor;
    ``means`` (3,) kernel means (zero-mean kernels, nf = 4); ``coef`` (K, 3)
    steering coefficients; ``halfw`` (2R+1,) window half-width per row offset;
    ``wts`` (2R+1,) the separable window weights (read with ``weighted`` only);
    ``out`` (N, H, W) Upsilon, or with ``parts`` det and ``tr2`` the trace.
    """
    RH = T + 2 * R
    RW = RH
    PH = RH + 2 * rk
    SA, SB = _shared_doubles(K, R, rk, nf, T)
    P = K * (K + 1) // 2
    NR = 2 * R + 1
    TAPS = 2 * rk + 1
    NT = T * T

    @cuda.jit
    def kernel(img, fx, fy, odd, means, coef, halfw, wts, out, tr2):  # pragma: no cover - device code
        A = cuda.shared.array(SA, float64)
        B = cuda.shared.array(SB, float64)
        n = cuda.blockIdx.z
        H = img.shape[1]
        W = img.shape[2]
        y0 = cuda.blockIdx.y * T
        x0 = cuda.blockIdx.x * T
        tid = cuda.threadIdx.y * T + cuda.threadIdx.x
        # response rows/columns the tile reads, in the coordinates where they are filtered:
        # the virtual range itself (image mode), or its reflection into the image (response mode)
        if image_mode:
            ymin = y0 - R
            ymax = y0 + T + R - 1
            xmin = x0 - R
            xmax = x0 + T + R - 1
        else:
            ymin = max(0, min(y0 - R, 2 * H - 1 - (y0 + T + R - 1)))
            ymax = min(H - 1, max(y0 + T + R - 1, R - y0 - 1))
            xmin = max(0, min(x0 - R, 2 * W - 1 - (x0 + T + R - 1)))
            xmax = min(W - 1, max(x0 + T + R - 1, R - x0 - 1))
        ny = ymax - ymin + 1
        nx = xmax - xmin + 1
        py = ny + 2 * rk
        px = nx + 2 * rk
        # 1. the image patch, reflected at the image edges
        for t in range(tid, py * px, NT):
            a = t // px
            c = t - a * px
            A[a * PH + c] = img[n, _reflect(ymin - rk + a, H), _reflect(xmin - rk + c, W)]
        cuda.syncthreads()
        # 2. horizontal passes: B[i, a, c] for patch rows a and response columns c
        for t in range(tid, nf * py * nx, NT):
            i = t // (py * nx)
            rem = t - i * (py * nx)
            a = rem // nx
            c = rem - a * nx
            base = a * PH + c
            h = fx[i, rk] * A[base + rk]
            if odd[i]:
                for b in range(rk):
                    h += fx[i, b] * (A[base + b] - A[base + TAPS - 1 - b])
            else:
                for b in range(rk):
                    h += fx[i, b] * (A[base + b] + A[base + TAPS - 1 - b])
            B[(i * PH + a) * RW + c] = h
        cuda.syncthreads()
        # 3. vertical passes: the basis planes A[p, r, c] (the image patch is no longer needed)
        for t in range(tid, ny * nx, NT):
            r = t // nx
            c = t - r * nx
            box = 0.0
            for i in range(nf - 1, -1, -1):  # the box filter (i = 3) first
                col = (i * PH + r) * RW + c
                v = fy[i, rk] * B[col + rk * RW]
                if odd[nf + i]:
                    for a in range(rk):
                        v += fy[i, a] * (B[col + a * RW] - B[col + (TAPS - 1 - a) * RW])
                else:
                    for a in range(rk):
                        v += fy[i, a] * (B[col + a * RW] + B[col + (TAPS - 1 - a) * RW])
                if i == 3:
                    box = v
                else:
                    if nf == 4:
                        v -= means[i] * box
                    A[(i * RH + r) * RW + c] = v
        cuda.syncthreads()
        # 4. steering and |.| on the tile plus its window margin: B[k, vy, vx]
        for t in range(tid, RH * RW, NT):
            vy = t // RW
            vx = t - vy * RW
            gy = y0 - R + vy
            gx = x0 - R + vx
            if not image_mode:
                gy = _reflect(gy, H)
                gx = _reflect(gx, W)
            o = (gy - ymin) * RW + (gx - xmin)
            g0 = A[o]
            g1 = A[RH * RW + o]
            g2 = A[2 * RH * RW + o]
            for k in range(K):
                B[(k * RH + vy) * RW + vx] = abs(coef[k, 0] * g0 + coef[k, 1] * g1 + coef[k, 2] * g2)
        cuda.syncthreads()
        # 5. one pixel per thread: window sums of the products, then det and trace
        ty = cuda.threadIdx.y
        tx = cuda.threadIdx.x
        y = y0 + ty
        x = x0 + tx
        if y >= H or x >= W:
            return
        acc = cuda.local.array(P, float64)
        lv = cuda.local.array(K, float64)
        for q in range(P):
            acc[q] = 0.0
        for dy in range(NR):
            hw = halfw[dy]
            for dx in range(R - hw, R + hw + 1):
                o = (ty + dy) * RW + tx + dx
                wgt = wts[dy] * wts[dx] if weighted else 1.0
                for k in range(K):
                    lv[k] = B[k * RH * RW + o]
                q = 0
                for i in range(K):
                    li = lv[i]
                    for j in range(i, K):
                        if weighted:
                            acc[q] += wgt * (li * lv[j])
                        else:
                            acc[q] += li * lv[j]
                        q += 1
        # symmetric elimination (LDL^T, no pivoting) as sogdd's CPU kernel; det = product of pivots
        tr = 0.0
        for i in range(K):
            tr += acc[i * K - i * (i - 1) // 2]
        det = 1.0
        for j in range(K):
            dj = j * K - j * (j - 1) // 2
            d = acc[dj]
            det *= d
            inv = 1.0 / d if d != 0.0 else 0.0
            for i in range(j + 1, K):
                f = acc[dj + (i - j)] * inv
                di = i * K - i * (i - 1) // 2
                for kk in range(i, K):
                    acc[di + (kk - i)] -= f * acc[dj + (kk - j)]
        if parts:
            out[n, y, x] = det
            tr2[n, y, x] = tr
        else:
            out[n, y, x] = det / (tr + VARSIGMA)

    return kernel


@cuda.jit
def to_grey_kernel(src, dst, lo, scale, unit, full):  # pragma: no cover - device code
    """dst = (src - lo) * scale on the 0-255 scale, as sogdd.image.grey.to_gray255.

    ``unit``: clip to [0, 1] before scaling (float images); ``full``: clip to
    [0, 255] after (``value_range``).
    """
    x, y, n = cuda.grid(3)
    if n < dst.shape[0] and y < dst.shape[1] and x < dst.shape[2]:
        v = float64(src[n, y, x]) - lo
        if unit:
            v = min(max(v, 0.0), 1.0)
        v *= scale
        if full:
            v = min(max(v, 0.0), 255.0)
        dst[n, y, x] = v


@cuda.jit
def range_kernel(src, stats):  # pragma: no cover - device code
    """stats[0] = min, stats[1] = max, stats[2] = 1 if any value is not finite (grid-stride)."""
    flat = src.size
    H = src.shape[1]
    W = src.shape[2]
    start = cuda.grid(1)
    step = cuda.gridsize(1)
    lo = math.inf
    hi = -math.inf
    bad = 0.0
    for t in range(start, flat, step):
        n = t // (H * W)
        r = t - n * H * W
        y = r // W
        v = float64(src[n, y, r - y * W])
        if not math.isfinite(v):
            bad = 1.0
        else:
            lo = min(lo, v)
            hi = max(hi, v)
    cuda.atomic.min(stats, 0, lo)
    cuda.atomic.max(stats, 1, hi)
    cuda.atomic.max(stats, 2, bad)


@cuda.jit
def abs_max_kernel(a, res):  # pragma: no cover - device code
    """res[n] = max |a[n]| over each image (grid-stride per image, grid z = image)."""
    n = cuda.blockIdx.z
    H = a.shape[1]
    W = a.shape[2]
    start = cuda.blockIdx.x * cuda.blockDim.x + cuda.threadIdx.x
    step = cuda.gridDim.x * cuda.blockDim.x
    m = 0.0
    for t in range(start, H * W, step):
        y = t // W
        m = max(m, abs(a[n, y, t - y * W]))
    cuda.atomic.max(res, n, m)


@cuda.jit
def authors_kernel(det, tr, big, eps, out):  # pragma: no cover - device code
    """The authors' post-processing (authors_measure): det in [-eps max|det|, 0) -> 0, non-finite -> -inf."""
    x, y, n = cuda.grid(3)
    if n < out.shape[0] and y < out.shape[1] and x < out.shape[2]:
        d = det[n, y, x]
        if d < 0.0 and d >= -eps * big[n]:
            d = 0.0
        u = d / (tr[n, y, x] + eps)
        out[n, y, x] = u if math.isfinite(u) else -math.inf


@cuda.jit
def peaks_kernel(resp, thr, radius, border, count, rows, cols, vals, patches):  # pragma: no cover - device code
    """Local maxima strictly above ``thr`` that no pixel of their (2 radius + 1)^2 square exceeds.

    The same test as :func:`sogdd.select.peaks.maxima_above`, on the valid area alone
    (``border`` px excluded on every side, as :func:`sogdd.select.peaks.select_peaks`
    does when ``2 border`` is less than both sides). Each peak is appended (order
    arbitrary) with its value and the 3 x 3 patch around it, centred on the pixel
    moved one step inwards at the image edge, as :func:`sogdd.select.refine.refine_quadratic` reads it.
    """
    x, y, n = cuda.grid(3)
    H = resp.shape[1]
    W = resp.shape[2]
    if n >= resp.shape[0] or y >= H or x >= W:
        return
    b = border if 2 * border < H and 2 * border < W else 0
    if y < b or y >= H - b or x < b or x >= W - b:
        return
    v = resp[n, y, x]
    if not v > thr:
        return
    for yy in range(max(b, y - radius), min(H - b, y + radius + 1)):
        for xx in range(max(b, x - radius), min(W - b, x + radius + 1)):
            if resp[n, yy, xx] > v:
                return
    i = cuda.atomic.add(count, n, 1)
    if i < rows.shape[1]:
        rows[n, i] = y
        cols[n, i] = x
        vals[n, i] = v
        r = min(max(y, 1), H - 2)
        c = min(max(x, 1), W - 2)
        for a in range(3):
            for b in range(3):
                patches[n, i, a, b] = resp[n, r + a - 1, c + b - 1]


@cuda.jit
def gather_patches_kernel(img, n, rows, cols, half, out):  # pragma: no cover - device code
    """out[i] = image n around (rows[i], cols[i]), +-half, edges replicated (OpenCV's BORDER_REPLICATE)."""
    b, a, i = cuda.grid(3)
    H = img.shape[1]
    W = img.shape[2]
    if i < rows.shape[0] and a < out.shape[1] and b < out.shape[2]:
        y = min(max(rows[i] + a - half, 0), H - 1)
        x = min(max(cols[i] + b - half, 0), W - 1)
        out[i, a, b] = img[n, y, x]
