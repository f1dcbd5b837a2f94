"""The search: every candidate within the budget scored by the separation criterion.

Run protocols alone (on the user's rig) and new poses with a chip (each recorded with one
protocol; the best poses then with every protocol). Scores are the least ``z`` over ordered
pairs of rivals (:mod:`thermrs.design.separation`). The proof order takes the candidates
whose score reaches :data:`Z_TARGET` first, those that leave the least canonical correlation
between the rivals' signatures over all runs (the diagnoser calls a pair confounded above 0.9
of it, whatever the held-out gain) before the others, and those the robot alone can record
before those that ask the room to change; then the rest by score.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.design.files import rig_toml
from thermrs.design.forecast import forecast_tables, protocol_samples
from thermrs.design.measurements import Candidate, Protocol, candidates, protocols
from thermrs.design.separation import Block, Rival, pair_cos, pair_z, rival_families
from thermrs.rig import Rig
from thermrs.signatures import VisitSet

__all__ = ["NOT_SEARCHED", "Z_TARGET", "Found", "conclude", "search"]

#: Score (least z over ordered pairs, white noise) a candidate should reach; about 3 standard
#: errors once the residuals' autocorrelation is accounted for (z is optimistic by √3–√10).
Z_TARGET = 10.0
#: Poses re-scored with every protocol.
TOP_POSES = 6
#: Below this score for a pair on every candidate, the pair is called inseparable here.
SAME_PHYSICS_Z = 1.0

NOT_SEARCHED = [
    {
        "what": "the other chip axis",
        "why": "every chip's two axes (u and v) are already recorded and used by the "
        "diagnoser; turning a chip adds nothing",
    },
    {
        "what": "a thermal ROI on another link",
        "why": "a ROI is a rectangle of the thermal image; the rig file has no image to place "
        "one on (add it to the rig and diagnose again, it is then searched as a driver)",
    },
]


#: Candidates with their least z and their z per ordered pair.
Scored = list[tuple[float, Candidate, dict[tuple[str, str], float]]]


@dataclass
class Found:
    """The search's outcome."""

    now: list[dict[str, Any]]
    ranked: list[tuple[dict[str, Any], Candidate]]
    proof_order: list[Candidate]
    why_not: str | None


def _pairs(z: dict[tuple[str, str], float]) -> list[dict[str, Any]]:
    return [{"truth": a, "rival": b, "z": v} for (a, b), v in z.items()]


def _protocols(taken: set[str], rig: Rig) -> list[Protocol]:
    """The protocols, their runs named so that no name is one of the user's runs; a room
    swing only where the rig records the room's temperature."""
    swing = rig.ambient_topic is not None
    prefix = "design"
    k = 1
    while any(r.name in taken for p in protocols(prefix=prefix, room_swing=swing) for r in p.runs):
        k += 1
        prefix = f"design{k}"
    return protocols(prefix=prefix, room_swing=swing)


