"""``thermrs diagnose`` and ``thermrs diagnose-bench``: parse, call :mod:`thermrs.diagnose`,
render. Registered on the CLI group by :mod:`thermrs.cli`."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from rich.table import Table

# The CLI's console: the terminal's width on a terminal; piped, tables are never cut or wrapped.
from thermrs.cli.common import (
    campaign_options,
    exclude_option,
    fold_options,
    input_file,
    json_option,
    out,
    runs_option,
    seed_option,
    verbose_option,
)

if TYPE_CHECKING:  # pragma: no cover
    from thermrs.analyses.diagnose import DiagnosisFold


def _f(x: Any, digits: int = 2) -> str:
    if x is None:
        return "—"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def _params(p: dict[str, Any], ci: dict[str, Any] | None = None) -> str:
    from thermrs.diagnose.verdict import format_params

    return format_params(p, ci)


def render_diagnosis(doc: dict[str, Any]) -> None:
    """Print a diagnosis document (``Diagnosis.to_json()``) as tables."""
    _say_baseline(doc)
    _say_floor(doc)
    _say_where(doc)
    _say_which(doc)
    for c in doc["confounded"]:
        out.print(
            f"Confounded: {' and '.join(c['families'])} (canonical correlation {c['cos']:.2f}); "
            f"to separate them: {c['separate_by']}"
        )
    _say_verdict(doc)
    if doc.get("excluded"):
        out.print(f"Excluded (--exclude, never named): {', '.join(doc['excluded'])}")


def _say_baseline(doc: dict[str, Any]) -> None:
    """The nominal fit: α, training and held-out rms, the noise floor."""
    b = doc["baseline"]
    a = b["alpha_per_k"]
    out.print(
        f"[bold]Baseline[/bold]: α = {a['value'] * 1e6:.3f}×10⁻⁶/K "
        f"[{a['ci95'][0] * 1e6:.3f}, {a['ci95'][1] * 1e6:.3f}] on the training runs; rms "
        f"{b['train_rms_um']:.2f} µm training, {b['holdout_rms_um']:.2f} µm held out "
        f"(max {b['holdout_max_um']:.2f}); noise floor {doc['noise_floor_um']:.2f}"
        + (f" ± {se:.2f}" if (se := (doc.get("noise_floor") or {}).get("holdout_se_um")) else "")
        + " µm"
    )


def _say_floor(doc: dict[str, Any]) -> None:
    """The noise floor's parts, when the document has them."""
    nf = doc.get("noise_floor") or {}
    parts = nf.get("parts") or {}
    if not parts:
        return
    cen = parts.get("centroid_um")
    corr_t = parts.get("pose_correlation_time_min")
    out.print(
        "[bold]Floor[/bold] (noise by physics): visit repeatability "
        f"{parts.get('visit_white_um', float('nan')):.2f} µm white + "
        f"{parts.get('pose_correlated_um', float('nan')):.2f} µm correlated"
        + (f" over {corr_t:.1f} min" if corr_t else "")
        + f" (allowed ≤ {nf.get('correlation_time_max_min', float('nan')):.1f} min, a tenth "
        "of the shortest thermal time constant); centroid "
        + (f"{cen:.2f} µm" if cen is not None else f"not separated ({parts.get('centroid')})")
        + "; per held-out run "
        + ", ".join(
            f"{r} {v:.2f} µm"
            for r, v in (nf.get("per_run_um") or {}).items()
            if any(x.get("run") == r and x.get("role") == "holdout" for x in doc["location"])
        )
    )
    th = nf.get("thermometers") or {}
    if th.get("chips_um") is not None:
        ci = th.get("chips_ci95")
        k = th.get("reading_noise_k") or {}
        out.print(
            f"  of it the thermal camera's reading noise through the model "
            f"{th['thermometers_um']:.2f} µm (each ROI's scatter: "
            + ", ".join(f"{r} {v:.3f} K" for r, v in k.items())
            + f"), the chips' and poses' {th['chips_um']:.2f} µm"
            + (f" [{ci[0]:.2f}, {ci[1]:.2f}]" if ci else "")
        )


