"""The feature-file schema: one encoding of detected corners, written atomically, read back.

One schema for ``sogdd detect -o FILE``, ``sogdd detect --out DIR`` (one file
per image) and ``sogdd colmap export``. A file holds one or more image
records; each record has

- the corners: ``xy`` (N, 2; x = column, y = row, pixel centres at
  integers), ``response`` (N,), ``size`` (N,) and ``level`` (N,, the pyramid
  level, 0 = full resolution);
- ``image`` (the input path as given), ``image_shape`` (height, width);
- optionally, in npz files only, ``descriptors`` (N, D), one row per corner,
  which ``sogdd colmap export`` writes into the database. ``sogdd detect``
  does not write them; :func:`read_descriptors` is the one reader;
- provenance: ``params`` (every resolved detector parameter and the preset),
  ``sogdd_version``, ``source_size``, ``source_mtime_ns`` and
  ``source_sha256`` (of the image file, taken before it was read), which
  ``--resume`` compares before trusting a file.

Encodings:

- ``npz``: one image: the arrays above by name (``params`` as a JSON string);
  several: ``images`` (M,) and each image's arrays under ``<image>/<name>``.
- ``csv``: a header, then one row per corner, written with the :mod:`csv`
  module: ``[image,]x,y,response,size[,level]`` (``image`` when the file holds
  several images; ``level`` when the parameters have ``levels > 1``). Nothing
  else is in the file, so ``pandas.read_csv(path)`` and ``csv.DictReader``
  read it with no options. The provenance goes to a *sidecar*, ``<file>.json``
  (``all.csv`` -> ``all.csv.json``): ``{"format": "sogdd-csv-sidecar",
  "csv_sha256": ..., "images": [one object per image: image, image_shape and
  the provenance]}``. Why a sidecar: a ``# sogdd {json}`` first line (sogdd <=
  0.1) made every plain CSV reader see JSON fragments as column names, and for
  a large batch it was most of the file; a sidecar harms no reader and keeps
  images without corners (which have no rows). ``csv_sha256`` binds it to the
  bytes of its CSV: a sidecar that does not match (the CSV edited or replaced,
  or a run interrupted between the two renames) is ignored, and the CSV then
  reads as plain rows without provenance (so ``--resume`` redoes it). CSV on
  stdout is header and rows only. Files with the old first line still read.
- ``json``: always a list with one object per image: ``image``,
  ``image_shape``, ``n``, ``x``, ``y``, ``response``, ``size``, ``level``,
  ``params``, ``sogdd_version``, ``source_size``, ``source_mtime_ns``,
  ``source_sha256``.

Image names must be valid UTF-8 in every encoding (a file name such as the
bytes ``b"caf\\xe9.png"`` on Linux is refused by :func:`check_name`, naming it
escaped). Files are written to a temporary file (``.<name>.<random>.sogdd.tmp``)
in the target folder, then renamed, so an interrupted run never leaves a
half-written file; the final file gets the permissions of a normal file (0644
under umask 022). A failed write raises ``OSError`` naming the target, never
the temporary file.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np

from ..corners import Corners
from .feature_csv import SIDECAR, encode_csv, encode_sidecar, read_csv, sidecar_path
from .record import META, FeatureRecord, check_name, make_record, params_dict, record, source_stamp
from .safe_write import TMP_SUFFIX, temporary_beside

__all__ = [
    "FORMATS",
    "FeatureRecord",
    "check_name",
    "encode_features",
    "feature_files",
    "load_features",
    "make_record",
    "params_dict",
    "read_descriptors",
    "read_features",
    "remove_stale_temporaries",
    "sidecar_path",
    "source_stamp",
    "write_features",
]

FORMATS = ("npz", "csv", "json")


def _as_records(records) -> list[FeatureRecord]:
    recs = [records] if isinstance(records, FeatureRecord) else list(records)
    for r in recs:
        check_name(r.image)
    return recs


def encode_features(records: FeatureRecord | list[FeatureRecord], fmt: str) -> bytes:
    """The bytes of one feature file in format ``fmt`` holding ``records``.

    For ``csv`` these are the header and the rows only; the provenance is the
    sidecar's (:func:`write_features` writes both).
    """
    recs = _as_records(records)
    if fmt == "npz":
        return _encode_npz(recs)
    if fmt == "csv":
        return encode_csv(recs)
    if fmt == "json":
        return (json.dumps([_json_object(r) for r in recs]) + "\n").encode()
    raise ValueError(f"unknown format {fmt!r}; choose from {', '.join(FORMATS)}")


def _npz_arrays(r: FeatureRecord) -> dict[str, np.ndarray]:
    c = r.corners
    return {"xy": c.xy, "response": c.response, "size": c.size, "level": c.level,
            "image_shape": np.asarray(r.image_shape, np.int64), "image": np.asarray(r.image),
            "params": np.asarray(json.dumps(r.params)), "sogdd_version": np.asarray(r.sogdd_version or ""),
            "source_size": np.asarray(-1 if r.source_size is None else r.source_size, np.int64),
            "source_mtime_ns": np.asarray(-1 if r.source_mtime_ns is None else r.source_mtime_ns, np.int64),
            "source_sha256": np.asarray(r.source_sha256 or "")}


def _encode_npz(recs: list[FeatureRecord]) -> bytes:
    if len(recs) == 1:
        arrays = _npz_arrays(recs[0])
    else:
        arrays = {"images": np.asarray([r.image for r in recs])}
        for r in recs:
            arrays.update({f"{r.image}/{k}": v for k, v in _npz_arrays(r).items()})
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _json_object(r: FeatureRecord) -> dict:
    c = r.corners
    return {"image": r.image, "image_shape": [int(v) for v in r.image_shape], "n": len(c),
            "x": c.xy[:, 0].round(4).tolist(), "y": c.xy[:, 1].round(4).tolist(),
            "response": c.response.tolist(), "size": c.size.tolist(), "level": c.level.tolist(),
            **{k: getattr(r, k) for k in META}}


def write_features(path: str | os.PathLike, records: FeatureRecord | list[FeatureRecord],
                   fmt: str | None = None) -> None:
    """Write one feature file atomically (a temporary file, then ``os.replace``).

    ``fmt`` defaults to the file's suffix. A CSV file gets its provenance
    sidecar :func:`sidecar_path` beside it (both temporary files are written
    before either is renamed). The files get ``0666 & ~umask`` permissions, as
    ``open()`` would give them. Raises ``OSError`` naming ``path`` (never the
    temporary file) when the folder cannot be written, the disk is full or
    ``path`` is a folder.
    """
    path = Path(path)
    fmt = fmt or path.suffix.lower().lstrip(".")
    recs = _as_records(records)
    data = encode_features(recs, fmt)
    files = [(path, data)]
    if fmt == "csv":
        files.append((sidecar_path(path), encode_sidecar(recs, data)))
    for target, _ in files:
        if target.is_dir():
            raise IsADirectoryError(f"{target}: is a folder, not a file name")
    temps: list[str] = []
    try:
        try:
            for target, blob in files:
                temps.append(_write_temporary(target, blob))
            for (target, _), tmp in zip(files, temps):
                os.replace(tmp, target)
        except OSError as exc:  # the target's name, not the temporary file's
            raise type(exc)(exc.errno, f"{path}: cannot write ({exc.strerror or exc})") from None
    finally:
        for tmp in temps:
            Path(tmp).unlink(missing_ok=True)


def _write_temporary(target: Path, data: bytes) -> str:
    tmp = temporary_beside(target)
    try:
        tmp.write_bytes(data)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return str(tmp)


def remove_stale_temporaries(folder: str | os.PathLike) -> int:
    """Delete the temporary files an interrupted writer left in ``folder`` (recursively); return how many."""
    n = 0
    for p in Path(folder).rglob(f".*{TMP_SUFFIX}"):
        try:
            p.unlink()
            n += 1
        except OSError:
            pass
    return n


def _check_npz(p: Path) -> None:
    """An npz file is a zip archive: anything else (a text file named ``.npz``) is said to be so, not
    left to numpy's message about pickled data."""
    with open(p, "rb") as f:  # a missing file raises FileNotFoundError: "no such file"
        head = f.read(4)
    if head not in (b"PK\x03\x04", b"PK\x05\x06"):  # a zip archive's first bytes (a truncated one: numpy's)
        raise ValueError(f"{p}: not an npz file (not a zip archive); sogdd detect --format npz writes them")


