"""The grey image's way through detection stays in its stage folders in order: image -> measure -> select.

The calls are recorded with a profiler (``sys.setprofile``, and ``threading.setprofile`` for the
tiles' threads) while :func:`sogdd.detect_corners` runs on a small colour image, for each preset and
for the band-streaming (absolute, relative, quantile) and full-map paths. The rule, precisely:

- **Stages.** A function belongs to the stage of its folder: ``sogdd/image`` (0), ``sogdd/measure``
  (1), ``sogdd/select`` (2). ``sogdd.detector`` is the orchestrator: it belongs to no stage and may
  call any, but the stages it hands the image to come in order (rule 3). Every other frame (numpy,
  OpenCV, ``sogdd.params``, ``sogdd.corners``, ``sogdd._jit``...) is transparent: a call's *caller*
  is the nearest enclosing frame of a stage or of the orchestrator.
- **The grey image's way.** Only calls that carry the image count: an argument that is the
  image stage's lazy grey image (:class:`sogdd.image.rows.GreyRows`) or an array of at least two
  dimensions whose columns (the last axis, or the one before a colour image's channels) are at
  least the image's width (the image, a crop or band of it, a map of the measure, the filter
  planes). The image's width (331) is larger than every other array the stages handle (the
  64 x 64 calibration images of the grey-level units, 3 x 3 patches, points).
- **Streams.** A stage hands data forward as a stream: a generator that a later stage pulls (the
  measure's bands, :func:`sogdd.measure.bands.measure_bands`; the pyramid's levels). The start or
  resumption of a generator is a *pull*, not a call into its stage: the data moves forward.
- **Reading the grey image.** :class:`~sogdd.image.rows.GreyRows` is the grey image the image stage
  made, converted lazily where it is read; reading it (its methods and ``measure_rows``, in
  ``sogdd/image/rows.py``) is reading that array, as indexing an ndarray is (which is no call).

Then (1) no call carrying the image goes from a stage back to an earlier stage (a stage, once it
handed the image on, is never re-entered from a later one); (2) every pull goes to a stream of the
same or an earlier stage (data never flows back); (3) the stages the orchestrator hands the image
to come in the order image, then select (the selection stage's entry point pulls the measure), and
all three stages see the image.
"""

from __future__ import annotations

import functools
import inspect
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import sogdd
from sogdd.image.rows import GreyRows
from sogdd.synthetic import pattern_image

PKG = Path(sogdd.__file__).resolve().parent
RANK = {"image": 0, "measure": 1, "select": 2}
READS = str(PKG / "image" / "rows.py")
WIDTH = 331


@functools.cache
def _stage_of(filename: str) -> str | None:
    try:
        rel = Path(filename).resolve().relative_to(PKG)
    except (ValueError, OSError):
        return None
    if rel.parts[0] in RANK:
        return rel.parts[0]
    return "detector" if rel.as_posix() == "detector.py" else None


def _stage(code) -> str | None:
    """``"image"``, ``"measure"``, ``"select"``, ``"detector"`` (the orchestrator) or None."""
    return _stage_of(code.co_filename)


def _carries(frame) -> bool:
    code = frame.f_code
    n = code.co_argcount + code.co_kwonlyargcount + bool(code.co_flags & inspect.CO_VARARGS)
    values = [frame.f_locals.get(name) for name in code.co_varnames[:n]]
    for v in values:
        for x in v if isinstance(v, tuple) else (v,):
            if isinstance(x, GreyRows):
                return True
            if isinstance(x, np.ndarray) and x.ndim >= 2:  # columns last; a colour image's before its channels
                if x.shape[-1] >= WIDTH or (x.ndim == 3 and x.shape[-1] <= 4 and x.shape[1] >= WIDTH):
                    return True
    return False


