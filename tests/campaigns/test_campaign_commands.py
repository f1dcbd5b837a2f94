"""fit, predict, drift, diagnose, design and report on the runs of a campaign dataset
(``--campaign DATASET --where … --rule …``, ``thermrs.analyses.fit`` …): each gives what the
same command gives on the same runs read from the recordings themselves (``FILE#RUN``), a path
that shares no code with the dataset's; and bad input is one line, exit 2."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote

import polars as pl
import pytest
import thermrs
from polars.testing import assert_frame_equal
from thermrs.runs import load_runs
from thermrs.simulate import simulate

from tests.campaigns.test_campaign import SCENARIO
from tests.support.nested import assert_nested_close
from tests.support.recordings import shift_days

RIG = str(thermrs.default_rig_path())


def cli(cmd: str, *args: str) -> subprocess.CompletedProcess[str]:
    """``thermrs CMD --rig RIG ARGS…`` in a new process."""
    env = {**os.environ, "THERMRS_DEBUG": ""}
    return subprocess.run(
        [sys.executable, "-m", "thermrs", cmd, "--rig", RIG, *args],
        capture_output=True,
        text=True,
        env=env,
    )


def on_campaign(camp: dict[str, Path], cmd: str, *args: str) -> subprocess.CompletedProcess[str]:
    """``thermrs CMD --rig RIG --campaign DATASET ARGS…``."""
    return cli(cmd, "--campaign", str(camp["ds"]), *args)


@pytest.fixture(scope="module")
def camp(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two recordings of two runs each (30 % and 75 % speed) and their campaign dataset,
    extracted in process (one recording per call: no cluster)."""
    d = tmp_path_factory.mktemp("campaign-commands")
    (d / "s.toml").write_text(SCENARIO)
    rig = thermrs.load_rig()
    recs = [simulate(rig, d / "s.toml", d / f"r{i}.mcap", seed=i).recording for i in (1, 2)]
    for r in recs:
        thermrs.campaign([r], d / "ds")
    return {"dir": d, "ds": d / "ds", "r1": recs[0], "r2": recs[1]}


def spec(camp: dict[str, Path], name: str) -> str:
    """The file run of a campaign run: ``r1-<hash>#run2`` → ``…/r1.mcap#run2``."""
    rec, _, run = name.partition("#")
    return f"{camp['dir'] / rec.rsplit('-', 1)[0]}.mcap#{run}"


def rec_id(camp: dict[str, Path], stem: str) -> str:
    """The catalog's id of a recording."""
    return str(thermrs.analyses.inputs.select_runs(camp["ds"], names=[stem])["recording"][0])


def named_and_files(
    camp: dict[str, Path], train: list[str], holdout: list[str]
) -> tuple[list[str], list[str]]:
    """``--train … --holdout …`` as campaign names and as the recordings' file runs."""
    runs = {"--train": train, "--holdout": holdout}
    named = [x for k, v in runs.items() for x in (k, *v)]
    return named, [x for k, v in runs.items() for x in (k, *[spec(camp, n) for n in v])]


def file_tables(camp: dict[str, Path], names: list[str]) -> list[pl.DataFrame]:
    rig = thermrs.load_rig()
    return [t for n in names for t in load_runs(spec(camp, n), rig).tables]


def same_table(a: pl.DataFrame, b: pl.DataFrame) -> None:
    assert_frame_equal(a.drop("run"), b.drop("run"), check_exact=False, rel_tol=1e-12)


