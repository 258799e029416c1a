"""A result over COLMAP seeds reports medians, not means: one unlucky seed must not move it.

With two seeds a median and a mean are equal, so these runs have three and
four seeds whose values are skewed, and the pose errors of a run that did not
align are left out.
"""

import numpy as np
import pytest

from sogdd.evaluation.sfm.seeds import SUMMARISED, seed_summary, seed_values


def _run(registered, points, track, reproj, rot=None, pos=None):
    pe = {"aligned": rot is not None, "rotation_deg_median": rot, "position_median": pos}
    return {"registered": registered, "points": points, "track_length": track, "reproj_error": reproj,
            "pose_errors": pe}


RUNS = {
    3: [_run(8, 1000, 3.0, 0.5, 0.1, 0.01), _run(8, 1100, 3.2, 0.6, 0.2, 0.02),
        _run(6, 9000, 9.0, 2.0, 5.0, 0.90)],
    4: [_run(8, 1000, 3.0, 0.5, 0.1, 0.01), _run(7, 1100, 3.2, 0.6, 0.2, 0.02),
        _run(8, 1300, 3.4, 0.7, 0.3, 0.03), _run(3, 9000, 9.0, 2.0, None, None)],
}


@pytest.mark.parametrize("n", sorted(RUNS))
def test_seed_values_are_medians_and_the_smallest_registered(n):
    runs = RUNS[n]
    v = seed_values(runs)
    assert v["registered"] == min(r["registered"] for r in runs)
    for key in ("points", "track_length", "reproj_error"):
        vals = [r[key] for r in runs]
        assert v[key] == pytest.approx(float(np.median(vals)))
        assert v[key] != pytest.approx(float(np.mean(vals)))  # the runs tell a median from a mean
    aligned = [r["pose_errors"] for r in runs if r["pose_errors"]["aligned"]]
    for key in ("rotation_deg_median", "position_median"):
        assert v[key] == pytest.approx(float(np.median([pe[key] for pe in aligned])))


def test_the_summary_holds_median_min_max_and_values():
    s = seed_summary(RUNS[4])
    assert set(s) == set(SUMMARISED)
    assert s["points"] == {"median": 1200.0, "min": 1000.0, "max": 9000.0,
                           "values": [1000.0, 1100.0, 1300.0, 9000.0]}
    assert s["rotation_deg_median"]["median"] == pytest.approx(0.2)  # the unaligned run left out
    assert s["rotation_deg_median"]["values"] == pytest.approx([0.1, 0.2, 0.3])
    assert seed_values(RUNS[3])["points"] == 1100.0 and seed_values(RUNS[4])["position_median"] == 0.02
