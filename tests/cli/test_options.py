"""Options the command line reads as the issues write them (thermrs.cli.app): a list option
takes several values after one flag, like `--train A B` (issue #17)."""

from __future__ import annotations


def test_list_options_take_several_values_like_the_runs() -> None:
    # `--exclude A B` and `--between E1 E2 …` (as the issues write them) read like `--train A B`.
    from thermrs.cli.app import expand_multi

    assert expand_multi(["design", "--between", "a", "b", "c", "-o", "D"]) == [
        "design", "--between", "a", "--between", "b", "--between", "c", "-o", "D",
    ]  # fmt: skip
    assert expand_multi(["diagnose", "--exclude", "x", "y", "--json", "j"]) == [
        "diagnose", "--exclude", "x", "--exclude", "y", "--json", "j",
    ]  # fmt: skip
