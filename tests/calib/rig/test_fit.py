"""calibrate_rig() on boards projected through known rigs: recovery, shared and partial boards, labels that
differ between cameras, rejection, errors, speed."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.rig import calibrate_rig
from sogdd.calib.rig.demo import synthetic_rig
from sogdd.calib.rig.labels import ambiguity, consensus, relabel
from sogdd.calib.targets.board import Board


def _errors(rig, d):
    """Per camera: max |T - T_true| (squares), rotation error (degrees), fx error (px)."""
    out = []
    for c, cam in enumerate(rig.cameras):
        dR = cam.R @ d.R[c].T
        ang = float(np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1))))
        out.append((float(np.abs(cam.T - d.T[c]).max()), ang, float(abs(cam.K[0, 0] - d.K[c][0, 0]))))
    return out


def _intrinsics_off(rig, d, z=4.0):
    """Per camera, the intrinsics (fx, fy, cx, cy, each distortion coefficient) further than ``z`` of their
    predicted standard deviations from the truth: name -> (fitted, true, std)."""
    out = {}
    for c, cam in enumerate(rig.cameras):
        cal = cam.calibration
        names = ["fx", "fy", "cx", "cy", *cal.coefficients()]
        fitted = [cam.K[0, 0], cam.K[1, 1], cam.K[0, 2], cam.K[1, 2], *cam.dist]
        true = [d.K[c][0, 0], d.K[c][1, 1], d.K[c][0, 2], d.K[c][1, 2], *d.dist[c]]
        assert len(fitted) == len(true) == len(names)
        for n, f, t in zip(names, fitted, true):
            assert cam.std[n] > 0, (cam.name, n)
            if not abs(f - t) <= z * cam.std[n]:
                out[f"{cam.name}.{n}"] = (float(f), float(t), cam.std[n])
    return out


def test_a_two_camera_rig_is_recovered():
    d = synthetic_rig(cameras=2, frames=12, noise=0.05, seed=0)
    rig = calibrate_rig(d.boards, d.image_sizes, view_names={"cam1": [f"r{f}.png" for f in range(12)]})
    for dt, ang, dfx in _errors(rig, d):
        assert dt < 0.03 and ang < 0.05 and dfx < 1.5
    assert _intrinsics_off(rig, d) == {}
    assert rig.rms < 0.1 and rig.sigma == pytest.approx(0.05, rel=0.2)
    cam = rig.camera("cam1")
    assert cam.calibration.names[3] == "r3.png" and rig.camera("cam0").calibration.names[3] == "3"
    assert np.allclose(rig.cameras[0].R, np.eye(3)) and rig.cameras[0].std["baseline"] == 0
    assert 0 < cam.std["baseline"] < 0.02 and 0 < cam.std["rotation_deg"] < 0.2 and 0 < cam.std["fx"] < 1
    assert len(cam.std["T"]) == 3 and cam.calibration.std["fx"] == cam.std["fx"]
    # the board's pose in a camera is the frame's pose carried by the camera's pose
    f = int(np.flatnonzero(cam.calibration.view_used)[0])
    R_f = d.R[1] @ _rot(d.rvecs[f])
    assert np.allclose(_rot(cam.calibration.rvecs[f]), R_f, atol=1e-3)
    assert cam.calibration.cross_validation is None and rig.covariance.shape[0] == rig.covariance.shape[1]
    assert rig.layout["cam1.pose"].stop - rig.layout["cam1.pose"].start == 6 and "cam0.pose" not in rig.layout


def test_the_rms_is_over_corners_not_coordinates():
    """Corner noise of 0.05 px per coordinate: a corner's residual has an RMS length of sqrt(2) 0.05 px; the
    rig's RMS and each camera's are the root mean squared residual length of their used corners."""
    noise = 0.05
    d = synthetic_rig(cameras=2, frames=12, noise=noise, seed=5)
    rig = calibrate_rig(d.boards, d.image_sizes)
    per_camera = []
    for cam in rig.cameras:
        cal = cam.calibration
        r2 = np.concatenate([np.sum(cal.residuals[v][cal.corner_used[v]] ** 2, axis=1)
                             for v in np.flatnonzero(cal.view_used)])
        assert cal.rms == pytest.approx(np.sqrt(np.mean(r2)), rel=1e-9)
        per_camera.append(r2)
    assert rig.rms == pytest.approx(np.sqrt(np.mean(np.concatenate(per_camera))), rel=1e-9)
    # and of the size the noise gives a corner (a per-coordinate RMS would be near 0.05)
    for rms in (rig.rms, *(cam.calibration.rms for cam in rig.cameras)):
        assert np.sqrt(2) * noise * 0.85 < rms < np.sqrt(2) * noise * 1.1


def _rot(rv):
    import cv2

    return cv2.Rodrigues(np.asarray(rv, float))[0]


def test_three_cameras_with_boards_seen_by_only_some():
    d = synthetic_rig(cameras=3, frames=16, noise=0.05, seed=1, baseline=3.0, missing=0.25)
    rig = calibrate_rig(d.boards, d.image_sizes)
    for dt, ang, dfx in _errors(rig, d):
        assert dt < 0.05 and ang < 0.1 and dfx < 3
    assert _intrinsics_off(rig, d) == {}
    seen = np.array([[b is not None for b in d.boards[n]] for n in d.names])
    assert (seen.sum(axis=0) < 3).any()  # some frames lack a camera ...
    single = np.flatnonzero(seen.sum(axis=0) == 1)
    assert rig.frame_used[single].all()  # ... and a frame one camera saw still counts


def test_partial_boards_with_relative_labels_are_placed_and_used():
    d = synthetic_rig(cameras=2, frames=14, noise=0.05, seed=2, partial=True, relabel=True, spread=1.8)
    rig = calibrate_rig(d.boards, d.image_sizes, pattern=(9, 6))
    for dt, ang, _ in _errors(rig, d):
        assert dt < 0.05 and ang < 0.15
    parts = [(b, u) for cam in rig.cameras for b, u in zip(cam.calibration.boards, cam.calibration.view_used)
             if b is not None and b.size is None]
    assert len(parts) >= 5 and all(u for _, u in parts)
    assert any("relabelled" in n for n in rig.notes)


def test_a_half_turn_symmetric_board_is_relabelled_across_cameras():
    # 9 x 7: cols + rows even, each camera's (0, 0) at a random end of the board
    d = synthetic_rig(cameras=2, frames=12, noise=0.05, seed=3, pattern=(9, 7), relabel=True)
    assert all(ambiguity(b, (9, 7)) == "half turn" for b in d.boards["cam1"] if b is not None)
    rig = calibrate_rig(d.boards, d.image_sizes, pattern=(9, 7))
    for dt, ang, _ in _errors(rig, d):
        assert dt < 0.03 and ang < 0.05
    assert rig.rms < 0.1 and all(cam.calibration.n_used == sum(b is not None for b in d.boards[cam.name])
                                 for cam in rig.cameras)
    # the same boards taken as absolute labels contradict each other across cameras
    bad = calibrate_rig(d.boards, d.image_sizes, reject=False)
    assert bad.rms > 20 * rig.rms


def test_a_square_board_is_relabelled_by_quarter_turns():
    d = synthetic_rig(cameras=2, frames=12, noise=0.05, seed=8, pattern=(7, 7), relabel=True, baseline=3.0)
    rig = calibrate_rig(d.boards, d.image_sizes, pattern=(7, 7))
    for dt, ang, _ in _errors(rig, d):
        assert dt < 0.03 and ang < 0.15
    assert any("relabelled" in n for n in rig.notes)
    assert rig.rms < 0.1 and all(cam.calibration.n_used == sum(b is not None for b in d.boards[cam.name])
                                 for cam in rig.cameras)


def test_labels_that_no_candidate_explains_drop_the_view_with_a_reason():
    d = synthetic_rig(cameras=2, frames=10, noise=0.05, seed=3, pattern=(9, 7), relabel=True)
    f = next(f for f in range(10) if d.boards["cam0"][f] is not None and d.boards["cam1"][f] is not None)
    g = next(g for g in range(10) if g != f and d.boards["cam1"][g] is not None)
    d.boards["cam1"][f] = d.boards["cam1"][g]  # another frame's image: no turn of it fits this frame
    rig = calibrate_rig(d.boards, d.image_sizes, pattern=(9, 7))
    cal = rig.camera("cam1").calibration
    assert not cal.view_used[f] and "labels ambiguous (half turn)" in cal.reasons[f]


def test_a_gross_outlier_corner_is_rejected():
    d = synthetic_rig(cameras=2, frames=10, noise=0.05, seed=4)
    f = next(f for f in range(10) if d.boards["cam1"][f] is not None)
    b = d.boards["cam1"][f]
    pts = b.image_points.copy()
    pts[7] += [6.0, -5.0]
    d.boards["cam1"][f] = Board(pts, b.labels, size=b.size)
    rig = calibrate_rig(d.boards, d.image_sizes)
    cal = rig.camera("cam1").calibration
    assert cal.view_used[f] and not cal.corner_used[f][7] and cal.corner_used[f].sum() == len(b) - 1
    assert "beyond the limit" in cal.corner_reasons[f][7]
    assert np.hypot(*cal.residuals[f][7]) > 5 and rig.rms < 0.1


def test_a_fisheye_camera_in_the_rig():
    d = synthetic_rig(cameras=2, frames=12, noise=0.05, seed=4, models={"cam1": "fisheye"})
    rig = calibrate_rig(d.boards, d.image_sizes, models={"cam0": "pinhole", "cam1": "fisheye"})
    assert rig.camera("cam1").model == "fisheye" and len(rig.camera("cam1").dist) == 4
    for dt, ang, dfx in _errors(rig, d):
        assert dt < 0.05 and ang < 0.1 and dfx < 2
    assert rig.rms < 0.1


def test_one_camera_is_a_rig_too():
    d = synthetic_rig(cameras=1, frames=8, noise=0.05, seed=5)
    rig = calibrate_rig(d.boards, d.image_sizes)
    assert rig.names == ("cam0",) and abs(rig.cameras[0].K[0, 0] - 600) < 2 and rig.frame_used.all()


@pytest.mark.parametrize(("model", "flags"), [("pinhole", 0), ("rational", cv2.CALIB_RATIONAL_MODEL)])
def test_one_camera_through_the_joint_solver_is_opencvs_calibration(model, flags):
    """A rig of one, fitted by the joint solver, is ``cv2.calibrateCamera`` on the same corners and model."""
    d = synthetic_rig(cameras=1, frames=8, noise=0.05, seed=6)
    rig = calibrate_rig(d.boards, d.image_sizes, models=model, reject=False)
    seen = [b for b in d.boards["cam0"] if b is not None]
    obj = [np.c_[b.labels, np.zeros(len(b))].astype(np.float64) for b in seen]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    rms, K, D, *_ = cv2.calibrateCamera(obj, [b.image_points for b in seen], d.image_sizes["cam0"], None, None,
                                        flags=flags, criteria=crit)
    cam = rig.cameras[0]
    assert abs(cam.K[0, 0] - K[0, 0]) < 1e-6 and abs(cam.K[1, 2] - K[1, 2]) < 1e-6
    assert np.allclose(cam.dist, D.ravel()[:len(cam.dist)], atol=1e-8) and abs(rig.rms - rms) < 1e-9


def _apart():
    """A two-camera rig's boards with no frame seen by both (each of cam1's frames given to one camera alone),
    and the frames cam1 saw."""
    d = synthetic_rig(cameras=2, frames=12, noise=0.05, seed=0)
    seen = [f for f in range(12) if d.boards["cam1"][f] is not None]
    for f in seen[:5]:
        d.boards["cam0"][f] = None
    for f in seen[5:]:
        d.boards["cam1"][f] = None
    return d, seen


def test_a_camera_sharing_no_frame_is_refused_naming_the_groups():
    d, _ = _apart()
    with pytest.raises(ValueError, match=r"^cameras are not connected: \{cam0\} and \{cam1\}: no frame shows"):
        calibrate_rig(d.boards, d.image_sizes, min_views=3)


def test_a_camera_whose_shared_views_are_rejected_has_no_pose():
    """The one frame both cameras saw is one the second camera's own calibration rejects: nothing ties it to
    the first in the joint fit, so it keeps its views in frames of its own."""
    d, seen = _apart()
    f = next(f for f in range(12) if d.boards["cam0"][f] is not None)
    b = d.boards["cam1"][seen[0]]
    noisy = b.image_points + np.random.default_rng(0).normal(0, 6.0, b.image_points.shape)
    d.boards["cam1"][f] = Board(noisy, b.labels, size=b.size)
    rig = calibrate_rig(d.boards, d.image_sizes, min_views=3)
    cam = rig.camera("cam1")
    assert not cam.calibration.view_used[f]
    assert np.isnan(cam.T).all() and np.isnan(cam.std["baseline"]) and abs(cam.K[0, 0] - 625) < 3
    assert any("shares no frame" in n for n in rig.notes)
    # the fit's connectivity: two groups, though the boards tied them
    assert rig.connectivity.components == (("cam0",), ("cam1",)) and rig.connectivity.pairs == {}
    assert any(".frame." in k for k in rig.layout)


def test_bad_input_is_refused_in_one_line():
    d = synthetic_rig(cameras=2, frames=10, seed=0)
    with pytest.raises(ValueError, match="has 5 frames but 'cam0' has 10"):
        calibrate_rig({"cam0": d.boards["cam0"], "cam1": d.boards["cam1"][:5]}, d.image_sizes)
    with pytest.raises(ValueError, match="camera 'cam1': unknown camera model 'pinhol'"):
        calibrate_rig(d.boards, d.image_sizes, models={"cam0": "pinhole", "cam1": "pinhol"})
    with pytest.raises(ValueError, match="no image size for camera"):
        calibrate_rig(d.boards, {"cam0": (640, 480)})
    first = next(b for b in d.boards["cam1"] if b is not None)
    sparse = {"cam0": d.boards["cam0"], "cam1": [first] + [None] * 9}
    with pytest.raises(ValueError, match="camera 'cam1': too few views"):
        calibrate_rig(sparse, d.image_sizes)
    with pytest.raises(ValueError, match="frame names"):
        calibrate_rig(d.boards, d.image_sizes, frames=["a"])
    with pytest.raises(ValueError, match="boards must map"):
        calibrate_rig([], d.image_sizes)
    with pytest.raises(ValueError, match="pattern"):
        calibrate_rig(d.boards, d.image_sizes, pattern=(9,))


@pytest.mark.parametrize("shift", [1, -1, 3])
def test_a_camera_paired_a_few_frames_off_is_refused_with_the_shift(shift):
    """Each frame of cam1 paired with cam0's frame ``shift`` earlier: no pose explains them, and the
    error names the shift under which they agree instead of fitting intrinsics bent to reconcile them."""
    d = synthetic_rig(cameras=2, frames=14, noise=0.05, seed=2, baseline=2.0)  # 11 shared frames
    b1 = list(d.boards["cam1"])
    rolled = {"cam0": d.boards["cam0"], "cam1": b1[-shift:] + b1[:-shift]}  # cam1's frame f at f + shift
    names = {n: [f"{n}_{f:02d}.png" for f in range(14)] for n in rolled}
    with pytest.raises(ValueError, match="the shared frames disagree") as info:
        calibrate_rig(rolled, d.image_sizes, view_names=names)
    first = f"cam0_{max(0, -shift):02d}.png with cam1_{max(0, shift):02d}.png"
    assert f"shifted by {shift:+d} ({first}" in str(info.value)


def test_frames_that_disagree_under_any_shift_are_refused():
    """cam1's frames in a random order: no shift makes them agree, and the error says so."""
    d = synthetic_rig(cameras=2, frames=14, noise=0.05, seed=2, baseline=2.0)  # 11 shared frames
    order = np.random.default_rng(0).permutation(14)
    mixed = {"cam0": d.boards["cam0"], "cam1": [d.boards["cam1"][k] for k in order]}
    with pytest.raises(ValueError, match="no shift of the pairing by up to 3 frames makes them agree"):
        calibrate_rig(mixed, d.image_sizes)


