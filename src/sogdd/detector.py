"""The public detection API: the corner measure map and the corner detector.

The pipeline is image -> measure -> select: an image is validated and brought to
grey on the 0-255 scale (:mod:`sogdd.image`), measured (:mod:`sogdd.measure`), and
the peaks of the measure selected and refined by the selection stage's one entry
point (:func:`sogdd.select.stage.select_corners`), which reads the measure band by
band or whole; :func:`detect_corners` adds the image pyramid (:mod:`sogdd.image.pyramid`).
"""

from __future__ import annotations

import numpy as np

from .corners import Corners
from .image.grey import to_gray255
from .image.pyramid import pyramid_levels
from .image.rows import GreyRows
from .image.validate import check_mask, validate_image
from .measure.soddc import soddc_measure
from .params import PRESET, Params, given, resolve_params
from .select.assemble import merge_levels
from .select.stage import select_corners

__all__ = ["corner_response", "detect_corners"]

def _prepare(image, p: Params, lazy: bool = False) -> np.ndarray | GreyRows:
    """The grey 0-255 image; ``lazy``: converted crop by crop when read (no H x W float64 copy)."""
    img = validate_image(image, value_range=p.value_range)
    gray = dict(weights=p.gray_weights, round_integer=p.gray_round, channel_order=p.channel_order,
                value_range=p.value_range)
    return GreyRows(img, **gray) if lazy else to_gray255(img, **gray)


#: the keywords of the measure, as numpydoc entries (shared by both functions' docstrings)
_MEASURE_DOC = """sigma2 : float
        sigma^2 of the SOGDD kernels psi (eq. 22). paper 1.2, authors 1.44, hr 1.5.
    n_orientations : int
        K, the number of orientations theta_k = (k - 1) pi / K. paper 8, authors 4, hr 4.
    window : int
        Window size (odd): the square's side, the disk's diameter, or 4 sigma_w of
        the Gaussian window. paper 7, authors 5, hr 3.
    window_shape : {"square", "disk", "gaussian"}
        paper "square", authors "disk", hr "gaussian".
    kernel_radius_rule : {"paper", "authors"}
        Kernel support r = ceil(4 sigma) (paper) or max(3, ceil(4 sigma)) (authors).
    zero_mean : bool
        Make each kernel zero-mean (authors True).
    padding : {"response", "image"}
        Reflect the responses at the border (paper) or pad the image by 9 px (authors).
    authors_measure : bool
        The authors' clamp of det and epsilon instead of varsigma (authors True).
    gray_weights : (float, float, float)
        Luma weights of colour input: BT.601 (paper, hr) or MATLAB's rgb2gray (authors).
    gray_round : bool
        Round the grey value of integer colour input to its dtype (MATLAB; authors True).
    channel_order : {"rgb", "bgr"}
        Channel order of colour arrays ("rgb"; :class:`~sogdd.feature2d.SOGDD` uses "bgr").
    value_range : (float, float), optional
        Input values mapped onto 0-255; None: by dtype (:mod:`sogdd.image.grey`)."""

_SELECT_DOC = """threshold : float or None
        Absolute threshold on the response (paper 1e9 on Upsilon; hr 20 grey
        levels); None: no absolute threshold (authors).
    threshold_rel : float, optional
        Keep responses >= this fraction of the largest one.
    quantile : float, optional
        Keep responses >= this quantile of the positive responses (authors 0.99).
    threshold_units : {"measure", "grey"}
        "measure": threshold and response on Upsilon itself (paper, authors);
        "grey": in grey levels of corner contrast (:mod:`sogdd.measure.units`; hr).
    nms_radius : int
        Non-maximum suppression over the (2r + 1)^2 square (1 in every preset).
    max_corners : int, optional
        Keep the strongest this many (None: all).
    subpixel : {"gradient", "quadratic", "none", "adaptive"} or bool
        Sub-pixel refinement (paper "gradient", authors "none", hr "adaptive").
    border : int
        Exclude this many pixels at each edge (authors 9, else 0).
    x_junctions : bool
        Report each X-junction once, on its saddle point (hr True; needs
        threshold_units="grey").
    levels : int
        Levels of the image pyramid (1: none).
    scale_factor : float
        Scale between pyramid levels (2.0)."""


def _documented(func):
    """Fill the shared parameter entries into ``func``'s docstring."""
    func.__doc__ = func.__doc__.replace("{measure}", _MEASURE_DOC).replace("{select}", _SELECT_DOC)
    return func


