"""``thermrs fit``: α over training runs (:mod:`thermrs.analyses.fit`)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from thermrs.cli.common import (
    CAMPAIGN_NAMES_HELP,
    EXIT_DATA_LOSS,
    TRAIN_HELP,
    campaign_options,
    chosen_runs,
    json_option,
    out,
    rig_option,
    run_file,
    table,
    writable,
    write_json,
)


@click.command()
@rig_option
@click.option(
    "--train",
    "train",
    multiple=True,
    type=run_file,
    help=TRAIN_HELP + CAMPAIGN_NAMES_HELP + " Default with --campaign: every run chosen.",
)
@json_option()
@campaign_options()
def fit(
    rig_path: Path,
    train: tuple[Path, ...],
    json_path: Path | None,
    campaign_path: Path | None,
    query: str | None,
) -> None:
    """Fit the expansion coefficient α over training runs: a time-series least-squares fit of
    the forward model to every visit's spot, with a 95 % interval, and the paper's start/end
    estimator per camera beside it. The runs are files, or runs of a --campaign dataset.

    Exits 3 (after fitting) if part of a training recording was lost.
    """
    from thermrs.analyses.fit import fit_document
    from thermrs.rig import load_rig

    writable(json_path, "--json")
    r = load_rig(rig_path)
    tables, loss = chosen_runs(campaign_path, query, train, r, "--train")
    result = fit_document(tables, r)
    f, start_end, doc = result.fit, result.start_end, result.to_json()
    if json_path is not None:
        write_json(json_path, doc)
    t = table(
        f"α from {len(tables)} run(s), {f.n_visits} visits",
        [
            (c, "right" if c not in ("estimator", "run") else "left")
            for c in ("estimator", "run", "camera", "α (×10⁻⁶/K)", "95 % interval", "rms (µm)")
        ],
    )
    t.add_row(
        "time-series",
        "all",
        "all",
        f"{f.alpha_per_k * 1e6:.3f}",
        f"{f.ci95[0] * 1e6:.3f} – {f.ci95[1] * 1e6:.3f}",
        f"{f.rms_um:.3f}",
    )
    for run, se in start_end.items():
        for cam, (a, (lo, hi)) in [*se.per_camera.items(), ("mean", se.mean)]:
            t.add_row(
                "start/end", run, cam, f"{a * 1e6:.3f}", f"{lo * 1e6:.3f} – {hi * 1e6:.3f}", ""
            )
    out.print(t)
    if loss:
        sys.exit(EXIT_DATA_LOSS)
