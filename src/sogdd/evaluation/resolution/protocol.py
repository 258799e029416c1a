"""Adjacent-corner resolution: scoring detectors on the rendered pairs of :mod:`.scenes`.

Score
-----
A configuration is *resolved* when both corners are matched (one to one,
nearest first) to detections within ``delta`` (1.5 px) and no other detection
lies between them: within ``delta`` of the segment joining them with its
projection strictly inside the segment. The localisation error is the RMS
distance over the matched corners of resolved configurations.

Two threshold modes:

``default``
    Each detector at its default parameters, as a user would run it.
``oracle``
    The best threshold for each configuration, found on the detector's
    permissive run (:func:`~sogdd.evaluation.specs.permissive_detections`):
    the two corners are taken as the pair of detections (one within ``delta``
    of each corner) whose weaker response is largest, the threshold is that
    weaker response, and the configuration is resolved when no other detection
    at or above it lies between them. This measures what the response itself
    can separate, independently of any threshold; it is the mode of the
    ``sigma^2`` sweep, because the measure's scale changes by orders of
    magnitude with ``sigma^2`` and no fixed threshold is fair across it.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..points import match_points
from ..specs import DetectorSpec, build_detector, detect, permissive_detections
from .scenes import configurations, render_configuration

__all__ = ["RECORDS_FORMAT", "ResolutionReport", "evaluate_resolution", "load_records", "score_configuration",
           "score_oracle", "sigma2_specs"]

#: tag of the per-configuration records file written by :meth:`ResolutionReport.write`
RECORDS_FORMAT = "sogdd-resolution-records/1"
_CFG_KEYS = ("kind", "d", "alpha", "beta", "noise")


def score_configuration(corners: np.ndarray, det_xy: np.ndarray, delta: float = 1.5
                        ) -> tuple[bool, np.ndarray]:
    """``(resolved, matched distances)`` for one configuration (module doc)."""
    det_xy = np.asarray(det_xy, dtype=np.float64).reshape(-1, 2)
    m = match_points(corners, det_xy, delta)
    if len(m) < 2:
        return False, m.dist
    others = np.setdiff1d(np.arange(len(det_xy)), m.ib)
    return not bool(np.any(_between(corners, det_xy[others], delta))), m.dist


def _between(corners: np.ndarray, pts: np.ndarray, delta: float) -> np.ndarray:
    p, q = corners
    seg = q - p
    length2 = float(seg @ seg)
    rel = pts - p
    t = rel @ seg / length2
    perp = np.abs(rel[:, 0] * seg[1] - rel[:, 1] * seg[0]) / math.sqrt(length2)
    return (t > 0) & (t < 1) & (perp <= delta)


def score_oracle(corners: np.ndarray, det_xy: np.ndarray, response: np.ndarray,
                 delta: float = 1.5) -> tuple[bool, np.ndarray]:
    """``(resolved, matched distances)`` at the best threshold for this configuration."""
    xy = np.asarray(det_xy, dtype=np.float64).reshape(-1, 2)
    resp = np.asarray(response, dtype=np.float64).reshape(-1)
    c0 = np.flatnonzero(np.hypot(*(xy - corners[0]).T) <= delta)
    c1 = np.flatnonzero(np.hypot(*(xy - corners[1]).T) <= delta)
    best = None
    for i in c0:
        for j in c1:
            if i != j and (best is None or min(resp[i], resp[j]) > best[0]):
                best = (min(resp[i], resp[j]), i, j)
    if best is None:
        return False, np.zeros(0)
    t, i, j = best
    others = np.setdiff1d(np.flatnonzero(resp >= t), [i, j])
    dist = np.array([np.hypot(*(xy[i] - corners[0])), np.hypot(*(xy[j] - corners[1]))])
    return not bool(np.any(_between(corners, xy[others], delta))), dist


def sigma2_specs(values=None) -> list[DetectorSpec]:
    """sogdd at sigma^2 from 0.8 to 3.0 (step 0.2), all else as the paper preset."""
    vals = values if values is not None else [round(0.8 + 0.2 * i, 1) for i in range(12)]
    return [DetectorSpec("sogdd", {"sigma2": float(v)}) for v in vals]


@dataclass
class ResolutionReport:
    """Per (detector, configuration) outcomes, with curves per ``d``."""

    records: list[dict]
    detectors: list[str]
    delta: float
    quick: bool
    mode: str = "default"
    seconds: float = 0.0
    seed: int = 0
    size: int = 96

    def ds(self) -> list[float]:
        return sorted({r["d"] for r in self.records})

    def rate(self, detector: str, *, kind: str | None = None, noise: float | None = None
             ) -> dict[float, float]:
        """Resolution rate per ``d`` (optionally for one kind / noise level)."""
        acc: dict[float, list[bool]] = defaultdict(list)
        for r in self.records:
            if r["detector"] != detector:
                continue
            if kind is not None and r["kind"] != kind:
                continue
            if noise is not None and r["noise"] != noise:
                continue
            acc[r["d"]].append(r["resolved"])
        return {d: float(np.mean(v)) for d, v in sorted(acc.items())}

    def le(self, detector: str) -> float:
        sq = [x for r in self.records if r["detector"] == detector and r["resolved"]
              for x in r["dist"]]
        return float(np.sqrt(np.mean(np.square(sq)))) if sq else math.nan

    def mean_rate(self, detector: str) -> float:
        return float(np.mean([r["resolved"] for r in self.records if r["detector"] == detector]))

    def min_resolved_d(self, detector: str, level: float = 0.5) -> float:
        """Smallest ``d`` from which the rate stays at or above ``level`` (NaN if never)."""
        rates = self.rate(detector)
        ds = sorted(rates)
        for i, d in enumerate(ds):
            if all(rates[x] >= level for x in ds[i:]):
                return d
        return math.nan

    def summary(self) -> dict:
        """Per detector: the rate per d, the mean rate, Le and d50 (the ``--json`` output)."""
        return {
            d: {"rate": {f"{k:g}": v for k, v in self.rate(d).items()},
                "mean_rate": self.mean_rate(d), "le": _num(self.le(d)),
                "d50": _num(self.min_resolved_d(d))}
            for d in self.detectors
        }

    def write(self, out: str | os.PathLike) -> list[Path]:
        o = Path(out)
        o.mkdir(parents=True, exist_ok=True)
        js = {"delta": self.delta, "quick": self.quick, "mode": self.mode,
              "seconds": self.seconds,
              "detectors": self.summary()}
        stem = "resolution" if self.mode == "default" else f"resolution_{self.mode}"
        (o / f"{stem}.json").write_text(json.dumps(js, indent=1))
        ds = self.ds()
        lines = ["detector," + ",".join(f"d={d:g}" for d in ds) + ",mean,le,d50"]
        for det in self.detectors:
            r = self.rate(det)
            lines.append(det + "," + ",".join(f"{r.get(d, math.nan):.3f}" for d in ds)
                         + f",{self.mean_rate(det):.3f},{self.le(det):.3f},"
                         f"{self.min_resolved_d(det):g}")
        (o / f"{stem}.csv").write_text("\n".join(lines) + "\n")
        (o / f"{stem}_records.json").write_text(json.dumps(self.records_json(), separators=(",", ":")))
        return [o / f"{stem}.json", o / f"{stem}.csv", o / f"{stem}_records.json"]

    def records_json(self) -> dict:
        """Every configuration's outcome, compactly, for :func:`load_records` (cached runs).

        ``configs`` lists ``[kind, d, alpha, beta, noise]`` once; ``outcomes[detector]``
        holds per configuration ``0`` (unresolved) or the two matched distances
        rounded to 1e-5 px (only resolved configurations enter Le).
        """
        keys, outcomes = [], {d: [] for d in self.detectors}
        for r in self.records:  # in configuration order for every detector
            if r["detector"] == self.detectors[0]:
                keys.append([r[c] for c in _CFG_KEYS])
            outcomes[r["detector"]].append([round(float(x), 5) for x in r["dist"]] if r["resolved"] else 0)
        return {"format": RECORDS_FORMAT, "mode": self.mode, "quick": self.quick, "delta": self.delta,
                "seed": self.seed, "size": self.size, "seconds": self.seconds,
                "detectors": self.detectors, "configs": keys, "outcomes": outcomes}

    @classmethod
    def from_records_json(cls, obj: dict) -> ResolutionReport:
        """The report written by :meth:`records_json` (distances as rounded there)."""
        if not isinstance(obj, dict) or obj.get("format") != RECORDS_FORMAT:
            raise ValueError(f"not a {RECORDS_FORMAT} object")
        cfgs = obj["configs"]
        recs = []
        for det in obj["detectors"]:
            outs = obj["outcomes"][det]
            if len(outs) != len(cfgs):
                raise ValueError(f"{det}: {len(outs)} outcomes for {len(cfgs)} configurations")
            for c, o in zip(cfgs, outs):
                recs.append({**dict(zip(_CFG_KEYS, c)), "detector": det, "resolved": o != 0,
                             "dist": list(o) if o != 0 else []})
        return cls(recs, list(obj["detectors"]), obj["delta"], obj["quick"], obj["mode"],
                   obj.get("seconds", 0.0), obj.get("seed", 0), obj.get("size", 96))

    def merged(self, other: ResolutionReport) -> ResolutionReport:
        """This report with ``other``'s detectors added (same grid and settings, checked)."""
        same = ("mode", "quick", "delta", "seed", "size")
        if any(getattr(self, a) != getattr(other, a) for a in same):
            raise ValueError("cannot merge resolution runs with different " + "/".join(same))
        mine = [tuple(r[c] for c in _CFG_KEYS) for r in self.records if r["detector"] == self.detectors[0]]
        theirs = [tuple(r[c] for c in _CFG_KEYS) for r in other.records if r["detector"] == other.detectors[0]]
        if mine != theirs:
            raise ValueError("cannot merge resolution runs over different configurations")
        if set(self.detectors) & set(other.detectors):
            raise ValueError(f"detectors in both runs: {sorted(set(self.detectors) & set(other.detectors))}")
        return ResolutionReport(self.records + other.records, self.detectors + other.detectors, self.delta,
                                self.quick, self.mode, self.seconds + other.seconds, self.seed, self.size)