def test_the_consensus_follows_the_majority_of_frames():
    R = _rot([0.0, 0.1, 0.0])
    flip = np.diag([-1.0, -1.0, 1.0])
    good = (R, np.array([-5.0, 0.0, 0.0]))
    cands = [[good, (R @ flip, np.array([-3.0, 2.0, 0.0]))] for _ in range(3)]
    cands.append([(R @ flip, np.array([-3.0, 2.0, 0.0])), good])  # the right one second here
    cands.append([(_rot([0.5, 0, 0]), np.array([4.0, 0, 0]))])  # an outlier frame
    Rc, tc, chosen = consensus(cands, 20.0)
    assert np.allclose(Rc, R) and np.allclose(tc, good[1]) and chosen == [0, 0, 0, 1, -1]
    b = Board(np.zeros((4, 2)), np.array([[0, 0], [1, 0], [0, 1], [1, 1]]), size=(2, 2))
    assert relabel(b, 2, (1, 1)).labels.tolist() == [[1, 1], [0, 1], [1, 0], [0, 0]]


def test_the_joint_fit_of_a_full_session():
    """2 cameras x 20 frames x 54 corners, the per-camera starts included (timed: benchmarks/bench_rig.py)."""
    d = synthetic_rig(cameras=2, frames=20, noise=0.05, seed=7, spread=0.5, baseline=2.0)
    assert all(sum(b is not None and len(b) == 54 for b in d.boards[n]) >= 19 for n in d.names)
    rig = calibrate_rig(d.boards, d.image_sizes)
    assert _errors(rig, d)[1][0] < 0.03