def search(
    tables: Sequence[pl.DataFrame],
    rig: Rig,
    rivals: Sequence[Rival],
    sigma_um: float,
    *,
    budget_h: float,
    cycle_s: float,
    limits_deg: tuple[tuple[float, float], ...],
    workdir: Path,
    taken: set[str],
    progress: Callable[[str], object],
) -> Found:
    """Score every candidate within ``budget_h`` (see the module docstring)."""
    protos = [p for p in _protocols(taken, rig) if p.hours <= budget_h + 1e-9]
    if not protos:
        shortest = min(p.hours for p in protocols())
        return Found([], [], [], f"the budget ({budget_h:g} h) is below the shortest protocol "
                     f"searched ({shortest:g} h)")  # fmt: skip
    base_p = max((p for p in protos if p.hours <= 12.0), key=lambda p: p.hours, default=protos[0])
    poses = candidates(rig, limits_deg=limits_deg, protocol=base_p)
    rig_c = rig_toml(rig, poses[0])[1] if poses else rig
    old = Block(VisitSet(list(tables), rig_c), rivals)
    fams = rival_families(rig_c, old.vs, rivals)
    now = _pairs(pair_z([old], rivals, fams, sigma_um))
    progress("forecasting the protocols")
    fc: dict[str, tuple[pl.DataFrame, pl.DataFrame, Block]] = {}
    scored: Scored = []
    cosines: dict[int, dict[tuple[str, str], float]] = {}
    for p in protos:
        vis, samp = protocol_samples(rig, p, cycle_s=cycle_s, workdir=workdir)
        blk = Block(VisitSet(forecast_tables(rig, vis, samp), rig_c), rivals)
        fc[p.label] = (vis, samp, blk)
        z = pair_z([old, blk], rivals, fams, sigma_um)
        cand = Candidate(label=f"runs only: {p.label}", kind="protocol", protocol=p)
        cosines[id(cand)] = pair_cos([old, blk], rivals, fams)
        scored.append((min(z.values()), cand, z))

    # A new chip's forecast visits: its base pose's visit times and temperatures, the same
    # for every pose and chip at that base pose (computed once per protocol and base pose).
    visits_of: dict[tuple[str, ...], list[pl.DataFrame]] = {}

    def score_pose(c: Candidate) -> None:
        vis, samp, blk = fc[c.protocol.label]
        assert c.camera is not None
        new = rig_toml(rig, c)[1]
        like = str(c.detail["from_camera"])
        key = (c.protocol.label, like, str(c.camera["name"]), *(r.name for r in new.rois))
        if key not in visits_of:
            tabs = forecast_tables(
                new, vis.filter(pl.col("camera") == like), samp, new_camera=c.camera["name"],
                like_camera=like,
            )  # fmt: skip
            visits_of[key] = [t.filter(pl.col("camera") == c.camera["name"]) for t in tabs]
        nb = Block(VisitSet(visits_of[key], new), rivals)
        z = pair_z([old, blk, nb], rivals, fams, sigma_um)
        cosines[id(c)] = pair_cos([old, blk, nb], rivals, fams)
        scored.append((min(z.values()), c, z))

    progress(f"scoring {len(poses)} new poses")
    for c in poses:
        score_pose(c)
    best_poses = sorted((s for s in scored if s[1].kind == "pose"), key=lambda s: -s[0])
    for _, c, _ in best_poses[:TOP_POSES]:
        for p in protos:
            if p.label != base_p.label:
                score_pose(
                    replace(c, protocol=p, label=c.label.rsplit("; ", 1)[0] + "; " + p.label)
                )
    return conclude(now, scored, cosines, rivals)


def conclude(
    now: list[dict[str, Any]],
    scored: Scored,
    cosines: dict[int, dict[tuple[str, str], float]],
    rivals: Sequence[Rival],
) -> Found:
    """The ranking, the proof order and, if a pair is inseparable everywhere, why.

    Parameters
    ----------
    now
        The separation on the user's runs alone (``{truth, rival, z}`` per ordered pair).
    scored
        Per candidate: its least z, the candidate, its z per ordered pair (sorted here).
    cosines
        Per candidate (by ``id``): the canonical correlation of each pair's signatures.
    rivals
        The rivals separated.

    Returns
    -------
    Found
        ``ranked`` by least z; ``proof_order``: those reaching :data:`Z_TARGET` first (the
        robot alone before a room change, then the least alike signatures first), then the
        rest by score; ``why_not`` when a pair is inseparable on every candidate.
    """
    scored.sort(key=lambda s: -s[0])
    ranked = []

    def worst_cos(c: Candidate) -> float:
        return max(cosines[id(c)].values(), default=0.0)

    for i, (m, c, z) in enumerate(scored):
        cos = [{"effects": [a, b], "cos": v} for (a, b), v in cosines[id(c)].items()]
        ranked.append(
            (
                {**c.to_json(), "rank": i, "min_z": m, "separation": _pairs(z), "cos": cos},
                c,
            )
        )
    # A candidate that asks the room to change (a room swing) is proved after those the
    # robot alone can record: turning off a hall's climate control is the larger request.
    good = sorted(
        (s for s in scored if s[0] >= Z_TARGET),
        key=lambda s: (s[1].protocol.room is not None, worst_cos(s[1])),
    )
    rest = [s for s in scored if s[0] < Z_TARGET]
    order = [c for _, c, _ in good + rest]
    why = None
    for a in rivals:
        for b in rivals:
            if a is not b and max(z[(a.effect, b.effect)] for _, _, z in scored) < SAME_PHYSICS_Z:
                why = (
                    f"no candidate separates {a.effect} from {b.effect} (z < {SAME_PHYSICS_Z:g} "
                    "on every pose and protocol searched): their signatures coincide on this "
                    "rig, the same physics to it"
                )
    return Found(now, ranked, order, why)
