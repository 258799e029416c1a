"""The numba compilation options of every compiled kernel, in one place.

``cache=True`` keeps the compiled code between runs; ``nogil=True`` lets the
tile driver run kernels in threads; ``error_model="numpy"`` drops Python's
zero-division checks from the hot loops; ``fastmath={"contract"}`` allows fused
multiply-adds only (no reassociation, so results stay deterministic and
independent of tiling).
"""

JIT = dict(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