def _say_where(doc: dict[str, Any]) -> None:
    """Where the residual lies, and its strongest driver."""
    t = Table(title="Where: largest shares of the residual (run, camera, chip axis, phase)")
    for c in ("run", "role", "camera", "axis", "phase", "visits", "rms µm", "share"):
        t.add_column(c, justify="right" if c in ("visits", "rms µm", "share") else "left",
                     overflow="fold")  # fmt: skip
    for r in sorted(doc["location"], key=lambda r: -r["share"])[:8]:
        t.add_row(
            r["run"], r["role"], r["camera"], r["axis"], r["phase"], str(r["n"]),
            f"{r['rms_um']:.2f}", f"{r['share']:.0%}",
        )  # fmt: skip
    out.print(t)
    if doc["drivers"]:
        d = doc["drivers"][0]
        out.print(
            f"Strongest driver: {d['driver']} (chip {d['axis']}: r = {d['corr']:.2f}, "
            f"p = {d['p']:.2g}); held-out residual "
            + ("white" if doc["whiteness"].get("white") else "not white")
            + f" (Ljung–Box p = {_f(doc['whiteness'].get('ljung_box_p'), 3)})"
        )


def _say_which(doc: dict[str, Any]) -> None:
    """Each effect's fit and evidence, then those whose parameters are implausible."""
    t = Table(title="Which: each effect fitted on the training runs, scored on the held-out runs")
    for c in ("effect", "parameters", "held-out rms µm", "shrink", "gain z", "gap closed",
              "placebo rms", "stability", "ok"):  # fmt: skip
        t.add_column(c, justify="left" if c in ("effect", "parameters") else "right",
                     overflow="fold")  # fmt: skip
    from thermrs.numbers import implausible

    beyond = []
    for r in doc["ranking"]:
        e = r["evidence"]
        why = implausible(r["effect"], r["params"])
        if why is not None:
            beyond.append(f"{r['family']}: {why}")
        t.add_row(
            r["family"],
            _params(r["params"]),
            f"{r['holdout_rms_um']:.2f}",
            f"{r['shrink']:.0%}",
            _f(e["gain_z"], 1),
            "—" if e["gap_closed"] is None else f"{min(e['gap_closed'], 1.0):.0%}",
            _f(e["placebo_holdout_rms_um"]),
            _f(e["stability"]),
            ("at bound" if "search bound" in why else "implausible")
            if why is not None
            else "yes"
            if e["qualifies"]
            else "no",
        )
    out.print(t)
    for line in beyond:
        out.print(f"Implausible: {line}")


def _say_verdict(doc: dict[str, Any]) -> None:
    """The verdict and how far the residual shrinks."""
    v = doc["verdict"]
    hf = doc["how_far"]
    out.print(f"[bold]Verdict: {v['status']}[/bold] — {v['reason']}")
    if v["effect"]:
        out.print(f"  {v['effect']}: {_params(v['params'], v.get('params_ci95'))} (95 % intervals)")
        a, aci = v.get("alpha_per_k"), v.get("alpha_ci95")
        if a is not None and aci:
            out.print(
                f"  α with it: {a * 1e6:.3f}×10⁻⁶/K [{aci[0] * 1e6:.3f}, {aci[1] * 1e6:.3f}] "
                "(the joint fit, the rig's tolerances counted; the baseline's interval is the "
                "nominal model's)"
            )
        spans = [x.get("alpha_ci95") for x in v.get("params_alternatives_fitted") or []]
        spans = [x for x in spans if x]
        if aci and spans:
            lo = min([aci[0], *(x[0] for x in spans)])
            hi = max([aci[1], *(x[1] for x in spans)])
            out.print(
                f"  α over the choices the data cannot tell apart: [{lo * 1e6:.3f}, "
                f"{hi * 1e6:.3f}]×10⁻⁶/K (each fitted in the effect's place; the law spans them)"
            )
    from thermrs.numbers import gap_closed

    gap = hf.get("gap_closed_raw", hf["gap_closed"])  # uncapped: the display says why it caps
    shown = gap_closed(gap, hf["holdout_rms_after_um"], hf.get("noise_floor_um"))
    ci = hf.get("gap_closed_ci95")
    if gap is not None and ci:
        shown += (
            f" ({100 * ci[0]:.0f}–{100 * ci[1]:.0f} % at 95 %, before, after and the floor "
            "uncertain together)"
        )
    out.print(
        f"How far: held-out rms {hf['holdout_rms_before_um']:.2f} → "
        f"{hf['holdout_rms_after_um']:.2f} µm, max {hf['holdout_max_before_um']:.2f} → "
        f"{hf['holdout_max_after_um']:.2f} µm"
        + ("" if gap is None else f"; the gap above the noise floor closed: {shown}")
    )