@_documented
def corner_response(
    image, *, preset: str = "paper", device: str = "cpu",
    sigma2: float = PRESET, n_orientations: int = PRESET, window: int = PRESET, window_shape: str = PRESET,
    kernel_radius_rule: str = PRESET, zero_mean: bool = PRESET, padding: str = PRESET,
    authors_measure: bool = PRESET, gray_weights: tuple[float, float, float] = PRESET,
    gray_round: bool = PRESET, channel_order: str = PRESET, value_range: tuple[float, float] | None = PRESET,
) -> np.ndarray:
    """The corner measure Upsilon (eq. 25) of an image: an H x W float64 map.

    Parameters
    ----------
    image : ndarray
        Grey (H, W) or colour (H, W, 3|4) image; uint8, uint16, float in [0, 1]
        or bool. Converted to grey on the 0-255 scale (see :mod:`sogdd.image.grey`).
    preset : {"paper", "authors", "hr"}
        Starting parameter set; every keyword left at ``PRESET`` takes its value.
    device : {"cpu", "cuda"}
        ``"cuda"`` runs on an NVIDIA GPU (:mod:`sogdd.gpu`); a device input gives a device map.
    {measure}

    Returns
    -------
    ndarray
        Upsilon = det(Lambda) / (tr(Lambda) + varsigma) at every pixel, with
        Lambda the window sum of ``|l| |l|^T`` over the K absolute SOGDD
        responses ``l_k = psi_{sigma, theta_k} * I`` (eqs. 23-25).

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img, _ = pattern_image((120, 160))
    >>> R = corner_response(img)
    >>> R.shape, R.dtype.name
    ((120, 160), 'float64')
    >>> bool(R.max() > 1e9)  # strong corners pass the paper's T_h
    True
    """
    params = given(locals())  # the keywords the caller set; the rest come from the preset
    if (gpu := _gpu(device)) is not None:
        return gpu.corner_response(image, preset=preset, **params)
    p = resolve_params(preset, **params)
    grey = _prepare(image, p, lazy=True)  # a uint8 grey image is measured as it is (no float64 copy)
    return soddc_measure(grey.exact_rows(0, grey.shape[0]), p.measure_spec())


def _gpu(device: str):
    """The GPU module for ``device="cuda"``; ``device="cpu"`` gives None."""
    if device == "cpu":
        return None
    if device != "cuda":
        raise ValueError(f"device must be 'cpu' or 'cuda', got {device!r}")
    # the one lazy import of the core: CPU users never load numba.cuda or need the gpu extra
    from . import gpu

    return gpu


@_documented
def detect_corners(
    image, *, preset: str = "paper", mask=None, device: str = "cpu",
    sigma2: float = PRESET, n_orientations: int = PRESET, window: int = PRESET, window_shape: str = PRESET,
    threshold: float | None = PRESET, threshold_rel: float | None = PRESET, quantile: float | None = PRESET,
    threshold_units: str = PRESET, nms_radius: int = PRESET, max_corners: int | None = PRESET,
    subpixel: str | bool = PRESET, border: int = PRESET, x_junctions: bool = PRESET, levels: int = PRESET,
    scale_factor: float = PRESET, kernel_radius_rule: str = PRESET, zero_mean: bool = PRESET,
    padding: str = PRESET, authors_measure: bool = PRESET, gray_weights: tuple[float, float, float] = PRESET,
    gray_round: bool = PRESET, channel_order: str = PRESET, value_range: tuple[float, float] | None = PRESET,
) -> Corners:
    """Detect corners: local maxima of Upsilon above a threshold.

    Parameters
    ----------
    image : ndarray
        Grey or colour image (see :func:`corner_response`).
    preset : {"paper", "authors", "hr"}
        Starting parameter set; every keyword left at ``PRESET`` takes its value
        (the README's preset table gives them all, with the reason for each).
    mask : ndarray of uint8 or bool, optional
        Same height and width as the image; corners are kept where it is non-zero.
        Mask and ``border`` hold for the final positions: a point that sub-pixel
        refinement or a pyramid level moves outside them is dropped.
    device : {"cpu", "cuda"}
        ``"cuda"`` runs on an NVIDIA GPU (:mod:`sogdd.gpu`, ``pip install 'sogdd[gpu]'``);
        it also takes grey torch/CuPy device arrays.
    {select}
    {measure}

    Returns
    -------
    Corners
        Strongest first. ``xy`` is (x, y) with pixel centres at integers.

    Notes
    -----
    Corners are the local maxima of Upsilon (:func:`corner_response`) within
    ``nms_radius`` above the threshold, refined to sub-pixel positions
    (``subpixel="gradient"``: the least-squares point q with
    ``grad I(p) . (p - q) = 0`` over a window, Foerstner 1987). With
    ``levels > 1`` the image pyramid's corners are mapped back to full
    resolution and ranked together.

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img, truth = pattern_image((240, 320))
    >>> c = detect_corners(img)
    >>> len(c) > 20, c.xy.shape[1]
    (True, 2)
    >>> d = np.hypot(*(c.xy[:, None, :] - truth[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    >>> bool(np.median(d) < 0.5)  # sub-pixel: on the rendered vertices
    True
    """
    params = given(locals())  # the keywords the caller set; the rest come from the preset
    if (gpu := _gpu(device)) is not None:
        return gpu.detect_corners(image, preset=preset, mask=mask, **params)
    p = resolve_params(preset, **params)
    # one level reads the grey image in crops only (the pyramid resizes it whole)
    grey = _prepare(image, p, lazy=p.levels == 1)
    mask = check_mask(mask, grey.shape)
    levels = pyramid_levels(grey, p.levels, p.scale_factor, border=p.border, mask=mask)
    found = [(level, select_corners(level.grey, p, level.mask)) for level in levels]
    return merge_levels(found, p, mask, grey.shape)
