"""The CSV feature file is plain rows that every reader loads with no options; the provenance is in a
sidecar ``<file>.json`` bound to the CSV's bytes."""

import csv
import json

import numpy as np
import pytest

import sogdd
from sogdd.cli.main import main
from sogdd.collection import run_batch
from sogdd.formats.features import FeatureRecord, read_features, sidecar_path, write_features


def test_a_batch_csv_loads_with_plain_pandas_and_dictreader(tmp_path, image, write_image):
    pd = pytest.importorskip("pandas")
    a = write_image(tmp_path / "a.png", image)
    b = write_image(tmp_path / "b.png", np.roll(image, 7, axis=1))
    out = tmp_path / "all.csv"
    assert main(["detect", a, b, "-o", str(out)]) == 0
    df = pd.read_csv(out)  # no options
    assert list(df.columns) == ["image", "x", "y", "response", "size"]
    assert set(df["image"]) == {"a.png", "b.png"} and df["response"].dtype == np.float64
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["image", "x", "y", "response", "size"] and len(rows) == len(df)
    want = sogdd.detect_corners(image)
    got = df[df["image"] == "a.png"][["x", "y"]].to_numpy()
    np.testing.assert_allclose(got, want.xy, atol=6e-5)
    # the provenance: in the sidecar, and read back with the rows
    side = json.loads(sidecar_path(out).read_text())
    assert side["format"] == "sogdd-csv-sidecar" and [m["image"] for m in side["images"]] == ["a.png", "b.png"]
    recs = read_features(out)
    assert recs[0].params["threshold"] == 1e9 and recs[0].image_shape == (120, 160)
    assert recs[0].source_size == (tmp_path / "a.png").stat().st_size and len(recs[0].source_sha256) == 64


def test_stdout_csv_is_the_header_and_the_rows_only(tmp_path, image, capsys, write_image):
    pd = pytest.importorskip("pandas")
    a = write_image(tmp_path / "a.png", image)
    assert main(["detect", a]) == 0
    text = capsys.readouterr().out
    (tmp_path / "s.csv").write_text(text)
    assert text.splitlines()[0] == "x,y,response,size"
    df = pd.read_csv(tmp_path / "s.csv")
    assert list(df.columns) == ["x", "y", "response", "size"] and len(df) == len(sogdd.detect_corners(image))
    assert len(sogdd.load_features(tmp_path / "s.csv")) == len(df)  # rows without provenance still load


def test_images_without_corners_keep_their_record(tmp_path, image, write_image):
    flat = write_image(tmp_path / "flat.png", np.full((60, 80), 128, np.uint8))
    a = write_image(tmp_path / "a.png", image)
    out = tmp_path / "all.csv"
    assert main(["detect", flat, a, "-o", str(out)]) == 0
    recs = read_features(out)
    assert [(r.image, len(r.corners) > 0, r.image_shape) for r in recs] == [
        ("flat.png", False, (60, 80)), ("a.png", True, (120, 160))]


def test_an_edited_csv_drops_its_stale_provenance_and_resume_redoes_it(tmp_path, image, write_image):
    pd = pytest.importorskip("pandas")
    src = tmp_path / "src" / "a.png"
    write_image(src, image)
    out = tmp_path / "feats"
    assert run_batch([src], out, fmt="csv")[0].status == "done"
    f = out / "a.png.csv"
    df = pd.read_csv(f)
    df[df["response"] > df["response"].median()].to_csv(f, index=False)  # edited by hand
    (r,) = read_features(f)
    assert r.params is None and len(r.corners) == len(pd.read_csv(f))  # the rows, not the old provenance
    assert run_batch([src], out, fmt="csv", resume=True)[0].status == "done"
    assert run_batch([src], out, fmt="csv", resume=True)[0].status == "skipped"
    assert read_features(f)[0].params is not None


def test_old_csv_files_with_the_provenance_line_still_read(tmp_path):
    meta = {"image": "p.png", "image_shape": [10, 20], "params": {"preset": "paper", "window": 7},
            "sogdd_version": "0.1.0", "source_size": 5, "source_mtime_ns": 7}
    f = tmp_path / "old.csv"
    f.write_text("# sogdd " + json.dumps({"images": [meta]}) + "\nx,y,response,size\n1.5,2.5,3e9,17\n")
    (r,) = read_features(f)
    assert r.image == "p.png" and r.image_shape == (10, 20) and r.params["window"] == 7
    assert r.corners.xy.tolist() == [[1.5, 2.5]] and r.corners.response.tolist() == [3e9]


def test_the_sidecar_is_not_a_feature_file(tmp_path):
    c = sogdd.Corners(np.array([[1.0, 2.0]]), [5.0])
    write_features(tmp_path / "x.csv", FeatureRecord("x.png", c, (4, 4)))
    with pytest.raises(ValueError, match="sidecar of a CSV; read x.csv"):
        read_features(tmp_path / "x.csv.json")