def test_runs_by_name_and_query(camp: dict[str, Path]) -> None:
    from thermrs.analyses.inputs import select_runs, selected, splits
    from thermrs.errors import InputError

    rig = thermrs.load_rig()
    every = select_runs(camp["ds"])
    assert every.height == 4
    # A recording by its stem or its id; alone, each of its runs.
    rid = every.filter(pl.col("run") == "run1")["recording"][0]
    assert select_runs(camp["ds"], names=[rid.rsplit("-", 1)[0]]).height == 2
    one = selected(camp["ds"], rig, names=[f"{rid}#run2"])
    # The run table read from the dataset is the one read from the recording.
    same_table(one.train[0], file_tables(camp, [f"{rid}#run2"])[0])
    with pytest.raises(InputError, match="no such run"):
        selected(camp["ds"], rig, names=["r9#run1"])
    s = splits(camp["ds"], rig, where="run=run1", train=["r1#run1"])
    assert [len(s[0].train), len(s[0].holdout)] == [1, 1]
    with pytest.raises(InputError, match="both trained on and held out"):
        splits(camp["ds"], rig, train=["r1"], holdout=["r1#run2"])


@pytest.mark.slow
@pytest.mark.floors
def test_fit_from_the_catalog_is_the_fit_of_the_files(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    from thermrs.analyses.fit import fit_document

    rig = thermrs.load_rig()
    names = ["r1#run1", "r2#run1"]
    got = thermrs.analyses.fit(camp["ds"], rig, where="run=run1")
    truth = fit_document(file_tables(camp, names), rig)
    assert got.fit.alpha_per_k == pytest.approx(truth.fit.alpha_per_k, rel=1e-9)
    assert got.fit.ci95 == pytest.approx(truth.fit.ci95, rel=1e-9)
    # The CLI: --campaign with --where, against --train FILE#RUN.
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    p = on_campaign(camp, "fit", "--where", "run=run1", "--json", str(a))
    assert p.returncode == 0, p.stderr
    p = cli("fit", "--train", *[spec(camp, n) for n in names], "--json", str(b))
    assert p.returncode == 0, p.stderr
    da, db = json.loads(a.read_text()), json.loads(b.read_text())
    assert da["alpha_per_k"]["value"] == pytest.approx(db["alpha_per_k"]["value"], rel=1e-9)
    assert sorted(
        se["mean"]["value"] if isinstance(se["mean"], dict) else se["mean"][0]
        for se in da["start_end"].values()
    ) == pytest.approx(
        sorted(
            se["mean"]["value"] if isinstance(se["mean"], dict) else se["mean"][0]
            for se in db["start_end"].values()
        ),
        rel=1e-9,
    )


@pytest.mark.slow
@pytest.mark.floors
def test_predict_by_rule_is_each_fold_predicted_from_files(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    from thermrs.analyses.fit import fit_document, training_alphas
    from thermrs.predict import prediction_table

    rig = thermrs.load_rig()
    out = tmp_path / "p.json"
    series = tmp_path / "s.parquet"
    p = on_campaign(
        camp, "predict", "--rule", "leave-one-run-out", "--json", str(out), "--series", str(series)
    )
    assert p.returncode == 0, p.stderr
    assert "Held out by fold (leave-one-run-out)" in p.stdout
    doc = json.loads(out.read_text())
    # One held-out rms over the folds: every fold's mean-removed residual series pooled,
    # recomputed here from the series file.
    s = pl.read_parquet(series).filter(pl.col("alpha") == "series")
    keys = ["fold", "run", "camera"]
    centred = pl.concat(
        [
            s.select(
                (pl.col(f"residual_{a}_um") - pl.col(f"residual_{a}_um").mean().over(keys)).alias(
                    "r"
                )
            )
            for a in "uv"
        ]
    )["r"].drop_nans()
    pooled = float((centred**2).mean() ** 0.5)  # type: ignore[operator]
    syn = doc["synthesis"]
    assert syn["folds"] == 4 and syn["holdout_rms_um"] == pytest.approx(pooled, rel=1e-9)
    assert syn["fold_rms_um"][0] <= pooled <= syn["fold_rms_um"][1]
    assert f"Across the folds: held-out rms {pooled:.3f} µm over 4 fold(s)" in p.stdout
    assert doc["rule"] == "leave-one-run-out" and len(doc["folds"]) == 4
    for fold in doc["folds"]:
        assert len(fold["train"]) == 3 and len(fold["holdout"]) == 1
        assert fold["holdout"][0] not in fold["train"]
        alphas = training_alphas(fit_document(file_tables(camp, fold["train"]), rig))
        assert fold["alpha_per_k"] == pytest.approx(alphas, rel=1e-9)
        truth = prediction_table(file_tables(camp, fold["holdout"]), rig, alphas=alphas)
        got = pl.DataFrame(fold["table"])
        for c in ("predicted_um", "measured_um", "rms_centred_um"):
            assert got[c].to_list() == pytest.approx(truth[c].to_list(), rel=1e-9, abs=1e-12)
    # α given, runs by query: the same table as the files with that α.
    p = on_campaign(camp, "predict", "--where", "speed>150", "--alpha", "23.2u", "--json", str(out))
    assert p.returncode == 0, p.stderr
    got = pl.DataFrame(json.loads(out.read_text())["table"])
    truth = prediction_table(
        file_tables(camp, ["r1#run2", "r2#run2"]), rig, alphas={"given": 23.2e-6}
    )
    assert got["predicted_um"].to_list() == pytest.approx(truth["predicted_um"].to_list())


@pytest.mark.slow
@pytest.mark.floors
def test_by_day_trains_on_one_day_and_predicts_the_next(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    from thermrs.analyses.fit import fit_document, training_alphas
    from thermrs.predict import prediction_table

    # r2 recorded a day later (the same bytes but for the stamps), beside r1.
    shift_days(camp["r2"], tmp_path / "r2d.mcap", 1)
    for r in (camp["r1"], tmp_path / "r2d.mcap"):
        thermrs.campaign([r], tmp_path / "ds")
    out = tmp_path / "p.json"
    p = cli("predict", "--campaign", str(tmp_path / "ds"), "--rule", "by-day", "--json", str(out))
    assert p.returncode == 0, p.stderr
    (fold,) = json.loads(out.read_text())["folds"]
    assert fold["fold"] == "train 2025-06-15, hold out 2025-06-16"
    assert [n.split("-")[0] for n in fold["train"] + fold["holdout"]] == ["r1", "r1", "r2d", "r2d"]
    rig = thermrs.load_rig()
    files = [f"{camp['r1']}#run1", f"{camp['r1']}#run2"]
    alphas = training_alphas(
        fit_document([t for f in files for t in load_runs(f, rig).tables], rig)
    )
    assert fold["alpha_per_k"] == pytest.approx(alphas, rel=1e-9)
    held = load_runs(tmp_path / "r2d.mcap", rig).tables
    truth = prediction_table(held, rig, alphas=alphas)
    got = pl.DataFrame(fold["table"])
    assert got["predicted_um"].to_list() == pytest.approx(truth["predicted_um"].to_list(), rel=1e-9)


@pytest.mark.slow
@pytest.mark.floors
def test_drift_from_the_catalog_is_drift_of_the_files(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    p = on_campaign(camp, "drift", "--run", "r2#run2", "--json", str(a))
    assert p.returncode == 0, p.stderr
    p = cli("drift", "--run", spec(camp, "r2#run2"), "--json", str(b))
    assert p.returncode == 0, p.stderr
    rid = rec_id(camp, "r2")
    # Everything the same but the run's name.
    da = json.loads(a.read_text().replace(f"{rid}#run2", "RUN"))
    db = json.loads(b.read_text().replace("r2#run2", "RUN"))
    assert_frame_equal(pl.DataFrame(da["curves"]), pl.DataFrame(db["curves"]), rel_tol=1e-9)
    assert da["iso9283"] == db["iso9283"]


@pytest.mark.slow
@pytest.mark.floors
def test_diagnose_from_the_catalog_is_the_diagnosis_of_the_files(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    named, files = named_and_files(camp, ["r1#run1", "r2#run1"], ["r1#run2"])
    p = on_campaign(camp, "diagnose", "--bootstrap", "0", *named, "--json", str(a))
    assert p.returncode == 0, p.stderr
    p = cli("diagnose", "--bootstrap", "0", *files, "--json", str(b))
    assert p.returncode == 0, p.stderr
    da, db = json.loads(a.read_text()), json.loads(b.read_text())
    assert da["verdict"]["status"] == db["verdict"]["status"]
    assert da["verdict"]["effect"] == db["verdict"]["effect"]
    assert da["baseline"]["alpha_per_k"]["value"] == pytest.approx(
        db["baseline"]["alpha_per_k"]["value"], rel=1e-9
    )
    assert da["how_far"]["holdout_rms_after_um"] == pytest.approx(
        db["how_far"]["holdout_rms_after_um"], rel=1e-6
    )


@pytest.mark.slow
@pytest.mark.floors
def test_diagnose_by_rule_is_each_fold_diagnosed_and_predict_uses_a_diagnosis(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    from thermrs.diagnose import diagnose

    rig = thermrs.load_rig()
    out = tmp_path / "d.json"
    where = ["--where", "recording=" + rec_id(camp, "r1")]
    p = on_campaign(
        camp,
        "diagnose",
        "--bootstrap",
        "0",
        "--rule",
        "leave-one-run-out",
        "--workers",
        "2",
        *where,
        "--json",
        str(out),
    )
    assert p.returncode == 0, p.stderr
    assert "Diagnosis by fold (leave-one-run-out)" in p.stdout
    # The folds ran side by side on two workers, each saying when it ended.
    assert len(re.findall(r": without .*: done \(\d+\.\d s\)", p.stderr)) == 2, p.stderr
    doc = json.loads(out.read_text())
    assert doc["rule"] == "leave-one-run-out" and len(doc["folds"]) == 2
    first = doc["folds"][0]
    assert first["holdout"] == [f"{rec_id(camp, 'r1')}#run1"]
    truth = diagnose(
        file_tables(camp, first["train"]), file_tables(camp, first["holdout"]), rig, bootstrap=0
    ).to_json()
    # The same diagnosis to the last digits, runs named by the catalog's id.
    named = json.loads(json.dumps(first["diagnosis"]).replace(rec_id(camp, "r1"), "r1"))
    assert_nested_close(named, truth, rel=1e-9)
    # The synthesis tallies what the folds' own documents say, and is printed.
    outcomes = [
        f["diagnosis"]["verdict"].get("outcome", f["diagnosis"]["verdict"]["status"])
        for f in doc["folds"]
    ]
    syn = doc["synthesis"]
    assert syn["tally"] == {o: outcomes.count(o) for o in set(outcomes)}
    effects = {f["diagnosis"]["verdict"]["effect"] for f in doc["folds"]}
    assert syn["consistent"] == (len(set(outcomes)) == 1 and len(effects) == 1)
    assert f"Across the folds: {syn['sentence']}." in " ".join(p.stdout.split())
    # That fold's diagnosis predicts its held-out run as it predicts the file's.
    (tmp_path / "one.json").write_text(json.dumps(first["diagnosis"]))
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    diag = ["--diagnosis", str(tmp_path / "one.json")]
    p = on_campaign(camp, "predict", *diag, "--run", "r1#run1", "--json", str(a))
    assert p.returncode == 0, p.stderr
    p = cli("predict", *diag, "--run", spec(camp, "r1#run1"), "--json", str(b))
    assert p.returncode == 0, p.stderr
    ta, tb = (pl.DataFrame(json.loads(x.read_text())["table"]) for x in (a, b))
    assert_frame_equal(ta.drop("run"), tb.drop("run"), rel_tol=1e-9)


@pytest.mark.slow
@pytest.mark.floors
def test_report_from_the_catalog_is_the_report_of_the_files(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    from thermrs.analyses.report import campaign_report_runs
    from thermrs.analyses.report_runs import load_runs as report_runs

    rig = thermrs.load_rig()
    got, train = campaign_report_runs(camp["ds"], rig, train=["r2#run2"], runs=["r1"])
    assert [r.name.split("-")[0] + "#" + r.name.split("#")[1] for r in got] == [
        "r2#run2",
        "r1#run1",
        "r1#run2",
    ]
    assert train == [got[0].name]
    for r in got:
        (truth,) = report_runs(spec(camp, r.name), rig)
        same_table(r.table, truth.table)
        assert truth.temperatures is not None and r.temperatures is not None
        assert_frame_equal(r.temperatures, truth.temperatures.select(r.temperatures.columns))
        assert (r.joints, r.frames_by_status) == (truth.joints, truth.frames_by_status)
    # The report itself (one run: no diagnosis, quick): the same text but for names and the
    # extraction's own report, which a dataset does not keep.
    a, b = tmp_path / "a.html", tmp_path / "b.html"
    p = on_campaign(
        camp,
        "report",
        "--where",
        "recording=" + got[1].name.split("#")[0] + ", run=run1",
        "-o",
        str(a),
        "--quiet",
    )
    assert p.returncode == 0, p.stderr
    p = cli("report", "--run", spec(camp, "r1#run1"), "-o", str(b), "--quiet")
    assert p.returncode == 0, p.stderr

    def body(md: Path, name: str) -> str:
        text = md.read_text().replace(name, "RUN").replace(f"{md.stem}_files", "FIG")
        text = text.replace(re.sub(r"[^A-Za-z0-9._-]+", "-", name), "RUN")  # figure files
        text = text.replace("Extraction lost nothing and skipped no message.\n\n", "")
        return text.split("## What extraction")[0]

    assert body(tmp_path / "a.md", got[1].name) == body(tmp_path / "b.md", "r1#run1")
    # Every figure link opens in a Markdown viewer: no "#" cuts it, the file is there.
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", (tmp_path / "a.md").read_text())
    assert links
    for link in links:
        assert "#" not in link and (tmp_path / unquote(link)).read_text().startswith("<svg")

    # The extraction's own report, kept in the catalog, is the recording's: the same lines
    # but for the section's title (where the run came from).
    def extraction(md: Path, name: str) -> list[str]:
        return md.read_text().replace(name, "RUN").split("## What extraction")[1].splitlines()[3:]

    assert extraction(tmp_path / "a.md", got[1].name) == extraction(tmp_path / "b.md", "r1#run1")
    assert any(line.startswith("Read ") for line in extraction(tmp_path / "a.md", "RUN"))
    # The library face writes the same report.
    thermrs.analyses.report(camp["ds"], rig, tmp_path / "c.html", runs=[got[1].name])
    assert body(tmp_path / "c.md", got[1].name) == body(tmp_path / "b.md", "r1#run1")


@pytest.mark.slow
def test_design_from_the_catalog_is_the_design_of_the_files(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    named, files = named_and_files(camp, ["r1#run1"], ["r1#run2"])
    p = on_campaign(camp, "design", "--no-proof", *named, "-o", str(tmp_path / "a"))
    assert p.returncode == 0, p.stderr
    p = cli("design", "--no-proof", *files, "-o", str(tmp_path / "b"))
    assert p.returncode == 0, p.stderr
    da, db = (json.loads((tmp_path / x / "design.json").read_text()) for x in "ab")
    assert da["confounded"] == db["confounded"]
    assert [c["label"] for c in da["candidates"]] == [c["label"] for c in db["candidates"]]
    assert [c["min_z"] for c in da["candidates"]] == pytest.approx(
        [c["min_z"] for c in db["candidates"]], rel=1e-6
    )


@pytest.mark.slow
def test_design_by_rule_designs_each_fold_on_the_workers_as_here(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    from thermrs.design import design

    rig = thermrs.load_rig()
    out = tmp_path / "next"
    where = ["--where", "recording=" + rec_id(camp, "r1")]
    args = ["--no-proof", "--rule", "leave-one-run-out", "--workers", "2", "-o", str(out)]
    p = on_campaign(camp, "design", *args, *where)
    assert p.returncode == 0, p.stderr
    assert len(re.findall(r": without .*: done \(\d+\.\d s\)", p.stderr)) == 2, p.stderr
    folds = json.loads((out / "folds.json").read_text())["folds"]
    assert [f["folder"] for f in folds] == ["fold-1", "fold-2"]
    for f in folds:
        got = json.loads((out / f["folder"] / "design.json").read_text())
        truth = design(
            file_tables(camp, f["train"]), file_tables(camp, f["holdout"]), rig, prove_it=False
        ).to_json()
        assert got["confounded"] == truth["confounded"]
        assert [c["label"] for c in got["candidates"]] == [c["label"] for c in truth["candidates"]]
        assert [c["min_z"] for c in got["candidates"]] == pytest.approx(
            [c["min_z"] for c in truth["candidates"]], rel=1e-9
        )


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["fit", "--campaign", "{d}/nothing"], "dataset {d}/nothing: no such folder"),
        (["fit", "--campaign", "{d}"], "not a campaign dataset"),
        (["fit", "--campaign", "{ds}", "--where", "date>=2030-01-01"], "no run matches"),
        (["predict", "--campaign", "{ds}", "--rule", "by-day"], "at least two days"),
        (["diagnose", "--campaign", "{ds}", "--rule", "by-day"], "at least two days"),
        (["drift", "--campaign", "{ds}", "--run", "r7#run1"], "--run r7#run1: no such run"),
        (["fit", "--train", "{ds}/../r1.mcap", "--where", "run=run1"], "give --campaign"),
        (["diagnose", "--campaign", "{ds}"], "no held-out run"),
        (["report", "--campaign", "{ds}", "--where", "speed<0"], "no run matches"),
    ],
)
def test_bad_campaign_input_is_one_line_exit_2(
    camp: dict[str, Path], args: list[str], says: str
) -> None:
    fill = {"d": str(camp["dir"]), "ds": str(camp["ds"])}
    p = cli(*[a.format(**fill) for a in args])
    assert p.returncode == 2, p.stderr
    assert says.format(**fill) in p.stderr
    errors = [line for line in p.stderr.splitlines() if "error" in line]
    assert "Traceback" not in p.stderr and len(errors) == 1


@pytest.mark.slow
@pytest.mark.floors
def test_a_dataset_refuses_a_rig_it_was_not_extracted_with(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    """A rig whose chip pitch differs changes every number: refused in one line (exit 2).
    The same rig with a comment added is the same rig."""
    text = Path(RIG).read_text()
    commented = tmp_path / "commented.toml"
    commented.write_text("# the same rig, annotated\n" + text)
    head, sep, tail = text.partition("pixel_pitch_um = [")
    assert sep
    other = tmp_path / "other-pitch.toml"
    other.write_text(head + sep + tail.replace("8.3", "8.6", 2))
    assert other.read_text() != text
    args = ["--campaign", str(camp["ds"]), "--where", "run=run1"]
    ok = subprocess.run(
        [sys.executable, "-m", "thermrs", "fit", "--rig", str(commented), *args],
        capture_output=True,
        text=True,
    )
    assert ok.returncode == 0, ok.stderr
    bad = subprocess.run(
        [sys.executable, "-m", "thermrs", "fit", "--rig", str(other), *args],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2, bad.stderr
    errors = [ln for ln in bad.stderr.splitlines() if "error" in ln]
    assert len(errors) == 1 and "extracted with another rig" in errors[0], bad.stderr
    # Reading never creates: a dataset folder that is not there stays not there.
    from thermrs.errors import InputError

    with pytest.raises(InputError, match="no such folder"):
        thermrs.campaigns.Dataset(tmp_path / "typo")
    assert not (tmp_path / "typo").exists()


def test_where_takes_what_people_type(camp: dict[str, Path], tmp_path: Path) -> None:
    """Stems, rig files, the date formats people type (one that could be read two ways is
    refused with how to write it), quoted values; a miss lists the values there are, and
    `campaign --list` lists them all."""
    from thermrs.analyses.inputs import select_runs
    from thermrs.campaigns.select import parse_date
    from thermrs.errors import InputError

    every = select_runs(camp["ds"])
    r1 = every.filter(pl.col("recording").str.starts_with("r1-"))
    assert select_runs(camp["ds"], where="recording=r1").height == r1.height == 2
    assert select_runs(camp["ds"], where="recording!=r1").height == 2
    assert select_runs(camp["ds"], where=f"rig={RIG}").height == 4
    day = every["date"][0]
    for typed in (day.isoformat(), day.strftime("%d.%m.%Y"), day.strftime("%Y/%m/%d")):
        assert parse_date(typed) == day
        assert select_runs(camp["ds"], where=f"date={typed}").height >= 1
    assert parse_date("16/06/2025").isoformat() == "2025-06-16"
    with pytest.raises(ValueError, match="could be day/month or month/day"):
        parse_date("03/04/2025")
    with pytest.raises(InputError, match="is not a date"):
        select_runs(camp["ds"], where="date=16.06.25x")
    robot = every["robot"][0]
    assert select_runs(camp["ds"], where=f'robot="{robot}", run=run1').height == 2
    with pytest.raises(InputError, match=r"no run matches .*run: run1, run2"):
        select_runs(camp["ds"], where="run=run9")
    p = subprocess.run(
        [sys.executable, "-m", "thermrs", "campaign", str(camp["ds"]), "--list"],
        capture_output=True,
        text=True,
    )
    assert p.returncode == 0, p.stderr
    lines = dict(ln.split(": ", 1) for ln in p.stdout.splitlines())
    assert lines["run"] == "run1, run2"
    assert "r1" in lines["recording"].split(", ") and "r2" in lines["recording"].split(", ")
    assert day.isoformat() in lines["date"]
    assert lines["speed%"] == "30–75"  # the scenario's overrides


@pytest.mark.slow
@pytest.mark.floors
def test_where_speed_override_is_the_scenarios(camp: dict[str, Path]) -> None:
    """``speed%`` is the override each run was simulated at (run1 30 %, run2 75 %), through
    the CLI: the table shows it, a query picks by it, and a miss says the range there is."""
    from thermrs.analyses.inputs import select_runs

    fast = select_runs(camp["ds"], where="speed%>=50")
    assert sorted(fast["run"].to_list()) == ["run2", "run2"]
    assert fast["speed_pct"].to_list() == [75.0, 75.0]
    assert select_runs(camp["ds"], where="speed%=30")["run"].to_list() == ["run1", "run1"]
    p = cli("campaign", str(camp["ds"]), "--where", "speed%<50")
    assert p.returncode == 0, p.stderr
    assert "speed (%)" in p.stdout and " run2 " not in p.stdout
    p = cli("campaign", str(camp["ds"]), "--where", "speed%>90")
    assert p.returncode == 2 and "speed%: 30–75" in p.stderr, p.stderr


@pytest.mark.slow
@pytest.mark.floors
def test_the_campaign_page_has_tables_figures_and_the_trend(
    camp: dict[str, Path], tmp_path: Path
) -> None:
    """`thermrs campaign DATASET -o page.html|page.md`: the same content twice — the trend
    sentence, α and drift against date and speed as figures, per-day and per-speed tables —
    HTML tables as tables, the Markdown's figures beside it."""
    from thermrs.campaigns.summary import alpha_by_run, alpha_trend

    html_page, md_page = tmp_path / "page.html", tmp_path / "page.md"
    for page in (html_page, md_page):
        p = cli("campaign", str(camp["ds"]), "-o", str(page))
        assert p.returncode == 0, p.stderr
        assert "Over time:" in p.stdout
    trend = alpha_trend(alpha_by_run(thermrs.analyses.inputs.open_dataset(camp["ds"]), RIG))
    html = html_page.read_text()
    assert "<pre>" not in html and html.count("<table") == 3  # per day, per speed, every run
    for fig in ("campaign-time", "campaign-speed"):
        assert f'data-figure="{fig}"' in html
    md = md_page.read_text()
    for text in (html, md):
        assert trend["sentence"].split(" (")[0] in text
        assert "Per day" in text and "Per speed" in text
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert len(links) == 2
    for link in links:
        assert (tmp_path / unquote(link)).read_text().startswith("<svg")
    assert md.count("\n| ") >= 8


#: One 40-minute run at 75 % per recording of the trend campaign: it resolves α to about
#: ±2×10⁻⁶/K (95 %), so twenty runs over six days resolve a slope to about ±2.3×10⁻⁶/K per
#: week (95 %): the 6×10⁻⁶/K per week injected lies about five standard errors from zero.
TREND_SCENARIO = """format = "thermrs-scenario/1"
start_time = {start}
[[run]]
name = "run1"
speed_pct = 75
duration_min = 40
cycle_s = 60
start = "ambient"
[camera]
mode = "visits"
frames_per_visit = 2
[output]
compression = "zstd"
"""


@pytest.mark.slow
@pytest.mark.parametrize("per_week", [0.0, 6e-6])
def test_the_page_finds_a_trend_injected_into_a_simulated_campaign(
    tmp_path: Path, per_week: float
) -> None:
    """Twenty recordings over six days (each started on its day by its scenario), each
    simulated with the rig's α moved by ``per_week`` × its day / 7 (the robot's expansion
    drifting over the weeks) and extracted with the nominal rig: the page's trend interval
    holds the injected slope; the page says "α changed by" where a trend was injected and
    "no change" where none was."""
    import tomllib
    from concurrent.futures import ThreadPoolExecutor

    from thermrs.campaigns.summary import alpha_by_run, alpha_trend

    rig = thermrs.load_rig()
    text = Path(RIG).read_text()
    base = tomllib.loads(text)["expansion"]["alpha_per_k"]

    def one(i: int) -> Path:
        day = (6 * i) // 20
        alpha = base + per_week * day / 7.0
        rig_i = tmp_path / f"rig{i}.toml"
        rig_i.write_text(text.replace(f"alpha_per_k = {base!r}", f"alpha_per_k = {alpha!r}"))
        assert thermrs.load_rig(rig_i).alpha_per_k == pytest.approx(alpha)
        sc = tmp_path / f"s{i}.toml"
        sc.write_text(TREND_SCENARIO.format(start=f"2026-11-{2 + day:02d}T{8 + i % 4:02d}:00:00Z"))
        return simulate(rig_i, sc, tmp_path / f"d{day}-{i}.mcap", seed=100 + i).recording

    with ThreadPoolExecutor(2) as pool:  # the simulator runs without the GIL
        recs = list(pool.map(one, range(20)))
    thermrs.campaign(recs, tmp_path / "ds", rig=rig)
    per_run = alpha_by_run(thermrs.analyses.inputs.open_dataset(tmp_path / "ds"), rig)
    assert per_run.height == 20 and per_run["date"].n_unique() == 6
    trend = alpha_trend(per_run)
    lo, hi = trend["ci95"]
    assert lo <= per_week <= hi, trend
    page = tmp_path / "page.html"
    p = cli("campaign", str(tmp_path / "ds"), "-o", str(page))
    assert p.returncode == 0, p.stderr
    said = "α changed by" if per_week else "no change in α above"
    assert said in page.read_text() and said in p.stdout, trend["sentence"]
