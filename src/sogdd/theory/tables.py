"""Markdown tables for docs/theory.md, computed (never typed in).

``sogdd theory tables`` prints all of them; the numbers in the documentation
come from that command.
"""

from __future__ import annotations

import numpy as np

from .figures import PAPER_PARAMS
from .lattice import lattice_study
from .models import make_model
from .paper_formulas import paper_end_corner, paper_end_edge, paper_l_corner, paper_l_edge
from .psi import coefficients
from .scale_rule import PAPER_CLAIMS, crossings, sigma_range, sigma_range_grid

__all__ = [
    "formula_grid_table",
    "formula_points_table",
    "lattice_table",
    "sigma_grid_table",
    "sigma_table",
    "all_tables",
]

_FORMULAS = (
    ("eq. 4", "end", "corner", paper_end_corner),
    ("eq. 6", "end", "edge", paper_end_edge),
    ("eq. 12", "l", "corner", paper_l_corner),
    ("eq. 14", "l", "edge", paper_l_edge),
)
_ANGLES = {"pi/12": np.pi / 12, "pi/8": np.pi / 8, "pi/4": np.pi / 4, "3pi/8": 3 * np.pi / 8}


def _row(cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _table(head, rows) -> str:
    return "\n".join([_row(head), _row(["---"] * len(head)), *(_row(r) for r in rows)])


def _printed(f, m, theta, sigma, *, erratum=False):
    kw = dict(sigma=sigma, d=m.d, alpha=m.alpha, T1=m.T1, T2=m.T2, erratum=erratum)
    if m.kind == "end":
        kw["beta"] = m.beta
    return f(theta, **kw)


def formula_points_table() -> str:
    """Psi at the paper's parameters (sigma^2 = 1.2): exact, quadrature, printed."""
    p = PAPER_PARAMS
    sigma = float(np.sqrt(1.2))
    rows = []
    for name, model, point, f in _FORMULAS:
        m = make_model(model, d=p["d"], alpha=p["alpha"], beta=p["beta"])
        ex, qu = coefficients(m, point, sigma, "exact"), coefficients(m, point, sigma, "quadrature")
        for lab, th in (("0", 0.0), ("pi/4", np.pi / 4), ("pi/2", np.pi / 2), ("3pi/4", 3 * np.pi / 4)):
            t = np.array([th])
            e, q, pr = float(ex(t)[0]), float(qu(t)[0]), float(_printed(f, m, t, sigma)[0])
            rows.append([name, f"{model.upper()} {point}", lab, f"{e:.4f}", f"{q:.4f}", f"{pr:.4f}",
                         f"{pr - e:+.4f}"])
    head = ["formula", "model/point", "theta", "exact", "quadrature", "printed", "printed - exact"]
    return _table(head, rows)


def formula_grid_table(*, quadrature: bool = True) -> str:
    """Worst and median error of each printed formula over a parameter grid.

    Errors are ``max_theta |Psi_printed - Psi_exact| / max_theta |Psi_exact|``,
    and the same for the quadrature and for the printed formula with the two
    corrections of :mod:`.paper_formulas` (``erratum=True``).
    """
    ds, sigmas = (1.0, 2.0, 3.0, 5.0), (0.5, 0.8, 1.12, 1.5, 2.5)
    alphas, betas = list(_ANGLES.values()), (np.pi / 6, np.pi / 3, 5 * np.pi / 12)
    th = np.linspace(0.0, np.pi, 37)
    rows = []
    for name, model, point, f in _FORMULAS:
        errs, errs_fix, errs_q = [], [], []
        for d in ds:
            for s in sigmas:
                for a in alphas:
                    for b in betas if model == "end" else (None,):
                        m = make_model(model, d=d, alpha=a, beta=b)
                        ex = coefficients(m, point, s, "exact")
                        ve = ex(th)
                        scale = np.max(np.abs(ve))
                        errs.append(np.max(np.abs(_printed(f, m, th, s) - ve)) / scale)
                        errs_fix.append(np.max(np.abs(_printed(f, m, th, s, erratum=True) - ve)) / scale)
                        if quadrature:
                            vq = coefficients(m, point, s, "quadrature")(th)
                            errs_q.append(np.max(np.abs(vq - ve)) / scale)
        rows.append([name, f"{model.upper()} {point}", len(errs), f"{np.median(errs):.3f}",
                     f"{np.max(errs):.3f}", f"{np.max(errs_fix):.1e}",
                     f"{np.max(errs_q):.1e}" if quadrature else "-"])
    return _table(["formula", "model/point", "cases", "printed: median rel. err", "printed: max rel. err",
                   "corrected: max rel. err", "quadrature: max rel. err"], rows)


def sigma_table() -> str:
    """The paper's examples: exact and printed-formula crossings against the claims."""
    p = PAPER_PARAMS
    rows = []
    for model, claim in (("end", PAPER_CLAIMS["sigma_11"]), ("l", PAPER_CLAIMS["sigma_13"])):
        kw = dict(d=p["d"], alpha=p["alpha"], beta=p["beta"] if model == "end" else None)
        ex = sigma_range(model, **kw, sigma_min=0.05, sigma_max=50.0)
        cr = crossings(model, **kw, sigma_min=0.05, sigma_max=50.0)
        crp = crossings(model, **kw, sigma_min=0.05, sigma_max=50.0, method="paper")
        fmt = ", ".join(f"({lo:.4g}, {hi:.4g})" for lo, hi in ex)
        rows.append([
            model.upper(), fmt,
            ", ".join(f"{c:.4f} (sigma^2 = {c * c:.3f})" for c in cr) or "none in [0.05, 50]",
            ", ".join(f"{c:.4f}" for c in crp) or "none in [0.05, 50]",
            f"sigma < {claim}",
        ])
    return _table(["model (d = 3)", "corner wins for sigma in", "crossing E1 = E2 (exact)",
                   "crossing (printed eqs.)", "paper's claim"], rows)


def sigma_grid_table() -> str:
    """Crossings over a grid of d, alpha, beta; ``sigma* / d`` shows the scaling law."""
    alphas = list(_ANGLES.values())
    rows = []
    for model in ("end", "l"):
        for d in (1.0, 2.0, 3.0, 4.0, 6.0):
            recs = sigma_range_grid(model, [d], alphas, alphas if model == "end" else None,
                                    sigma_min=0.05, sigma_max=100.0)
            first = np.array([r["first_crossing"] for r in recs if r["first_crossing"] is not None])
            none = sum(r["first_crossing"] is None for r in recs)
            if len(first):
                rng_s = f"{first.min():.3f} .. {np.median(first):.3f} .. {first.max():.3f}"
                rng_r = f"{first.min() / d:.4f} .. {first.max() / d:.4f}"
            else:
                rng_s = rng_r = "-"
            rows.append([model.upper(), f"{d:g}", len(recs), none, rng_s, rng_r])
    return _table(["model", "d", "(alpha, beta) cases", "no crossing in [0.05, 100]",
                   "first crossing sigma*: min .. median .. max", "sigma* / d: min .. max"], rows)


def lattice_table(*, sigma2s=None, ds=(2.0, 3.0, 4.0, 5.0, 6.0, 8.0)) -> str:
    """The lattice study at the paper's angles: Upsilon and energy, corner vs edge."""
    p = PAPER_PARAMS
    s2 = np.asarray(sigma2s if sigma2s is not None else np.round(np.arange(0.5, 4.01, 0.1), 2))
    j12 = int(np.argmin(np.abs(s2 - 1.2)))

    def runs(mask):
        out, start = [], None
        for k, w in enumerate(mask):
            if w and start is None:
                start = k
            if (not w or k == len(mask) - 1) and start is not None:
                end = k if w else k - 1
                out.append(f"{s2[start]:.1f}-{s2[end]:.1f}")
                start = None
        return ", ".join(out) or "none"

    rows = []
    for model in ("end", "l"):
        st = lattice_study(model, s2, np.asarray(ds), alpha=p["alpha"], beta=p["beta"])
        for i, d in enumerate(st.ds):
            rows.append([
                model.upper(), f"{d:g}",
                f"{st.measure_corner[i, j12] / st.measure_edge[i, j12]:.3g}",
                runs(st.measure_wins[i]),
                # within one pixel of the corner reaches the edge pixel itself when d/2 <= 1
                runs(st.measure_near_wins[i]) if d > 2.0 else "n/a",
                f"{st.energy_corner[i, j12] / st.energy_edge[i, j12]:.3g}",
                runs(st.energy_wins[i]),
            ])
    return _table(["model", "d (px)", "Upsilon corner/edge at sigma^2 = 1.2",
                   f"sigma^2 in [{s2[0]:g}, {s2[-1]:g}] where Upsilon(corner) > Upsilon(edge)",
                   "same, max Upsilon within 1 px of the corner",
                   "energy corner/edge at sigma^2 = 1.2", "sigma^2 where energy(corner) > energy(edge)"], rows)


def all_tables(*, quadrature: bool = True) -> str:
    """Every table, with headings, as one markdown string."""
    parts = [
        ("Psi at the paper's parameters, sigma^2 = 1.2", formula_points_table()),
        ("Printed formulas over a grid", formula_grid_table(quadrature=quadrature)),
        ("Scale rule, the paper's examples", sigma_table()),
        ("Scale rule over a grid", sigma_grid_table()),
        ("Lattice study", lattice_table()),
    ]
    return "\n\n".join(f"### {h}\n\n{t}" for h, t in parts) + "\n"
