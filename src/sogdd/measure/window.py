"""The summation window of the SODDC matrix, and the one border reflection.

The window of eq. (24) is described by its half-width on each row offset
``dy = -R..R`` (``size = 2R + 1``), which covers squares and disks alike. At the
image border every stage (the filters and the window sums) uses half-sample
symmetric reflection: scipy ``mode="reflect"``, numpy/MATLAB ``symmetric``,
OpenCV ``BORDER_REFLECT``.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import JIT

__all__ = [
    "disk_halfwidths", "is_square", "reflect_index", "take_reflected", "window_halfwidths", "window_offsets",
]


def window_halfwidths(shape: str, size: int) -> tuple[int, ...]:
    """Half-width of the window on each row offset ``dy = -R..R``, ``size = 2R + 1``.

    ``"square"``: a ``size x size`` square. ``"disk"``: the offsets with
    ``dy^2 + dx^2 <= (R + 1/2)^2``; ``size = 5`` gives the 21 offsets with
    ``dy^2 + dx^2 <= 5`` of the authors' code.

    Examples
    --------
    >>> window_halfwidths("square", 5)
    (2, 2, 2, 2, 2)
    >>> window_halfwidths("disk", 5)
    (1, 2, 2, 2, 1)
    """
    R = int(size) // 2
    if shape == "square":
        return (R,) * (2 * R + 1)
    if shape == "disk":
        return disk_halfwidths((R + 0.5) ** 2)
    raise ValueError(f"unknown window shape {shape!r}")


def disk_halfwidths(r2: float) -> tuple[int, ...]:
    """Half-widths of the disk of integer offsets with ``dy^2 + dx^2 <= r2``.

    Examples
    --------
    >>> h = disk_halfwidths(10.0)  # the 37-pixel window of Zhang & Sun's detectors
    >>> h, sum(2 * w + 1 for w in h)
    ((1, 2, 3, 3, 3, 2, 1), 37)
    """
    R = int(np.floor(np.sqrt(r2)))
    dy = np.arange(-R, R + 1)
    return tuple(int(h) for h in np.floor(np.sqrt(r2 - dy * dy)))


def window_offsets(halfwidths) -> np.ndarray:
    """(N, 2) ``(dy, dx)`` offsets covered by a window given by its half-widths.

    Examples
    --------
    >>> len(window_offsets(window_halfwidths("disk", 5)))
    21
    """
    R = (len(halfwidths) - 1) // 2
    return np.array(
        [(dy - R, dx) for dy, h in enumerate(halfwidths) for dx in range(-h, h + 1)], dtype=np.int64
    )


def is_square(halfwidths) -> bool:
    """Whether a window given by its half-widths is a square."""
    return bool(np.all(np.asarray(halfwidths) == (len(halfwidths) - 1) // 2))


@numba.njit(**JIT)
def reflect1(i, n):  # pragma: no cover - jit
    """Half-sample symmetric reflection of one index into ``[0, n)``, any reach (compiled)."""
    m = i % (2 * n)
    return m if m < n else 2 * n - 1 - m


@numba.njit(**JIT)
def _reflect_all(idx, n, out):  # pragma: no cover - jit
    for t in range(idx.shape[0]):
        out[t] = reflect1(idx[t], n)


def reflect_index(idx, n: int) -> np.ndarray:
    """Half-sample symmetric index map into ``[0, n)`` of an array of indices, any reach.

    ``-1 -> 0``, ``-2 -> 1``, ``n -> n - 1``: the edge sample is repeated, as in
    scipy ``mode="reflect"``.

    Examples
    --------
    >>> reflect_index([-2, -1, 0, 3, 4, 5], 4).tolist()
    [1, 0, 0, 3, 3, 2]
    """
    a = np.ascontiguousarray(idx, dtype=np.int64)
    out = np.empty_like(a).reshape(-1)
    _reflect_all(a.reshape(-1), int(n), out)
    return out.reshape(a.shape)


def take_reflected(arr: np.ndarray, axis: int, start: int, stop: int) -> np.ndarray:
    """Indices ``start..stop-1`` of ``arr`` along ``axis`` with half-sample reflection.

    A view when the range lies inside; otherwise the reflected copy (image edges).
    """
    n = arr.shape[axis]
    if 0 <= start and stop <= n:
        return arr[(slice(None),) * axis + (slice(start, stop),)]
    return np.take(arr, reflect_index(np.arange(start, stop), n), axis=axis)
