"""Fair protocols: an equal feature budget, detectors in processes, matching at the budget."""

import json
from operator import attrgetter

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.matching import load_sequences
from sogdd.evaluation.matching.budget import budget_of, map_specs, with_budget
from sogdd.evaluation.matching.protocol import evaluate_specs
from sogdd.evaluation.specs import parse_spec
from sogdd.synthetic import pattern_image

H = np.array([[0.95, -0.12, 30.0], [0.10, 0.97, 12.0], [1.0e-4, -5.0e-5, 1.0]])


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    """One viewpoint sequence (a textured rendering and its warps), HPatches layout."""
    r = tmp_path_factory.mktemp("hp")
    img, _ = pattern_image((300, 360), seed=11)
    tex = cv2.GaussianBlur(np.random.default_rng(0).normal(0, 1, img.shape), (0, 0), 6)
    img = cv2.cvtColor(np.clip(img + 25 * tex / tex.std(), 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
    d = r / "v_synth"
    d.mkdir()
    cv2.imwrite(str(d / "1.ppm"), img)
    warped = cv2.warpPerspective(img, H, (img.shape[1], img.shape[0]))
    for k in range(2, 7):
        cv2.imwrite(str(d / f"{k}.ppm"), warped)
        np.savetxt(d / f"H_1_{k}", H)
    return r


def test_with_budget_caps_and_keeps_tighter():
    s = with_budget(parse_spec("sogdd-hr:sigma2=2.0"), 300)
    assert (s.top_k, s.params, s.label) == (300, {"sigma2": 2.0}, "sogdd-hr:sigma2=2.0:top_k=300")
    assert with_budget(parse_spec("orb:top_k=100"), 300).top_k == 100
    assert with_budget(parse_spec("sift:remove_border=5"), 10).remove_border == 5
    assert with_budget(parse_spec("sift"), None).label == "sift"
    assert budget_of(s.to_json()) == 300
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError):
            with_budget(parse_spec("sift"), bad)


def test_map_specs_in_processes_keeps_order():
    specs = [parse_spec(t) for t in ("sift", "orb", "harris", "fast")]
    seen = []
    assert map_specs(attrgetter("name"), specs, jobs=2, on_result=lambda s, r: seen.append(r)) == [
        "sift", "orb", "harris", "fast"]
    assert sorted(seen) == ["fast", "harris", "orb", "sift"]
    with pytest.raises(ValueError):
        map_specs(attrgetter("name"), specs, jobs=0)


def test_matching_at_an_equal_budget(root):
    seqs = load_sequences(root)
    specs = [parse_spec("sogdd-hr"), parse_spec("shi-tomasi")]
    free = evaluate_specs(seqs, specs)
    assert min(min(r.features) for r in free.values()) > 40  # both find more than the budget everywhere
    capped = evaluate_specs(seqs, specs, max_features=40, jobs=2)
    assert list(capped) == ["sogdd-hr:top_k=40", "shi-tomasi:top_k=40"]
    for r in capped.values():
        s = r.summary()
        assert r.features == [40] * 6 and s["spec"]["top_k"] == 40
        assert s["mma"]["overall"][2] > 0.5  # the strongest points of a rendered pair still match
    # processes give the same numbers as one process
    one = evaluate_specs(seqs, specs, max_features=40, jobs=1)
    for k in capped:
        assert capped[k].summary()["mma"] == one[k].summary()["mma"]


def test_cli_matching_max_features(root, tmp_path, capsys):
    rc = main(["eval", "matching", "--root", str(root), "--detectors", "sogdd-hr,sift", "--max-features", "50",
               "--jobs", "2", "--out", str(tmp_path), "--json", "--quiet", "--no-published"])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    assert set(obj) == {"sogdd-hr:top_k=50", "sift:top_k=50"}
    assert all(v["budget"] == 50 and v["features"] <= 50 for v in obj.values())
    assert json.loads((tmp_path / "matching.json").read_text()) == obj
    for bad in (["--max-features", "0"], ["--jobs", "0"], ["--max-features", "x"]):
        with pytest.raises(SystemExit) as e:
            main(["eval", "matching", "--root", str(root), "--quiet", *bad])
        assert e.value.code == 2
    assert "expected a positive integer" in capsys.readouterr().err
