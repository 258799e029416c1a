"""The paper's two high-resolution corner models as data (eqs. 3, 5, 11 and 13).

Coordinates are the paper's: ``x`` runs along the edge, ``y`` points *up* and the
brighter-or-darker region of grey level ``T1`` lies above a polyline ``y = b(x)``;
``T2`` fills the rest.

END type (eq. 3): corners at ``u = 0`` and ``u = d`` joined by the edge ``y = 0``;
left of the first corner the boundary is the ray ``y = cot(alpha) x`` (x < 0),
right of the second the ray ``y = -cot(beta) (x - d)`` (x > d).

L type (eq. 11): a single corner at ``u = 0``; the boundary is the ray
``y = cot(alpha) x`` for ``x < 0`` and the edge ``y = 0`` for ``x >= 0``.

Each model is evaluated at two points on the edge: the corner at ``u = 0`` and
the edge point at ``u = d/2`` (eqs. 5 and 13 are eqs. 3 and 11 translated so that
this point is the origin). Everything here is expressed relative to the
evaluation point, which is the origin of the SOGDD filter in eq. 3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "POINTS",
    "MODELS",
    "Boundary",
    "CornerModel",
    "Wedge",
    "make_model",
]

MODELS = ("end", "l")
POINTS = ("corner", "edge")


@dataclass(frozen=True)
class Wedge:
    """The infinite wedge ``{apex + r (cos phi, sin phi): r >= 0, phi1 <= phi <= phi2}``."""

    apex: tuple[float, float]
    phi1: float
    phi2: float


@dataclass(frozen=True)
class Boundary:
    """The polyline ``y = b(x)`` below the ``T1`` region ``{y >= b(x)}``.

    ``vertices`` (n, 2) are sorted by ``x``; left of the first vertex ``b`` has
    slope ``slope_left``, right of the last ``slope_right``, and in between it is
    linear between consecutive vertices.
    """

    vertices: np.ndarray
    slope_left: float
    slope_right: float

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """``b(x)`` for an array of ``x``."""
        x = np.asarray(x, dtype=np.float64)
        vx, vy = self.vertices[:, 0], self.vertices[:, 1]
        out = np.interp(x, vx, vy)
        out = np.where(x < vx[0], vy[0] + self.slope_left * (x - vx[0]), out)
        return np.where(x > vx[-1], vy[-1] + self.slope_right * (x - vx[-1]), out)


@dataclass(frozen=True)
class CornerModel:
    """One of the paper's corner models with its parameters.

    Parameters
    ----------
    kind : {"end", "l"}
    d : float
        Distance between the two corners (END) or from the corner to the edge
        point's double (L); the edge point is at ``u = d/2``.
    alpha, beta : float
        Angles in ``(0, pi/2)``; ``beta`` is used by the END model only.
    T1, T2 : float
        Grey level above and below the boundary.
    """

    kind: str
    d: float
    alpha: float
    beta: float | None = None
    T1: float = 50.0
    T2: float = 100.0

    @property
    def contrast(self) -> float:
        """``T1 - T2``: since psi integrates to zero, Psi = (T1 - T2) * integral over T1."""
        return float(self.T1) - float(self.T2)

    def offset(self, point: str) -> float:
        """Position ``u`` of an evaluation point along the edge."""
        if point == "corner":
            return 0.0
        if point == "edge":
            return 0.5 * self.d
        raise ValueError(f"point must be 'corner' or 'edge', not {point!r}")

    def boundary(self, point: str) -> Boundary:
        """The boundary polyline in coordinates centred on the evaluation point."""
        u = self.offset(point)
        cot_a = 1.0 / np.tan(self.alpha)
        if self.kind == "end":
            verts = np.array([[-u, 0.0], [self.d - u, 0.0]])
            return Boundary(verts, cot_a, -1.0 / np.tan(self.beta))
        return Boundary(np.array([[-u, 0.0]]), cot_a, 0.0)

    def wedges(self, point: str) -> list[Wedge]:
        """The ``T1`` region as the upper half-plane ``y >= 0`` plus disjoint wedges.

        Below the edge line the ``T1`` region consists of the wedge between the
        ``-x`` direction and the left ray (angle ``pi/2 - alpha``) and, for END,
        the wedge between the right ray and the ``+x`` direction (angle
        ``pi/2 - beta``). A half-plane bounded by a line through the evaluation
        point contributes nothing to Psi (see :mod:`.closed_form`).
        """
        u = self.offset(point)
        out = [Wedge((-u, 0.0), np.pi, 1.5 * np.pi - self.alpha)]
        if self.kind == "end":
            out.append(Wedge((self.d - u, 0.0), self.beta - 0.5 * np.pi, 0.0))
        return out


def make_model(
    model: str,
    *,
    d: float,
    alpha: float,
    beta: float | None = None,
    T1: float = 50.0,
    T2: float = 100.0,
) -> CornerModel:
    """Validate parameters and build a :class:`CornerModel`.

    Raises
    ------
    ValueError
        On an unknown model, a non-positive or non-finite ``d``, angles outside
        ``(0, pi/2)``, or a missing ``beta`` for the END model.
    """
    kind = str(model).lower()
    if kind not in MODELS:
        raise ValueError(f"model must be 'end' or 'l', not {model!r}")
    if not (np.isfinite(d) and d > 0):
        raise ValueError(f"d must be a positive number, not {d!r}")
    angles = {"alpha": alpha}
    if kind == "end":
        if beta is None:
            raise ValueError("the END model needs beta")
        angles["beta"] = beta
    for name, val in angles.items():
        if not (np.isfinite(val) and 0.0 < val < 0.5 * np.pi):
            raise ValueError(f"{name} must lie in (0, pi/2), not {val!r}")
    return CornerModel(
        kind, float(d), float(alpha), None if kind == "l" else float(beta), float(T1), float(T2)
    )
