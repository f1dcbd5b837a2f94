"""``thermrs design``: parse, call :func:`thermrs.design.design`, write and render. Registered
on the CLI group by :mod:`thermrs.cli`."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click
from rich.table import Table

from thermrs.cli.common import (
    campaign_options,
    exclude_option,
    fold_options,
    input_file,
    out,
    runs_option,
    seed_option,
    stages,
    verbose_option,
)
from thermrs.defaults import DESIGN_BUDGET_H


def render_design(doc: dict[str, Any], out_dir: Path) -> None:
    """Print a ``design.json`` document."""
    dg = doc["diagnosis"]
    if not doc["confounded"]:
        out.print(f"Nothing to design: {doc['why_not']}")
        return
    names = doc["confounded"]
    # Effects asked for with --between are not called confounded: the diagnosis may have
    # told them apart.
    what = (
        f"asked to separate {', '.join(names[:-1])} and {names[-1]}"
        if doc.get("between")
        else f"confounded: {', '.join(names)}"
    )
    out.print(f"Diagnosis: {dg['status']} — {what} (noise floor {dg['noise_floor_um']:.2f} µm)")
    now = {(p["truth"], p["rival"]): p["z"] for p in doc["separation_now"]}
    t = Table(
        title="Candidates (best first): least z over ordered pairs (truth over rival; every "
        "visit counted as independent)"
    )
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
    if doc.get("separation_said"):
        out.print(doc["separation_said"], markup=False, soft_wrap=True)
    if doc.get("proofs_tried"):
        t = Table(title="Proofs, in the order tried (each rival simulated as the truth, diagnosed)")
        for c in ("tried", "measurement", "rank", "hours", "outcome"):
            t.add_column(c, justify="left" if c in ("measurement", "outcome") else "right")
        for pt in doc["proofs_tried"]:
            t.add_row(
                str(pt["tried"]),
                pt["candidate"],
                "—" if pt["rank"] is None else str(pt["rank"]),
                "—" if pt["hours"] is None else f"{pt['hours']:g}",
                "every truth identified" if pt["all_right"] else "wrong: " + "; ".join(pt["wrong"]),
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
        if rec.get("room"):
            out.print(f"Meanwhile {rec['room']}.", markup=False, soft_wrap=True)
        out.print(
            f"Wrote {out_dir / 'rig.toml'}, {out_dir / 'scenario.toml'} and "
            f"{out_dir / 'design.json'}"
        )
    else:
        out.print(f"[bold]Nothing recommended[/bold]: {doc['why_not']}")
        out.print(f"Wrote {out_dir / 'design.json'} (no candidate's files: none is recommended)")


@click.command()
@click.option("--rig", "rig_path", required=True, type=input_file, help="Rig file (SPEC §3).")
@runs_option("Training runs", name="--train", dest="train")
@runs_option("Held-out runs", name="--holdout", dest="holdout")
@exclude_option("Effects the diagnoser may not name (SPEC §6 names).")
@click.option(
    "--between",
    "between",
    multiple=True,
    help="The effects to separate (default: the diagnosis's confounded ones).",
)
@click.option(
    "--budget-h",
    "budget_h",
    default=DESIGN_BUDGET_H,
    show_default=True,
    type=click.FloatRange(1.0, 1000.0),
    help="Most recording hours to ask for.",
)
@click.option(
    "--diagnosis",
    "diagnosis_path",
    type=click.Path(path_type=Path),
    default=None,
    help="A `thermrs diagnose --json` file of the same runs: designed from as it is, instead "
    "of diagnosing the runs again (not with --rule).",
)
@seed_option("Seed of the proof's simulations.")
@click.option(
    "--no-proof",
    "no_proof",
    is_flag=True,
    help="Rank only; skip the proof (then nothing is recommended).",
)
@click.option(
    "--recorded-proof",
    "recorded_proof",
    is_flag=True,
    help="Simulate the proof's runs as recordings read back by the extraction (every image "
    "rendered), not as the simulator's truth: slower, the whole chain.",
)
@click.option(
    "-o",
    "--out",
    "out_dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Folder for rig.toml, scenario.toml and design.json (created); with --rule, a "
    "folder per fold inside it (fold-1, fold-2, …, listed in folds.json).",
)
@campaign_options(rule="With --campaign: a design per fold, each in its own folder under -o.")
@fold_options
@verbose_option
def design(
    rig_path: Path,
    train: tuple[Path, ...],
    holdout: tuple[Path, ...],
    exclude: tuple[str, ...],
    between: tuple[str, ...],
    budget_h: float,
    diagnosis_path: Path | None,
    seed: int,
    no_proof: bool,
    recorded_proof: bool,
    out_dir: Path,
    campaign_path: Path | None,
    query: str | None,
    rule: str | None,
    workers: int | None,
    scheduler: str | None,
    verbose: bool,
) -> None:
    """Design the measurement that separates confounded effects, and prove it by simulation.

    Ranks new poses with a chip and run protocols by how surely they tell each confounded
    effect from its rivals; simulates the best with each rival as the truth and diagnoses
    again; recommends one only if every truth is identified. The runs are files, or runs of
    a --campaign dataset (named, or held out by --rule). Exits 3 (after designing) if part
    of a recording was lost.
    """
    from thermrs.analyses.design import design_splits
    from thermrs.cli.common import EXIT_DATA_LOSS, chosen_splits, write_json
    from thermrs.errors import InputError
    from thermrs.rig import load_rig

    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"-o {out_dir}: exists and is not a folder")
    if not out_dir.parent.exists():
        raise InputError(f"-o {out_dir}: its parent folder {out_dir.parent} does not exist")
    if diagnosis_path is not None and rule is not None:
        raise InputError("--diagnosis is one split's diagnosis: it cannot go with --rule")
    given = None
    if diagnosis_path is not None:
        from thermrs.diagnose.result import Diagnosis

        given = Diagnosis.read(diagnosis_path)
        if given.unverified:
            click.echo(f"thermrs: warning: {diagnosis_path}: {given.unverified}", err=True)
    r = load_rig(rig_path)
    sets = chosen_splits(campaign_path, query, rule, train, holdout, r)
    dirs = [out_dir] if rule is None else [out_dir / f"fold-{i + 1}" for i in range(len(sets))]
    with stages("design", verbose=verbose) as say:
        res = design_splits(sets, r, exclude=list(exclude), between=list(between) or None,
                            budget_h=budget_h, seed=seed, prove_it=not no_proof,
                            recorded_proof=recorded_proof, diagnosis=given,
                            progress=say, workers=workers,
                            scheduler=scheduler)  # fmt: skip
        for d, f in zip(dirs, res, strict=True):
            d.mkdir(parents=True, exist_ok=True)
            f.result.write(d)
        if rule is not None:
            write_json(out_dir / "folds.json", {"rule": rule, "folds": [
                {"fold": f.split.name, "folder": d.name, "train": f.split.train_names,
                 "holdout": f.split.holdout_names} for d, f in zip(dirs, res, strict=True)
            ]})  # fmt: skip
    for d, f in zip(dirs, res, strict=True):
        if f.split.name:
            out.rule(f"[bold]{f.split.name}[/bold] ({d})")
        render_design(f.result.to_json(), d)
    if any(s.data_loss for s in sets):
        sys.exit(EXIT_DATA_LOSS)
