"""Compiled code's settings, in one place: numba's options, row padding, the thread count.

``cache=True`` keeps the compiled code between runs; ``nogil=True`` lets the
tile driver run compiled functions in threads; ``error_model="numpy"`` drops Python's
zero-division checks from the hot loops; ``fastmath={"contract"}`` allows fused
multiply-adds only (no reassociation, so results stay deterministic and
independent of tiling).
"""

import os

JIT = dict(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})

#: Doubles added to the rows of compiled scratch arrays whose natural length is a
#: power of two (a block of 256 or 512 columns). Rows 2^k x 8 bytes apart map to the
#: same L1 cache sets, so a loop reading many such rows at once (the elimination reads
#: 36 at K = 8) evicts its own data: the paper preset's full map took 62 ms/MP on one
#: thread with such rows and 50 with padded ones.
ROW_PAD = 8


def thread_count() -> int:
    """Threads for the tiled measure: ``$SOGDD_NUM_THREADS``, else the cores (at most 8).

    Raises ``ValueError`` for a value that is not a positive integer.
    """
    env = os.environ.get("SOGDD_NUM_THREADS")
    if env:
        if not env.strip().isdigit() or int(env) < 1:
            raise ValueError(f"SOGDD_NUM_THREADS must be a positive integer, got {env!r}")
        return int(env)
    return max(1, min(os.cpu_count() or 1, 8))
