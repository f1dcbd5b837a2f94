"""Moved to :mod:`thermrs.analyses.fit`; its names stay importable from here."""

from __future__ import annotations

from thermrs.analyses.fit import FitResult, fit_document, training_alphas, training_axes

__all__ = ["FitResult", "fit_document", "training_alphas", "training_axes"]