def _jacobian_problem(model: str):
    """A 3-camera fit's corners and parameters near the truth: the reference, a ``model`` camera with a pose,
    and a pinhole camera without one (frames of its own); every corner weighted differently."""
    from types import SimpleNamespace

    import cv2

    from sogdd.calib.cameras import MODELS
    from sogdd.calib.rig import fit

    d = synthetic_rig(cameras=3, frames=6, noise=0.05, seed=0, baseline=3.0, models={"cam1": model})
    rng = np.random.default_rng(1)
    def weighted(b):  # each corner's precision, relative to the typical 0.1 px: weights 1/3 to 2
        return Board(b.image_points, b.labels, size=b.size, precision=rng.uniform(0.05, 0.3, len(b)))

    states = [SimpleNamespace(typical=0.1, boards=[None if b is None else weighted(b) for b in d.boards[n]])
              for n in d.names]
    models, private = ["pinhole", model, "pinhole"], [False, False, True]
    co = fit._gather(states, 1.0, lambda c, f, st: np.arange(len(st.boards[f])), private)
    lay = fit._layout([len(MODELS[m]) for m in models], sorted(set(co.frame.tolist())), private)
    x = np.zeros(lay.size)
    for c, m in enumerate(models):
        dist = np.zeros(len(MODELS[m]))
        dist[:min(len(dist), len(d.dist[c]))] = d.dist[c][:len(dist)]
        if m == "rational":
            dist[5:] = [0.01, -0.003, 0.001]
        x[lay.intr[c]] = np.r_[d.K[c][0, 0], d.K[c][1, 1], d.K[c][0, 2], d.K[c][1, 2], dist]
        if lay.pose[c] is not None:
            x[lay.pose[c]] = np.r_[cv2.Rodrigues(d.R[c])[0].ravel(), d.T[c]]
    F = len(d.rvecs)
    for f, s in lay.frame.items():
        R, t = cv2.Rodrigues(d.rvecs[f % F])[0], d.tvecs[f % F]
        if f >= F:  # the camera without a pose: the board in its own frame
            R, t = d.R[2] @ R, d.R[2] @ t + d.T[2]
        x[s] = np.r_[cv2.Rodrigues(R)[0].ravel(), t]
    return x + rng.normal(0, 1e-3, x.shape) * np.maximum(np.abs(x), 0.01), lay, models, co


