"""Images onto the GPU: numpy arrays, CUDA array interface and DLPack objects, as float64 grey stacks.

Device arrays (torch, CuPy, numba, anything with ``__cuda_array_interface__``
or a CUDA ``__dlpack__``) are viewed in place, never copied to the host. They
must be grey: (H, W), or a stack (N, H, W) of same-sized images; uint8, uint16,
float32 or float64, scaled to 0-255 on the device exactly as
:func:`sogdd.image.grey.to_gray255` does on the host (float values must lie in [0, 1]).
Host arrays go through :func:`sogdd.image.validate.validate_image` and
:func:`sogdd.image.grey.to_gray255` (colour included) and are uploaded once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import cuda

from ..image.grey import to_gray255
from ..image.validate import FLOAT_TOL, validate_image
from . import device_code as ck

__all__ = ["GreyStack", "cuda_runtime_available", "is_device_array", "require_cuda", "to_grey_stacks"]

_KDL_CUDA = (2, 3, 13)  # DLPack device types: CUDA, CUDA host (pinned), CUDA managed
_DTYPES = ("uint8", "uint16", "float32", "float64")


def cuda_runtime_available() -> bool:
    """Whether numba finds a usable CUDA GPU and driver (or its CUDA simulator is on)."""
    try:
        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - a broken driver install means "not available"
        return False


def require_cuda() -> None:
    """Raise a one-line ``ValueError`` where no CUDA runtime is present."""
    if not cuda_runtime_available():
        raise ValueError(
            "device='cuda' needs an NVIDIA GPU, its driver and the GPU extra "
            "(pip install 'sogdd[gpu]'); no CUDA device was found"
        )


def is_device_array(obj) -> bool:
    """Whether ``obj`` lives on a CUDA device (CUDA array interface, or DLPack with a CUDA device)."""
    if hasattr(obj, "__cuda_array_interface__") or cuda.devicearray.is_cuda_ndarray(obj):
        return True
    dev = getattr(obj, "__dlpack_device__", None)
    if dev is None or isinstance(obj, np.ndarray):
        return False
    try:
        return int(dev()[0]) in _KDL_CUDA
    except Exception:  # noqa: BLE001 - a foreign object that cannot say is not ours
        return False


def _interface(obj) -> dict:
    """The CUDA array interface of a device array; DLPack objects go through cuda.core's memory view."""
    cai = getattr(obj, "__cuda_array_interface__", None)
    if cai is not None:
        return dict(cai)
    try:  # numba-cuda depends on cuda-core, which reads DLPack without copying
        from cuda.core.utils import StridedMemoryView
    except ImportError as exc:
        raise ValueError(
            "a DLPack array without __cuda_array_interface__ needs cuda-core (pip install 'sogdd[gpu]'); "
            "or pass a torch/CuPy array"
        ) from exc
    # -1: no stream handshake. numba launches on the legacy default stream, which waits for work on
    # blocking streams (torch's and CuPy's defaults); a producer on a non-blocking stream must sync first.
    smv = StridedMemoryView.from_dlpack(obj, stream_ptr=-1)
    dt = np.dtype(smv.dtype)
    strides = None if smv.strides is None else tuple(s * dt.itemsize for s in smv.strides)
    return {"shape": tuple(smv.shape), "strides": strides, "typestr": dt.str, "data": (smv.ptr, False),
            "version": 3, "_owner": smv}


def _check_grey(shape: tuple[int, ...], dt: np.dtype) -> None:
    if dt.name not in _DTYPES:
        raise ValueError(f"unsupported device dtype {dt.name}; use uint8, uint16, float32 or float64")
    if len(shape) not in (2, 3):
        raise ValueError(
            f"device images must be grey (H, W) or a stack (N, H, W); got shape {shape} "
            "(convert colour to grey on the device first)"
        )
    if 0 in shape:
        raise ValueError(f"empty image (shape {shape})")
    if shape[-2] < 2 or shape[-1] < 2:
        raise ValueError(f"image too small: {shape[-2]}x{shape[-1]} (need at least 2x2)")