def load_records(path: str | os.PathLike) -> ResolutionReport:
    """Read a ``*_records.json`` file written by :meth:`ResolutionReport.write`."""
    p = Path(path)
    try:
        obj = json.loads(p.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{p}: cannot read resolution records ({exc})") from exc
    try:
        return ResolutionReport.from_records_json(obj)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{p}: {exc}") from exc


def _num(v: float):
    return v if math.isfinite(v) else None


def evaluate_resolution(
    specs: list[DetectorSpec],
    *,
    quick: bool = False,
    delta: float = 1.5,
    seed: int = 0,
    size: int = 96,
    mode: str = "default",
    progress: bool = True,
) -> ResolutionReport:
    """Render every configuration once and score every detector on it (``mode``: module doc)."""
    if mode not in ("default", "oracle"):
        raise ValueError(f"mode must be 'default' or 'oracle', got {mode!r}")
    cfgs = configurations(quick, seed)
    dets = [build_detector(s) for s in specs] if mode == "default" else [None] * len(specs)
    recs = []
    t0 = time.perf_counter()
    for cfg in tqdm(cfgs, desc="resolution", disable=not progress, leave=False):
        img, corners = render_configuration(cfg, size)
        for s, det in zip(specs, dets):
            if mode == "default":
                ok, dist = score_configuration(corners, detect(s, img, det).xy, delta)
            else:
                _, perm, _ = permissive_detections(s, img)
                ok, dist = score_oracle(corners, perm.xy, perm.response, delta)
            recs.append({"detector": s.label, "kind": cfg.kind, "d": cfg.d, "alpha": cfg.alpha,
                         "beta": cfg.beta, "noise": cfg.noise, "resolved": ok,
                         "dist": [float(x) for x in dist]})
    return ResolutionReport(recs, [s.label for s in specs], delta, quick, mode,
                            time.perf_counter() - t0, seed, size)