class Trace:
    """Calls into the stages, as (caller stage, callee stage, pull?, function)."""

    def __init__(self) -> None:
        self.calls: list[tuple[str | None, str, bool, str]] = []
        self.visited: set[str] = set()

    def __call__(self, frame, event, arg):
        if event != "call":
            return
        stage = _stage(frame.f_code)
        if stage is None or stage == "detector":
            return
        pull = bool(frame.f_code.co_flags & (inspect.CO_GENERATOR | inspect.CO_ASYNC_GENERATOR))
        if frame.f_code.co_filename == READS or not (pull or _carries(frame)):
            return
        self.visited.add(stage)
        caller = frame.f_back
        while caller is not None and _stage(caller.f_code) is None:
            caller = caller.f_back
        self.calls.append((None if caller is None else _stage(caller.f_code), stage, pull,
                           f"{frame.f_code.co_filename.rsplit('sogdd', 1)[-1]}:{frame.f_code.co_name}"))


def _record(image, **kw) -> Trace:
    trace = Trace()
    threading.setprofile(trace)
    sys.setprofile(trace)
    try:
        sogdd.detect_corners(image, **kw)
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    return trace


@pytest.fixture(scope="module")
def colour():
    img, _ = pattern_image((150, WIDTH), seed=5)
    col = np.stack([img, 0.6 * img + 50, 255 - img], axis=2)
    col = col + np.random.default_rng(5).normal(0, 3, col.shape)
    return np.clip(col, 0, 255).astype(np.uint8)


PATHS = {
    "paper": {"preset": "paper"},  # absolute threshold: bands pruned below it, gradient refinement
    "authors": {"preset": "authors"},  # quantile, the authors' raw det and trace in bands
    "hr": {"preset": "hr"},  # grey-level threshold, X-junctions from the measure's planes, adaptive
    "relative": {"preset": "paper", "threshold": None, "threshold_rel": 0.01},  # bands, relative threshold
    "full map": {"preset": "paper", "threshold": None, "threshold_rel": 0.01},  # forced below: the full map
    "hr full map": {"preset": "hr"},
    "pyramid": {"preset": "paper", "levels": 2},
}


@pytest.mark.parametrize("name", list(PATHS))
def test_the_image_never_goes_back_to_a_stage_it_left(colour, monkeypatch, name):
    from sogdd.select import stage

    monkeypatch.setenv("SOGDD_NUM_THREADS", "2")
    seen = []
    real = stage.stream_peaks
    if name in ("full map", "hr full map"):  # thresholds are >= 0: the stream is told it cannot tell
        monkeypatch.setattr(stage, "stream_peaks", lambda *a, **k: seen.append(None))
    else:
        monkeypatch.setattr(stage, "stream_peaks", lambda *a, **k: seen.append(real(*a, **k)) or seen[-1])
    sogdd.detect_corners(colour, **PATHS[name])  # compiled before the trace (numba's compiler is Python)
    seen.clear()
    trace = _record(colour, **PATHS[name])
    assert (seen[0] is None) == name.endswith("full map")
    back = [c for c in trace.calls if not c[2] and c[0] in RANK and RANK[c[0]] > RANK[c[1]]]
    assert back == [], f"calls back up the stage order: {sorted(set(back))}"
    pulls_back = [c for c in trace.calls if c[2] and c[0] in RANK and RANK[c[0]] < RANK[c[1]]]
    assert pulls_back == [], f"streams pulled by an earlier stage: {sorted(set(pulls_back))}"
    handed = [c[1] for c in trace.calls if c[0] == "detector" and not c[2]]
    assert handed and handed == sorted(handed, key=RANK.get), f"the orchestrator's order: {handed}"
    assert trace.visited == set(RANK)


def test_the_rule_sees_a_call_back_up(colour, monkeypatch):
    """The check can fail: selection that measured the image itself would be a call back to the measure."""
    from sogdd.measure.soddc import soddc_measure
    from sogdd.select import stage

    real = stage.stream_peaks

    def measuring(grey, spec, **kw):
        soddc_measure(np.asarray(grey), spec)  # what the selection stage did before it read a stream
        return real(grey, spec, **kw)

    monkeypatch.setattr(stage, "stream_peaks", measuring)
    trace = _record(colour, preset="paper")
    assert ("select", "measure", False, "/measure/soddc.py:soddc_measure") in trace.calls
