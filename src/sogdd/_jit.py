"""Compiled code's settings, in one place: numba's options, row padding, the thread count,
and the arguments that choose at compile time what numba compiles.

``cache=True`` keeps the compiled code between runs; ``nogil=True`` lets the
tile driver run compiled functions in threads; ``error_model="numpy"`` drops Python's
zero-division checks from the hot loops; ``fastmath={"contract"}`` allows fused
multiply-adds only (no reassociation, so results stay deterministic and
independent of tiling).

Numba compiles a function again for each new combination of argument *types*,
and drops a branch before typing it when the branch tests ``x is None`` on an
argument or ``len(t)`` of a tuple argument (dead branch pruning). The kernels use
that to compile only what a call runs: ``wts=None`` for a box window (no
weighted sums), :func:`elimination` for K and :func:`window_rows` for the window
height. The first ``sogdd demo`` compiles about half the code it did before
(``benchmarks/bench_compile.py``).

**The on-disk cache is keyed on the sources of the whole core.** Numba checks a
cached function against its own file only, yet a compiled function carries the
code of every compiled function it calls, from any module, and the values of the
globals it reads: after an edit of ``measure/window.py``, ``filters._basis_tile``
would load its old copy of ``reflect1``. Importing this module therefore puts in
front of numba's cache locators copies that, for the files of this package, add
:func:`sources_key` (a hash of the package version and of every source file of the
core) to numba's own stamp: any edit of the core, or another version, makes every
cached entry of the package stale, and numba compiles it again (and overwrites
it). A client's compiled code may call the compiled code of another module of its
own folder (the chessboard lattice's growth calls ``mapping.predict_local``), so
the stamp also holds :func:`folder_key`, a hash of the sources of the function's
own folder. Other packages' numba caches are untouched.
"""

import functools
import hashlib
import os
from pathlib import Path

JIT = dict(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
#: :data:`JIT` without ``fastmath`` (not even contraction): a compiled loop that computes the same
#: floating-point operations, in the same order, as the numpy it replaces, bit for bit
EXACT_JIT = dict(cache=True, nogil=True, error_model="numpy")

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


def elimination(K: int) -> tuple:
    """The ``kdim`` argument of the compiled elimination for K orientations.

    See :func:`sogdd.measure.square_tiles.det_trace`. A tuple of K zeros for the K
    with an unrolled elimination (4, 6, 8), else empty. Numba knows a tuple's
    length when it compiles (its type is ``UniTuple(int64, K)``) and drops the
    branches on it, so each call compiles the one elimination it runs: the first
    run of the ``paper`` preset (K = 8) no longer compiles those of K = 4, 6 and
    the loop.

    Examples
    --------
    >>> len(elimination(8)), elimination(5)
    (8, ())
    """
    return (0,) * K if K in (4, 6, 8) else ()


def window_rows(nr: int) -> tuple:
    """The ``wdim`` argument of the compiled code for a window of ``nr`` rows.

    Seven zeros for the 7-row windows (the ``paper`` preset's 7 x 7 box and ``hr``'s
    7-tap Gaussian), else empty: as :func:`elimination` does for K, a branch on
    ``len(wdim) == 7`` is decided when numba compiles, so a 7-row window compiles the
    7-row sums alone and any other size the code for every size (one compilation
    for all of them).

    Examples
    --------
    >>> len(window_rows(7)), window_rows(5)
    (7, ())
    """
    return (0,) * 7 if nr == 7 else ()


#: The package's folders whose sources key the cache: the root modules and the core's stage folders
#: (the clients, which compiled code never imports, are left out).
CORE_FOLDERS = ("", "image", "measure", "select", "gpu", "formats")
_PACKAGE = Path(__file__).resolve().parent


@functools.cache
def sources_key() -> str:
    """A hash of the package version and of every ``.py`` file of the core (:data:`CORE_FOLDERS`).

    Computed once per process (about 50 files).

    Examples
    --------
    >>> len(sources_key())
    64
    """
    from ._version import __version__

    h = hashlib.sha256(__version__.encode())
    for folder in CORE_FOLDERS:
        _hash_sources(h, _PACKAGE / folder, f"{folder}/")
    return h.hexdigest()


def _hash_sources(h, folder: Path, prefix: str) -> None:
    """Feed ``h`` each ``.py`` file of ``folder``, sorted: its name after ``prefix``, then its bytes."""
    for f in sorted(folder.glob("*.py")):
        h.update(f"{prefix}{f.name}".encode())
        h.update(f.read_bytes())


@functools.cache
def folder_key(folder: str) -> str:
    """A hash of the ``.py`` files of one folder (the module docstring), computed once per process.

    Examples
    --------
    >>> len(folder_key(str(_PACKAGE / "calib" / "targets" / "chessboard")))
    64
    """
    h = hashlib.sha256()
    _hash_sources(h, Path(folder), "")
    return h.hexdigest()


class _CoreKeyed:
    """Mix-in for a numba cache locator: this package's files only, stamped with :func:`sources_key` and the
    :func:`folder_key` of the function's folder."""

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            Path(py_file).resolve().relative_to(_PACKAGE)
        except (ValueError, OSError):
            return None  # another package's function: numba's own locators take it
        return super().from_function(py_func, py_file)

    def get_source_stamp(self):
        return super().get_source_stamp(), sources_key(), folder_key(str(Path(self._py_file).parent))


def _key_the_cache() -> None:
    """Put :class:`_CoreKeyed` copies of numba's cache locators in front of them (once)."""
    try:
        from numba.core import caching

        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
        classes = list(impl._locator_classes)
    except (ImportError, AttributeError):  # another numba: its own stamps only (module docstring)
        return
    if any(issubclass(c, _CoreKeyed) for c in classes):
        return
    keyed = [type(f"CoreKeyed{c.__name__}", (_CoreKeyed, c), {}) for c in classes]
    impl._locator_classes = keyed + classes


_key_the_cache()