@pytest.mark.parametrize("model", ["pinhole4", "pinhole", "rational", "fisheye"])
def test_the_analytic_jacobian_matches_finite_differences(model):
    from scipy.sparse import issparse

    from sogdd.calib.rig import fit

    x, lay, models, co = _jacobian_problem(model)
    assert any(s is None for s in lay.pose[1:]) and any(f >= 6 for f in lay.frame)  # a camera without a pose
    J = fit._jacobian(x, lay, models, co)
    assert issparse(J) and J.format == "csr" and J.shape == (2 * len(co.cam), lay.size)
    Jn = np.zeros(J.shape)
    for j in range(lay.size):  # central differences of the whitened residuals
        h = 1e-6 * max(abs(x[j]), 1.0)
        up, down = x.copy(), x.copy()
        up[j] += h
        down[j] -= h
        Jn[:, j] = (fit._whitened(up, lay, models, co) - fit._whitened(down, lay, models, co)) / (2 * h)
    scale = np.abs(Jn).max(axis=0)
    assert np.all(scale > 0)
    rel = np.abs(J.toarray() - Jn).max(axis=0) / scale
    assert rel.max() < 1e-5, (model, rel.max(), int(rel.argmax()))
    # each residual depends on its camera's intrinsics and pose and its frame's pose only: the pattern holds at
    # most 4 + nd + 12 entries a row
    assert np.diff(J.indptr).max() <= 4 + max(s.stop - s.start for s in lay.intr) + 12