def _device_view(obj):
    """A numba (N, H, W) view of a grey device image or stack, with no copy."""
    if cuda.devicearray.is_cuda_ndarray(obj) and (obj.ndim == 3 or obj.is_c_contiguous()):
        # numba's own arrays (and the CUDA simulator's, which have no array interface)
        _check_grey(tuple(obj.shape), np.dtype(obj.dtype))
        return obj if obj.ndim == 3 else obj.reshape(1, *obj.shape)
    desc = _interface(obj)
    owner = desc.pop("_owner", obj)
    shape = tuple(int(s) for s in desc["shape"])
    dt = np.dtype(desc["typestr"])
    _check_grey(shape, dt)
    strides = desc.get("strides")
    if strides is None:  # C-contiguous
        strides = tuple(int(np.prod(shape[i + 1 :], dtype=np.int64)) * dt.itemsize for i in range(len(shape)))
    if len(shape) == 2:
        shape, strides = (1, *shape), (shape[0] * shape[1] * dt.itemsize, *strides)
    desc.update(shape=shape, strides=tuple(int(s) for s in strides))
    return cuda.from_cuda_array_interface(desc, owner=owner)


def _launch_3d(shape) -> tuple[tuple[int, int, int], tuple[int, int, int]]:
    """Grid and block for one thread per (x, y, n): consecutive threads read consecutive columns."""
    n, h, w = shape
    return (math.ceil(w / 32), math.ceil(h / 8), n), (32, 8, 1)


def _grey_on_device(view, value_range):
    """float64 0-255 copy of a validated device view, converted on the device (sogdd.image.grey.to_gray255)."""
    kind = np.dtype(view.dtype)
    if kind.kind == "f":
        stats = cuda.to_device(np.array([np.inf, -np.inf, 0.0]))
        ck.range_kernel[min(256, math.ceil(view.size / 256)), 256](view, stats)
        lo, hi, bad = stats.copy_to_host()
        if bad:
            raise ValueError("image contains NaN or inf")
        if value_range is None and (lo < -FLOAT_TOL or hi > 1 + FLOAT_TOL):
            raise ValueError(
                f"float images must be on [0, 1] (got [{lo:g}, {hi:g}]); divide by 255 or pass uint8"
            )
    if value_range is not None:
        lo, hi = value_range
        off, scale, unit, full = float(lo), 255.0 / (hi - lo), False, True
    else:
        off, scale = 0.0, {"uint8": 1.0, "uint16": 255.0 / 65535.0}.get(kind.name, 255.0)
        unit, full = kind.kind == "f", False
    out = cuda.device_array(view.shape, dtype=np.float64)
    grid, block = _launch_3d(view.shape)
    ck.to_grey_kernel[grid, block](view, out, off, scale, unit, full)
    return out


@dataclass
class GreyStack:
    """Same-sized grey images on the device, and where they came from.

    ``index`` maps each image of ``dev`` (N, H, W) float64 to its position in the
    caller's input; ``host`` is the (N, H, W) grey image on the host where the input
    was a host array (sub-pixel refinement then reads it), else None.
    """

    dev: object
    index: list[int]
    host: np.ndarray | None
    on_device: bool


def to_grey_stacks(images, params, *, batch: bool) -> list[GreyStack]:
    """Group the input images by size and put each group on the device as one float64 stack.

    ``batch=False``: ``images`` is one image (host colour/grey, or a device grey
    (H, W) image). ``batch=True``: a sequence of images, a host (N, H, W) array
    or a device (N, H, W) stack.
    """
    if not batch:
        items = [images]
    elif is_device_array(images):
        view = _device_view(images)
        return [GreyStack(_grey_on_device(view, params.value_range), list(range(view.shape[0])), None, True)]
    else:
        items = list(images)
        if not items:
            raise ValueError("no images given")
    stacks: list[GreyStack] = []
    host_groups: dict[tuple[int, int], list[tuple[int, np.ndarray]]] = {}
    for i, img in enumerate(items):
        if is_device_array(img):
            view = _device_view(img)
            if view.shape[0] != 1:
                raise ValueError(f"item {i}: a (N, H, W) stack inside a list; pass the stack itself")
            stacks.append(GreyStack(_grey_on_device(view, params.value_range), [i], None, True))
            continue
        grey = to_gray255(validate_image(img, value_range=params.value_range), weights=params.gray_weights,
                          round_integer=params.gray_round, channel_order=params.channel_order,
                          value_range=params.value_range)
        host_groups.setdefault(grey.shape, []).append((i, grey))
    for group in host_groups.values():
        host = np.ascontiguousarray(np.stack([g for _, g in group]))
        stacks.append(GreyStack(cuda.to_device(host), [i for i, _ in group], host, False))
    return stacks
