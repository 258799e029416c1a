"""Figures: the paper's Fig. 3 (END) and Fig. 5 (L), the sigma range, the lattice study, Fig. 1.

All drawing uses matplotlib's Agg backend (no display needed).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .lattice import lattice_study  # noqa: E402
from .models import make_model  # noqa: E402
from .psi import representation  # noqa: E402
from .scale_rule import PAPER_CLAIMS, energy_gap  # noqa: E402

__all__ = ["PAPER_PARAMS", "figure_lattice", "figure_psi", "figure_sigma_range", "write_figures"]

#: The parameters of the paper's Figs. 3 and 5.
PAPER_PARAMS = dict(T1=50.0, T2=100.0, alpha=np.pi / 8, beta=np.pi / 3, d=3.0, sigma_end=1.12, sigma_l=1.15)


def figure_psi(model: str, path: Path, *, sigma: float | None = None) -> Path:
    """Psi_1 (corner) and Psi_2 (edge point) against theta, exact and as printed."""
    p = PAPER_PARAMS
    sigma = float(sigma if sigma is not None else (p["sigma_end"] if model == "end" else p["sigma_l"]))
    beta = p["beta"] if model == "end" else None
    th = np.linspace(0.0, 2.0 * np.pi, 721)
    kw = dict(d=p["d"], alpha=p["alpha"], beta=beta, T1=p["T1"], T2=p["T2"])
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    curves = (("corner", "C0", r"$\Psi_1$ corner $u=0$"), ("edge", "C3", r"$\Psi_2$ edge $u=d/2$"))
    for point, colour, label in curves:
        ax.plot(th, representation(model, point, th, sigma, **kw), color=colour, lw=2, label=f"{label}, exact")
        ax.plot(th, representation(model, point, th, sigma, method="paper", **kw), color=colour, lw=1.2,
                ls="--", label=f"{label}, printed eq.")
    eqs = "4, 6" if model == "end" else "12, 14"
    title = "END" if model == "end" else "L"
    ang = r"$\alpha=\pi/8$" + (r", $\beta=\pi/3$" if model == "end" else "")
    ax.set_title(f"{title}-type model: {ang}, $d=3$, $\\sigma={sigma:g}$ (printed: eqs. {eqs})", fontsize=10)
    ax.set_xlabel(r"$\theta$ (rad)")
    ax.set_ylabel(r"$\Psi(\theta)$")
    ax.set_xlim(0, 2 * np.pi)
    ax.axhline(0, color="0.6", lw=0.6)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def figure_sigma_range(path: Path, *, ds=(2.0, 3.0, 4.0, 6.0)) -> Path:
    """``(E_1 - E_2) / (E_1 + E_2)`` against sigma for several d, END and L."""
    p = PAPER_PARAMS
    sig = np.geomspace(0.3, 6.0, 300)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), dpi=100, sharey=True)
    for ax, model in zip(axes, ("end", "l")):
        for d in ds:
            m = make_model(model, d=d, alpha=p["alpha"], beta=p["beta"])
            ax.plot(sig, [energy_gap(m, s) for s in sig], label=f"d = {d:g}")
            if d == 3.0:
                ax.plot(sig, [energy_gap(m, s, "paper") for s in sig], color="k", ls=":", lw=1,
                        label="d = 3, printed eqs.")
        lo, hi = PAPER_CLAIMS["range"]
        ax.axvspan(lo, hi, color="0.85", label=r"paper: $\sigma\in(1,1.2)$")
        ax.axhline(0, color="0.4", lw=0.8)
        ax.set_xscale("log")
        ticks = [0.3, 0.5, 1.0, 2.0, 3.0, 6.0]
        ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel(r"$\sigma$")
        title = r"END, $\alpha=\pi/8$, $\beta=\pi/3$" if model == "end" else r"L, $\alpha=\pi/8$"
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=8)
    axes[0].set_ylabel(r"$(E_1-E_2)/(E_1+E_2)$   (> 0: corner wins)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def figure_lattice(path: Path, *, ds=(2.0, 3.0, 4.0, 5.0, 6.0), sigma2s=None) -> Path:
    """``log10(Upsilon_corner / Upsilon_edge)`` on the pixel lattice against sigma^2."""
    p = PAPER_PARAMS
    s2 = np.asarray(sigma2s if sigma2s is not None else np.round(np.arange(0.5, 4.01, 0.1), 2))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), dpi=100, sharey=True)
    for ax, model in zip(axes, ("end", "l")):
        st = lattice_study(model, s2, np.asarray(ds), alpha=p["alpha"], beta=p["beta"])
        for i, d in enumerate(st.ds):
            with np.errstate(divide="ignore", invalid="ignore"):
                ax.plot(s2, np.log10(st.measure_corner[i] / st.measure_edge[i]), label=f"d = {d:g}")
        ax.axvline(1.2, color="k", ls="--", lw=1, label=r"preset $\sigma^2=1.2$")
        ax.axhline(0, color="0.4", lw=0.8)
        ax.set_xlabel(r"$\sigma^2$")
        name = "END" if model == "end" else "L"
        ax.set_title(f"{name}-type on the lattice (K=8, 7x7 window)", fontsize=10)
        ax.legend(fontsize=8)
    axes[0].set_ylabel(r"$\log_{10}(\Upsilon_{corner}/\Upsilon_{edge})$   (> 0: corner wins)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def write_figures(out: str | Path, *, lattice: bool = True, data: str | Path | None = None) -> list[Path]:
    """Write all theory figures as PNGs into ``out`` (created if needed); returns the paths.

    With ``data`` (the shared data root) the paper's Fig. 1 is redone on a real
    image too (:func:`sogdd.theory.fig1.write_fig1`: ``fig1_*.png``).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [
        figure_psi("end", out / "fig3_end.png"),
        figure_psi("l", out / "fig5_l.png"),
        figure_sigma_range(out / "sigma_range.png"),
    ]
    if lattice:
        paths.append(figure_lattice(out / "lattice.png"))
    if data is not None:
        from .fig1 import write_fig1  # reads an image: only when asked

        paths += write_fig1(out, data)
    return paths
