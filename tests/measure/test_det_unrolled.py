"""The unrolled elimination (generated) against the loop it unrolls, and the generator against its file."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from sogdd._jit import elimination
from sogdd.measure import det_unrolled as _det_unrolled
from sogdd.measure.square_tiles import det_trace, det_trace_loop, pair_index

GENERATOR = Path(__file__).resolve().parents[2] / "tools" / "gen_unrolled_det.py"


def _packed_psd(K: int, n: int, seed: int) -> np.ndarray:
    """(P, n) packed upper triangles of sums of |l| |l|^T, some singular (zero rows) and one zero matrix."""
    rng = np.random.default_rng(seed)
    lab = np.abs(rng.normal(size=(49, K, n))) * rng.uniform(0.1, 300.0, size=(1, 1, n))
    lab[:, K // 2, 1::7] = 0.0  # a zero row and column: det = 0, a zero pivot on the way
    lab[:, :, 3] = 0.0
    m = np.einsum("wkn,wln->kln", lab, lab)
    pi, pj, _ = pair_index(K)
    return np.ascontiguousarray(m[pi, pj]), m


@pytest.mark.skipif(not GENERATOR.is_file(), reason="the repository's tools/ folder is not here")
def test_generated_module_is_current():
    spec = importlib.util.spec_from_file_location("gen_unrolled_det", GENERATOR)
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert Path(_det_unrolled.__file__).read_text() == gen.module_source()


@pytest.mark.parametrize("K", [4, 6, 8])
def test_unrolled_equals_loop_bit_for_bit(K):
    acc, m = _packed_psd(K, 203, seed=K)
    _, _, diag = pair_index(K)
    n = acc.shape[1]
    det_l, tr_l, f = np.empty(n), np.empty(n), np.empty(n)
    det_trace_loop(acc.copy(), diag, det_l, tr_l, f, n)
    det_u, tr_u = np.empty(n), np.empty(n)
    getattr(_det_unrolled, f"det_trace_{K}")(acc, det_u, tr_u, n)
    assert np.array_equal(det_u, det_l) and np.array_equal(tr_u, tr_l)
    # and both are the determinant: exactly 0 for the singular ones, else numpy's to rounding
    assert np.all(det_u[1::7] == 0.0) and det_u[3] == 0.0 and tr_u[3] == 0.0
    ref = np.linalg.det(np.moveaxis(m, 2, 0))
    ok = det_u != 0.0
    assert ok.sum() > n // 2
    np.testing.assert_allclose(det_u[ok], ref[ok], rtol=1e-8)
    np.testing.assert_allclose(tr_u, np.trace(m), rtol=1e-14)


@pytest.mark.parametrize("K", [3, 4, 5, 8])
def test_det_trace_dispatch_matches_loop(K):
    acc, _ = _packed_psd(K, 64, seed=10 + K)
    _, _, diag = pair_index(K)
    outs = []
    for fn in (lambda *a: det_trace(*a, elimination(K)), det_trace_loop):  # kdim: the compiled elimination
        det, tr, f = np.empty(64), np.empty(64), np.empty(64)
        fn(acc.copy(), diag, det, tr, f, 64)
        outs.append((det, tr))
    assert np.array_equal(outs[0][0], outs[1][0]) and np.array_equal(outs[0][1], outs[1][1])
