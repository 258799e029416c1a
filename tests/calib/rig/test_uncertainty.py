"""The rig's uncertainties: predicted standard deviations against the spread over noise draws, and the map
of the projection uncertainty."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.rig import calibrate_rig, projection_uncertainty, ray_uncertainty
from sogdd.calib.rig.demo import synthetic_rig
from sogdd.calib.targets.board import Board
from sogdd.calib.uncertainty import covariance


def _noisy(boards: dict, rng, noise: float) -> dict:
    return {n: [None if b is None else Board(b.image_points + rng.normal(0, noise, b.image_points.shape),
                                             b.labels, size=b.size) for b in bs] for n, bs in boards.items()}


@pytest.mark.slow
def test_predicted_std_matches_the_spread_over_noise_draws():
    """fx, cx, the baseline and a fixed ray's projection over 30 draws of the corner noise: the empirical
    standard deviation over the mean predicted one within 0.7-1.4."""
    d = synthetic_rig(cameras=2, frames=10, noise=0.0, seed=11)
    rng = np.random.default_rng(0)
    ray = np.array([0.25, -0.15, 1.0])  # fixed in the first camera's frame
    est, pred = [], []
    for _ in range(30):
        rig = calibrate_rig(_noisy(d.boards, rng, 0.1), d.image_sizes, reject=False)
        c0, c1 = rig.cameras
        q, cov, _ = ray_uncertainty(rig, "cam1", ray)
        est.append([c0.K[0, 0], c1.K[0, 2], c1.baseline, *q])
        pred.append([c0.std["fx"], c1.std["cx"], c1.std["baseline"], *np.sqrt(np.diag(cov))])
    ratio = np.std(np.array(est), axis=0, ddof=1) / np.mean(np.array(pred), axis=0)
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio.round(3)
    # and the fixed ray lands where the true camera puts it
    R, K, D = d.R[1], d.K[1], d.dist[1]
    truth = project((R @ ray)[None], K, D, "pinhole")[0]
    assert np.linalg.norm(np.mean(np.array(est)[:, 3:], axis=0) - truth) < 0.2


def _corner_over_centre(rig, name):
    px, s = projection_uncertainty(rig, name, grid=(9, 7))
    assert np.all(np.isfinite(s))
    s = s.reshape(7, 9)
    return float(np.mean(s[[0, 0, -1, -1], [0, -1, 0, -1]]) / s[3, 4])


def test_the_uncertainty_grows_where_no_board_reached():
    d = synthetic_rig(cameras=2, frames=10, noise=0.05, seed=12, spread=0.1)  # boards near the centre
    rig = calibrate_rig(d.boards, d.image_sizes)
    # partial boards with absolute labels (as ChArUco gives) into the frame's corners
    wide = synthetic_rig(cameras=2, frames=14, noise=0.05, seed=12, spread=2.0, partial=True, absolute=True)
    rig_wide = calibrate_rig(wide.boards, wide.image_sizes)
    for name in rig.names:
        narrow = _corner_over_centre(rig, name)
        assert narrow > 1.7 and narrow > 1.2 * _corner_over_centre(rig_wide, name), name
    # nearer points of the second camera carry its translation's uncertainty too
    _, far = projection_uncertainty(rig, "cam1", grid=(3, 3))
    _, near = projection_uncertainty(rig, "cam1", grid=(3, 3), distance=5.0)
    assert not np.allclose(far, near)


def test_at_the_principal_point_the_first_camera_moves_with_cx_cy_alone():
    d = synthetic_rig(cameras=1, frames=8, noise=0.05, seed=13)
    rig = calibrate_rig(d.boards, d.image_sizes)
    cam = rig.cameras[0]
    _, s = projection_uncertainty(rig, "cam0", np.array([[cam.K[0, 2], cam.K[1, 2]]]))
    sl = rig.layout["cam0.intrinsics"]
    C = rig.covariance[sl, sl][2:4, 2:4]  # cx, cy
    assert s[0] == pytest.approx(np.sqrt(np.linalg.eigvalsh(C).max()), rel=1e-3)
    q, cov, sigma = ray_uncertainty(rig, "cam0", np.array([0.0, 0.0, 1.0]))
    assert sigma > 0 and np.allclose(q, project(np.array([[0, 0, 1.0]]), cam.K, cam.dist, cam.model)[0])


def test_the_pose_std_is_consistent_with_the_covariance():
    d = synthetic_rig(cameras=2, frames=8, noise=0.05, seed=14)
    rig = calibrate_rig(d.boards, d.image_sizes)
    cam = rig.camera("cam1")
    sl = rig.layout["cam1.pose"]
    C = rig.covariance[sl, sl]
    assert np.allclose(cam.std["T"], np.sqrt(np.diag(C)[3:]))
    g = cam.T / np.linalg.norm(cam.T)
    assert cam.std["baseline"] == pytest.approx(np.sqrt(g @ C[3:, 3:] @ g))
    # a small rotation: the rotation vector's error is nearly the rotation's
    assert cam.std["rotation_deg"] == pytest.approx(np.degrees(np.sqrt(np.trace(C[:3, :3]))), rel=0.05)
    # the fitted rotation is the true one within its predicted uncertainty: its error's angle within four
    # times the RMS angle, each component of the rotation vector within four of its standard deviations
    R_true = d.R[1]
    # a rotation: orthonormal and right-handed (not a reflection, not a scaled or sheared matrix)
    assert np.allclose(cam.R @ cam.R.T, np.eye(3), atol=1e-9) and np.linalg.det(cam.R) == pytest.approx(1.0)
    dR = cam.R @ R_true.T
    angle = np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
    assert angle < 4 * cam.std["rotation_deg"]
    off = cv2.Rodrigues(cam.R)[0].ravel() - cv2.Rodrigues(R_true)[0].ravel()
    assert np.all(np.abs(off) < 4 * np.sqrt(np.diag(C)[:3])), (off, np.sqrt(np.diag(C)[:3]))
    # (the truth's rotation is far beyond that uncertainty: the test can tell a wrong rotation)
    assert np.degrees(np.linalg.norm(cv2.Rodrigues(R_true)[0])) > 20 * cam.std["rotation_deg"]


def test_a_degenerate_fit_has_no_covariance():
    J = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])  # two columns the residuals cannot tell apart
    cov, sigma, note = covariance(J.T @ J, np.array([0.1, 0.2, 0.3]))
    assert cov.size == 0 and "degenerate" in note and sigma > 0
    cov, sigma, note = covariance(np.eye(3), np.array([0.1, 0.2]))
    assert cov.size == 0 and np.isnan(sigma)


def test_a_large_fit_keeps_the_cameras_block_by_the_schur_complement(monkeypatch):
    """Past the size of the full inverse the covariance is the cameras' block alone, eliminated frame by frame:
    the same numbers as the full inverse's block (forced here on a small rig), and the same uncertainties."""
    from sogdd.calib.rig import fit

    d = synthetic_rig(cameras=3, frames=16, noise=0.05, seed=1, baseline=3.0, missing=0.25)
    full = calibrate_rig(d.boards, d.image_sizes)
    monkeypatch.setattr(fit, "_FULL_COVARIANCE_MAX", 0)
    block = calibrate_rig(d.boards, d.image_sizes)
    n = block.covariance.shape[0]
    assert n == max(s.stop for k, s in full.layout.items() if ".frame" not in k and not k.startswith("frame"))
    assert n < full.covariance.shape[0] and not any("frame" in k for k in block.layout)
    assert any("Schur complement" in note for note in block.notes)
    scale = np.sqrt(np.outer(np.diag(full.covariance[:n, :n]), np.diag(full.covariance[:n, :n])))
    assert np.abs(block.covariance - full.covariance[:n, :n]).max() / scale.max() < 1e-6
    assert block.sigma == pytest.approx(full.sigma, rel=1e-9)
    for a, b in zip(full.cameras, block.cameras):
        for k in ("fx", "cx", "k1", "baseline", "rotation_deg"):
            assert b.std[k] == pytest.approx(a.std[k], rel=1e-5, abs=1e-12), (a.name, k)
    _, s_full = projection_uncertainty(full, "cam2", grid=(3, 3))
    _, s_block = projection_uncertainty(block, "cam2", grid=(3, 3))
    assert np.allclose(s_block, s_full, rtol=1e-5)
