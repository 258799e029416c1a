"""SfM over several seeds and at an equal budget: summary, pipeline, CLI, table."""

import json

import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.sfm.seeds import seed_summary
from sogdd.report.sfm import sfm_markdown


def test_seed_summary_median_and_spread():
    runs = [{"points": 10, "reproj_error": 0.9, "registered": 4,
             "pose_errors": {"aligned": True, "rotation_deg_median": 0.2, "position_median": 0.01}},
            {"points": 30, "reproj_error": 0.7, "registered": 4,
             "pose_errors": {"aligned": True, "rotation_deg_median": 0.05, "position_median": 0.03}},
            {"points": 12, "reproj_error": None, "registered": 3, "pose_errors": {"aligned": False}}]
    s = seed_summary(runs)
    assert (s["points"]["median"], s["points"]["min"], s["points"]["max"]) == (12.0, 10.0, 30.0)
    assert s["reproj_error"]["median"] == pytest.approx(0.8) and s["reproj_error"]["values"] == [0.9, 0.7]
    rot = s["rotation_deg_median"]
    assert (rot["median"], rot["min"], rot["max"]) == pytest.approx((0.125, 0.05, 0.2))
    assert s["registered"]["min"] == 3.0 and s["track_length"] is None


def test_table_shows_the_spread():
    r = {"registered": 4, "images": 4, "points": 12.0, "track_length": 3.0, "reproj_error": 0.8,
         "features": 100.0, "seconds": 5.0, "dense_points": "not run", "seeds": [0, 1, 2], "budget": 100,
         "rotation_deg_median": 0.125, "position_median": 0.02,
         "spread": seed_summary([{"points": 10, "reproj_error": 0.9}, {"points": 30, "reproj_error": 0.7},
                                 {"points": 12, "reproj_error": 0.8}])
         | {"rotation_deg_median": {"median": 0.125, "min": 0.05, "max": 0.2},
            "position_median": {"median": 0.02, "min": 0.01, "max": 0.03}}}
    md = sfm_markdown({"sift:top_k=100": r}, "x")
    row = next(ln for ln in md.splitlines() if ln.startswith("| `sift:top_k=100` |"))
    assert "| 12 (10–30) |" in row and "| 0.80 (0.70–0.90) |" in row
    assert "| 0.125 (0.050–0.200) | 0.0200 (0.0100–0.0300) |" in row
    assert "Seeds: 0,1,2" in md and "100 strongest points" in md
    plain = {k: v for k, v in r.items() if k not in ("spread", "seeds", "budget")}
    pe = {"rotation_deg_median": 0.1, "position_median": 0.002}
    single = sfm_markdown({"sift": {**plain, "pose_errors": pe}}, "x")
    assert "| 0.125 | 0.0200 |" in single and "Seeds" not in single


def _chair_subset(data_dir, tmp_path, n=4):
    chair = data_dir / "multiview" / "chair"
    if not chair.is_dir():
        pytest.skip("chair image set not available")
    sub = tmp_path / "imgs"
    sub.mkdir()
    for i in range(n):
        (sub / f"image{i:03d}.jpg").write_bytes((chair / f"image{i:03d}.jpg").read_bytes())
    for y in chair.glob("*.yaml"):
        (sub / y.name).write_bytes(y.read_bytes())
    return sub


def test_seeds_share_the_features(data_dir, tmp_path):
    pytest.importorskip("pycolmap")
    from sogdd.evaluation.sfm import run_sfm_seeds
    from sogdd.evaluation.specs import parse_spec

    sub = _chair_subset(data_dir, tmp_path)
    r = run_sfm_seeds(sub, parse_spec("sogdd"), tmp_path / "w", [0, 1], matcher="mnn", num_threads=1)
    assert r["seeds"] == [0, 1] and [x["seed"] for x in r["runs"]] == [0, 1]
    assert r["registered"] == min(x["registered"] for x in r["runs"]) >= 3
    pts = [x["points"] for x in r["runs"]]
    assert r["spread"]["points"]["values"] == [float(p) for p in pts]
    assert r["points"] == float(np.median(pts)) and r["features"] > 50
    assert (tmp_path / "w" / "features.db").is_file()  # detected once, copied per seed
    assert (tmp_path / "w" / "seed0" / "database.db").is_file() and (tmp_path / "w" / "seed1").is_dir()
    with pytest.raises(ValueError):
        run_sfm_seeds(sub, parse_spec("sogdd"), tmp_path / "w2", [1, 1])


def test_cli_sfm_seeds_and_budget(data_dir, tmp_path, capsys):
    pytest.importorskip("pycolmap")
    sub = _chair_subset(data_dir, tmp_path)
    rc = main(["eval", "sfm", "--images", str(sub), "--detectors", "sogdd-hr,sift", "--matcher", "mnn",
               "--seeds", "0,1", "--max-features", "150", "--jobs", "2", "--threads", "1",
               "--out", str(tmp_path / "out"), "--json", "--quiet", "--no-dense"])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    assert list(obj) == ["sogdd-hr:top_k=150", "sift:top_k=150"]
    for r in obj.values():
        assert r["budget"] == 150 and r["features"] <= 150 and r["seeds"] == [0, 1] and len(r["runs"]) == 2
        sp = r["spread"]["reproj_error"]
        assert sp["min"] <= sp["median"] <= sp["max"]
    md = (tmp_path / "out" / "sfm.md").read_text()
    assert "Seeds: 0,1" in md and "–" in md
    assert main(["eval", "sfm", "--images", str(sub), "--seeds", "0,0", "--quiet"]) == 2
    assert "distinct" in capsys.readouterr().err
