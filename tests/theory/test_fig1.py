"""Fig. 1 redone on a real image: ``sogdd theory figures`` with and without the shared data."""

import matplotlib.image as mpimg
import numpy as np

from sogdd.cli.main import main
from sogdd.measure.filters import orientations
from sogdd.theory.fig1 import _load_set, fig1_case, sogdd_abs_responses

FIG1 = {"fig1_detections.png", "fig1_sogdd_theta.png"}


def test_fig1_files_written_from_data(tmp_path, data_dir, capsys):
    out = tmp_path / "figs"
    assert main(["theory", "figures", "--out", str(out), "--no-lattice", "--data", str(data_dir)]) == 0
    names = {p.name for p in out.iterdir()}
    assert FIG1 <= names
    printed = capsys.readouterr().out.split()
    assert {p.rsplit("/", 1)[-1] for p in printed} == names
    for name in FIG1:
        img = mpimg.imread(out / name)
        grey = img[..., :3].mean(axis=2)
        assert img.shape[0] >= 300 and 0.005 < np.mean(grey < 0.9) < 0.9


def test_fig1_skipped_with_a_note_without_data(tmp_path, monkeypatch, capsys):
    empty = tmp_path / "nodata"
    empty.mkdir()
    monkeypatch.setenv("SOGDD_DATA", str(empty))
    monkeypatch.chdir(tmp_path)  # no ../shared/data from here
    out = tmp_path / "figs"
    assert main(["theory", "figures", "--out", str(out), "--no-lattice"]) == 0
    assert not FIG1 & {p.name for p in out.iterdir()}
    assert "Fig. 1 skipped" in capsys.readouterr().err


def test_fig1_bad_data_path_exits_2(tmp_path, capsys):
    assert main(["theory", "figures", "--out", str(tmp_path / "f"), "--data", str(tmp_path / "none")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sogdd: error:") and len(err.strip().splitlines()) == 1


def test_fig1_pair_is_lost_at_the_larger_scale(data_dir):
    """The chosen pair is found at sigma^2 = 2, one corner is lost at sigma^2 = 5, and there the
    edge point out-responds the lost corner at some of the K = 8 orientations (the paper's panel d)."""
    image, truth = _load_set(data_dir / "corners_gt" / "geometric")
    case = fig1_case(image, truth)
    assert case.rule_met
    lost, other = truth[case.pair[0]], truth[case.pair[1]]
    assert np.hypot(*(lost - other)) < 10
    d2 = np.hypot(*(case.detections[2.0] - lost).T).min()
    d5 = np.hypot(*(case.detections[5.0] - lost).T).min()
    assert d2 <= 2.5 < d5
    k = orientations(8)
    corner5 = sogdd_abs_responses(case.grey, lost, 5.0, k)
    edge5 = sogdd_abs_responses(case.grey, case.edge, 5.0, k)
    assert np.sum(edge5 > corner5) >= 3


def test_abs_responses_of_a_straight_edge_vanish_along_it():
    """On a vertical step, the derivative along the edge (theta = pi/2) is ~0 (only the
    sampled kernel's truncation remains) while the one across it (theta = 0) is not."""
    img = np.zeros((41, 41))
    img[:, 21:] = 255.0
    r = sogdd_abs_responses(img, (20, 20), 2.0, np.array([0.0, np.pi / 2]))
    assert r[0] > 10.0 and r[1] < 1e-3 * r[0]
