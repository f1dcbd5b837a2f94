"""The report's "experiment that settles it": for an ambiguous diagnosis, the measurement
:func:`thermrs.design.design` recommends (poses, chip placement, runs, hours), its predicted
separation of every confounded pair, the rivals' predicted drift on the new measurement, and
the proof matrix — or, when nothing is recommended, why.

:func:`design_section` builds a :class:`~thermrs.report.blocks.Section` from a
``design.json`` document and :func:`thermrs.design.rival_drift`; the report's diagnosis
section appends it as a subsection (``id`` ``design``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import polars as pl

from thermrs.report.blocks import Figure, Missing, Paragraph, Section, Table
from thermrs.report.figures import figure, legend, svg

__all__ = ["design_section", "fig_rival_drift"]


def _run_text(runs: Sequence[Mapping[str, Any]]) -> str:
    parts = []
    for r in runs:
        idle = f" after {r['idle_before_min']:g} min idle" if r["idle_before_min"] else ""
        start = "from cold" if r["start"] == "ambient" else "straight on"
        parts.append(
            f"{r['name']} ({r['speed_pct']:g} % for {r['duration_min'] / 60:g} h, {start}{idle}; "
            f"{r['role']})"
        )
    return ", ".join(parts)


def _what(rec: Mapping[str, Any]) -> str:
    text = f"{rec['label']}: {rec['hours']:g} recording hours. "
    if rec.get("pose") is not None and rec.get("camera") is not None:
        q = ", ".join(f"{v:.1f}" for v in rec["pose"]["joints_deg"])
        c = rec["camera"]
        centre = ", ".join(f"{v:.1f}" for v in c["centre_mm"])
        text += (
            f"Teach pose {rec['pose']['name']} at joints [{q}]° and mount chip "
            f"{c['name']} with its centre at ({centre}) mm in the base frame, facing the beam "
            f"{rec.get('distance_mm', 0):g} mm from the laser. "
        )
    text += f"Record {_run_text(rec['runs'])}."
    if rec.get("room"):
        text += f" Meanwhile {rec['room']}."
    return text


def fig_rival_drift(drift: pl.DataFrame, doc: Mapping[str, Any]) -> str:
    """The rivals' predicted drift (both chip axes) on the new measurement, per run."""
    fig = figure(3.2)
    axes = fig.subplots(1, 2, sharex=True)
    palette = ("#1b6ca8", "#d1495b", "#2e933c", "#edae49", "#6c4f9e")
    for k, eff in enumerate(dict.fromkeys(drift["effect"].to_list())):
        for (run, _cam), g in drift.filter(pl.col("effect") == eff).group_by(
            "run", "camera", maintain_order=True
        ):
            for ax, col in zip(axes, ("drift_u_um", "drift_v_um"), strict=True):
                first = run == drift["run"][0]
                ax.plot(
                    g["t_h"].to_numpy(),
                    g[col].to_numpy(),
                    color=palette[k % len(palette)],
                    lw=1.2,
                    label=f"{eff}" if first and ax is axes[1] else None,
                )
    for ax, name in zip(axes, ("chip u", "chip v"), strict=True):
        ax.set_xlabel("hours since the designed runs begin")
        ax.set_ylabel(f"predicted drift along {name} (µm)")
    legend(axes[1])
    return svg(fig)


def design_section(doc: Mapping[str, Any], drift: pl.DataFrame | None = None) -> Section:
    """The subsection for a ``design.json`` document (see the module docstring)."""
    s = Section("design", "The experiment that settles it")
    if not doc.get("confounded"):
        s.blocks.append(Missing(f"No experiment designed: {doc.get('why_not')}."))
        return s
    rec = doc.get("recommended")
    now = {(p["truth"], p["rival"]): p["z"] for p in doc.get("separation_now", [])}
    if rec is None:
        s.blocks.append(
            Paragraph(
                f"{', '.join(doc['confounded'])} explain the runs about equally well, and no "
                f"measurement searched separates them within {doc['budget_h']:g} h: "
                f"{doc.get('why_not')}."
            )
        )
    else:
        s.blocks.append(
            Paragraph(
                f"{', '.join(doc['confounded'])} explain these runs about equally well. "
                "thermrs searched new poses with a chip and run protocols, ranked them by how "
                "surely each would tell every effect from its rivals, and simulated the best "
                "with each rival as the truth. Recommended: " + _what(rec)
            )
        )
        rows = [
            [p["truth"], p["rival"], f"{now.get((p['truth'], p['rival']), np.nan):.1f}",
             f"{p['z']:.1f}"]
            for p in rec["separation"]
        ]  # fmt: skip
        if doc.get("separation_said"):
            s.blocks.append(Paragraph(doc["separation_said"]))
        s.blocks.append(
            Table(
                "Predicted separation: the margin (standard errors, every visit counted as "
                "independent) by which each effect, were it the truth, would beat its rival — "
                "on the given runs, and with the recommended measurement added",
                ["truth", "rival", "z now", "z with the design"],
                rows,
            )
        )
    if drift is not None and drift.height:
        s.blocks.append(
            Figure(
                "design-rivals",
                "What each rival predicts on the new measurement (at its fitted parameters): "
                "the curves that part are what the experiment reads",
                fig_rival_drift(drift, doc),
            )
        )
    proof = doc.get("proof")
    if proof is not None:
        s.blocks.append(
            Table(
                f"Proof before the robot ({proof['candidate']}): each rival simulated as the "
                "truth, diagnosed with the given runs ("
                + (
                    "the design's runs recorded and read back by the extraction)"
                    if proof.get("route") == "recording"
                    else "the design's runs as the simulator's truth: true spots with the "
                    "robot's pose error, no image rendered)"
                ),
                ["truth (simulated)", "verdict", "effect named", "right"],
                [
                    [r["truth"], r["status"], str(r["effect"]), "yes" if r["right"] else "no"]
                    for r in proof["matrix"]
                ],
            )
        )
    return s
