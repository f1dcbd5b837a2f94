"""The baselines' table (``thermrs diagnose --baselines``): the physical models and each
regression side by side on the held-out runs (:mod:`thermrs.analyses.baselines`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.table import Table

from thermrs.cli.common import out


def render_baselines(doc: dict[str, Any]) -> None:
    """Print ``BaselineComparison.to_json()`` as a table, then what it says."""
    comp = doc["baselines_comparison"]
    rows = [comp["nominal"], *([comp["diagnosed"]] if comp["diagnosed"] else []), *doc["baselines"]]
    runs = [r["run"] for r in rows[0]["per_run"]]
    t = Table(title="Baselines: the physical models and regressions on the same held-out runs")
    for c in ("model", "what", "params", "held-out rms µm [95 %]", *runs):
        t.add_column(c, overflow="fold")
    if comp["diagnosed"]:
        t.add_column("− diagnosed µm [95 %]")
    from thermrs.diagnose.baselines import row_cells

    def num(x: float, sign: bool = False) -> str:
        return f"{x:+.2f}" if sign else f"{x:.2f}"

    for r in rows:
        t.add_row(*row_cells(r, with_diagnosed=bool(comp["diagnosed"]), num=num))
    out.print(t)
    fl = comp["noise_floor_um"]
    ci = comp["noise_floor_ci95"]
    out.print(
        f"Noise floor of the held-out runs: {fl:.2f} µm"
        + (f" [{ci[0]:.2f}, {ci[1]:.2f}]" if ci else "")
        + f". Penalties cross-validated {comp['cv'] or '—'}."
    )
    if comp["diagnosed"]:
        from thermrs.analyses.baselines import said

        out.print(said(doc))


def compensate_baseline(rig: Any, diagnosis: Path, out_path: Path, check: tuple[Path, ...]) -> None:
    """``thermrs compensate --model baseline``: the best linear baseline of a
    ``diagnose --baselines --json`` file as a law (CSV or JSON), shown, and applied to the
    ``--check`` runs with a warning wherever they leave the temperatures it was fitted on."""
    import json

    import click

    from thermrs.analyses.baselines import BaselineLaw
    from thermrs.cli.common import file_tables, write_csv, write_json
    from thermrs.errors import InputError

    try:
        doc = json.loads(Path(diagnosis).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"--diagnosis {diagnosis}: not a JSON file ({e})") from None
    law = BaselineLaw.from_diagnosis(doc, source=f"--diagnosis {diagnosis}")
    checked = None
    if check:
        held, _ = file_tables(check, rig, "--check")
        checked = law.check(held, rig)
    if out_path.name.endswith(".csv"):
        write_csv(out_path, law.wide())
    else:
        write_json(out_path, {"law": law.doc, "score": law.score, "check": checked})
    s = law.score
    t = Table(
        title=f"Compensation law ({law.model}): drift (µm) = intercept + Σ coefficient × feature",
        caption="features relative to the run's first visit: "
        + ", ".join(law.doc["features"])
        + (
            f"; held-out rms {s['holdout_rms_um']:.2f} µm "
            f"[{s['holdout_rms_ci95'][0]:.2f}, {s['holdout_rms_ci95'][1]:.2f}]"
            if s.get("holdout_rms_um") is not None
            else ""
        ),
    )
    for c in ("camera", "axis", "term", "coefficient", "95 % interval", "unit"):
        t.add_column(c, justify="left" if c in ("camera", "axis", "term", "unit") else "right")
    units = law.doc["units"]
    for row in law.doc["rows"]:
        lo, hi = row["intercept_ci95"]
        t.add_row(row["camera"], row["axis"], "intercept", f"{row['intercept_um']:.4g}",
                  f"{lo:.4g} – {hi:.4g}", "µm")  # fmt: skip
        for n in law.doc["features"]:
            lo, hi = row["coefficients_ci95"][n]
            t.add_row(row["camera"], row["axis"], n, f"{row['coefficients'][n]:.4g}",
                      f"{lo:.4g} – {hi:.4g}", units[n])  # fmt: skip
    out.print(t)
    rng = ", ".join(f"{k} {a:.2f}–{b:.2f} °C" for k, (a, b) in law.doc["train_range_c"].items())
    out.print(f"Fitted on temperatures within: {rng}.")
    if checked is not None:
        for row in checked["runs"]:
            out.print(f"Check on {row['run']}: {row['compensated_rms_um']:.2f} µm rms compensated.")
        for w in checked["outside"]:
            click.echo(f"warning: {w}: the law extrapolates there", err=True)
    click.echo(f"wrote {out_path}", err=True)
