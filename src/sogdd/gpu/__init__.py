"""The device path: the same stages on a CUDA GPU (``device="cuda"``, ``pip install 'sogdd[gpu]'``).

It mirrors the CPU stages without copying them: :mod:`.input` brings arrays
and device arrays to grey on the device (the image stage), :mod:`.device_code`
holds the compiled device code of the measure and the peak search, and
:mod:`.detect` runs them and finishes the few peaks on the host with the CPU's
own selection stage (:mod:`sogdd.select`).

================  ===================================================================
module            what it does
================  ===================================================================
:mod:`.input`     host and device arrays (CUDA array interface, DLPack) to grey stacks
:mod:`.device_code`  CUDA code: fused measure tiles, grey conversion, peaks, patches
:mod:`.detect`    the map and detection on the device, single images and batches
================  ===================================================================
"""

from .detect import available, corner_response, corner_response_batch, detect_corners, detect_corners_batch

__all__ = ["available", "corner_response", "corner_response_batch", "detect_corners", "detect_corners_batch"]
