"""The CSV layout of feature files: plain rows, the provenance in a sidecar.

The layout and the reason for it are in :mod:`sogdd.formats.features`: the
CSV holds a header and one row per corner, ``[image,]x,y,response,size[,level]``;
``<file>.json`` beside it holds the provenance, bound to the CSV's bytes by
their SHA-256.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
from pathlib import Path

import numpy as np

from ..corners import Corners
from .record import FeatureRecord, record

__all__ = ["SIDECAR", "encode_csv", "encode_sidecar", "read_csv", "sidecar_path", "with_level"]

SIDECAR = "sogdd-csv-sidecar"
_OLD_CSV = "# sogdd "  # the provenance line of sogdd <= 0.1 CSV files


def with_level(recs: list[FeatureRecord]) -> bool:
    return any((r.params or {}).get("levels", 1) > 1 or np.any(r.corners.level) for r in recs)


def encode_csv(recs: list[FeatureRecord]) -> bytes:
    """Header and rows of a CSV feature file holding ``recs`` (nothing else: see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> from sogdd.corners import Corners
    >>> rec = FeatureRecord("a.png", Corners(np.array([[1.5, 2.0]]), [3e9]), (10, 10))
    >>> print(encode_csv([rec]).decode(), end="")
    x,y,response,size
    1.5000,2.0000,3e+09,7
    """
    many, level = len(recs) > 1, with_level(recs)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow((["image"] if many else []) + ["x", "y", "response", "size"] + (["level"] if level else []))
    for r in recs:
        c = r.corners
        for (x, y), resp, s, lv in zip(c.xy, c.response, c.size, c.level):
            w.writerow(([r.image] if many else []) + [f"{x:.4f}", f"{y:.4f}", f"{resp:.9g}", f"{s:.4g}"]
                       + ([int(lv)] if level else []))
    return buf.getvalue().encode()


def sidecar_path(path: str | os.PathLike) -> Path:
    """Where the provenance of the CSV feature file ``path`` goes: ``<path>.json``.

    Examples
    --------
    >>> sidecar_path("feats/all.csv").as_posix()
    'feats/all.csv.json'
    """
    p = Path(path)
    return p.with_name(p.name + ".json")


def encode_sidecar(recs: list[FeatureRecord], data: bytes) -> bytes:
    """The sidecar of the CSV bytes ``data`` holding ``recs``: their provenance and ``data``'s SHA-256."""
    obj = {"format": SIDECAR, "csv_sha256": hashlib.sha256(data).hexdigest(),
           "images": [r.meta() for r in recs]}
    return (json.dumps(obj) + "\n").encode()


def _csv_metas(p: Path, data: bytes) -> list[dict] | None:
    """The provenance of the CSV ``p`` from its sidecar, if there is one that matches ``data``."""
    side = sidecar_path(p)
    try:
        obj = json.loads(side.read_bytes())
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        raise ValueError(f"its sidecar {side.name} does not load ({exc})") from None
    if not isinstance(obj, dict) or obj.get("format") != SIDECAR:
        raise ValueError(f"{side.name} beside it is not a sogdd sidecar")
    if obj.get("csv_sha256") != hashlib.sha256(data).hexdigest():
        return None  # the CSV changed after its sidecar was written: its provenance no longer holds
    return obj["images"]


def read_csv(p: Path) -> list[FeatureRecord]:
    """Every record of the CSV feature file ``p``: rows, with the provenance of a matching sidecar.

    Without one (a CSV from stdout, edited, or moved without its sidecar) each
    image named in the ``image`` column (or the file's stem) is a record with
    no provenance; a CSV of sogdd <= 0.1 takes it from its ``# sogdd`` line.
    """
    data = p.read_bytes()
    text = data.decode("utf-8")
    if text.startswith(_OLD_CSV):  # sogdd <= 0.1: the provenance on the first line
        first, _, text = text.partition("\n")
        metas = json.loads(first[len(_OLD_CSV):])["images"]
    else:
        metas = _csv_metas(p, data)
    rows = list(csv.DictReader(io.StringIO(text, newline="")))
    if metas is None:  # plain rows: one record per image named in the rows (or the file's stem)
        named = rows[0].get("image") is not None if rows else False
        images = list(dict.fromkeys(r["image"] for r in rows)) if named else [p.stem]
        metas = [{"image": name, "image_shape": [0, 0]} for name in images]
    out = []
    for m in metas:
        mine = [r for r in rows if r.get("image", m["image"]) == m["image"]]
        cols = {k: np.array([float(r[k]) for r in mine]) for k in ("x", "y", "response", "size")}
        level = np.array([int(r["level"]) for r in mine]) if mine and "level" in mine[0] else None
        xy = np.stack([cols["x"], cols["y"]], axis=1) if mine else np.zeros((0, 2))
        out.append(record(m["image"], Corners(xy, cols["response"], cols["size"], level), m["image_shape"], m))
    return out
