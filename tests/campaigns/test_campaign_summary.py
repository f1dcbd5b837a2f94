"""The folds' synthesis: what several folds' diagnoses conclude together, on documents whose
verdicts are known."""

from __future__ import annotations

from typing import Any

from thermrs.campaigns.summary import fold_synthesis


def _doc(status: str, effect: str | None, **params: Any) -> dict[str, Any]:
    return {
        "verdict": {
            "status": status,
            "outcome": status,
            "effect": effect,
            "params": params,
            "confounded_with": [],
            "effects": [effect] if effect else [],
        }
    }


def test_folds_that_agree_are_said_to() -> None:
    s = fold_synthesis(
        [
            ("without r1", _doc("identified", "thermal_lag", tau_min=40.0)),
            ("without r2", _doc("identified", "thermal_lag", tau_min=50.0)),
            ("without r3", _doc("identified", "thermal_lag", tau_min=45.0)),
        ]
    )
    assert s["consistent"] and s["leading"] == "thermal_lag"
    assert s["tally"] == {"identified": 3}
    assert s["params"]["tau_min"] == {"median": 45.0, "min": 40.0, "max": 50.0, "folds": 3}
    assert s["sentence"].startswith("consistent across folds: identified in all 3")


def test_folds_that_disagree_say_where() -> None:
    s = fold_synthesis(
        [
            ("without r1", _doc("identified", "thermal_lag", tau_min=40.0)),
            ("without r2", _doc("none", None)),
            ("without r3", _doc("identified", "thermal_lag", tau_min=60.0)),
        ]
    )
    assert not s["consistent"]
    assert s["named"] == {"thermal_lag": 2}
    assert "the folds disagree: identified ×2, none ×1" in s["sentence"]
    assert "thermal_lag named in 2 of 3 folds" in s["sentence"]
    assert "without r2: none" in s["sentence"] and "without r1:" not in s["sentence"]


def test_no_effect_anywhere_is_consistent() -> None:
    s = fold_synthesis([("a", _doc("none", None)), ("b", _doc("none", None))])
    assert s["consistent"] and s["leading"] is None and s["params"] == {}
    assert "no effect named in any fold" in s["sentence"]
