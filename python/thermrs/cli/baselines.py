"""The baselines' table (``thermrs diagnose --baselines``): the physical models and each
regression side by side on the held-out runs (:mod:`thermrs.analyses.baselines`)."""

from __future__ import annotations

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
    for r in rows:
        lo, hi = r["holdout_rms_ci95"]
        cells = [
            r["name"],
            r["description"],
            str(r["n_params"]),
            f"{r['holdout_rms_um']:.2f} [{lo:.2f}, {hi:.2f}]",
            *(f"{p['rms_um']:.2f}" for p in r["per_run"]),
        ]
        if comp["diagnosed"]:
            d = r["minus_diagnosed_ci95"]
            cells.append("—" if r["name"] == "diagnosed" else f"[{d[0]:+.2f}, {d[1]:+.2f}]")
        t.add_row(*cells)
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
