"""The rig: robot, cameras, thermal camera, α, and where the laser meets each chip at every pose."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from thermrs.numbers import fmt, fmt_alpha
from thermrs.report.blocks import Figure, Paragraph, Section, Table
from thermrs.report.data import ReportData
from thermrs.report.figures import fig_rig
from thermrs.report.sections.common import join

__all__ = ["section"]


def section(d: ReportData, colours: Mapping[str, str]) -> Section:
    """The rig section: what the rig is, and where the laser meets each chip at every pose."""
    r = d.rig
    s = Section("rig", "The rig")
    s.blocks.append(
        Paragraph(
            f"{r.name or r.model} ({Path(r.source).name}): robot {r.model}, joint states on "
            f"{r.joint_states_topic}; camera{'s' if len(r.cameras) != 1 else ''} "
            + join([f"{c.name} at pose {c.pose} ({c.topic})" for c in r.cameras])
            + "; "
            + (
                f"thermal camera on {r.thermal_topic} with ROIs {join([x.name for x in r.rois])}"
                if r.thermal_topic
                else "no thermal camera"
            )
            + f"; nominal α = {fmt_alpha(r.alpha_per_k)} ×10⁻⁶/K at {fmt(r.reference_c, 1)} °C, "
            "expanding " + join([f"{m.name} with {m.temperature}" for m in r.lengths]) + "."
        )
    )
    rows = []
    for pose, p in d.rig_view["poses"].items():
        for cam, spot in p["spot_px"].items():
            own = r.camera(cam).pose == pose
            rows.append(
                [
                    pose,
                    ", ".join(fmt(v) for v in p["flange_mm"]),
                    fmt(p.get("elevation_deg")),
                    fmt(p.get("azimuth_deg")),
                    cam + (" (its pose)" if own else ""),
                    "misses" if spot is None else f"{fmt(spot[0], 3)}, {fmt(spot[1], 3)}",
                    fmt(p["incidence_deg"].get(cam), 4),
                    fmt(p.get("distance_mm", {}).get(cam), 3),
                ]
            )
    s.blocks.append(
        Table(
            "Poses: flange position, and where the laser meets each chip at nominal lengths",
            [
                "pose",
                "flange x, y, z (mm)",
                "elevation (°)",
                "azimuth (°)",
                "camera",
                "spot x, y (px)",
                "incidence (°)",
                "distance (mm)",
            ],
            rows,
        )
    )
    s.blocks.append(
        Figure(
            "rig",
            "Where the laser meets each camera's chip at the camera's own pose (nominal lengths).",
            fig_rig(
                d.rig_view,
                {c.name: (int(c.size_px[0]), int(c.size_px[1])) for c in r.cameras},
                {c.name: c.pose for c in r.cameras},
                colours,
            ),
        )
    )
    return s
