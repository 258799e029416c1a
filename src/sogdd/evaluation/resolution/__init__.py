"""Adjacent-corner resolution on rendered END- and L-type pairs with exact ground truth.

:mod:`.scenes` renders the configurations, :mod:`.protocol` scores detectors
on them (default thresholds, or the best threshold per configuration).
"""

from .protocol import ResolutionReport, evaluate_resolution, score_configuration, score_oracle, sigma2_specs
from .scenes import Config, configurations, render_configuration

__all__ = ["Config", "ResolutionReport", "configurations", "evaluate_resolution", "render_configuration",
           "score_configuration", "score_oracle", "sigma2_specs"]
