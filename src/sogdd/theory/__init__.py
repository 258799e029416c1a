"""Theory of high-resolution corners: the paper's SOGDD representations, checked.

The paper models two adjacent corners (END type, eqs. 3 and 5) and a corner
next to an edge (L type, eqs. 11 and 13), derives the SOGDD representation
Psi(theta) at the corner and at the edge point between (eqs. 4, 6, 12, 14) and
turns eq. 15 into a range of scales. This package computes all of it three ways:

* :mod:`.quadrature` -- numerical integration of eq. 3 (reference);
* :mod:`.closed_form` -- our exact closed forms (wedges and boundary fluxes);
* :mod:`.paper_formulas` -- the printed formulas, transcribed literally;

plus the scale rule (:mod:`.scale_rule`), the same question on the pixel
lattice with the detector's discrete filters (:mod:`.lattice`) and figures
(:mod:`.figures`). See docs/theory.md for the results.
"""

from .closed_form import centred_wedge, exact_coefficients, offset_wedge
from .lattice import LatticeScores, LatticeStudy, lattice_scores, lattice_study, rasterise
from .models import MODELS, POINTS, Boundary, CornerModel, Wedge, make_model
from .paper_formulas import paper_end_corner, paper_end_edge, paper_l_corner, paper_l_edge
from .psi import METHODS, coefficients, representation
from .quadrature import quadrature_coefficients, region_coefficients
from .scale_rule import (
    PAPER_CLAIMS,
    SigmaScan,
    crossings,
    energies,
    energy_gap,
    scan_sigma,
    sigma_range,
    sigma_range_grid,
)
from .steering import Coefficients, fit_coefficients

__all__ = [
    "METHODS",
    "MODELS",
    "PAPER_CLAIMS",
    "POINTS",
    "Boundary",
    "Coefficients",
    "CornerModel",
    "LatticeScores",
    "LatticeStudy",
    "SigmaScan",
    "Wedge",
    "centred_wedge",
    "coefficients",
    "crossings",
    "energies",
    "energy_gap",
    "exact_coefficients",
    "fit_coefficients",
    "lattice_scores",
    "lattice_study",
    "make_model",
    "offset_wedge",
    "paper_end_corner",
    "paper_end_edge",
    "paper_l_corner",
    "paper_l_edge",
    "quadrature_coefficients",
    "rasterise",
    "region_coefficients",
    "representation",
    "scan_sigma",
    "sigma_range",
    "sigma_range_grid",
]
