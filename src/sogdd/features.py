"""The feature-file schema: one encoding of detected corners, written atomically, read back.

Coordinates: ``x`` = column, ``y`` = row, pixel centres at integers.

- ``npz``: arrays ``xy`` (N, 2), ``response`` (N,), ``size`` (N,), ``level`` (N,)
  and ``image_shape`` (2,);
- ``csv``: a header ``x,y,response,size`` and one row per corner;
- ``json``: ``{"image", "n", "x", "y", "response", "size"}``.

Files are written to a temporary file in the target folder, then renamed, so
an interrupted run never leaves a half-written file.
"""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from .corners import Corners

__all__ = ["FORMATS", "csv_rows", "encode_features", "json_object", "load_features", "write_features"]

FORMATS = ("npz", "csv", "json")


def csv_rows(c: Corners, prefix: str = "") -> list[str]:
    """``x,y,response,size`` rows (no header), each optionally prefixed (``"image,"``)."""
    return [f"{prefix}{x:.4f},{y:.4f},{r:.9g},{s:.4g}" for (x, y), r, s in zip(c.xy, c.response, c.size)]


def json_object(c: Corners, image: str) -> dict:
    """The JSON form of one image's corners."""
    return {"image": image, "n": len(c), "x": c.xy[:, 0].round(4).tolist(),
            "y": c.xy[:, 1].round(4).tolist(), "response": c.response.tolist(),
            "size": c.size.tolist()}


def encode_features(c: Corners, fmt: str, image: str, shape: tuple[int, ...]) -> bytes:
    """The bytes of one feature file in format ``fmt``."""
    if fmt == "npz":
        buf = io.BytesIO()
        np.savez(buf, xy=c.xy, response=c.response, size=c.size, level=c.level,
                 image_shape=np.asarray(shape[:2]))
        return buf.getvalue()
    if fmt == "csv":
        return ("\n".join(["x,y,response,size", *csv_rows(c)]) + "\n").encode()
    if fmt == "json":
        return json.dumps(json_object(c, image)).encode()
    raise ValueError(f"unknown format {fmt!r}; choose from {', '.join(FORMATS)}")


def write_features(path: str | os.PathLike, c: Corners, fmt: str, image: str, shape: tuple[int, ...]) -> None:
    """Write one feature file atomically (a temporary file, then ``os.replace``)."""
    path = Path(path)
    data = encode_features(c, fmt, image, shape)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_features(path: str | os.PathLike) -> Corners:
    """Read a feature file written by ``sogdd detect`` (npz, csv or json, by suffix).

    Raises ``ValueError`` (one line, naming the file) for a missing, truncated or
    malformed file.

    Examples
    --------
    >>> import tempfile
    >>> c = Corners(np.array([[10.5, 20.25], [3.0, 4.0]]), response=[2e9, 1e9])
    >>> path = Path(tempfile.mkdtemp()) / "photo.png.npz"
    >>> write_features(path, c, "npz", "photo.png", (480, 640))
    >>> back = load_features(path)
    >>> back.xy.tolist(), back.response.tolist()
    ([[10.5, 20.25], [3.0, 4.0]], [2000000000.0, 1000000000.0])
    """
    p = Path(path)
    fmt = p.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise ValueError(f"{p}: not a feature file (expected .npz, .csv or .json)")
    try:
        if fmt == "npz":
            with np.load(p, allow_pickle=False) as z:
                return Corners(z["xy"], z["response"], z["size"], z["level"])
        if fmt == "csv":
            with open(p, newline="") as f:
                rows = list(csv.DictReader(f))
            cols = {k: np.array([float(r[k]) for r in rows]) for k in ("x", "y", "response", "size")}
            xy = np.stack([cols["x"], cols["y"]], axis=1) if rows else np.zeros((0, 2))
            return Corners(xy, cols["response"], cols["size"])
        obj = json.loads(p.read_text())
        return Corners(np.stack([obj["x"], obj["y"]], axis=1) if obj["n"] else np.zeros((0, 2)),
                       obj["response"], obj["size"])
    except FileNotFoundError:
        raise ValueError(f"{p}: no such file") from None
    except Exception as exc:  # noqa: BLE001 - any decoding failure is a bad file
        raise ValueError(f"{p}: not a valid {fmt} feature file ({type(exc).__name__}: {exc})") from None
