"""Numbers as a metrologist may read them: a figure shown only where it means something.

- :func:`end_error`: a % error of an end-of-run drift; where the measured drift is not
  distinguishable from zero (a % of it would be arbitrary), the error in µm, said "within
  noise" only where the prediction's error itself is inside the noise.
- :func:`tau_determined`: whether a fitted heating curve's time constant is determined (its
  standard error below half of it); an undetermined one is not a heating curve to draw.
- :func:`gap_closed`: the share of the gap above the noise floor an effect closed, capped at
  100 % with the reason when the effect removed more than the gap (the floor is then
  estimated above what is left).
- :func:`implausible`: why a candidate effect's parameters lie outside the effect's own
  physical bounds (SPEC §6, checked in the Rust core), or None.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

__all__ = [
    "end_error",
    "fmt",
    "fmt_alpha",
    "gap_closed",
    "implausible",
    "tau_determined",
    "within_noise",
]

#: A measured end drift within this many standard deviations of the difference of two noisy
#: visits (√2·noise) of zero is "within noise".
NOISE_Z = 2.0
#: A time constant whose standard error exceeds this share of it is not determined.
TAU_REL_SE = 0.5


def fmt(x: object, digits: int = 2, *, sign: bool = False) -> str:
    """A number with ``digits`` decimals (``sign``: always signed); "—" for None, a bool or
    NaN; anything else as text.

    Examples
    --------
    >>> fmt(1.23456), fmt(None), fmt(float("nan")), fmt(-0.5, 1, sign=True), fmt(2.0, sign=True)
    ('1.23', '—', '—', '-0.5', '+2.00')
    """
    if x is None or isinstance(x, bool):
        return "—"
    if not isinstance(x, int | float):
        return str(x)
    v = float(x)
    if not math.isfinite(v):
        return "—"
    return f"{v:+.{digits}f}" if sign else f"{v:.{digits}f}"


def fmt_alpha(a: float | None) -> str:
    """α (1/K) in 10⁻⁶/K, three decimals: ``fmt_alpha(2.3438e-05)`` → ``'23.438'``."""
    return "—" if a is None else fmt(a * 1e6, 3)


def within_noise(measured_um: float, noise_um: float) -> bool:
    """Whether an end drift (the difference of two visits, each with ``noise_um``) is not
    distinguishable from zero."""
    if not (math.isfinite(measured_um) and math.isfinite(noise_um)):
        return False
    return abs(measured_um) <= NOISE_Z * math.sqrt(2.0) * noise_um


def end_error(
    predicted_um: float, measured_um: float, noise_um: float, *, suffix: str = " %"
) -> str:
    """``+12.34 %``; where the measured drift is inside the noise (a % of it would be
    arbitrary), the error in µm: ``within noise (Δ +1.20 µm, noise 2.00 µm)`` where the
    prediction's error itself is inside the noise of a difference of two visits, else
    ``Δ +6.10 µm, 2.2× the visit-pair noise (drift too small for a %)``. ``suffix`` follows
    the percentage (a column headed "%" takes "").

    Examples
    --------
    >>> end_error(10.0, 8.0, 0.5)
    '+25.00 %'
    >>> end_error(2.56, -0.67, 2.0)
    'within noise (Δ +3.23 µm, noise 2.00 µm)'
    >>> end_error(7.0, 0.9, 1.0)
    'Δ +6.10 µm, 4.3× the visit-pair noise (drift too small for a %)'
    """
    if within_noise(measured_um, noise_um) or measured_um == 0:
        diff = predicted_um - measured_um
        if within_noise(diff, noise_um):
            return f"within noise (Δ {diff:+.2f} µm, noise {noise_um:.2f} µm)"
        pair = math.sqrt(2.0) * noise_um
        times = f", {abs(diff) / pair:.1f}× the visit-pair noise" if pair > 0 else ""
        return f"Δ {diff:+.2f} µm{times} (drift too small for a %)"
    return f"{(predicted_um - measured_um) / measured_um * 100:+.2f}{suffix}"


def tau_determined(tau_min: float | None, tau_se_min: float | None) -> bool:
    """Whether a heating curve's τ is determined: finite, positive, its standard error finite
    and below :data:`TAU_REL_SE` of it."""
    if tau_min is None or tau_se_min is None:
        return False
    if not (math.isfinite(tau_min) and math.isfinite(tau_se_min)) or tau_min <= 0:
        return False
    return tau_se_min <= TAU_REL_SE * tau_min


def gap_closed(share: float | None, rms_after_um: float | None, floor_um: float | None) -> str:
    """The share of the gap closed as shown: ``83.0 %``, or ``100 % (…)`` with why it is
    capped.

    Examples
    --------
    >>> gap_closed(0.5, 2.0, 1.0)
    '50.0 %'
    >>> gap_closed(1.24, 1.73, 3.39)  # doctest: +ELLIPSIS
    '100 % (the effect removed 124 % of the gap: what is left, 1.73 µm, is below the noise ...'
    """
    if share is None or not math.isfinite(share):
        return "—"
    if share <= 1.0:
        return f"{100 * share:.1f} %"
    left = "" if rms_after_um is None else f"{rms_after_um:.2f} µm, "
    floor = "" if floor_um is None else f" {floor_um:.2f} µm"
    return (
        f"100 % (the effect removed {100 * share:.0f} % of the gap: what is left, {left}is "
        f"below the noise floor{floor}, so the floor is estimated too high)"
    )


def implausible(effect: str, params: Mapping[str, Any]) -> str | None:
    """Why ``params`` cannot be the physics of ``effect``, in words (one line), or None: a
    parameter beyond the effect's physical bounds, or a time constant at the end of the range
    the diagnoser searched (the data want a process faster or slower than any it tried)."""
    import re

    from thermrs.effect_base import TAU_GRID_MIN
    from thermrs.effects import effect_classes, from_dict
    from thermrs.errors import ThermrsError

    if effect not in effect_classes():
        return None
    tau = params.get("tau_min")
    if isinstance(tau, int | float) and tau in (TAU_GRID_MIN[0], TAU_GRID_MIN[-1]):
        end = "longest" if tau == TAU_GRID_MIN[-1] else "shortest"
        return (
            f"its time constant is at the search bound ({tau:g} min, the {end} tried): the data "
            f"want a {'slower' if end == 'longest' else 'faster'} process than any the library "
            "searched, so this one stands in for it"
        )
    try:
        from_dict({"name": effect, **params})
    except ThermrsError as e:
        text = str(e)
        m = re.match(
            r"effect \S+: (?P<key>[^:]+): is (?P<value>[^,]+), expected (?P<want>.*)", text
        )
        if m is None:
            return text
        want = m["want"].removeprefix("a finite value with ").strip()
        try:
            value = f"{float(m['value']):.4g}"
        except ValueError:
            value = m["value"]
        return f"its {m['key']} would be {value}, beyond what the effect can physically be ({want})"
    return None
    try:
        from_dict({"name": effect, **params})
    except ThermrsError as e:
        return str(e)
    return None
