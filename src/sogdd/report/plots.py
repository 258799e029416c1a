"""Figures: repeatability curves (Fig. 9 style), resolution curves, the sigma^2 sweep."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from ..evaluation.repeatability.protocol import RepeatabilityReport  # noqa: E402
from ..evaluation.resolution.protocol import ResolutionReport  # noqa: E402

__all__ = ["repeatability_figure", "resolution_figure", "sigma2_figure"]

_XLABEL = {"rotation": "angle (deg)", "scale": "scale factor", "anisotropic": "sy (mean over sx)",
           "shear": "shear c", "jpeg": "JPEG quality", "noise": "noise std (0-255)",
           "gaussian": "Gaussian blur sigma (px)", "motion": "motion blur length (px), seeded angle"}
_TITLE = {"rotation": "(a) rotation", "scale": "(b) uniform scaling",
          "anisotropic": "(c) non-uniform scaling", "shear": "(d) shear", "jpeg": "(e) JPEG",
          "noise": "(f) Gaussian noise", "gaussian": "(g) Gaussian blur (beyond the paper)",
          "motion": "(h) motion blur (beyond the paper)"}


def _style(label: str, i: int) -> dict:
    if label.startswith("sogdd"):
        return {"lw": 2.2, "color": "k" if label == "sogdd" else None, "zorder": 5}
    return {"lw": 1.0, "ls": ["-", "--", ":", "-."][i % 4]}


def _save(fig, path: str | os.PathLike) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=72)
    plt.close(fig)
    return p


def repeatability_figure(rep: RepeatabilityReport, path: str | os.PathLike,
                         detectors: list[str] | None = None) -> Path:
    """R_avg against each family's parameter, one line per detector (blur: two panels)."""
    panels = [(f, k) for f in rep.families for k in ((None,) if f != "blur" else ("gaussian", "motion"))]
    cols = 3
    rows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(11, 3.2 * rows), squeeze=False)
    for ax, (fam, kind) in zip(axes.flat, panels):
        for i, d in enumerate(detectors or rep.detectors):
            x, y = rep.curve(d, fam, kind)
            ax.plot(x, y, marker=".", ms=3, label=d, **_style(d, i))
        ax.set_title(_TITLE.get(kind or fam, fam), fontsize=9)
        ax.set_xlabel(_XLABEL.get(kind or fam, fam), fontsize=8)
        ax.set_ylabel("R_avg", fontsize=8)
        ax.set_ylim(0, 1)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=6, ncol=2)
    fig.tight_layout()
    return _save(fig, path)


def resolution_figure(rep: ResolutionReport, path: str | os.PathLike) -> Path:
    """Resolution rate against corner distance d, END- and L-type separately."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), sharey=True)
    for ax, kind in zip(axes, ("END", "L")):
        for i, d in enumerate(rep.detectors):
            r = rep.rate(d, kind=kind)
            ax.plot(list(r), list(r.values()), marker=".", label=d, **_style(d, i))
        ax.set_title(f"{kind}-type pairs ({rep.mode} threshold)", fontsize=9)
        ax.set_xlabel("distance between the corners d (px)", fontsize=8)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("resolved fraction", fontsize=8)
    axes[0].legend(fontsize=6, ncol=2)
    fig.tight_layout()
    return _save(fig, path)


def sigma2_figure(rep: ResolutionReport, path: str | os.PathLike) -> Path:
    """Resolution rate against d for each sigma^2 of the sweep (colour = sigma^2)."""
    fig, ax = plt.subplots(figsize=(6, 3.8))
    cmap = plt.get_cmap("viridis")
    n = len(rep.detectors)
    for i, d in enumerate(rep.detectors):
        r = rep.rate(d)
        ax.plot(list(r), list(r.values()), marker=".", color=cmap(i / max(n - 1, 1)),
                label=d.replace("sogdd:sigma2=", "σ²="))
    ax.set_xlabel("distance between the corners d (px)", fontsize=8)
    ax.set_ylabel(f"resolved fraction ({rep.mode} threshold)", fontsize=8)
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, ncol=2)
    ax.tick_params(labelsize=7)
    fig.tight_layout()
    return _save(fig, path)


