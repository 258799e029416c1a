"""Evaluations of the paper's claims, runnable on any detector of :mod:`sogdd.baselines`.

One package per experiment, each with its data loading, protocol and metrics:

* :mod:`.gt`: ground-truth accuracy, the protocol of Table 1;
* :mod:`.repeatability`: average repeatability under the transforms of Fig. 9;
* :mod:`.resolution`: adjacent-corner resolution on rendered END- and L-type pairs;
* :mod:`.matching`: mean matching accuracy on homography sequences (Fig. 10);
* :mod:`.sfm`: 3D reconstruction with COLMAP (Table 2).

Shared by them: :mod:`.specs` (the one detector spec, ``sogdd`` or
``sogdd:subpixel=false``, its parser, and the permissive run used for
threshold sweeps), :mod:`.points` (one-to-one point matching) and
:mod:`.features` (detect, select and describe, for matching and SfM).
Tables and figures are in :mod:`sogdd.report`.
"""

from .specs import DetectorSpec, parse_spec, parse_specs

__all__ = ["DetectorSpec", "parse_spec", "parse_specs"]