def _read_npz(p: Path) -> list[FeatureRecord]:
    _check_npz(p)
    with np.load(p, allow_pickle=False) as z:
        keys = set(z.files)
        names = [str(n) for n in z["images"]] if "images" in keys else [None]
        out = []
        for name in names:
            pre = "" if name is None else f"{name}/"
            g = {k[len(pre):]: z[k] for k in keys if k.startswith(pre) and "/" not in k[len(pre):]}
            level = g["level"] if "level" in g else None
            c = Corners(g["xy"], g["response"], g.get("size"), level)
            meta = {"params": json.loads(str(g["params"])) if "params" in g else None,
                    "sogdd_version": str(g["sogdd_version"]) if "sogdd_version" in g else None,
                    "source_sha256": str(g["source_sha256"]) if "source_sha256" in g else None}
            for k in ("source_size", "source_mtime_ns"):
                v = int(g[k]) if k in g else -1
                meta[k] = None if v < 0 else v
            image = str(g["image"]) if "image" in g else (name or p.stem)
            shape = g["image_shape"] if "image_shape" in g else (0, 0)
            out.append(record(image, c, shape, meta))
    return out


def _read_json(p: Path) -> list[FeatureRecord]:
    objs = json.loads(p.read_text())
    if isinstance(objs, dict) and objs.get("format") == SIDECAR:
        raise ValueError(f"the provenance sidecar of a CSV; read {p.name[: -len('.json')]} instead")
    if isinstance(objs, dict):  # files of sogdd <= 0.1 held one object
        objs = [objs]
    out = []
    for o in objs:
        xy = np.stack([o["x"], o["y"]], axis=1) if o["n"] else np.zeros((0, 2))
        c = Corners(xy, o["response"], o["size"], o.get("level"))
        out.append(record(o["image"], c, o.get("image_shape", (0, 0)), o))
    return out