def _bench():
    """benchmarks/bench_rig.py, whose :func:`ring_rig` builds a ring of cameras."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[3] / "benchmarks" / "bench_rig.py"
    spec = importlib.util.spec_from_file_location("bench_rig", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_a_ring_of_cameras_is_recovered():
    """6 cameras around 30 frames of a board (benchmarks/bench_rig.py's ring; 0.1 px noise): each camera
    tied to the first only through its neighbours."""
    bench = _bench()
    d = bench.ring_rig(cameras=6, frames=30, seed=3)
    seen = np.array([[b is not None for b in d.boards[n]] for n in d.names])
    assert not (seen[0] & seen[3]).any()  # the opposite camera shares no frame with the first
    rig = calibrate_rig(d.boards, d.image_sizes)
    assert rig.connectivity.connected and rig.connectivity.shared("cam0", "cam3") == (0, 0)
    assert rig.connectivity.shared("cam0", "cam1")[0] > 0
    for c, cam in enumerate(rig.cameras):
        assert abs(cam.K[0, 0] / d.K[c][0, 0] - 1) < 0.005, cam.name
        if c:
            assert abs(cam.baseline / np.linalg.norm(d.T[c]) - 1) < 0.01, cam.name
    err = bench.truth_errors(rig, d)
    assert err["rotation_deg"] < 0.5 and rig.rms < 0.2
