"""Image sequences related by known homographies: HPatches, Oxford and HOMOGR layouts.

Every loader returns :class:`HomographySequence` objects: a reference image and
a list of ``(image, H)`` targets, where ``H`` maps reference pixel coordinates
to target pixel coordinates in the project's convention (x = column,
y = row, 0-based, pixel centres at integers).

Layouts
-------
``hpatches``
    Sequence folders ``i_*`` (illumination) and ``v_*`` (viewpoint), each with
    ``1.ppm`` .. ``6.ppm`` and ``H_1_2`` .. ``H_1_6`` (Balntas et al., CVPR 2017).
    D2-Net's 8 excluded sequences (:data:`D2NET_EXCLUDED`) are dropped.
``oxford``
    Sequence folders with ``img1`` .. ``img6`` (``.ppm``/``.pgm``/``.png``/
    ``.jpg``) and ``H1to2p`` .. ``H1to6p`` (Mikolajczyk et al., IJCV 2005).
``homogr``
    Pair folders ``<pair>/`` with ``<pair>A.*``, ``<pair>B.*`` and
    ``<pair>_model.txt`` (Lebeda, Matas and Chum, BMVC 2012). The model maps B
    to A in MATLAB's 1-based coordinates; it is converted to a 0-based A-to-B
    homography here.

``root`` may be the folder holding the sequences or one sequence folder itself.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...image.files import IMAGE_SUFFIXES

__all__ = [
    "D2NET_EXCLUDED",
    "LAYOUTS",
    "HomographySequence",
    "detect_layout",
    "homogr_to_zero_based",
    "load_published",
    "load_sequences",
]

# The sequences D2-Net's HPatches benchmark drops (images above 1200 x 1600 px).
D2NET_EXCLUDED: frozenset[str] = frozenset(
    {
        "i_contruction",
        "i_crownnight",
        "i_dc",
        "i_pencils",
        "i_whitebuilding",
        "v_artisans",
        "v_astronautis",
        "v_talent",
    }
)

LAYOUTS = ("hpatches", "oxford", "homogr")
# Oxford sequences by the change they contain (Mikolajczyk et al. 2005)
_OXFORD_SPLIT = {"leuven": "illumination", "graf": "viewpoint", "wall": "viewpoint",
                 "boat": "viewpoint", "bark": "viewpoint"}


@dataclass(frozen=True)
class HomographySequence:
    """A reference image and the images it maps to by known homographies.

    Attributes
    ----------
    name : str
        Sequence (folder) name.
    split : str
        ``"illumination"``, ``"viewpoint"`` or ``"other"``.
    reference : Path
        The reference image (HPatches' image 1, HOMOGR's A).
    targets : list of (Path, ndarray)
        ``(image, H)`` with ``H`` (3, 3) mapping reference pixels to target pixels.
    """

    name: str
    split: str
    reference: Path
    targets: list[tuple[Path, np.ndarray]] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.targets)


def _find_image(folder: Path, stem: str) -> Path | None:
    cands = sorted(q for q in folder.iterdir() if q.stem == stem and q.suffix.lower() in IMAGE_SUFFIXES)
    return cands[0] if cands and cands[0].is_file() else None


def _read_h(path: Path) -> np.ndarray:
    try:
        h = np.loadtxt(path, dtype=np.float64)
    except ValueError as exc:
        raise ValueError(f"{path}: not a 3x3 homography ({exc})") from exc
    if h.shape != (3, 3) or not np.isfinite(h).all() or abs(np.linalg.det(h)) < 1e-300:
        raise ValueError(f"{path}: not an invertible 3x3 homography (shape {h.shape})")
    return h / h[2, 2] if h[2, 2] != 0 else h


def homogr_to_zero_based(h_b_to_a_1based: np.ndarray) -> np.ndarray:
    """Convert a HOMOGR model (B to A, MATLAB 1-based) to a 0-based A-to-B homography.

    With ``T`` the shift ``p1 = p0 + 1``, the 0-based B-to-A map is
    ``T^-1 H T``; its inverse maps A to B.
    """
    t = np.array([[1.0, 0, 1], [0, 1, 1], [0, 0, 1]])
    h_ba = np.linalg.inv(t) @ np.asarray(h_b_to_a_1based, dtype=np.float64) @ t
    h_ab = np.linalg.inv(h_ba)
    return h_ab / h_ab[2, 2]


def _is_hpatches_seq(d: Path) -> bool:
    return (d / "H_1_2").is_file() and _find_image(d, "1") is not None


def _is_oxford_seq(d: Path) -> bool:
    return (d / "H1to2p").is_file() and _find_image(d, "img1") is not None


def _is_homogr_pair(d: Path) -> bool:
    return (d / f"{d.name}_model.txt").is_file()


_CHECKS = {"hpatches": _is_hpatches_seq, "oxford": _is_oxford_seq, "homogr": _is_homogr_pair}


def detect_layout(root: str | Path) -> str:
    """Guess a folder's layout from the files in it (or in its sub-folders)."""
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"{root}: not a folder")
    subdirs = [d for d in sorted(root.iterdir()) if d.is_dir()]
    for name, check in _CHECKS.items():
        if check(root) or any(check(d) for d in subdirs):
            return name
    raise ValueError(
        f"{root}: no HPatches (i_*/v_* with H_1_k), Oxford (img1.., H1toNp) or HOMOGR (*_model.txt) data"
    )


