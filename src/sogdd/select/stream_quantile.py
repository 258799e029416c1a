"""numpy's linear quantile of values that arrive in batches, exact, keeping only those that can matter.

``np.quantile(x, q)`` (method ``"linear"``) interpolates between the order
statistics ``S_i`` and ``S_{i+1}`` of the n values, ``i = floor((n - 1) q)``.
When at most ``rest`` more values can still arrive, the final ``S_i`` is at
least the ``r``-th smallest kept value with ``r = floor((n + rest - 1) q) - rest``
(minus what was dropped, minus 1 for rounding): even if every value still to
come were smaller, no more than ``rest`` of them can rank below it. Kept values
strictly below that one can never be ``S_i`` or ``S_{i+1}``, so they are
dropped and only counted; any lower bound of it will do, and a histogram of the
values' leading bits (:func:`rank_floor`, two compiled passes) gives one at a
fraction of the cost of selecting it exactly. Near the end ``rest`` is small and about
``(1 - q) n`` values remain (1 % for the authors' ``q = 0.99``); the result is
then numpy's own interpolation between the two order statistics.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import JIT

__all__ = ["StreamQuantile", "quantile_from_order_stats", "rank_floor"]

_BUCKET_BITS = 16  # sign, exponent and 4 mantissa bits: a bucket is a sixteenth of an octave


@numba.njit(**JIT, inline="always")
def _order_key(k):  # pragma: no cover - jit
    """An unsigned key of a float64's bits (as int64 ``k``) that sorts as the floats do."""
    return np.uint64(~k) if k < 0 else np.uint64(k) | np.uint64(1 << 63)


@numba.njit(**JIT)
def _rank_floor(values, r):  # pragma: no cover - jit
    shift = 64 - _BUCKET_BITS
    counts = np.zeros(1 << _BUCKET_BITS, np.int64)
    keys = values.view(np.int64)
    for i in range(values.shape[0]):
        counts[_order_key(keys[i]) >> np.uint64(shift)] += 1
    seen = 0
    b = 0
    while seen + counts[b] <= r:
        seen += counts[b]
        b += 1
    low = np.inf
    for i in range(values.shape[0]):
        if _order_key(keys[i]) >> np.uint64(shift) == b:
            low = min(low, values[i])
    return low


def rank_floor(values: np.ndarray, r: int) -> float:
    """A value of ``values`` at or below its ``r``-th smallest (0-based): the least in that one's bucket.

    Buckets are the leading 16 bits of an order-preserving integer key of each
    float (finite values): the sign, the octave and its sixteenth, so the result
    is within 1/16 of the ``r``-th smallest's magnitude below it (rounded up to a power
    of two), from two linear passes instead of a selection.

    Examples
    --------
    >>> x = np.random.default_rng(2).random(10000)
    >>> lo = rank_floor(x, 9900)
    >>> bool(lo <= np.partition(x, 9900)[9900]), bool(lo > 0.9)
    (True, True)
    """
    values = np.ascontiguousarray(values, dtype=np.float64)
    if not 0 <= r < len(values):
        raise ValueError("rank out of range")
    return float(_rank_floor(values, int(r)))


def quantile_from_order_stats(n: int, q: float, order_stat) -> float:
    """``np.quantile(x, q)`` for ``len(x) == n`` from ``order_stat(k)``, the k-th smallest value of x.

    The virtual index ``(n - 1) q``, its floor and fraction are numpy's; the
    interpolation is numpy's own, on the two order statistics (a two-value
    array whose virtual index is the fraction itself).

    Examples
    --------
    >>> x = np.random.default_rng(1).random(1001)
    >>> s = np.sort(x)
    >>> bool(quantile_from_order_stats(len(x), 0.99, lambda k: s[k]) == np.quantile(x, 0.99))
    True
    """
    if n <= 0:
        raise ValueError("the quantile of no values")
    v = (n - 1) * np.asarray(q, dtype=np.float64)  # as numpy's "linear" get_virtual_index
    if not v < n - 1:  # numpy takes the maximum there
        return float(order_stat(n - 1))
    i = int(np.floor(v))
    g = float(v - np.floor(v))
    a, b = float(order_stat(i)), float(order_stat(i + 1))
    return float(np.quantile(np.array([a, b]), g))


class StreamQuantile:
    """The exact ``np.quantile`` of values added in batches, with at most ``capacity`` values in all.

    Parameters
    ----------
    q : float
        The quantile, in [0, 1).
    capacity : int
        An upper bound on the number of values that will be added (the valid pixels).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> parts = [rng.random(n) for n in (500, 300, 700)]
    >>> sq = StreamQuantile(0.99, 1600)
    >>> for x in parts:
    ...     sq.add(x, slots=len(x) + 20)
    >>> bool(sq.result() == np.quantile(np.concatenate(parts), 0.99)), sq.kept < 100
    (True, True)
    """

    def __init__(self, q: float, capacity: int) -> None:
        self.q = float(q)
        self.rest = int(capacity)
        self.dropped = 0
        self.floor = -np.inf  # every dropped value is below it; the result is not
        self._parts: list[np.ndarray] = []
        self.kept = 0

    @property
    def count(self) -> int:
        """The number of values added so far."""
        return self.dropped + self.kept

    def add(self, values: np.ndarray, slots: int, dropped: int = 0) -> None:
        """Add a batch; ``slots`` is how much of the capacity it used (at least its size).

        ``dropped``: values of the batch below :attr:`floor` that the caller left out
        of ``values`` (they only count).
        """
        values = np.asarray(values, dtype=np.float64).ravel()
        if len(values) + dropped > slots:
            raise ValueError("a batch holds more values than its slots")
        self.rest -= int(slots)
        self.dropped += int(dropped)
        below = values < self.floor
        if below.any():
            self.dropped += int(np.count_nonzero(below))
            values = values[~below]
        self._parts.append(values)
        self.kept += len(values)
        r = math.floor((self.count + self.rest - 1) * self.q) - self.rest - self.dropped - 1
        # partition only when it frees a good share of what is kept (amortised linear time)
        if r > 0 and r >= self.kept // 4:
            kept = np.concatenate(self._parts)
            kth = rank_floor(kept, r)  # at most the r-th smallest: what is below it can go
            keep = kept[kept >= kth]
            self.dropped += len(kept) - len(keep)
            self._parts, self.kept = [keep], len(keep)
            self.floor = max(self.floor, kth)

    def result(self) -> float | None:
        """``np.quantile`` of every value added (None when there are none)."""
        if self.count == 0:
            return None
        kept = np.concatenate(self._parts)
        self._parts = [kept]
        cache: dict[int, float] = {}

        def order_stat(k: int) -> float:
            j = k - self.dropped
            if j not in cache:
                cache[j] = float(np.partition(kept, j)[j])
            return cache[j]

        return quantile_from_order_stats(self.count, self.q, order_stat)