def render_paper(doc: dict[str, Any]) -> None:
    """Print the paper diagnosis (:func:`thermrs.diagnose.paper.paper_diagnosis`)."""
    keys = list(doc["measured_um"])
    runs = list(dict.fromkeys(k.split("/")[0] for k in keys))

    def per_run(values: dict[str, float]) -> list[str]:
        return ["/".join(f"{values[k]:.0f}" for k in keys if k.startswith(r + "/")) for r in runs]

    t = Table(title="Table 4 (drift along chip y, µm, cameras A/B) and the effects that fit it")
    t.add_column("model", justify="left", ratio=3, overflow="fold")
    for r in runs:
        t.add_column(r, justify="right", overflow="fold")
    t.add_column("rms µm", justify="right", overflow="fold")
    t.add_column("possible", justify="right", overflow="fold")
    t.add_row("measured (Table 4)", *per_run(doc["measured_um"]), "", "")
    nom = doc["nominal"]
    t.add_row(
        "nominal model, α = 23.2×10⁻⁶/K",
        *per_run(nom["predicted_v_um"]),
        f"{nom['rms_um']:.1f}",
        "",
    )
    for c in doc["candidates"][:10]:
        t.add_row(
            f"{c['effect']}: {_params(c['params'])}",
            *per_run(c["predicted_v_um"]),
            f"{c['rms_um']:.1f}",
            "yes" if c["plausible"] else "no",
        )
    out.print(t)
    out.print(doc["summary"])
    for s in doc["separate_by"]:
        out.print(f"  To separate them: {s}")
    for c in doc["cannot_act"]:
        out.print(f"  {c['effect']}: cannot act here — {c['why']}")