def read_features(path: str | os.PathLike) -> list[FeatureRecord]:
    """Every image record of a feature file (npz, csv or json, by suffix).

    Raises ``ValueError`` (one line, naming the file) for a missing, truncated or
    malformed file.
    """
    p = Path(path)
    fmt = p.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise ValueError(f"{p}: not a feature file (expected .npz, .csv or .json)")
    try:
        recs = {"npz": _read_npz, "csv": read_csv, "json": _read_json}[fmt](p)
        for r in recs:
            if len(r.corners.xy) != len(r.corners.response):
                raise ValueError("arrays of different lengths")
        return recs
    except FileNotFoundError:
        raise ValueError(f"{p}: no such file") from None
    except ValueError as exc:
        if str(exc).startswith(f"{p}: "):  # already one line naming the file
            raise
        raise ValueError(f"{p}: not a valid {fmt} feature file (ValueError: {exc})") from None
    except Exception as exc:  # noqa: BLE001 - any decoding failure is a bad file
        raise ValueError(f"{p}: not a valid {fmt} feature file ({type(exc).__name__}: {exc})") from None


def read_descriptors(path: str | os.PathLike, image: str | None = None) -> np.ndarray | None:
    """The optional ``descriptors`` (N, D) of a feature file, one row per corner; ``None`` if it has none.

    ``image`` names the record of an npz file of several images. CSV and JSON
    files hold no descriptors. Raises ``ValueError`` (one line, naming the file)
    for a file that cannot be read, or descriptors that are not an (N, D) array
    of finite numbers with one row per corner.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "photo.png.npz"
    >>> np.savez(path, xy=np.zeros((2, 2)), response=np.ones(2), descriptors=np.ones((2, 128)))
    >>> read_descriptors(path).shape
    (2, 128)
    >>> np.savez(path, xy=np.zeros((3, 2)), response=np.ones(3), descriptors=np.ones((2, 128)))
    >>> read_descriptors(path)
    Traceback (most recent call last):
    ...
    ValueError: ...photo.png.npz: descriptors of shape (2, 128) for 3 corners
    """
    p = Path(path)
    if p.suffix.lower() != ".npz":
        return None
    pre = "" if image is None else f"{image}/"
    try:
        _check_npz(p)
        with np.load(p, allow_pickle=False) as z:
            if f"{pre}descriptors" not in z.files:
                return None
            desc, n = np.asarray(z[f"{pre}descriptors"]), len(z[f"{pre}xy"])
    except FileNotFoundError:
        raise ValueError(f"{p}: no such file") from None
    except Exception as exc:  # noqa: BLE001 - any decoding failure is a bad file
        if isinstance(exc, ValueError) and str(exc).startswith(f"{p}: "):
            raise
        raise ValueError(f"{p}: not a valid npz feature file ({type(exc).__name__}: {exc})") from None
    if desc.ndim != 2 or len(desc) != n:
        raise ValueError(f"{p}: descriptors of shape {desc.shape} for {n} corners")
    if desc.dtype.kind not in "iuf" or not np.isfinite(desc).all():
        raise ValueError(f"{p}: descriptors must be finite numbers (dtype {desc.dtype})")
    return desc


