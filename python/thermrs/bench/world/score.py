"""Scoring of bench cases against their truth, per nuisance world and SNR bin.

- **One effect, in the library**: ``right`` if the verdict (``identified``, ``ambiguous`` or
  ``partially explained``) names the true effect among its effect, confounded set or selected
  effects; ``false none``: ``none``; ``false attribution``: effects named, the truth not among
  them; ``unexplained`` is counted on its own (honest, not right).
- **Withheld** (the same runs, the true effect excluded from the library): the verdict can
  only name wrong effects. ``identified`` or ``ambiguous`` states them as found (or as
  candidates for the truth): a false attribution. ``partially explained`` says that what is
  left is still a gap and that the effects named may stand in for one outside the library:
  ``stand-in``, honest. ``unexplained`` is honest; ``none`` is a failure (where the SNR ≥ 1).
- **No effect**: ``none`` is right; ``identified``/``ambiguous``/``partially explained`` is a
  false attribution, unless every effect named is the thermal camera's (``ir_gain``,
  ``ir_drift``, ``ir_clock``: ``instrument named``, the world's own instrument errors found);
  ``unexplained`` a false gap. The total rate of anything but ``none`` is
  reported beside them.
- **Two effects**: right only if the verdict names both (by name, among its effect, confounded
  set or selected effects); ``false none``: ``none``; anything else is wrong (one of them
  named, or ``unexplained``).

**Strict** (beside the lenient counts above): a case with effects is ``right`` only if it is
``identified`` and names exactly its true effects (for one effect: the truth alone, no rival,
no second effect); ``ambiguous`` with the truth among its names and ``partially explained``
count as right above, not here.

A case is binned by the SNR it reached (each effect's own, for a pair the smaller), at the
nearest target on a log scale; the SNR ≥ 1 rates (``must_reach``) take every case that reached
SNR ≥ 0.99.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["outcome", "score", "strict_outcome"]

NAMING = ("identified", "ambiguous", "partially explained")
#: The instrument effects' names (the diagnoser's library; the world draws such errors).
INSTRUMENTS = frozenset(("ir_gain", "ir_drift", "ir_clock", "ir_noise"))


def outcome(row: dict[str, Any]) -> str:
    """The outcome class of a diagnosed case (module docs)."""
    status = row["status"]
    named = set(row["named"])
    truth = set(row["truth"])
    if row["kind"] == "none":
        if status == "none":
            return "right"
        if status == "unexplained":
            return "false gap"
        # The world's own instrument errors (its IR gains, drifts and clock, drawn at a
        # multiple of the rig's tolerances) named as the instrument's: not the robot blamed.
        return "instrument named" if named and named <= INSTRUMENTS else "false attribution"
    if status == "none":
        return "false none"
    if row["kind"] == "pair":
        return "right" if status in NAMING and truth <= named else "wrong"
    if status in NAMING:
        return "right" if truth <= named else "false attribution"
    return "unexplained"


def strict_outcome(row: dict[str, Any]) -> str:
    """The strict outcome of a case with effects: ``right`` only if ``identified`` with exactly
    the true effects named (module docs); else the lenient class, ``right`` there becoming
    ``named among others``."""
    lenient = outcome(row)
    if row["kind"] == "none":
        return lenient
    if row["status"] == "identified" and set(row["named"]) == set(row["truth"]):
        return "right"
    return "named among others" if lenient == "right" else lenient


def withheld_outcome(row: dict[str, Any]) -> str:
    """The outcome class of a case diagnosed with its true effect excluded."""
    status = row["excluded"]["status"]
    if status == "none":
        return "none"
    if status in ("identified", "ambiguous"):
        return "false attribution"
    return "stand-in" if status == "partially explained" else "honest"


def _bin(snr: float, targets: tuple[float, ...]) -> str:
    t = min(targets, key=lambda x: abs(np.log(snr / x)) if snr > 0 else np.inf)
    return f"{t:g}"


def _count(rows: list[dict[str, Any]], key: str) -> dict[str, int]:
    out: dict[str, int] = {"cases": len(rows)}
    for r in rows:
        out[r[key]] = out.get(r[key], 0) + 1
    return out


def score(
    results: list[dict[str, Any]], targets: tuple[float, ...], seconds: float
) -> dict[str, Any]:
    """The bench document: counts per world and SNR bin of each case kind (module docs)."""
    done = [r for r in results if "skipped" not in r]
    for r in done:
        r["outcome"] = outcome(r)
        r["strict_outcome"] = strict_outcome(r)
        if "excluded" in r:
            r["excluded_outcome"] = withheld_outcome(r)
        r["bin"] = _bin(min(r["snr"]), targets) if r["snr"] else "-"
    worlds = list(dict.fromkeys(r["world"] for r in results))
    bins = [f"{t:g}" for t in targets]
    doc: dict[str, Any] = {"single": {}, "withheld": {}, "none": {}, "pair": {}, "by_effect": {}}
    for w in worlds:
        here = [r for r in done if r["world"] == w]
        doc["none"][w] = _count([r for r in here if r["kind"] == "none"], "outcome")
        doc.setdefault("none_by_nuisance", {})[w] = {
            label: _count(
                [r for r in here if r["kind"] == "none" and lo <= r.get("nuisance_snr", 0.0) < hi],
                "outcome",
            )
            for label, lo, hi in NUISANCE_BINS
        }
        for kind in ("single", "pair"):
            doc[kind][w] = {
                b: _count([r for r in here if r["kind"] == kind and r["bin"] == b], "outcome")
                for b in bins
            }
        doc["withheld"][w] = {
            b: _count([r for r in here if "excluded" in r and r["bin"] == b], "excluded_outcome")
            for b in bins
        }
    for e in dict.fromkeys(x for r in done if r["kind"] == "single" for x in r["truth"]):
        doc["by_effect"][e] = {
            b: _count(
                [r for r in done if r["kind"] == "single" and r["truth"] == [e] and r["bin"] == b],
                "outcome",
            )
            for b in bins
        }
        doc.setdefault("by_effect_strict", {})[e] = {
            b: _count(
                [r for r in done if r["kind"] == "single" and r["truth"] == [e] and r["bin"] == b],
                "strict_outcome",
            )
            for b in bins
        }
    doc["skipped"] = [
        f"{r['world']} {'+'.join(r['truth'])} SNR {r['target_snr']:g} seed {r['seed']}: "
        f"reaches SNR {min(r['snr']):.3g}"
        for r in results
        if "skipped" in r
    ]
    doc["must_reach"] = _must_reach(done)
    doc["cases"] = len(results)
    doc["seconds"] = seconds
    doc["results"] = results
    return doc


def _rate(rows: list[dict[str, Any]], key: str, values: tuple[str, ...]) -> dict[str, Any]:
    n = len(rows)
    k = sum(r[key] in values for r in rows)
    return {"k": k, "n": n, "rate": k / n if n else None}


#: Bins of a ``none`` case's nuisance SNR (what the world's instruments and rig leave over the
#: nominal model ÷ σ): below a quarter of the noise a gap is not there to attribute.
NUISANCE_BINS = (("< 0.25", 0.0, 0.25), ("0.25–0.5", 0.25, 0.5), ("≥ 0.5", 0.5, np.inf))


def _must_reach(done: list[dict[str, Any]]) -> dict[str, Any]:
    """Issue 16's targets per world: right and false ``none`` where SNR ≥ 1, false attribution
    on ``none``, withheld honest where SNR ≥ 1 (and ``none`` there, which must be 0)."""
    out: dict[str, Any] = {}
    for w in dict.fromkeys(r["world"] for r in done):
        here = [r for r in done if r["world"] == w]
        strong = [r for r in here if r["kind"] == "single" and min(r["snr"]) >= 0.99]
        held = [r for r in strong if "excluded" in r]
        out[w] = {
            "right_snr_ge_1": _rate(strong, "outcome", ("right",)),
            "right_strict_snr_ge_1": _rate(strong, "strict_outcome", ("right",)),
            "false_none_snr_ge_1": _rate(strong, "outcome", ("false none",)),
            "false_attribution_on_none": _rate(
                [r for r in here if r["kind"] == "none"], "outcome", ("false attribution",)
            ),
            "not_none_on_none": _rate(
                [r for r in here if r["kind"] == "none"],
                "outcome",
                ("false attribution", "false gap", "instrument named"),
            ),
            "instrument_named_on_none": _rate(
                [r for r in here if r["kind"] == "none"], "outcome", ("instrument named",)
            ),
            "false_attribution_on_none_nuisance_lt_0.25": _rate(
                [r for r in here if r["kind"] == "none" and r.get("nuisance_snr", 0.0) < 0.25],
                "outcome",
                ("false attribution",),
            ),
            "withheld_honest_snr_ge_1": _rate(held, "excluded_outcome", ("honest", "stand-in")),
            "withheld_false_attribution_snr_ge_1": _rate(
                held, "excluded_outcome", ("false attribution",)
            ),
            "withheld_none_snr_ge_1": _rate(held, "excluded_outcome", ("none",)),
            "pair_right": _rate([r for r in here if r["kind"] == "pair"], "outcome", ("right",)),
            "pair_right_strict": _rate(
                [r for r in here if r["kind"] == "pair"], "strict_outcome", ("right",)
            ),
        }
    return out
