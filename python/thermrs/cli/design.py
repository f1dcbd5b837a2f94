"""``thermrs design``: parse, call :func:`thermrs.design.design`, write and render. Registered
on the CLI group by :mod:`thermrs.cli`."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click
from rich.console import Console
from rich.table import Table

out = Console(highlight=False)


def _types() -> tuple[click.ParamType, click.ParamType]:  # type: ignore[type-arg]
    from thermrs.cli.common import input_file, run_file

    return input_file, run_file


input_file, run_file = _types()


def render_design(doc: dict[str, Any], out_dir: Path) -> None:
    """Print a ``design.json`` document."""
    dg = doc["diagnosis"]
    if not doc["confounded"]:
        out.print(f"Nothing to design: {doc['why_not']}")
        return
    out.print(
        f"Diagnosis: {dg['status']} — confounded: {', '.join(doc['confounded'])} "
        f"(noise floor {dg['noise_floor_um']:.2f} µm)"
    )
    now = {(p["truth"], p["rival"]): p["z"] for p in doc["separation_now"]}
    t = Table(title="Candidates (best first): least z over ordered pairs (truth over rival)")
    for c in ("#", "measurement", "hours", "least z", "now"):
        t.add_column(c, justify="left" if c == "measurement" else "right")
    for c in doc["candidates"][:8]:
        worst = min(c["separation"], key=lambda p: p["z"])
        t.add_row(
            str(c["rank"] + 1),
            c["label"],
            f"{c['hours']:g}",
            f"{c['min_z']:.1f} ({worst['truth']} > {worst['rival']})",
            f"{now.get((worst['truth'], worst['rival']), float('nan')):.1f}",
        )
    out.print(t)
    p = doc["proof"]
    if p is not None:
        t = Table(title=f"Proof: {p['candidate']}")
        for c in ("truth (simulated)", "verdict", "effect named", "right"):
            t.add_column(c)
        for r in p["matrix"]:
            t.add_row(r["truth"], r["status"], str(r["effect"]), "yes" if r["right"] else "NO")
        out.print(t)
    rec = doc["recommended"]
    if rec is not None:
        out.print(
            f"[bold]Recommended[/bold]: {rec['label']} ({rec['hours']:g} h); roles: "
            + ", ".join(f"{k} {v}" for k, v in doc["roles"].items())
        )
        out.print(
            f"Wrote {out_dir / 'rig.toml'}, {out_dir / 'scenario.toml'} and "
            f"{out_dir / 'design.json'}"
        )
    else:
        out.print(f"[bold]Nothing recommended[/bold]: {doc['why_not']}")
        out.print(f"Wrote {out_dir / 'design.json'} (and the best candidate's files)")


@click.command()
@click.option("--rig", "rig_path", required=True, type=input_file, help="Rig file (SPEC §3).")
@click.option(
    "--train",
    "train",
    multiple=True,
    required=True,
    type=run_file,
    help="Training runs (recordings or extracted tables).",
)
@click.option(
    "--holdout", "holdout", multiple=True, required=True, type=run_file, help="Held-out runs."
)
@click.option(
    "--exclude",
    "exclude",
    multiple=True,
    help="Effects the diagnoser may not name (SPEC §6 names).",
)
@click.option(
    "--between",
    "between",
    multiple=True,
    help="The effects to separate (default: the diagnosis's confounded ones).",
)
@click.option(
    "--budget-h",
    "budget_h",
    default=24.0,
    show_default=True,
    type=click.FloatRange(1.0, 1000.0),
    help="Most recording hours to ask for.",
)
@click.option(
    "--seed",
    default=0,
    show_default=True,
    type=click.IntRange(0, 2**32 - 1),
    help="Seed of the proof's simulations.",
)
@click.option(
    "--no-proof",
    "no_proof",
    is_flag=True,
    help="Rank only; skip the proof (then nothing is recommended).",
)
@click.option(
    "-o",
    "--out",
    "out_dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Folder for rig.toml, scenario.toml and design.json (created).",
)
def design(
    rig_path: Path,
    train: tuple[Path, ...],
    holdout: tuple[Path, ...],
    exclude: tuple[str, ...],
    between: tuple[str, ...],
    budget_h: float,
    seed: int,
    no_proof: bool,
    out_dir: Path,
) -> None:
    """Design the measurement that separates confounded effects, and prove it by simulation.

    Ranks new poses with a chip and run protocols by how surely they tell each confounded
    effect from its rivals; simulates the best with each rival as the truth and diagnoses
    again; recommends one only if every truth is identified. Exits 3 (after designing) if
    part of a recording was lost.
    """
    from thermrs.cli.common import EXIT_DATA_LOSS, run_tables
    from thermrs.design import design as run
    from thermrs.errors import InputError
    from thermrs.rig import load_rig

    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"-o {out_dir}: exists and is not a folder")
    if not out_dir.parent.exists():
        raise InputError(f"-o {out_dir}: its parent folder {out_dir.parent} does not exist")
    r = load_rig(rig_path)
    tt, loss1 = run_tables(train, r, "--train")
    th, loss2 = run_tables(holdout, r, "--holdout")
    with out.status("designing…") as status:
        res = run(tt, th, r, exclude=list(exclude), between=list(between) or None,
                  budget_h=budget_h, seed=seed, prove_it=not no_proof,
                  progress=lambda m: status.update(f"designing: {m}…"))  # fmt: skip
        res.write(out_dir)
    render_design(res.to_json(), out_dir)
    if loss1 or loss2:
        sys.exit(EXIT_DATA_LOSS)
