"""Every detector through the SfM pipeline: one run or several seeds each, an equal budget, processes.

:func:`evaluate_sfm` is what ``sogdd eval sfm`` runs: :func:`.pipeline.run_sfm`
per detector, or :func:`.seeds.run_sfm_seeds` with ``seeds``; work folders are
``work_root/<dataset>-<label>``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path

from ..matching.budget import map_specs, with_budget
from ..matching.protocol import safe_label
from ..specs import DetectorSpec
from .pipeline import run_sfm
from .seeds import run_sfm_seeds

__all__ = ["evaluate_sfm"]


def _run_one(spec: DetectorSpec, image_dir, work_root, dataset: str, seeds, options: dict) -> dict:
    work = Path(work_root) / f"{dataset}-{safe_label(spec.label)}"
    if seeds is None:
        return run_sfm(image_dir, spec, work, **options)
    opts = {k: v for k, v in options.items() if k not in ("dense", "seed")}
    return run_sfm_seeds(image_dir, spec, work, seeds, **opts)


def evaluate_sfm(image_dir: str | Path, specs: list[DetectorSpec], work_root: str | Path, *, dataset: str,
                 on_result: Callable[[dict], None] | None = None, seeds: Sequence[int] | None = None,
                 max_features: int | None = None, jobs: int = 1, **options) -> dict[str, dict]:
    """:func:`run_sfm` for every spec (work in ``work_root/<dataset>-<label>``): ``{label: result}``.

    ``seeds``: run each detector once per seed with the same features
    (:func:`sogdd.evaluation.sfm.seeds.run_sfm_seeds`: medians and spread).
    ``max_features``: an equal budget for every detector
    (:func:`sogdd.evaluation.matching.budget.with_budget`; labels gain ``:top_k=N``).
    ``jobs``: detectors in that many worker processes (progress messages then
    come only from the main process). ``on_result`` gets the results so far
    after each detector, so that a caller can keep what is done if a later
    detector fails or is stopped.
    """
    specs = [with_budget(s, max_features) for s in specs]
    out: dict[str, dict] = {}

    def done(spec: DetectorSpec, r: dict) -> None:
        r["dataset"] = dataset
        if max_features is not None:
            r["budget"] = max_features
        out[spec.label] = r
        if on_result is not None:
            on_result({s.label: out[s.label] for s in specs if s.label in out})

    if jobs > 1:
        options = {**options, "progress": None}  # a callback does not cross processes
    fn = partial(_run_one, image_dir=image_dir, work_root=work_root, dataset=dataset, seeds=seeds,
                 options=options)
    map_specs(fn, specs, jobs, on_result=done)
    return {s.label: out[s.label] for s in specs}
