"""``sogdd theory``: figures and sigma ranges from the command line."""

import json

import matplotlib.image as mpimg
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.theory import sigma_range


def test_figures_are_written_and_not_blank(tmp_path, capsys):
    out = tmp_path / "figs"
    assert main(["theory", "figures", "--out", str(out), "--no-fig1"]) == 0
    names = {"fig3_end.png", "fig5_l.png", "sigma_range.png", "lattice.png"}
    assert {p.name for p in out.iterdir()} == names
    printed = capsys.readouterr().out.split()
    assert len(printed) == 4
    for name in names:
        img = mpimg.imread(out / name)
        assert img.ndim == 3 and img.shape[0] >= 300 and img.shape[1] >= 500
        grey = img[..., :3].mean(axis=2)
        # mostly white background with a fair amount of ink (curves, axes, text)
        assert 0.005 < np.mean(grey < 0.9) < 0.5
        assert np.unique(img[..., :3].reshape(-1, 3), axis=0).shape[0] > 20  # colours, not one flat tone


def test_sigma_range_json(capsys):
    code = main(["theory", "sigma-range", "--model", "end", "--d", "3", "--alpha", "0.3927",
                 "--beta", "1.0472", "--json"])
    assert code == 0
    obj = json.loads(capsys.readouterr().out)
    want = sigma_range("end", d=3.0, alpha=0.3927, beta=1.0472)
    assert obj["intervals"] == [list(iv) for iv in want]
    assert len(obj["crossings"]) == 1 and obj["crossings"][0] == pytest.approx(want[0][1])


def test_sigma_range_text_and_l_model(capsys):
    assert main(["theory", "sigma-range", "--model", "l", "--d", "3", "--alpha", "0.3927"]) == 0
    out = capsys.readouterr().out
    assert "L model" in out and "(0.300000, 6.000000)" in out and "crossing" not in out


@pytest.mark.parametrize("argv", [
    ["theory", "sigma-range", "--model", "end", "--d", "3", "--alpha", "0.4"],  # no beta
    ["theory", "sigma-range", "--model", "l", "--d", "3", "--alpha", "3.0"],  # alpha out of range
    ["theory", "sigma-range", "--model", "l", "--d", "3", "--alpha", "0.4", "--sigma-min", "5",
     "--sigma-max", "1"],
])
def test_sigma_range_user_errors_exit_2(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("sogdd: error:") and len(err.strip().splitlines()) == 1


def test_theory_without_subcommand_prints_help(capsys):
    assert main(["theory"]) == 2