def _seq_dirs(root: Path, check) -> list[Path]:
    if check(root):
        return [root]
    return [d for d in sorted(root.iterdir()) if d.is_dir() and check(d)]


def _load_hpatches(d: Path) -> HomographySequence:
    ref = _find_image(d, "1")
    targets = []
    for k in range(2, 7):
        img, hf = _find_image(d, str(k)), d / f"H_1_{k}"
        if img is not None and hf.is_file():
            targets.append((img, _read_h(hf)))
    split = {"i": "illumination", "v": "viewpoint"}.get(d.name[:2].rstrip("_"), "other")
    if not d.name.startswith(("i_", "v_")):
        split = "other"
    return HomographySequence(d.name, split, ref, targets)


def _load_oxford(d: Path) -> HomographySequence:
    ref = _find_image(d, "img1")
    targets = []
    for k in range(2, 7):
        img, hf = _find_image(d, f"img{k}"), d / f"H1to{k}p"
        if img is not None and hf.is_file():
            targets.append((img, _read_h(hf)))
    return HomographySequence(d.name, _OXFORD_SPLIT.get(d.name.lower(), "other"), ref, targets)


def _load_homogr(d: Path) -> HomographySequence:
    name = d.name
    a, b = _find_image(d, f"{name}A"), _find_image(d, f"{name}B")
    if a is None or b is None:
        raise ValueError(f"{d}: missing {name}A.* or {name}B.*")
    h = homogr_to_zero_based(_read_h(d / f"{name}_model.txt"))
    # wide-baseline pairs of planar scenes: all count as viewpoint changes
    return HomographySequence(name, "viewpoint", a, [(b, h)])


_LOADERS = {"hpatches": _load_hpatches, "oxford": _load_oxford, "homogr": _load_homogr}


def load_sequences(
    root: str | Path,
    layout: str = "auto",
    *,
    exclude: frozenset[str] | set[str] | None = D2NET_EXCLUDED,
    include: list[str] | None = None,
) -> list[HomographySequence]:
    """Load every sequence under ``root``.

    Parameters
    ----------
    root : path
        Folder of sequences (or one sequence folder).
    layout : {"auto", "hpatches", "oxford", "homogr"}
    exclude : set of str, optional
        Sequence names to drop (default: D2-Net's list; only HPatches names are in it).
    include : list of str, optional
        Keep only these sequence names (or names matching these regular expressions).

    Returns
    -------
    list of HomographySequence
        Sorted by name; sequences without any target are left out.
    """
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"{root}: not a folder")
    if layout == "auto":
        layout = detect_layout(root)
    if layout not in _LOADERS:
        raise ValueError(f"unknown layout {layout!r}; choose from auto, {', '.join(LAYOUTS)}")
    seqs = []
    for d in _seq_dirs(root, _CHECKS[layout]):
        if exclude and d.name in exclude:
            continue
        if include and not any(d.name == p or re.fullmatch(p, d.name) for p in include):
            continue
        s = _LOADERS[layout](d)
        if s.targets:
            seqs.append(s)
    if not seqs:
        raise ValueError(f"{root}: no {layout} sequences found")
    return seqs


def load_published(path: str | Path) -> dict[str, dict[str, dict]]:
    """Published full-HPatches curves: ``{method: {split: {"mma": [...], "features", "matches"}}}``."""
    out: dict[str, dict[str, dict]] = {}
    with open(path, newline="") as fh:
        rows = csv.DictReader(line for line in fh if not line.startswith("#"))
        for r in rows:
            mma = [float(r[f"mma@{t}"]) for t in range(1, 11)]
            out.setdefault(r["method"], {})[r["split"]] = {
                "mma": mma,
                "features": float(r["mean_features"]),
                "matches": float(r["mean_matches"]),
            }
    return out
