"""One two-effect case of the independent world (:mod:`thermrs.bench.world`),
made and diagnosed as the bench does, for a test."""

from __future__ import annotations

from typing import Any

from thermrs.bench.world.cases import Campaign, Case, run_case


def run_pair(
    effects: tuple[str, str],
    *,
    rig_path: str,
    snr: float,
    seed: int,
    campaign: Campaign,
    lowest_snr: float | None = None,
    world: str = "white",
) -> dict[str, Any]:
    """The bench's result row of a pair case (``named``, ``status``, …; score it with
    :func:`thermrs.bench.world.score.outcome`)."""
    return run_case(
        Case(
            kind="pair",
            effects=effects,
            target_snr=snr,
            lowest_snr=snr if lowest_snr is None else lowest_snr,
            world=world,
            seed=seed,
            rig_path=rig_path,
            campaign=campaign,
            withheld=False,
        )
    )
