"""The verdict, from the selection's tests, and the sentences that say it.

``none``
    earned: the nominal model's held-out residual is at the floor (its mean square within the
    null world's), white at the thermal time scales (its smoothed mean square within the
    null's), no candidate has a significant held-out gain that also clears the practical
    margin, and no candidate leaves less than the null's best does (a candidate clearly below
    the floor proves the floor wrong). Said with the size of effect the data rule out: "no
    effect above X µm at 95 %". The null world is the user's: noise, and a rig within its
    stated tolerances (:mod:`.tolerances`).
``identified``
    one or more effects selected, none with a rival the data cannot reject, and what is left
    at the floor and white at the thermal time scales — judged against the gap-free world of
    the nominal model (the selected effects' own estimation error counts as gap, not noise).
``ambiguous``
    as identified, but a selected effect has rivals (named) the data cannot reject.
``partially explained``
    effects selected, but what is left is still above the floor or not white, or the effects
    cannot be shown to close at least half of the gap above the floor (the lower end of the
    share closed, with the floor at the low end of its 95 % interval, below
    :data:`MIN_CLOSED`), or an effect outside the library (an excluded one) explains the gap
    as well and the data cannot reject it: the effects named take a part off, and may only
    stand in for an effect outside the library.
``unexplained``
    a residual above the floor (or structured, or one the floor cannot account for) and no
    candidate with a significant, plausible held-out gain.

Every test is at ``level``/4 (Bonferroni over the four tests ``none`` must pass, so a run
without any gap is called otherwise at most ``level`` of the time). A p-value is never
printed below what the draws resolve (``< 0.005`` with 199 draws).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from thermrs.diagnose.null import format_p, quantile_above
from thermrs.diagnose.selection import Step

__all__ = ["MIN_CLOSED", "decide", "english_list", "format_params", "summary"]

#: An effect is said to explain the gap (``identified``, ``ambiguous``) only if it closes at
#: least this share of the gap above the floor at 95 %: one that leaves more than half of it is
#: a stand-in, not the cause.
MIN_CLOSED = 0.5


def english_list(items: Sequence[str], *, conj: str = "and") -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    items = list(items)
    if not items:
        return ""
    if len(items) == 1:
        return items[0]
    return f"{', '.join(items[:-1])} {conj} {items[-1]}"


def format_params(p: dict[str, Any], ci: dict[str, Any] | None = None) -> str:
    """An effect's parameters as one short text, each scalar with its 95 % interval where
    ``ci`` (``params_ci95``) gives one."""
    parts = []
    ci = ci or {}
    for k, v in p.items():
        c = ci.get(k)
        if isinstance(v, float) and isinstance(c, list | tuple) and len(c) == 2:
            parts.append(f"{k} = {v:.4g} [{float(c[0]):.4g}, {float(c[1]):.4g}]")
        elif isinstance(v, float):
            parts.append(f"{k} = {v:.4g}")
        elif isinstance(v, list):
            parts.append(f"{k} = [{', '.join(f'{x:.3g}' for x in v)}]")
        elif isinstance(v, dict):
            parts.append(f"{k} = {{{', '.join(f'{a}: {b:.3g}' for a, b in v.items())}}}")
        else:
            parts.append(f"{k} = {v}")
    return ", ".join(parts)


def decide(
    steps: list[Step],
    *,
    level: float,
    base_rms: float,
    floor_um: float,
    margin_um: float = 0.0,
    floor_se_um: float | None = None,
    tolerances_stated: bool = True,
) -> tuple[str, str, list[str]]:
    """(status, reason, rivals) from the selection's steps (module docs);
    ``tolerances_stated`` False: the rig file states no ``[tolerances]`` and the null drew the
    defaults, which the reason says."""
    lvl = level / 4.0
    tolerances = (
        "the rig's stated tolerances"
        if tolerances_stated
        else "the default tolerances (the rig file states no [tolerances]; state yours)"
    )
    b = steps[0].draws

    def fp(p: float) -> str:
        return format_p(p, b)

    first, last = steps[0], steps[-1]
    chosen = [s.chosen for s in steps if s.chosen is not None]
    # What is left is judged against the gap-free world of the first step (the nominal model
    # and noise): the selected effects' own estimation error is not noise to hide behind.
    p_floor = quantile_above(first.null_hold_ms, last.hold_ms)
    p_low = quantile_above(first.null_low, last.low)
    at_floor = p_floor >= lvl
    white = p_low >= lvl
    if not chosen:
        return _nothing_chosen(
            first,
            level=level,
            base_rms=base_rms,
            floor_um=floor_um,
            margin_um=margin_um,
            tolerances=tolerances,
            fp=fp,
        )
    return _chosen(
        steps,
        [c.label for c in chosen],
        base_rms=base_rms,
        floor_um=floor_um,
        floor_se_um=floor_se_um,
        p_floor=p_floor,
        p_low=p_low,
        fp=fp,
        at_floor=at_floor,
        white=white,
    )


def _nothing_chosen(
    first: Step,
    *,
    level: float,
    base_rms: float,
    floor_um: float,
    margin_um: float,
    tolerances: str,
    fp: Callable[[float], str],
) -> tuple[str, str, list[str]]:
    """(status, reason, rivals) when no effect was chosen: ``none`` (the residual is noise and
    the rig's tolerances, white, and nothing takes more off it than noise lets one take) or
    ``unexplained`` (it is not, and no candidate removes it)."""
    lvl = level / 4.0
    contradicted = first.p_floor_contradicted < lvl
    if first.p_at_floor >= lvl and first.p_low >= lvl and not contradicted:
        return (
            "none",
            f"no effect found at {1 - level:.0%}: the held-out "
            f"residual ({base_rms:.2f} µm) is within what noise (floor {floor_um:.2f} µm) "
            f"and {tolerances} leave "
            f"(p {fp(first.p_at_floor)}), white at the thermal time scales "
            f"(p {fp(first.p_low)}), and no effect of the library takes more off it than "
            "that null world lets one take (the most any took: "
            f"{_best_removal(first):.2f} µm; p {fp(first.p_gain)}"
            + (f"; practical margin {margin_um:.2f} µm" if margin_um > 0 else "")
            + ")"
            + _detectable_sizes(first),
            [],
        )
    why = []
    if first.p_at_floor < lvl:
        why.append(f"above the noise floor ({floor_um:.2f} µm; p {fp(first.p_at_floor)})")
    if first.p_low < lvl:
        why.append(f"slow at the thermal time scales (p {fp(first.p_low)})")
    if contradicted:
        why.append(
            "a candidate takes it further below the floor than noise would "
            f"(p {fp(first.p_floor_contradicted)}), so it is not noise"
        )
    return (
        "unexplained",
        f"the held-out residual ({base_rms:.2f} µm) is {english_list(why)}, and no candidate "
        "removes a significant, physically plausible part of it",
        [],
    )


def _chosen(
    steps: list[Step],
    names: list[str],
    *,
    base_rms: float,
    floor_um: float,
    floor_se_um: float | None,
    p_floor: float,
    p_low: float,
    fp: Callable[[float], str],
    at_floor: bool,
    white: bool,
) -> tuple[str, str, list[str]]:
    """(status, reason, rivals) when effects were chosen (``names``): ``partially
    explained`` (an excluded effect explains it as well, little of the gap may be closed, or
    what is left is not noise), ``ambiguous`` (rivals the data cannot reject) or
    ``identified``."""
    last = steps[-1]
    rivals = sorted({r for s in steps for r in s.rivals})
    outside = sorted({r for s in steps for r in s.outside})
    after = last.hold_ms**0.5
    if outside:
        ps = {e: fp(s.rival_p[e]) for s in steps for e in s.outside}
        said = english_list([f"{e} (rival test p {ps[e]})" for e in outside], conj="or")
        return (
            "partially explained",
            f"{english_list(names)} take{'s' if len(names) == 1 else ''} "
            f"{base_rms - after:.2f} µm off the held-out rms ({base_rms:.2f} → {after:.2f} µm), "
            f"but an effect outside the library explains the gap about as well and the data "
            f"cannot reject it as the truth: {said}, excluded from the library: "
            f"{english_list(names)} may only stand in for it",
            rivals,
        )
    floor_low = floor_um - 1.96 * (floor_se_um or 0.0)
    closed_low = (base_rms - after) / (base_rms - floor_low) if base_rms > floor_low else 1.0
    if at_floor and white and closed_low < MIN_CLOSED:
        return (
            "partially explained",
            f"{english_list(names)} take{'s' if len(names) == 1 else ''} "
            f"{base_rms - after:.2f} µm off the held-out rms ({base_rms:.2f} → {after:.2f} µm), "
            f"but may close as little as {max(closed_low, 0.0):.0%} of the gap above the floor "
            f"({floor_um:.2f} ± {1.96 * (floor_se_um or 0.0):.2f} µm): "
            f"{english_list(names)} may only stand in for an effect outside the library",
            rivals,
        )
    if not (at_floor and white):
        left = []
        if not at_floor:
            left.append(f"above the floor (p {fp(p_floor)})")
        if not white:
            left.append(f"slow at the thermal time scales (p {fp(p_low)})")
        removed = base_rms - last.hold_ms**0.5
        return (
            "partially explained",
            f"{english_list(names)} take{'s' if len(names) == 1 else ''} {removed:.2f} µm off "
            f"the held-out rms, but what is left ({last.hold_ms**0.5:.2f} µm) is still "
            f"{english_list(left)}: {english_list(names)} may only stand in for an effect "
            "outside the library, or a second effect is too small to attribute",
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
            "(the data cannot reject any of them as the truth; nor an effect outside the "
            "library with the same signature on these runs)",
            rivals,
        )
    tested = sorted({r for s in steps for r in s.rival_p})
    rivals_said = (
        f"{english_list(tested)} {'is' if len(tested) == 1 else 'are'} rejected as the truth"
        if tested
        else "no other effect is significant"
    )
    removed = base_rms - last.hold_ms**0.5
    return (
        "identified",
        f"{english_list(names)} take{'s' if len(names) == 1 else ''} {removed:.2f} µm off the "
        f"held-out rms ({base_rms:.2f} → {last.hold_ms**0.5:.2f} µm), to the noise floor "
        f"(p {fp(p_floor)}), white at the thermal time scales (p {fp(p_low)}); "
        f"{rivals_said}",
        [],
    )


def _detectable_sizes(step: Step) -> str:
    """What these runs could have found: per effect, the rms of drift it needs to be named
    with 80 % power (its easiest and hardest family), as a clause of the reason."""
    by: dict[str, list[float]] = {}
    for label, size in step.detectable_by_family.items():
        if np.isfinite(size):
            by.setdefault(label.split(" ")[0], []).append(size)
    if not by:
        return ""
    parts = []
    for effect, sizes in sorted(by.items(), key=lambda kv: min(kv[1])):
        lo, hi = min(sizes), max(sizes)
        parts.append(
            f"{effect} {lo:.2f} µm" if hi < 1.05 * lo else f"{effect} {lo:.2f}–{hi:.2f} µm"
        )
    return (
        "; an effect would have been named with 80 % power from an rms of drift of about "
        + ", ".join(parts)
    )


def _best_removal(step: Step) -> float:
    """The most any family took off the held-out rms at this step (µm)."""
    if not step.gain:
        return 0.0
    g = max(step.gain.values())
    return float(step.hold_ms**0.5 - max(step.hold_ms - g, 0.0) ** 0.5) if g > 0 else 0.0


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
        before, after = hf["holdout_rms_before_um"], hf["holdout_rms_after_um"]
        se = (d.noise_floor or {}).get("holdout_se_um")
        gap = before - d.noise_floor_um
        closed = hf.get("gap_closed")
        if se is not None and gap <= 1.96 * se:
            share = (
                f"; the gap above the floor ({gap:.2f} µm) is within the floor's uncertainty "
                f"(± {1.96 * se:.2f} µm), so no share of it is stated"
            )
        elif closed is not None:
            ci = hf.get("gap_closed_ci95")
            within = (
                f" ({ci[0]:.0%}–{ci[1]:.0%} at 95 %, before, after and the floor uncertain "
                "together)"
                if ci
                else " (no interval: the gap is not told from 0 once before, after and the "
                "floor are uncertain together)"
            )
            share = f", closing {closed:.0%}{within} of the gap above the floor"
        else:
            share = ""
        what = (
            f" Verdict: identified — {eff} ({format_params(v['params'])}); it takes "
            f"{before - after:.2f} µm off the held-out rms ({before:.2f} → {after:.2f} µm)"
            f"{share}."
        )
    else:
        what = f" Verdict: {st} — {v['reason']}."
    alts = ""
    if st in ("identified", "ambiguous"):
        for sel in d.selected:
            if sel.get("alternatives"):
                alts += (
                    f" The data cannot tell {sel['family']} from "
                    f"{english_list(sel['alternatives'], conj='or')} (rival tests of the other "
                    "choices of that effect): the choice among them is not established."
                )
    return head + where + what + alts
