"""The field's regressions beside the physical model (``thermrs diagnose --baselines``): the
library face of :mod:`thermrs.diagnose.baselines` (scoring), :mod:`thermrs.diagnose.
baseline_models` (the regressions) and :mod:`thermrs.diagnose.baseline_law` (the best linear
one as a compensation law)."""

from __future__ import annotations

from thermrs.diagnose.baseline_law import BaselineLaw
from thermrs.diagnose.baseline_models import (
    LOWPASS_TAUS_MIN,
    MODELS,
    Features,
    FittedBaseline,
    cv_folds,
    features,
    fit_baseline,
    lowpass,
)
from thermrs.diagnose.baselines import (
    BaselineComparison,
    ModelScore,
    baselines_folds,
    compare_baselines,
    said,
)

__all__ = [
    "LOWPASS_TAUS_MIN",
    "MODELS",
    "BaselineComparison",
    "BaselineLaw",
    "Features",
    "FittedBaseline",
    "ModelScore",
    "baselines_folds",
    "compare_baselines",
    "cv_folds",
    "features",
    "fit_baseline",
    "lowpass",
    "said",
]
