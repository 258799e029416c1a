"""Ground-truth accuracy: the protocol of the paper's Table 1.

For each detector and GT image, three operating points are reported:

``default``
    The detector as shipped (its default threshold).
``tuned``
    The threshold chosen on that image alone (:mod:`.tuning`): the paper's
    "properly tuned to achieve its best test results". Optimistic.
``joint``
    One threshold per detector, chosen on all images together.

Metrics per point: missed, false, Le (eq. 26), precision, recall, F1, and the
threshold (on the detector's ``response`` scale).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from ...corners import Corners
from ..points import match_points
from ..specs import DetectorSpec, permissive_detections
from .data import GTSet
from .metrics import GTMetrics, gt_metrics
from .tuning import SweepCurve, best_point, joint_tuning, sweep_curve

__all__ = ["GTEntry", "GTReport", "evaluate_gt"]


@dataclass
class GTEntry:
    """One detector on one image."""

    detector: str
    image: str
    default: GTMetrics
    tuned: GTMetrics
    tuned_threshold: float
    joint: GTMetrics | None = None
    curve: SweepCurve | None = None
    permissive: Corners | None = None
    default_corners: Corners | None = None
    sweep_mode: str = "permissive"
    #: fraction of the default run's points that are the permissive run's strongest ones
    #: (1.0 when the response sweep reproduces the default threshold exactly)
    consistency: float = float("nan")

    def corners_at(self, threshold: float) -> Corners:
        """The detections kept at ``threshold`` (``response >= threshold``)."""
        c = self.permissive
        return c.subset(c.response >= threshold)


@dataclass
class GTReport:
    """All entries plus the per-detector joint threshold and pooled metrics."""

    delta: float
    images: list[str]
    n_gt: dict[str, int]
    entries: list[GTEntry] = field(default_factory=list)
    joint_threshold: dict[str, float] = field(default_factory=dict)

    def detectors(self) -> list[str]:
        seen: list[str] = []
        for e in self.entries:
            if e.detector not in seen:
                seen.append(e.detector)
        return seen

    def entry(self, detector: str, image: str) -> GTEntry:
        for e in self.entries:
            if e.detector == detector and e.image == image:
                return e
        raise KeyError((detector, image))

    def pooled(self, detector: str, which: str) -> GTMetrics:
        """Metrics summed over all images (``which``: default, tuned or joint)."""
        ms = [getattr(e, which) for e in self.entries if e.detector == detector]
        out = ms[0]
        for m in ms[1:]:
            out = out + m
        return out

    def rows(self) -> list[dict]:
        """Flat records: one per detector, image (or ``ALL``) and operating point."""
        out = []
        for d in self.detectors():
            for e in [x for x in self.entries if x.detector == d]:
                for which, thr in (("default", math.nan), ("tuned", e.tuned_threshold),
                                   ("joint", self.joint_threshold.get(d, math.nan))):
                    m = getattr(e, which)
                    out.append({"detector": d, "image": e.image, "setting": which,
                                "threshold": thr, **m.as_dict()})
            for which in ("default", "tuned", "joint"):
                thr = self.joint_threshold.get(d, math.nan) if which == "joint" else math.nan
                out.append({"detector": d, "image": "ALL", "setting": which, "threshold": thr,
                            **self.pooled(d, which).as_dict()})
        return out

    def to_json(self) -> dict:
        """Per detector: per image and pooled metrics at each operating point."""
        res = {}
        for d in self.detectors():
            per = {}
            for e in [x for x in self.entries if x.detector == d]:
                per[e.image] = {
                    "default": _clean(e.default.as_dict()),
                    "tuned": {**_clean(e.tuned.as_dict()), "threshold": _num(e.tuned_threshold)},
                    "joint": {**_clean(e.joint.as_dict()),
                              "threshold": _num(self.joint_threshold[d])},
                }
            res[d] = {
                "sweep_consistency": float(np.mean([e.consistency for e in self.entries
                                                    if e.detector == d])),
                "images": per,
                "all": {
                    "default": _clean(self.pooled(d, "default").as_dict()),
                    "tuned": _clean(self.pooled(d, "tuned").as_dict()),
                    "joint": {**_clean(self.pooled(d, "joint").as_dict()),
                              "threshold": _num(self.joint_threshold[d])},
                },
            }
        return {"delta": self.delta, "images": self.images, "n_gt": self.n_gt, "detectors": res}


def _num(v):
    v = float(v)
    return v if math.isfinite(v) else None


def _clean(d: dict) -> dict:
    return {k: (_num(v) if isinstance(v, float) else v) for k, v in d.items()}


def sweep_consistency(default: Corners, permissive: Corners, tol: float = 1e-6) -> float:
    """Fraction of ``default``'s points found among the ``len(default)`` strongest permissive ones.

    1.0 means the default output is exactly one operating point of the response sweep,
    i.e. the detector thresholds after non-maximum suppression (see :mod:`sogdd.evaluation.specs`).
    """
    if len(default) == 0:
        return 1.0
    return len(match_points(default.xy, permissive.xy[: len(default)], tol)) / len(default)


def evaluate_gt(
    sets: list[GTSet],
    specs: list[DetectorSpec],
    *,
    delta: float = 2.0,
    progress: bool = True,
) -> GTReport:
    """Run every detector on every GT set; tune per image and jointly (see module doc)."""
    if delta <= 0:
        raise ValueError(f"delta must be > 0, got {delta}")
    rep = GTReport(delta, [s.name for s in sets], {s.name: len(s.corners) for s in sets})
    jobs = [(spec, s) for spec in specs for s in sets]
    bar = tqdm(jobs, desc="gt", disable=not progress, leave=False)
    for spec, s in bar:
        bar.set_postfix_str(f"{spec.label} on {s.name}")
        default, perm, over = permissive_detections(spec, s.image)
        curve = sweep_curve(s.corners, perm.xy, perm.response, delta)
        b = best_point(curve)
        rep.entries.append(GTEntry(
            spec.label, s.name, gt_metrics(s.corners, default.xy, delta), curve.metrics(b),
            float(curve.threshold[b]), None, curve, perm, default,
            "permissive" if over is not None else "default-only",
            sweep_consistency(default, perm),
        ))
    for spec in specs:
        ents = [e for e in rep.entries if e.detector == spec.label]
        t, idx = joint_tuning([e.curve for e in ents])
        rep.joint_threshold[spec.label] = t
        for e, i in zip(ents, idx):
            e.joint = e.curve.metrics(i)
    return rep


def rank_by(rows: dict[str, GTMetrics]) -> list[str]:
    """Detectors ordered best first: missed + false, then Le (the tuning criterion)."""
    def key(d):
        m = rows[d]
        return (m.missed + m.false, m.le if np.isfinite(m.le) else np.inf)
    return sorted(rows, key=key)
