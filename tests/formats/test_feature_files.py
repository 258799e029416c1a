"""Results keep their promises: one schema, colmap export, option checks,
mask strictness, messages."""

import csv
import json

import numpy as np
import pytest

import sogdd
from sogdd.cli.main import main
from sogdd.formats.features import read_features
from sogdd.select import assemble as pyramid_merge
from sogdd.synthetic import pattern_image


def _error(err: str) -> str:
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("sogdd: error:")]
    assert len(lines) == 1, err
    return lines[0]


def test_csv_survives_commas_and_carries_level(tmp_path, image, capsys, write_image):
    a = write_image(tmp_path / "x, y.png", image)
    b = write_image(tmp_path / "plain.png", np.roll(image, 5, axis=1))
    out = tmp_path / "all.csv"
    assert main(["detect", a, b, "--levels", "2", "-o", str(out)]) == 0
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))  # no comment line to skip: the provenance is in all.csv.json
    assert {r["image"] for r in rows} == {"x, y.png", "plain.png"}
    assert {int(r["level"]) for r in rows} <= {0, 1} and "level" in rows[0]
    recs = read_features(out)
    assert [r.image for r in recs] == ["x, y.png", "plain.png"]
    assert recs[0].params["levels"] == 2 and recs[0].image_shape == (120, 160)
    c = sogdd.detect_corners(image, levels=2)
    np.testing.assert_allclose(recs[0].corners.xy, c.xy, atol=6e-5)
    np.testing.assert_array_equal(recs[0].corners.level, c.level)


@pytest.mark.parametrize("n", [1, 2])
def test_json_has_one_shape_whatever_the_number_of_inputs(tmp_path, image, capsys, n, write_image):
    files = [write_image(tmp_path / f"i{i}.png", np.roll(image, 3 * i, axis=0)) for i in range(n)]
    assert main(["detect", *files, "--format", "json"]) == 0
    objs = json.loads(capsys.readouterr().out)
    assert isinstance(objs, list) and len(objs) == n
    for o in objs:
        assert {"image", "image_shape", "n", "x", "y", "response", "size", "level", "params",
                "sogdd_version", "source_size", "source_mtime_ns"} <= set(o)


def test_one_npz_of_several_images_keeps_every_image(tmp_path, image, write_image):
    a = write_image(tmp_path / "a" / "same.png", image)
    b = write_image(tmp_path / "b" / "same.png", np.roll(image, 9, axis=1))
    out = tmp_path / "all.npz"
    assert main(["detect", a, b, "--format", "npz", "-o", str(out)]) == 0
    recs = read_features(out)
    assert [r.image for r in recs] == ["a/same.png", "b/same.png"]
    assert not np.array_equal(recs[0].corners.xy, recs[1].corners.xy)
    np.testing.assert_array_equal(sogdd.load_features(out, image="b/same.png").xy, recs[1].corners.xy)
    with pytest.raises(ValueError, match="holds 2 images; choose one with image="):
        sogdd.load_features(out)


def test_load_features_rejects_truncated_files_in_one_line(tmp_path, image, write_image):
    f = tmp_path / "a.png"
    write_image(f, image)
    assert main(["detect", str(f), "--out", str(tmp_path / "feat")]) == 0
    npz = tmp_path / "feat" / "a.png.npz"
    npz.write_bytes(npz.read_bytes()[:100])
    with pytest.raises(ValueError, match="a.png.npz: not a valid npz feature file") as info:
        sogdd.load_features(npz)
    assert "\n" not in str(info.value)


def test_colmap_export_is_all_or_nothing_and_the_readme_command_works(tmp_path, image, capsys, write_image):
    pytest.importorskip("pycolmap")
    photos = tmp_path / "photos"
    for i in range(3):
        write_image(photos / f"p{i}.png", np.roll(image, 4 * i, axis=1))
    feats, db = tmp_path / "feats", tmp_path / "db.db"
    assert main(["detect", str(photos), "--out", str(feats)]) == 0
    # the README's commands, as written, on a fresh database
    assert main(["colmap", "export", str(feats), "--database", str(db), "--images", str(photos)]) == 0
    assert "keypoints" in capsys.readouterr().out
    before = db.read_bytes()
    feats2 = tmp_path / "feats2"
    assert main(["detect", str(photos), "--out", str(feats2)]) == 0
    (feats2 / "p2.png.npz").write_bytes(b"PK\x03\x04 broken")
    db2 = tmp_path / "db2.db"
    db2.write_bytes(before)
    assert main(["colmap", "export", str(feats2), "--database", str(db2), "--images", str(photos)]) == 2
    assert "p2.png.npz" in _error(capsys.readouterr().err)
    assert db2.read_bytes() == before  # untouched
    assert not list(tmp_path.glob(".*.tmp"))
    fresh = tmp_path / "fresh.db"
    assert main(["colmap", "export", str(feats2), "--database", str(fresh), "--images", str(photos)]) == 2
    assert not fresh.exists()  # a failed export creates nothing


