"""Which cameras share frames: the pairs' counts, the groups, the rig fit's refusal of a rig in pieces and the
connectivity its result carries."""

from __future__ import annotations

import numpy as np
import pytest

from sogdd.calib.rig import calibrate_rig
from sogdd.calib.rig.connectivity import Connectivity, rig_connectivity
from sogdd.calib.rig.demo import synthetic_rig


def test_pairs_count_the_frames_and_corners_both_cameras_saw():
    d = synthetic_rig(cameras=3, frames=16, noise=0.05, seed=1, baseline=3.0, missing=0.25, partial=True)
    con = rig_connectivity(d.boards)
    n = np.array([[0 if b is None else len(b) for b in d.boards[c]] for c in d.names])
    assert con.names == d.names and con.connected and con.components == (d.names,)
    for i, a in enumerate(d.names):
        assert con.frames[i, i] == (n[i] > 0).sum() and con.corners[i, i] == n[i].sum()
        for j, b in enumerate(d.names):
            both = (n[i] > 0) & (n[j] > 0)
            assert con.shared(a, b) == (both.sum(), np.minimum(n[i], n[j])[both].sum())
            assert con.frames[i, j] == con.frames[j, i]
    # partial boards make the two views of a frame differ: the pair counts the sparser one
    assert any(len(set(n[:, f][n[:, f] > 0])) > 1 for f in range(16))
    assert set(con.pairs) == {(a, b) for i, a in enumerate(d.names) for b in d.names[i + 1:]
                              if con.shared(a, b)[0] > 0}


def test_a_chain_is_connected_and_a_gap_splits_it_into_named_groups():
    # a-b share frame 0, b-c frame 1: a and c never meet, yet all three are tied
    chain = Connectivity.from_counts(["a", "b", "c"], np.array([[10, 0], [10, 12], [0, 12]]))
    assert chain.connected and chain.shared("a", "c") == (0, 0) and chain.problem() == ""
    # four cameras in three groups, the reference's first, each in the order of the names
    counts = np.array([[0, 5, 0], [9, 0, 0], [0, 6, 0], [0, 0, 7]])
    split = Connectivity.from_counts(["w", "x", "y", "z"], counts)
    assert not split.connected and split.components == (("w", "y"), ("x",), ("z",))
    assert split.problem() == ("cameras are not connected: {w, y}, {x} and {z}: no frame shows the board to "
                               "cameras of two of these groups")
    assert split.pairs == {("w", "y"): (1, 5)}


def test_the_rig_fit_refuses_cameras_in_groups_no_frame_ties():
    d = synthetic_rig(cameras=3, frames=12, noise=0.05, seed=1, baseline=3.0)
    boards = {n: list(b) for n, b in d.boards.items()}
    # cam2 keeps only the frames neither cam0 nor cam1 saw, and they lose those
    shared = [f for f in range(12) if boards["cam2"][f] is not None and
              (boards["cam0"][f] is not None or boards["cam1"][f] is not None)]
    assert shared
    for f in range(12):
        if f in shared:
            boards["cam2"][f] = None
        elif boards["cam2"][f] is not None:
            boards["cam0"][f] = boards["cam1"][f] = None
    with pytest.raises(ValueError) as err:
        calibrate_rig(boards, d.image_sizes, min_views=1)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg == "cameras are not connected: {cam0, cam1} and {cam2}: no frame shows the board to both groups"
    assert rig_connectivity(boards).problem() == msg


def test_the_result_carries_the_connectivity_of_the_views_it_used():
    d = synthetic_rig(cameras=3, frames=16, noise=0.05, seed=1, baseline=3.0, missing=0.25)
    rig = calibrate_rig(d.boards, d.image_sizes)
    con = rig.connectivity
    assert isinstance(con, Connectivity) and con.names == rig.names and con.connected
    used = np.array([[int(np.sum(u)) if v else 0 for u, v in zip(cam.calibration.corner_used,
                                                                   cam.calibration.view_used)]
                     for cam in rig.cameras])
    for i in range(3):
        for j in range(3):
            both = (used[i] > 0) & (used[j] > 0)
            assert con.frames[i, j] == both.sum()
            assert con.corners[i, j] == np.minimum(used[i], used[j])[both].sum()
    # every view used: the fit's pairs are the boards' pairs
    assert all(cam.calibration.n_used == sum(b is not None for b in d.boards[cam.name]) for cam in rig.cameras)
    boards = rig_connectivity(d.boards)
    assert {p: v[0] for p, v in con.pairs.items()} == {p: v[0] for p, v in boards.pairs.items()}


def test_boards_of_different_lengths_are_refused():
    d = synthetic_rig(cameras=2, frames=6, seed=0)
    with pytest.raises(ValueError, match="one entry"):
        rig_connectivity({"cam0": d.boards["cam0"], "cam1": d.boards["cam1"][:3]})
