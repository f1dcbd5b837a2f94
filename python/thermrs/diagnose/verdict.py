"""The verdict, from the selection's tests, and the sentences that say it.

``none``
    earned: the nominal model's held-out residual is at the floor (its mean square within the
    null world's), white at the thermal time scales (its smoothed mean square within the
    null's), no candidate has a significant held-out gain, and no candidate leaves less than
    the null's best does (a candidate clearly below the floor proves the floor wrong).
``identified``
    one or more effects selected, none with a rival the data cannot reject, and what is left
    at the floor and white at the thermal time scales — judged against the gap-free world of
    the nominal model (the selected effects' own estimation error counts as gap, not noise).
``ambiguous``
    as identified, but a selected effect has rivals (named) the data cannot reject.
``partially explained``
    effects selected, but what is left is still above the floor or not white: the effects
    named explain a part, the rest is unexplained.
``unexplained``
    a residual above the floor (or structured, or one the floor cannot account for) and no
    candidate with a significant, plausible held-out gain.

Every test is at ``level``/3 (Bonferroni over the three tests ``none`` must pass, so a run
without any gap is called otherwise at most ``level`` of the time).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from thermrs.diagnose.null import quantile_above
from thermrs.diagnose.selection import Step

__all__ = ["decide", "english_list", "format_params", "summary"]


def english_list(items: Sequence[str], *, conj: str = "and") -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    items = list(items)
    if not items:
        return ""
    if len(items) == 1:
        return items[0]
    return f"{', '.join(items[:-1])} {conj} {items[-1]}"


def format_params(p: dict[str, Any]) -> str:
    """An effect's parameters as one short text."""
    parts = []
    for k, v in p.items():
        if isinstance(v, float):
            parts.append(f"{k} = {v:.4g}")
        elif isinstance(v, list):
            parts.append(f"{k} = [{', '.join(f'{x:.3g}' for x in v)}]")
        elif isinstance(v, dict):
            parts.append(f"{k} = {{{', '.join(f'{a}: {b:.3g}' for a, b in v.items())}}}")
        else:
            parts.append(f"{k} = {v}")
    return ", ".join(parts)


def decide(
    steps: list[Step], *, level: float, base_rms: float, floor_um: float
) -> tuple[str, str, list[str]]:
    """(status, reason, rivals) from the selection's steps (module docs)."""
    lvl = level / 3.0
    first, last = steps[0], steps[-1]
    chosen = [s.chosen for s in steps if s.chosen is not None]
    # What is left is judged against the gap-free world of the first step (the nominal model
    # and noise): the selected effects' own estimation error is not noise to hide behind.
    p_floor = quantile_above(first.null_hold_ms, last.hold_ms)
    p_low = quantile_above(first.null_low, last.low)
    at_floor = p_floor >= lvl
    white = p_low >= lvl
    if not chosen:
        contradicted = first.p_floor_contradicted < lvl
        if first.p_at_floor >= lvl and first.p_low >= lvl and not contradicted:
            return (
                "none",
                f"the held-out residual ({base_rms:.2f} µm) is at the noise floor "
                f"({floor_um:.2f} µm; p = {first.p_at_floor:.2f}), white at the thermal time "
                f"scales (p = {first.p_low:.2f}), and no candidate has a significant held-out "
                f"gain (p = {first.p_gain:.2f})",
                [],
            )
        why = []
        if first.p_at_floor < lvl:
            why.append(f"above the noise floor ({floor_um:.2f} µm; p = {first.p_at_floor:.3f})")
        if first.p_low < lvl:
            why.append(f"slow at the thermal time scales (p = {first.p_low:.3f})")
        if contradicted:
            why.append(
                "a candidate takes it further below the floor than noise would "
                f"(p = {first.p_floor_contradicted:.3f}), so it is not noise"
            )
        return (
            "unexplained",
            f"the held-out residual ({base_rms:.2f} µm) is {english_list(why)}, and no candidate "
            "removes a significant, physically plausible part of it",
            [],
        )
    rivals = sorted({r for s in steps for r in s.rivals})
    names = [c.label for c in chosen]
    if not (at_floor and white):
        left = []
        if not at_floor:
            left.append(f"above the floor (p = {p_floor:.3f})")
        if not white:
            left.append(f"slow at the thermal time scales (p = {p_low:.3f})")
        return (
            "partially explained",
            f"{english_list(names)} explain{'s' if len(names) == 1 else ''} part of the gap; "
            f"what is left ({last.hold_ms**0.5:.2f} µm) is still {english_list(left)}: "
            "an effect outside the library, or a second one too small to attribute",
            rivals,
        )
    if rivals:
        groups = [
            english_list([s.chosen.effect, *s.rivals], conj="or")
            for s in steps
            if s.chosen is not None and s.rivals
        ]
        return (
            "ambiguous",
            f"{'; and '.join(groups)} explain the held-out runs about equally well "
            "(the data cannot reject any of them as the truth)",
            rivals,
        )
    return (
        "identified",
        f"{english_list(names)} take{'s' if len(names) == 1 else ''} the held-out residual to "
        f"the noise floor (p = {p_floor:.2f}), white at the thermal time scales "
        f"(p = {p_low:.2f}); every rival is rejected",
        [],
    )


def summary(d: Any) -> str:
    """The diagnosis in a few sentences (``d`` a :class:`thermrs.diagnose.Diagnosis`)."""
    v = d.verdict
    hf = d.how_far
    head = (
        "The nominal model, fitted on the training runs, leaves "
        f"{hf['holdout_rms_before_um']:.2f} µm "
        f"rms on the held-out runs against a noise floor of {d.noise_floor_um:.2f} µm."
    )
    hold = [r for r in d.location if r.get("role") == "holdout"] or d.location
    worst = max(hold, key=lambda r: r["share"]) if hold else None
    where = (
        f" The largest share on the held-out runs lies on run {worst['run']}, camera "
        f"{worst['camera']}, chip axis {worst['axis']}, {worst['phase']}."
        if worst
        else ""
    )
    st = v["status"]
    if st == "identified":
        eff = english_list([s["family"] for s in d.selected]) or str(v["effect"])
        closed = hf.get("gap_closed")
        what = (
            f" Verdict: identified — {eff} ({format_params(v['params'])}); with it the "
            f"held-out rms falls to {hf['holdout_rms_after_um']:.2f} µm"
            + (f", closing {closed:.0%} of the gap above the floor." if closed is not None else ".")
        )
    else:
        what = f" Verdict: {st} — {v['reason']}."
    return head + where + what
