"""``thermrs rig``: check and explain a rig file."""

from __future__ import annotations

import json
from pathlib import Path

import click

from thermrs.cli.common import (
    input_file,
    out,
    table,
)
from thermrs.errors import InputError, ThermrsError
from thermrs.numbers import fmt


@click.command()
@click.argument("rig_path", required=False, type=input_file)
@click.option("--json", "as_json", is_flag=True, help="Print SPEC §7 JSON instead of tables.")
def rig(rig_path: Path | None, as_json: bool) -> None:
    """Check and explain a rig file (default: the embedded paper rig).

    Per pose: the flange position and, for every camera, where the laser meets its chip and
    at what incidence. Exits 2 if the laser misses a pose's own camera.
    """
    from thermrs.rig import default_rig_path, load_rig, radians_hint

    r = load_rig(rig_path)
    try:
        view = r.check()
    except ThermrsError as e:
        raise InputError(f"{e}{radians_hint(r)}") from None
    if as_json:
        doc = {"poses": view["poses"]}
        click.echo(json.dumps(doc, indent=2))
        return
    out.print(f"[bold]{r.name or r.model}[/bold]  ({rig_path or default_rig_path()})")
    out.print(
        f"robot {r.model}; cameras {', '.join(c.name for c in r.cameras)}; "
        f"α = {r.alpha_per_k:.3g} /K at {r.reference_c:g} °C; expanding "
        + ", ".join(f"{m.name}←{m.temperature}" for m in r.lengths)
    )
    for pose_name, p in view["poses"].items():
        x, y, z = p["flange_mm"]
        t = table(
            f"Pose {pose_name}: flange ({x:.2f}, {y:.2f}, {z:.2f}) mm, "
            f"elevation {p['elevation_deg']:.2f}°, azimuth {p['azimuth_deg']:.2f}°",
            [
                (c, "left" if c in ("camera", "") else "right")
                for c in (
                    "camera",
                    "spot x (px)",
                    "spot y (px)",
                    "incidence (°)",
                    "distance (mm)",
                    "",
                )
            ],
        )
        for cam, spot in p["spot_px"].items():
            own = r.camera(cam).pose == pose_name
            inc = p["incidence_deg"][cam]
            dist = p["distance_mm"][cam]
            t.add_row(
                cam,
                fmt(spot[0], 3) if spot else "misses",
                fmt(spot[1], 3) if spot else "",
                fmt(inc, 4),
                fmt(dist, 3),
                "taught for this pose" if own else "",
            )
        out.print(t)
