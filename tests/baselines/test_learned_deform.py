"""The stand-in deformable convolution equals its definition, and torchvision's where that is installed."""

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="PyTorch (the 'learned' extra) is not installed")

from sogdd.baselines.learned_deform import deform_conv2d, stand_in_modules  # noqa: E402


def _bilinear(img: np.ndarray, y: float, x: float) -> float:
    """torchvision's bilinear_interpolate: each neighbour outside the image counts 0."""
    h, w = img.shape
    if y <= -1 or y >= h or x <= -1 or x >= w:
        return 0.0
    y0, x0 = int(np.floor(y)), int(np.floor(x))
    ly, lx = y - y0, x - x0
    v = 0.0
    for yy, xx, wt in ((y0, x0, (1 - ly) * (1 - lx)), (y0, x0 + 1, (1 - ly) * lx),
                       (y0 + 1, x0, ly * (1 - lx)), (y0 + 1, x0 + 1, ly * lx)):
        if 0 <= yy < h and 0 <= xx < w:
            v += wt * img[yy, xx]
    return v


def _reference(x, off, wgt, bias, pad, mask=None):
    b, c, h, w = x.shape
    o, _, kh, kw = wgt.shape
    ho, wo = h + 2 * pad - kh + 1, w + 2 * pad - kw + 1
    out = np.zeros((b, o, ho, wo))
    for n in range(b):
        for i in range(ho):
            for j in range(wo):
                for ki in range(kh):
                    for kj in range(kw):
                        k = ki * kw + kj
                        y = i - pad + ki + off[n, 2 * k, i, j]
                        xx = j - pad + kj + off[n, 2 * k + 1, i, j]
                        m = 1.0 if mask is None else mask[n, k, i, j]
                        vals = np.array([_bilinear(x[n, ch], y, xx) for ch in range(c)]) * m
                        out[n, :, i, j] += wgt[:, :, ki, kj] @ vals
    return out + bias[None, :, None, None]


@pytest.mark.parametrize("with_mask", [False, True])
def test_the_stand_in_follows_the_definition(with_mask):
    rng = np.random.default_rng(5)
    x = rng.normal(size=(2, 3, 5, 6))
    off = rng.normal(scale=2.0, size=(2, 18, 5, 6))  # large enough to leave the image
    off[0, 0, 0, 0] = -1.0  # exactly on the outer edge of the support
    wgt, bias = rng.normal(size=(4, 3, 3, 3)), rng.normal(size=4)
    mask = rng.uniform(size=(2, 9, 5, 6)) if with_mask else None
    def t(a):
        return None if a is None else torch.tensor(a, dtype=torch.float64)

    got = deform_conv2d(t(x), t(off), t(wgt), t(bias), padding=(1, 1), mask=t(mask)).numpy()
    np.testing.assert_allclose(got, _reference(x, off, wgt, bias, 1, mask), rtol=1e-10, atol=1e-10)


def test_the_stand_in_modules_are_what_aliked_imports():
    mods = stand_in_modules()
    conv = mods["torchvision.models.resnet"].conv3x3(4, 8)
    assert conv.kernel_size == (3, 3) and conv.padding == (1, 1) and conv.bias is None
    assert mods["torchvision.models.resnet"].conv1x1(4, 8).kernel_size == (1, 1)
    assert mods["torchvision"].SOGDD_STAND_IN is True


def _torchvision_ops():
    try:
        import torchvision.ops
    except Exception:  # a torchvision built for another PyTorch fails on import
        return None
    return torchvision.ops


@pytest.mark.skipif(_torchvision_ops() is None, reason="no working torchvision beside this PyTorch")
@pytest.mark.parametrize("with_mask", [False, True])
def test_the_stand_in_equals_torchvision(with_mask):
    ops = _torchvision_ops()
    g = torch.Generator().manual_seed(0)
    x = torch.randn(2, 16, 12, 15, generator=g)
    off = 3.0 * torch.randn(2, 18, 12, 15, generator=g)
    wgt, bias = torch.randn(8, 16, 3, 3, generator=g), torch.randn(8, generator=g)
    mask = torch.rand(2, 9, 12, 15, generator=g) if with_mask else None
    want = ops.deform_conv2d(x, off, wgt, bias, padding=(1, 1), mask=mask)
    got = deform_conv2d(x, off, wgt, bias, padding=(1, 1), mask=mask)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-4)