@click.command()
@click.option(
    "--rig",
    "rig_path",
    type=input_file,
    default=None,
    help="Rig file (default with --paper: the embedded paper rig).",
)
@runs_option("Training runs", name="--train", dest="train")
@runs_option("Held-out runs, scored but never fitted", name="--holdout", dest="holdout")
@exclude_option(
    "Effects removed from the library (SPEC §6 names; --exclude A B or repeats): never named, "
    "never rivals."
)
@click.option("--paper", "paper", is_flag=True, help="Diagnose the paper's own Table 4 numbers.")
@click.option(
    "--bootstrap",
    default=30,
    show_default=True,
    type=click.IntRange(0, 10_000),
    help="Block-bootstrap resamples for stability.",
)
@click.option(
    "--margin",
    "margin_um",
    type=click.FloatRange(min=0.0),
    default=None,
    metavar="UM",
    help="Practical margin: name an effect only if it takes at least this much (µm) off the "
    "held-out rms, beyond being significant [default: the held-out noise floor's standard "
    "error, what the held-out runs resolve].",
)
@click.option(
    "--baselines",
    "baselines",
    is_flag=True,
    help="Also fit regressions of the drift on the temperatures (least squares, ridge, LASSO, "
    "boosted trees) on the training runs and score them on the held-out runs beside the "
    "physical models (--json: `baselines`).",
)
@seed_option("Seed of the resampling.")
@json_option(
    "Write the SPEC §7 JSON here (atomically); with --rule, one document per fold and what "
    'they conclude together ({"rule", "folds": [{"fold", "train", "holdout", "diagnosis"}], '
    '"synthesis"}).'
)
@campaign_options(
    rule="With --campaign: a diagnosis per fold (each rendered in turn, then the verdicts "
    "side by side and what the folds conclude together)."
)
@fold_options
@verbose_option
def diagnose(
    rig_path: Path | None,
    train: tuple[Path, ...],
    holdout: tuple[Path, ...],
    exclude: tuple[str, ...],
    paper: bool,
    bootstrap: int,
    margin_um: float | None,
    baselines: bool,
    seed: int,
    json_path: Path | None,
    campaign_path: Path | None,
    query: str | None,
    rule: str | None,
    workers: int | None,
    scheduler: str | None,
    verbose: bool,
) -> None:
    """Diagnose the sim-to-real gap: where the nominal model's residual lies, which SPEC §6
    effect causes it, and how far it shrinks — scored on held-out runs. The runs are files,
    or runs of a --campaign dataset (named, or held out by --rule).

    Exits 3 (after diagnosing) if part of a recording was lost.
    """
    from thermrs.analyses.diagnose import diagnose_splits, fold_synthesis
    from thermrs.cli.common import EXIT_DATA_LOSS, chosen_splits, stages, writable, write_json
    from thermrs.errors import InputError
    from thermrs.rig import load_rig

    writable(json_path, "--json", suffixes=(".json",))

    if paper:
        if train or holdout or campaign_path is not None or query or rule:
            raise click.UsageError(
                "--paper diagnoses the paper's numbers; give no --train/--holdout/--campaign"
            )
        if baselines:
            raise click.UsageError("--baselines needs runs: --paper has only Table 4's numbers")
        from thermrs.diagnose.paper import paper_diagnosis

        pdoc = paper_diagnosis(rig=load_rig(rig_path))
        if json_path is not None:
            write_json(json_path, pdoc)
        render_paper(pdoc)
        return
    if rig_path is None:
        raise click.UsageError("Missing option '--rig' (or give --paper).")
    if campaign_path is None and train and not holdout:
        raise InputError(
            "no --holdout run: effects are scored on runs they were not fitted on; give at "
            "least one held-out run"
        )
    r = load_rig(rig_path)
    sets = chosen_splits(campaign_path, query, rule, train, holdout, r)
    with stages("diagnose", verbose=verbose) as say:
        folds = diagnose_splits(sets, r, exclude=exclude, bootstrap=bootstrap, seed=seed,
                                margin_um=margin_um, progress=say, workers=workers,
                                scheduler=scheduler)  # fmt: skip
        extra: list[dict[str, Any]] = [{} for _ in folds]
        if baselines:
            from thermrs.analyses.baselines import baselines_folds

            say("baselines")
            extra = [c.to_json() for c in baselines_folds(folds, r, seed=seed)]
    synthesis = (
        fold_synthesis([(f.split.name, f.diagnosis.to_json()) for f in folds])
        if rule is not None
        else None
    )
    if json_path is not None:
        if rule is None:
            write_json(json_path, {**folds[0].diagnosis.to_json(), **extra[0]})
        else:
            docs = [f.to_json() for f in folds]
            for d, e in zip(docs, extra, strict=True):
                d["diagnosis"].update(e)
            write_json(json_path, {"rule": rule, "folds": docs, "synthesis": synthesis})
    for f, e in zip(folds, extra, strict=True):
        if f.split.name:
            out.rule(f"[bold]{f.split.name}[/bold]")
        render_diagnosis(f.diagnosis.to_json())
        if e:
            from thermrs.cli.baselines import render_baselines

            render_baselines(e)
    if rule is not None:
        render_folds(folds, rule)
        assert synthesis is not None
        out.print(f"Across the folds: {synthesis['sentence']}.")
    if any(s.data_loss for s in sets):
        sys.exit(EXIT_DATA_LOSS)


