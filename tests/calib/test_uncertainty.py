"""A one-camera calibration's covariance and projection uncertainty: the rig's maths, checked as the rig's is
(tests/calib/rig/test_uncertainty.py): predicted standard deviations against the spread over noise draws."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from sogdd.calib import calibrate
from sogdd.calib.cameras import project
from sogdd.calib.files import calibration_dict
from sogdd.calib.report import write_report
from sogdd.calib.rig import calibrate_rig, projection_uncertainty
from sogdd.calib.rig.demo import synthetic_rig
from sogdd.calib.targets.board import Board
from sogdd.calib.uncertainty import image_uncertainty, pixel_covariance
from sogdd.calib.verdict import verdict


def _noisy(boards: list, rng, noise: float) -> list:
    return [None if b is None else Board(b.image_points + rng.normal(0, noise, b.image_points.shape), b.labels,
                                         size=b.size) for b in boards]


def test_predicted_std_matches_the_spread_over_noise_draws():
    """fx, cx and a far point's projection over 40 sessions of one known camera (the same board poses, the
    corner noise drawn anew): the empirical standard deviation over the mean predicted one within 0.7-1.4,
    and the far point lands where the true camera puts it."""
    d = synthetic_rig(cameras=1, frames=10, noise=0.0, seed=21)
    boards, size = d.boards["cam0"], d.image_sizes["cam0"]
    rng = np.random.default_rng(1)
    ray = np.array([0.3, -0.2, 1.0])  # a far point, fixed in the camera's frame, off the centre
    est, pred = [], []
    for _ in range(40):
        cal = calibrate(_noisy(boards, rng, 0.1), size, reject=False, cross_validate=False)
        q, S = pixel_covariance(ray[None], cal.K, cal.dist, cal.model, cal.covariance)
        est.append([cal.K[0, 0], cal.K[0, 2], *q[0]])
        pred.append([cal.std["fx"], cal.std["cx"], *np.sqrt(np.diag(S[0]))])
    ratio = np.std(np.array(est), axis=0, ddof=1) / np.mean(np.array(pred), axis=0)
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio.round(3)
    truth = project(ray[None], d.K[0], d.dist[0], "pinhole")[0]
    spread = np.mean(np.array(pred)[:, 2:], axis=0)
    assert np.all(np.abs(np.mean(np.array(est)[:, 2:], axis=0) - truth) < 3 * spread / np.sqrt(40))


def test_the_covariance_is_the_one_behind_the_standard_deviations():
    """Its diagonal is the square of ``std``: OpenCV's (pinhole), the Jacobian's (fisheye), the weighted
    refinement's (boards with their precision); and it is the rig of one's, without a second fit."""
    d = synthetic_rig(cameras=1, frames=10, noise=0.1, seed=22)
    boards, size = d.boards["cam0"], d.image_sizes["cam0"]
    cal = calibrate(boards, size, reject=False, cross_validate=False)
    names = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
    assert cal.covariance.shape == (9, 9)
    assert np.allclose(np.sqrt(np.diag(cal.covariance)), [cal.std[n] for n in names], rtol=1e-3)
    rig = calibrate_rig({"cam0": boards}, {"cam0": size}, reject=False)
    sl = rig.layout["cam0.intrinsics"]
    assert np.allclose(cal.covariance, rig.covariance[sl, sl], rtol=0.02, atol=1e-9)
    # the uncertainty over the image is the rig of one's: the same function, the same numbers
    _, mine = image_uncertainty(cal.K, cal.dist, cal.model, size, cal.covariance, grid=(5, 4))
    _, theirs = projection_uncertainty(rig, "cam0", grid=(5, 4))
    assert np.allclose(mine, theirs, rtol=0.02)

    rng = np.random.default_rng(3)
    weighted = [replace(b, precision=rng.uniform(0.05, 0.2, len(b))) for b in boards]
    calw = calibrate(weighted, size, reject=False, cross_validate=False)
    assert np.isfinite(calw.typical_precision)
    assert np.allclose(np.sqrt(np.diag(calw.covariance)), [calw.std[n] for n in names], rtol=1e-3)
    # the weights matter: a different covariance from the unweighted fit's
    assert not np.allclose(calw.covariance, cal.covariance, rtol=0.05)

    f = synthetic_rig(cameras=1, frames=10, noise=0.1, seed=23, models={"cam0": "fisheye"})
    calf = calibrate(f.boards["cam0"], f.image_sizes["cam0"], model="fisheye", reject=False,
                     cross_validate=False)
    fnames = ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4")
    assert np.allclose(np.sqrt(np.diag(calf.covariance)), [calf.std[n] for n in fnames], rtol=1e-3)


def test_the_far_point_uncertainty_in_the_file_and_the_verdict():
    """camera.json's ``projection_uncertainty_px`` and the verdict's line: "warn" beyond 1 px, where boards
    near the centre leave the frame's corners loose, "ok" where they covered it."""
    narrow = synthetic_rig(cameras=1, frames=10, noise=0.05, seed=24, spread=0.1)
    wide = synthetic_rig(cameras=1, frames=14, noise=0.05, seed=24, spread=2.0, partial=True, absolute=True)
    found = {}
    for what, d in (("narrow", narrow), ("wide", wide)):
        cal = calibrate(d.boards["cam0"], d.image_sizes["cam0"], cross_validate=False)
        centre, worst = cal.projection_uncertainty()
        assert 0 < centre < worst
        unc = json.loads(json.dumps(calibration_dict(cal)))["projection_uncertainty_px"]
        assert unc == pytest.approx({"centre": centre, "worst": worst})
        lines = [(level, text) for level, text in verdict(cal) if text.startswith("a far point")]
        assert len(lines) == 1 and f"{worst:.2g} px at worst" in lines[0][1]
        found[what] = (worst, lines[0][0])
    assert found["narrow"][0] > 1 and found["narrow"][1] == "warn"
    assert found["wide"][0] < 1 and found["wide"][1] == "ok"


def test_without_a_covariance_there_is_no_uncertainty():
    d = synthetic_rig(cameras=1, frames=6, noise=0.05, seed=25)
    cal = calibrate(d.boards["cam0"], d.image_sizes["cam0"], cross_validate=False)
    bare = replace(cal, covariance=np.zeros((0, 0)))
    assert np.isnan(bare.projection_uncertainty()).all()
    assert calibration_dict(bare)["projection_uncertainty_px"] == {"centre": None, "worst": None}
    assert not any(text.startswith("a far point") for _, text in verdict(bare))
    # a rig's camera carries none of its own: the rig's verdict gives its line once
    rig = calibrate_rig(d.boards, d.image_sizes)
    assert rig.cameras[0].calibration.covariance.size == 0
    assert not any(text.startswith("a far point") for _, text in verdict(rig.cameras[0].calibration))


def test_the_report_gives_the_verdicts_line(tmp_path):
    d = synthetic_rig(cameras=1, frames=8, noise=0.05, seed=26)
    cal = calibrate(d.boards["cam0"], d.image_sizes["cam0"], cross_validate=False)
    centre, worst = cal.projection_uncertainty()
    text = write_report(cal, tmp_path).read_text()
    assert f"a far point projects to within {centre:.2g} px (1 sigma) at the centre and {worst:.2g} px" in text