@pytest.mark.parametrize("argv, says", [
    (["--format", "npz"], "--format npz needs --output FILE"),
    (["--overlay", "NOEXT"], "give an image file name"),
    (["--overlay", "/nonexistent/dir/o.png"], "does not exist or is not writable"),
    (["-o", "/nonexistent/dir/c.csv"], "does not exist"),
    (["--out", "OUTDIR", "-o", "c.csv"], "exclude each other"),
    (["--resume"], "need --out DIR"),
    (["--threshold", "abc"], "--threshold: expected a number or 'none', got 'abc'"),
    (["--value-range", "0"], "--value-range: expected LO,HI"),
])
def test_options_are_checked_before_any_work(tmp_path, image, capsys, monkeypatch, argv, says, write_image):
    f = write_image(tmp_path / "a.png", image)
    calls = []
    monkeypatch.setattr("sogdd.cli.detect.detect_corners", lambda *a, **k: calls.append(1))
    argv = [str(tmp_path / a) if a in ("NOEXT", "OUTDIR") else a for a in argv]
    with pytest.raises(SystemExit) if argv[0] in ("--threshold", "--value-range") else _nothing() as ex:
        code = main(["detect", f, *argv])
    code = ex.value.code if ex is not None else code
    assert code == 2 and calls == []
    assert says in _error(capsys.readouterr().err)


class _nothing:
    def __enter__(self):
        return None

    def __exit__(self, *a):
        return False


def test_overlay_with_several_images_and_response_selection_flags_are_errors(
        tmp_path, image, capsys, write_image):
    a, b = (write_image(tmp_path / f"{n}.png", image) for n in "ab")
    assert main(["detect", a, b, "--overlay", str(tmp_path / "o.png")]) == 2
    assert "--overlay draws one image" in _error(capsys.readouterr().err)
    assert main(["response", a, "-o", str(tmp_path / "r.npy"), "--max-corners", "5"]) == 2
    assert "--max-corners: point selection, does not apply" in _error(capsys.readouterr().err)


def test_mask_and_border_hold_after_refinement_at_every_level(monkeypatch):
    img = pattern_image((240, 320), seed=2)[0]
    rng = np.random.default_rng(2)
    mask = np.zeros(img.shape, bool)
    for _ in range(6):
        y, x = rng.integers(0, 240), rng.integers(0, 320)
        mask[y:y + 50, x:x + 50] = True

    def outside(c):
        col, row = np.rint(c.xy).astype(int).T
        inside = (col >= 7) & (col <= 312) & (row >= 7) & (row <= 232)
        return int((~inside).sum() + (~mask[row[inside], col[inside]]).sum())

    c = sogdd.detect_corners(img, mask=mask, levels=3, border=7)
    assert len(c) > 10 and set(c.level.tolist()) >= {0, 1}
    assert outside(c) == 0
    monkeypatch.setattr(pyramid_merge, "inside_allowed", lambda xy, *a: np.ones(len(xy), bool))
    assert outside(sogdd.detect_corners(img, mask=mask, levels=3, border=7)) > 0  # the scene does test it


def test_messages_name_what_they_are_about(tmp_path, image, capsys, monkeypatch, write_image):
    with pytest.raises(ValueError, match="threshold_rel must be a number in"):
        sogdd.detect_corners(image, threshold_rel="x")
    f = write_image(tmp_path / "a.png", image)
    monkeypatch.setenv("SOGDD_NUM_THREADS", "abc")
    assert main(["detect", f]) == 2
    line = _error(capsys.readouterr().err)
    assert "SOGDD_NUM_THREADS must be a positive integer" in line and "a.png" not in line
    assert main(["detect", f, "--out", str(tmp_path / "o")]) == 2
    assert "SOGDD_NUM_THREADS" in _error(capsys.readouterr().err)