def render_folds(folds: list[DiagnosisFold], rule: str) -> None:
    """The folds' verdicts side by side."""
    t = Table(title=f"Diagnosis by fold ({rule})")
    for c in ("fold", "verdict", "effect", "held-out rms µm before → after"):
        t.add_column(c, overflow="fold")
    for f in folds:
        doc = f.diagnosis.to_json()
        hf = doc["how_far"]
        t.add_row(
            f.split.name,
            doc["verdict"]["status"],
            str(doc["verdict"]["effect"] or "—"),
            f"{hf['holdout_rms_before_um']:.2f} → {hf['holdout_rms_after_um']:.2f}",
        )
    out.print(t)


@click.command("diagnose-bench")
@click.option(
    "--rig",
    "rig_path",
    type=input_file,
    default=None,
    help="Rig file (default: the embedded paper rig).",
)
@click.option(
    "--seeds",
    default=1,
    show_default=True,
    type=click.IntRange(1, 1000),
    help="Repetitions of the whole plan (every case its own world).",
)
@click.option(
    "--hours",
    default=12.0,
    show_default=True,
    type=click.FloatRange(1.0, 72.0),
    help="Length of each of the three runs.",
)
@click.option(
    "--cycle-s",
    "cycle_s",
    default=600.0,
    show_default=True,
    type=click.FloatRange(30.0, 3600.0),
    help="Seconds per cycle (one visit to each camera).",
)
@click.option(
    "--effect",
    "effects",
    multiple=True,
    help="Only these effects (default: all; `none`: only the no-effect cases).",
)
@click.option(
    "--world",
    "worlds",
    multiple=True,
    type=click.Choice(["white", "ar1"]),
    help="Nuisance worlds (default: both).",
)
@click.option(
    "--snr",
    "snrs",
    multiple=True,
    type=click.FloatRange(0.01, 100.0),
    help="Target SNRs (default: 0.25 0.5 1 2 4).",
)
@click.option(
    "--nulls",
    default=4,
    show_default=True,
    type=click.IntRange(0, 1000),
    help="No-effect cases per seed and world.",
)
@click.option(
    "--jobs",
    default=1,
    show_default=True,
    type=click.IntRange(1, 256),
    help="Worker processes.",
)
@click.option(
    "--seed",
    "first_seed",
    default=1000,
    show_default=True,
    type=click.IntRange(0, 2**62),
    help="Seed of the first case (case k of repetition s: SEED + 1000·s + k). The diagnoser's "
    "rules were chosen on seeds 1000-4999: give one >= 100000 for worlds it was not tuned on.",
)
@click.option(
    "--tolerance-scale",
    "tolerance_scale",
    default=1.0,
    show_default=True,
    type=click.FloatRange(0.0, 100.0),
    help="The worlds' rig and IR nuisances at this multiple of the rig's stated [tolerances] "
    "(2, 3: a rig worse than it states).",
)
@json_option("Write the results here (atomically).")
def diagnose_bench(
    rig_path: Path | None,
    seeds: int,
    hours: float,
    cycle_s: float,
    effects: tuple[str, ...],
    worlds: tuple[str, ...],
    snrs: tuple[float, ...],
    nulls: int,
    jobs: int,
    first_seed: int,
    tolerance_scale: float,
    json_path: Path | None,
) -> None:
    """The diagnoser on runs made by an independent world (its own kinematics, thermal physics
    and effects) with each SPEC §6 effect at target signal-to-noise ratios (and withheld from
    the library), no effect, and two effects at once, in two nuisance worlds: right, false
    `none` and false attributions per world and SNR bin."""
    from thermrs.bench import run_bench
    from thermrs.cli.common import writable, write_json

    writable(json_path, "--json", suffixes=(".json",))
    from thermrs.effects import EFFECT_NAMES
    from thermrs.errors import InputError
    from thermrs.rig import load_rig

    bad = sorted(set(effects) - {*EFFECT_NAMES, "none"})
    if bad:
        raise InputError(f"--effect {bad}: not effects (known: none, {', '.join(EFFECT_NAMES)})")
    r = load_rig(rig_path)
    from thermrs.cli.common import stages

    with stages("diagnose-bench") as say:
        doc = run_bench(
            r,
            seeds=seeds,
            hours=hours,
            cycle_s=cycle_s,
            effects=tuple(e for e in effects if e != "none") if effects else None,
            worlds=tuple(worlds) or ("white", "ar1"),
            snrs=tuple(snrs) or (0.25, 0.5, 1.0, 2.0, 4.0),
            nulls=nulls,
            jobs=jobs,
            first_seed=first_seed,
            tolerance_scale=tolerance_scale,
            progress=say,
        )
    if json_path is not None:
        write_json(json_path, doc)
    render_bench(doc)