#: the suffixes of feature files in a folder: every format ``sogdd detect --out`` writes
FEATURE_SUFFIXES = (".npz", ".csv", ".json")


def feature_files(folder: str | os.PathLike) -> dict[str, Path]:
    """``{image name: file}`` of a feature folder, as ``sogdd colmap export`` reads it.

    The name is the file's path under ``folder`` without its suffix (``sogdd
    detect --out`` mirrors the inputs' sub-folders); npz, CSV or JSON files, not
    a CSV's sidecar ``<file>.csv.json`` nor anything that is not a regular file.
    One image with files in two formats is refused (``ValueError``), naming both.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder")
    files: dict[str, Path] = {}
    for p in sorted(folder.rglob("*")):
        suffix = p.suffix.lower()
        if suffix not in FEATURE_SUFFIXES or p.name.lower().endswith(".csv.json") or not p.is_file():
            continue  # a FIFO or a device named *.npz is not read (it could block for ever)
        name = p.relative_to(folder).as_posix()[: -len(suffix)]
        if name in files:
            raise ValueError(f"{files[name]} and {p.name}: two feature files of one image; keep one")
        files[name] = p
    if not files:
        raise ValueError(f"{folder}: no feature files (.npz, .csv or .json, as sogdd detect --out writes)")
    return files


def load_features(path: str | os.PathLike, image: str | None = None) -> Corners:
    """The corners stored in a feature file written by ``sogdd detect`` (npz, csv or json).

    A file of several images (``sogdd detect a.png b.png -o all.npz``) needs
    ``image=`` (the name as given to ``sogdd detect``); :func:`read_features`
    returns every record with its provenance.

    Raises ``ValueError`` (one line, naming the file) for a missing, truncated or
    malformed file.

    Examples
    --------
    >>> import tempfile
    >>> c = Corners(np.array([[10.5, 20.25], [3.0, 4.0]]), response=[2e9, 1e9])
    >>> path = Path(tempfile.mkdtemp()) / "photo.png.npz"
    >>> write_features(path, FeatureRecord("photo.png", c, (480, 640)))
    >>> back = load_features(path)
    >>> back.xy.tolist(), back.response.tolist()
    ([[10.5, 20.25], [3.0, 4.0]], [2000000000.0, 1000000000.0])
    """
    recs = read_features(path)
    if image is None:
        if len(recs) != 1:
            raise ValueError(f"{path}: holds {len(recs)} images; choose one with image= "
                             f"(e.g. {recs[0].image!r})")
        return recs[0].corners
    for r in recs:
        if r.image == str(image):
            return r.corners
    raise ValueError(f"{path}: no image {str(image)!r} (it holds {', '.join(r.image for r in recs[:5])})")
