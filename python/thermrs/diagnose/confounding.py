"""Which candidates the runs cannot tell apart: canonical correlations of their signatures
with the nominal model projected out (descriptive; the verdict's rivals come from the
parametric rival test of :mod:`.selection`).

Two signatures whose largest canonical correlation exceeds :data:`CONFOUND_COS` are listed as
confounded *on these runs*, with the run or channel of the data on which they differ most.
Which new measurement would separate them is a computation, not a template:
``thermrs design`` does it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.family_fit import DesignMatrix

__all__ = ["CONFOUND_COS", "canonical_cos", "confounded_pairs", "residualised"]

FloatArray = npt.NDArray[np.float64]

#: Canonical correlation above which two signatures are listed as confounded (a description:
#: no verdict depends on it).
CONFOUND_COS = 0.9


def residualised(design: DesignMatrix, cols: FloatArray) -> FloatArray:
    """Columns with the nominal model (α column and offsets) projected out, weighted, on
    every row; unit-norm."""
    w = np.sqrt(design.weights)
    base = np.column_stack([design.s, design.offsets]) * w[:, None]
    q, _ = np.linalg.qr(base / np.maximum(np.linalg.norm(base, axis=0), 1e-300))
    c = cols * w[:, None]
    c = c - q @ (q.T @ c)
    n = np.linalg.norm(c, axis=0)
    return c / np.where(n > 0, n, 1.0)


def canonical_cos(a: FloatArray, b: FloatArray) -> float:
    """Largest canonical correlation between two column spaces."""
    qa, _ = np.linalg.qr(a)
    qb, _ = np.linalg.qr(b)
    return float(np.clip(np.linalg.svd(qa.T @ qb, compute_uv=False)[0], 0.0, 1.0))


def _where_they_differ(design: DesignMatrix, a: FloatArray, b: FloatArray) -> str:
    vs = design.vs
    run2 = np.concatenate([vs.run, vs.run])
    cam2 = np.concatenate([vs.camera, vs.camera])
    subsets: list[tuple[str, npt.NDArray[np.bool_]]] = []
    for r in np.unique(run2):
        subsets.append((f"run {r}", run2 == r))
    for c in np.unique(cam2):
        for ax in ("u", "v"):
            subsets.append((f"camera {c} chip axis {ax}", (cam2 == c) & (vs.axis == ax)))
    best: tuple[float, str] | None = None
    for label, m in subsets:
        if m.sum() < 10:
            continue
        sa, sb = a[m], b[m]
        if np.linalg.norm(sa) < 1e-9 or np.linalg.norm(sb) < 1e-9:
            continue
        c = canonical_cos(sa, sb)
        if best is None or c < best[0]:
            best = (c, label)
    if best is not None and best[0] < CONFOUND_COS:
        return (
            f"on these runs they differ most on {best[1]} (canonical correlation "
            f"{best[0]:.2f} there); `thermrs design` computes the measurement that separates them"
        )
    return (
        "no run or channel of these data separates them; `thermrs design` computes the "
        "measurement that does"
    )


def _check_instrument(a: str, b: str) -> str:
    """For a pair with the thermal camera's error in it: what separates them is checking the
    instrument, not a run of the robot."""
    from thermrs.effects import is_instrument

    inst = [e for e in (a, b) if is_instrument(e)]
    if not inst:
        return ""
    return (
        f"{inst[0]} is the thermal camera's error: calibrate the camera (a contact probe on the "
        "link for its emissivity, its offset and clock) and diagnose again; no run of the "
        "robot separates them"
    )


def confounded_pairs(
    design: DesignMatrix, pool: list[tuple[str, str, FloatArray]]
) -> list[dict[str, Any]]:
    """Confounded pairs among (effect, family label, columns) candidates."""
    res = [(e, lab, residualised(design, c)) for e, lab, c in pool]
    out: list[dict[str, Any]] = []
    for i, (ea, la, ca) in enumerate(res):
        for eb, lb, cb in res[i + 1 :]:
            if ea == eb:
                continue
            c = canonical_cos(ca, cb)
            if c >= CONFOUND_COS:
                out.append(
                    {
                        "effects": [ea, eb],
                        "families": [la, lb],
                        "cos": c,
                        "separate_by": _check_instrument(ea, eb)
                        or _where_they_differ(design, ca, cb),
                    }
                )
    return out
