"""The fill's label bookkeeping (calib.targets.chessboard.fill): the labels it tries, the squares it reads."""

import numpy as np
import pytest

from sogdd.calib.targets.chessboard.fill import _fill_labels, _frame


def reference_fill_labels(labels, pattern):
    """``_fill_labels`` label by label: the free 4-neighbours, sorted, within the pattern or the box."""
    have = {tuple(q) for q in labels.tolist()}
    lo, hi = labels.min(axis=0), labels.max(axis=0)
    out = []
    for q in sorted({(i + a, j + b) for i, j in have for a, b in ((1, 0), (-1, 0), (0, 1), (0, -1))} - have):
        ext = np.sort(np.maximum(hi, q) - np.minimum(lo, q) + 1)
        if (np.all(ext <= sorted(pattern)) if pattern is not None
                else bool(np.all((np.array(q) >= lo) & (np.array(q) <= hi)))):
            out.append(q)
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def reference_frame(p, at, xy, labels, P):
    """``_frame`` corner by corner, axis by axis, side by side."""
    pos = {tuple(q): k for k, q in enumerate(labels.tolist())}
    steps = np.zeros((len(p), 2, 2, 2))
    for k, (i, j) in enumerate(at.tolist()):
        for ax, e in enumerate((np.array([1, 0]), np.array([0, 1]))):
            got = {}
            for side, sg in ((0, 1), (1, -1)):
                m = pos.get((i + sg * e[0], j + sg * e[1]))
                if m is not None:
                    got[side] = sg * (xy[m] - p[k])
            for side, sg in ((0, 1), (1, -1)):
                if side in got:
                    steps[k, ax, side] = got[side]
                elif 1 - side in got:
                    o = got[1 - side]
                    m2 = pos.get((i - 2 * sg * e[0], j - 2 * sg * e[1]))
                    m1 = pos.get((i - sg * e[0], j - sg * e[1]))
                    ratio = 1.0
                    if m2 is not None and m1 is not None:
                        ratio = float(np.clip(np.hypot(*o) / max(np.hypot(*(xy[m1] - xy[m2])), 1e-9), 0.3, 1.5))
                    steps[k, ax, side] = o * ratio
                else:
                    steps[k, ax, side] = P[k, 1 + 2 * ax] - P[k, 2 + 2 * ax]
    d = np.stack([(si * steps[:, 0, (1 - si) // 2] + sj * steps[:, 1, (1 - sj) // 2]) / 2
                  for si, sj in ((1, 1), (-1, -1), (1, -1), (-1, 1))], axis=1)
    return d, np.min(np.hypot(steps[..., 0], steps[..., 1]), axis=(1, 2))


def ragged_board(seed):
    """The labels of a board with holes and a ragged edge, and positions that curve a little."""
    rng = np.random.default_rng(seed)
    lab = np.array([(i, j) for j in range(-2, 5) for i in range(-3, 6)])
    lab = lab[rng.random(len(lab)) > 0.25]
    xy = 20.0 * lab + 0.4 * lab ** 2 + rng.normal(0, 0.3, lab.shape) + 100.0
    return lab, xy


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("pattern", [None, (9, 7), (4, 12), (3, 3)])
def test_fill_labels_are_the_free_neighbours_within_the_pattern(seed, pattern):
    lab, _ = ragged_board(seed)
    got = _fill_labels(lab, pattern)
    assert got.dtype == np.int64 and np.array_equal(got, reference_fill_labels(lab, pattern))


@pytest.mark.parametrize("seed", range(6))
def test_frame_reads_the_steps_to_the_neighbours_to_the_bit(seed):
    lab, xy = ragged_board(seed)
    rng = np.random.default_rng(seed + 10)
    at = np.r_[_fill_labels(lab, None), _fill_labels(lab, (12, 12))[:5], lab[:4]]
    p = 20.0 * at + 100.0 + rng.normal(0, 0.5, at.shape)
    P = np.repeat(p[:, None], 5, axis=1) + rng.normal(0, 10.0, (len(at), 5, 2))
    got, want = _frame(p, at, xy, lab, P), reference_frame(p, at, xy, lab, P)
    for g, w in zip(got, want):
        assert g.shape == w.shape and np.array_equal(g, w)
    assert [a.shape for a in _frame(p[:0], at[:0], xy, lab, P[:0])] == [(0, 4, 2), (0,)]