def render_bench(doc: dict[str, Any]) -> None:
    """Print a bench document (:func:`thermrs.bench.run_bench`) as tables."""
    sections = (
        ("single", "One effect", ("right", "false none", "false attribution", "unexplained")),
        ("withheld", "True effect excluded", ("honest", "stand-in", "none", "false attribution")),
        ("pair", "Two effects", ("right", "false none", "wrong")),
    )
    for key, title, cols in sections:
        if not any(n["cases"] for bins in doc[key].values() for n in bins.values()):
            continue
        t = Table(title=f"{title} (rows: nuisance world, SNR bin)")
        for c in ("world", "SNR", "cases", *cols):
            t.add_column(c, justify="left" if c == "world" else "right")
        for world, bins in doc[key].items():
            for b, n in bins.items():
                if n["cases"]:
                    t.add_row(world, b, str(n["cases"]), *[str(n.get(c, 0)) for c in cols])
        out.print(t)
    t = Table(title="No effect (rows: nuisance world, the gap its own nuisances leave ÷ σ)")
    for c in ("world", "nuisance", "cases", "none", "instrument named", "false attribution",
              "false gap"):  # fmt: skip
        t.add_column(c, justify="left" if c in ("world", "nuisance") else "right")
    for world, n in doc["none"].items():
        parts = (doc.get("none_by_nuisance") or {}).get(world) or {"all": n}
        for label, m in parts.items():
            if m["cases"]:
                counts = [
                    m["cases"],
                    m.get("right", 0),
                    m.get("instrument named", 0),
                    m.get("false attribution", 0),
                ]
                t.add_row(world, label, *map(str, counts), str(m.get("false gap", 0)))
    out.print(t)
    for world, m in (doc.get("must_reach") or {}).items():
        r = m.get("not_none_on_none") or {}
        if r.get("n"):
            out.print(
                f"{world}: a verdict other than `none` on {r['k']} of {r['n']} effect-free cases"
            )
        lenient, strict = m.get("right_snr_ge_1") or {}, m.get("right_strict_snr_ge_1") or {}
        if lenient.get("n"):
            out.print(
                f"{world}: one effect at SNR >= 1 named {lenient['k']} of {lenient['n']} "
                f"(identified alone, strict: {strict.get('k', 0)} of {strict.get('n', 0)})"
            )
    for s in doc["skipped"]:
        out.print(f"not run: {s}")
    first = (doc.get("setup") or {}).get("first_seed")
    seeds = f", seeds from {first}" if first is not None else ""
    setup = doc.get("setup") or {}
    if "tolerance_scale" in setup:
        seeds += f"; nuisances at {setup['tolerance_scale']:g}x the rig's " + (
            "stated tolerances" if setup.get("tolerances_stated") else "default tolerances"
        )
    out.print(f"{doc['cases']} cases in {doc['seconds']:.0f} s{seeds}")
