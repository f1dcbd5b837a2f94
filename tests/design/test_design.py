"""``thermrs design`` against truth.

- The criterion: a closed form (an effect's own signature leaves nothing of it, z = 0; with no
  family able to act, λ is the energy left after the nominal model).
- The files: ``rig.toml`` is a rig the Rust core accepts whose laser meets the new chip at its
  centre, normal to it; ``scenario.toml`` is a scenario the simulator runs, and its cycles visit
  every pose of the new rig.
- The design itself, as an independent world would check it: short confounded runs simulated
  with a known joint offset; the design's files (``rig.toml``, ``scenario.toml``, ``roles``)
  performed by the simulator with the true effect added by this test, the runs diagnosed
  again: the truth must come out ``identified`` (and each proof row must be right when the
  design recommends).
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import scipy.linalg
import thermrs
from thermrs.design import DesignResult, design, rival_drift
from thermrs.design.files import rig_toml, scenario_toml
from thermrs.design.measurements import candidates, protocols
from thermrs.design.search import Z_TARGET
from thermrs.design.separation import Block, Rival, pair_z, rival_families
from thermrs.effects import JointOffset, UnmodelledLength
from thermrs.signatures import VisitSet

SHORT = """format = "thermrs-scenario/1"
name = "short confounded runs"
seed = {seed}

[[run]]
name = "r1"
speed_pct = 30
duration_min = 300
cycle_s = 600
start = "ambient"

[[run]]
name = "r2"
speed_pct = 75
duration_min = 300
cycle_s = 600
start = "continue"
idle_before_min = 120

[camera]
frames_per_visit = 1

[output]
compression = "lz4"
{effect}
"""

JO = """
[[effect]]
name = "joint_offset"
joint = "joint_a3"
temperature = "link3"
urad_per_k = 12.8
"""


def _runs(
    rig: thermrs.Rig, rig_text: str | None, scenario: str, tmp: Path, stem: str
) -> dict[str, pl.DataFrame]:
    """Simulate, extract with ``rig`` and cut into runs (the way the demo does)."""
    from thermrs.fit import run_table_from
    from thermrs.ingest import extract
    from thermrs.simulate import simulate

    sc = tmp / f"{stem}.toml"
    sc.write_text(scenario)
    sim_rig: thermrs.Rig | Path = rig
    if rig_text is not None:
        sim_rig = tmp / f"{stem}.rig.toml"
        sim_rig.write_text(rig_text)
    sim = simulate(sim_rig, sc, tmp / f"{stem}.mcap")
    ex = extract(tmp / f"{stem}.mcap", rig)
    out = {}
    for (name,), g in sim.frames.group_by("run", maintain_order=True):
        lo, hi = int(g["t_ns"].min()) - 1, int(g["t_ns"].max()) + 1  # type: ignore[arg-type]
        ts = sim.samples.filter(pl.col("run") == name)
        lo, hi = min(lo, int(ts["t_ns"].min())), max(hi, int(ts["t_ns"].max()))  # type: ignore[arg-type]

        def cut(df: pl.DataFrame, lo: int = lo, hi: int = hi) -> pl.DataFrame:
            return df.filter((pl.col("t_ns") >= lo) & (pl.col("t_ns") <= hi))

        out[str(name)] = run_table_from(cut(ex.visits), cut(ex.temperatures), rig, run=str(name))
    return out


@pytest.fixture(scope="module")
def short_runs(
    paper_rig: thermrs.Rig, tmp_path_factory: pytest.TempPathFactory
) -> dict[str, pl.DataFrame]:
    tmp = tmp_path_factory.mktemp("design-runs")
    return _runs(paper_rig, None, SHORT.format(seed=11, effect=JO), tmp, "user")


def test_own_signature_leaves_nothing(
    paper_rig: thermrs.Rig, short_runs: dict[str, pl.DataFrame]
) -> None:
    """z of A against A's own families is 0 (A's drift lies in the span of its signature);
    against a rival that cannot act it is the energy left after the nominal model."""
    jo = JointOffset(joint="joint_a3", temperature="link3", urad_per_k=12.8)
    rv = [
        Rival("joint_offset", {}, paper_rig.alpha_per_k, jo),
        Rival("unmodelled_length", {}, paper_rig.alpha_per_k, UnmodelledLength("a3", "link3")),
    ]
    vs = VisitSet(list(short_runs.values()), paper_rig)
    block = Block(vs, rv)
    fams = rival_families(paper_rig, vs, rv)
    z = pair_z([block], [rv[0], rv[0]], fams, 1.0)
    assert all(v < 1e-6 for v in z.values())
    # Against no family at all: ‖P⊥[s, offsets] μ‖ by a least-squares fit of μ on [s, offsets].
    z2 = pair_z([block], rv, {"joint_offset": fams["joint_offset"], "unmodelled_length": []}, 2.0)
    off, _ = vs.offset_columns()
    x = np.column_stack([vs.alpha_column(), off])
    mu = vs.positions(effects=[jo])
    coef, *_ = np.linalg.lstsq(x, mu, rcond=None)
    left = float(np.linalg.norm(mu - x @ coef))
    assert z2[("joint_offset", "unmodelled_length")] == pytest.approx(left / 2.0, rel=1e-6)


def test_blocks_taken_together_are_the_stacked_least_squares(
    paper_rig: thermrs.Rig, short_runs: dict[str, pl.DataFrame]
) -> None:
    """z over two blocks (each compressed to its triangular factor) is the residual of μ_A
    fitted by least squares on the stacked visits: α, every block's mountings and B's
    signature, the least over B's families."""
    jo = JointOffset(joint="joint_a3", temperature="link3", urad_per_k=12.8)
    ul = UnmodelledLength("a3", "link3")
    rv = [
        Rival("joint_offset", {}, paper_rig.alpha_per_k, jo),
        Rival("unmodelled_length", {}, paper_rig.alpha_per_k, ul),
    ]
    runs = list(short_runs.values())
    vss = [VisitSet(runs[:1], paper_rig), VisitSet(runs[1:], paper_rig)]
    fams = rival_families(paper_rig, vss[0], rv)
    z = pair_z([Block(v, rv) for v in vss], rv, fams, 1.0)
    s = np.concatenate([v.alpha_column() for v in vss])
    off = scipy.linalg.block_diag(*[v.offset_columns()[0] for v in vss])
    for a, b in ((rv[0], rv[1]), (rv[1], rv[0])):
        mu = np.concatenate([v.positions(effects=[a.truth]) for v in vss])
        left = []
        for fam in fams[b.effect]:
            cols = np.concatenate([fam.columns(v, fam.grid[0]) for v in vss])
            x = np.column_stack([s, off, cols])
            coef, *_ = np.linalg.lstsq(x, mu, rcond=None)
            left.append(float(np.sum((mu - x @ coef) ** 2)))
        assert z[(a.effect, b.effect)] == pytest.approx(np.sqrt(min(left)), rel=1e-6)


def test_files_are_valid_and_the_laser_meets_the_new_chip(
    paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    p = protocols()[0]
    cands = candidates(paper_rig, protocol=p)
    assert cands
    lo_hi = (
        (-185.0, 185.0),
        (-155.0, 155.0),
        (-130.0, 154.0),
        (-350.0, 350.0),
        (-130.0, 130.0),
        (-350.0, 350.0),
    )
    for c in cands[:: max(1, len(cands) // 8)]:
        text, new = rig_toml(paper_rig, c)
        assert c.pose is not None and c.camera is not None
        assert all(lo <= q <= hi for q, (lo, hi) in zip(c.pose["joints_deg"], lo_hi, strict=True))
        again = thermrs.Rig.from_toml(text)  # the file as written parses to a valid rig
        view = again.check()
        name = c.camera["name"]
        spot = view["poses"][name]["spot_px"][name]
        w, h = c.camera["size_px"]
        assert spot is not None
        assert abs(spot[0] - (w - 1) / 2) < 0.5 and abs(spot[1] - (h - 1) / 2) < 0.5
        assert view["poses"][name]["incidence_deg"][name] <= 2.0
        assert abs(view["poses"][name]["distance_mm"][name] - c.detail["distance_mm"]) < 0.5
    # The scenario: the simulator runs it on the new rig and each cycle visits every pose.
    c = cands[0]
    text, new = rig_toml(paper_rig, c)
    sc = scenario_toml(c, cycle_s=600.0, name="t")
    assert "effect" not in tomllib.loads(sc)
    short = sc.replace("duration_min = 240.0", "duration_min = 30.0")
    (tmp_path / "rig.toml").write_text(text)
    (tmp_path / "sc.toml").write_text(short)
    sim = thermrs.simulate.simulate(
        tmp_path / "rig.toml", tmp_path / "sc.toml", tmp_path / "x.mcap"
    )
    per = sim.frames.group_by("camera").len()
    assert set(per["camera"].to_list()) == {cam.name for cam in new.cameras}


@pytest.fixture(scope="module")
def designed(
    paper_rig: thermrs.Rig,
    short_runs: dict[str, pl.DataFrame],
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[DesignResult, Path]:
    tmp = tmp_path_factory.mktemp("design")
    res = design(
        [short_runs["r1"]],
        [short_runs["r2"]],
        paper_rig,
        between=["joint_offset", "unmodelled_length"],
        budget_h=24.0,
        workdir=tmp / "work",
    )
    res.write(tmp / "out")
    return res, tmp


@pytest.mark.slow
def test_designed_experiment_identifies_the_truth(
    paper_rig: thermrs.Rig,
    short_runs: dict[str, pl.DataFrame],
    designed: tuple[DesignResult, Path],
) -> None:
    """An independent performance of the design: its rig and scenario simulated with the true
    effect added here, the runs in their roles diagnosed with the user's runs."""
    from thermrs.diagnose import diagnose

    _, tmp_path = designed
    doc = json.loads((tmp_path / "out" / "design.json").read_text())
    assert doc["confounded"] == ["joint_offset", "unmodelled_length"]
    assert doc["candidates"] and doc["roles"]
    runs = tomllib.loads((tmp_path / "out" / "scenario.toml").read_text())["run"]
    hours = sum((r["duration_min"] + r.get("idle_before_min", 0.0)) / 60 for r in runs)
    assert set(doc["roles"]) == {r["name"] for r in runs}
    assert hours <= 24.0
    assert doc["recommended"] is not None, doc["why_not"]
    assert all(r["right"] for r in doc["proof"]["matrix"])
    rig_text = (tmp_path / "out" / "rig.toml").read_text()
    new = thermrs.Rig.from_toml(rig_text)
    sc = (tmp_path / "out" / "scenario.toml").read_text()
    new_runs = _runs(new, rig_text, sc + JO, tmp_path, "performed")
    tr = [short_runs["r1"]] + [t for n, t in new_runs.items() if doc["roles"][n] == "train"]
    ho = [short_runs["r2"]] + [t for n, t in new_runs.items() if doc["roles"][n] == "holdout"]
    v = diagnose(tr, ho, new).to_json()["verdict"]
    assert (v["status"], v["effect"]) == ("identified", "joint_offset")
    assert v["params"]["joint"] == "joint_a3"
    assert v["params"]["urad_per_k"] == pytest.approx(12.8, rel=0.2)


@pytest.mark.slow
def test_a_proof_on_recordings_reaches_the_verdicts_of_the_proof_on_the_truth(
    paper_rig: thermrs.Rig,
    short_runs: dict[str, pl.DataFrame],
    designed: tuple[DesignResult, Path],
) -> None:
    """The proof's runs as recordings, every image rendered and read back by the extraction
    (the whole chain), against the default proof on the simulator's truth: the same verdict
    for every truth, and held-out residuals within the centroids' noise of each other."""
    from thermrs.design.proof import prove

    res, tmp_path = designed
    assert res.proof is not None and res.best is not None
    assert res.proof["route"] == "truth"
    cand = next(c for c in [res.best] if c.label == res.proof["candidate"])
    (tmp_path / "recorded").mkdir()
    rec = prove(
        paper_rig,
        cand,
        res.rivals,
        [short_runs["r1"]],
        [short_runs["r2"]],
        repeatability_urad=res.noise["repeatability_urad"],
        exclude=[],
        cycle_s=res.cycle_s,
        workdir=tmp_path / "recorded",
        seed=res.proof["seed"],
        recorded=True,
    )
    assert rec["route"] == "recording"
    for a, b in zip(res.proof["matrix"], rec["matrix"], strict=True):
        assert (a["truth"], a["status"], a["effect"]) == (b["truth"], b["status"], b["effect"])
        ra, rb = a["ranking"][0]["holdout_rms_um"], b["ranking"][0]["holdout_rms_um"]
        assert rb == pytest.approx(ra, rel=0.05)


@pytest.mark.slow
def test_report_subsection_shows_the_experiment(designed: tuple[DesignResult, Path]) -> None:
    """The report's subsection: the recommendation (or why none), the rivals' predicted drift
    on the new chip (they must differ there: that is what the experiment reads) and the proof
    matrix, rendered to HTML."""
    from thermrs.report.render import to_html
    from thermrs.report.sections.design import design_section

    res, _ = designed
    doc = res.to_json()
    drift = rival_drift(res)
    assert set(drift["effect"].unique()) == {"joint_offset", "unmodelled_length"}
    if res.best is not None and res.best.camera is not None:
        assert set(drift["camera"].unique()) == {res.best.camera["name"]}
        end = drift.group_by("effect").agg(
            pl.col("drift_v_um").abs().max(), pl.col("drift_u_um").abs().max()
        )
        assert end.height == 2
    sec = design_section(doc, drift)
    html = to_html([sec], title="t", meta="m")
    assert "The experiment that settles it" in html
    assert "<svg" in html
    if doc["proof"] is not None:
        for row in doc["proof"]["matrix"]:
            assert row["truth"] in html
    if doc["recommended"] is not None:
        assert doc["recommended"]["camera"]["name"] in html
        # The recommendation is the last candidate proved, the one whose proof passed.
        assert doc["proofs_tried"][-1]["candidate"] == doc["recommended"]["label"]
        assert doc["proofs_tried"][-1]["all_right"]
    # The separation is said once, agreeing with the diagnosis: its least z now is the
    # table's, and a white-noise z past the target beside a pair the diagnosis could not
    # separate is called an overstatement, not a separation.
    said = doc["separation_said"]
    assert html.count(said[:60]) == 1
    least = min(doc["separation_now"], key=lambda p: p["z"])
    assert f"least z is {least['z']:.1f}" in said
    assert ("overstates" in said) == any(p["z"] >= Z_TARGET for p in doc["separation_now"])


@pytest.mark.slow  # it needs the design (about 90 s of CPU)
def test_old_recording_reads_with_the_larger_rig(
    paper_rig: thermrs.Rig,
    designed: tuple[DesignResult, Path],
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """A recording made before the new chip, extracted with the design's rig, gives the same
    visits as with the rig it was made on (it simply lacks the new camera)."""
    from thermrs.ingest import extract

    _, tmp = designed
    new = thermrs.load_rig(tmp / "out" / "rig.toml")
    rec = next(tmp_path_factory.getbasetemp().glob("design-runs*/user.mcap"))
    old_v = extract(rec, paper_rig).visits.sort("camera", "t_ns")
    new_v = extract(rec, new).visits.sort("camera", "t_ns")
    assert old_v.select("camera", "t_ns", "u_um", "v_um").equals(
        new_v.select("camera", "t_ns", "u_um", "v_um")
    )


def test_cli_bad_between_is_one_line_exit_2(
    short_runs: dict[str, pl.DataFrame],
    tmp_path_factory: pytest.TempPathFactory,
    tmp_path: Path,
) -> None:
    import subprocess
    import sys

    rec = next(tmp_path_factory.getbasetemp().glob("design-runs*/user.mcap"))
    rig = str(thermrs.default_rig_path())
    cmd = [sys.executable, "-m", "thermrs", "design", "--rig", rig, "--train", f"{rec}#r1",
           "--holdout", f"{rec}#r2", "--between", "joint_offset", "--between", "no_such_effect",
           "-o", str(tmp_path / "out")]  # fmt: skip
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert p.returncode == 2, p.stderr
    err = [ln for ln in p.stderr.splitlines() if "error" in ln]
    assert len(err) == 1 and "no_such_effect" in err[0] and "Traceback" not in p.stderr


def test_design_uses_the_diagnosis_it_is_given(
    paper_rig: thermrs.Rig, short_runs: dict[str, pl.DataFrame]
) -> None:
    """Given a diagnosis (its JSON document, as `thermrs design --diagnosis` reads it), the
    design takes it as it is instead of diagnosing the runs again; one of other runs is
    refused."""
    from thermrs.diagnose import diagnose
    from thermrs.errors import InputError

    r1, r2 = short_runs["r1"], short_runs["r2"]
    doc = diagnose([r1], [r2], paper_rig, bootstrap=0, null_draws=49).to_json()
    doc["summary"] = "a sentence only the given diagnosis has"
    res = design([r1], [r2], paper_rig, diagnosis=doc, prove_it=False)
    assert res.diagnosis["summary"] == doc["summary"]
    assert res.diagnosis["baseline"] == doc["baseline"]
    with pytest.raises(InputError, match="the diagnosis was made with train runs r1"):
        design([r2], [r1], paper_rig, diagnosis=doc, prove_it=False)
    # The rig's path is a rig, as everywhere.
    by_path = design([r1], [r2], str(paper_rig.source), diagnosis=doc, prove_it=False)
    assert by_path.diagnosis["baseline"] == doc["baseline"]


def test_a_room_swing_separates_what_the_room_drives(
    paper_rig: thermrs.Rig, short_runs: dict[str, pl.DataFrame], tmp_path: Path
) -> None:
    """A fixture that moves with the room cannot be told from a length that follows a link
    while the room holds still: a steady-room protocol predicts no fixture drift at all, so
    it adds next to nothing to the separation (z stays within 1 % of what it is on the given
    runs: the rival's fit must now also leave the new, driftless visits alone). The room-swing
    protocol moves the room apart from the links, and the fixture's drift, um_per_k times
    the room's excursion, then separates it."""
    from thermrs.design.forecast import forecast_tables, protocol_samples
    from thermrs.design.measurements import ROOM_SWING_C
    from thermrs.effects import FixtureDrift

    rv = [
        Rival(
            "fixture_drift",
            {},
            paper_rig.alpha_per_k,
            FixtureDrift(camera="A", um_per_k=(3.0, -2.0)),
        ),
        Rival("unmodelled_length", {}, paper_rig.alpha_per_k, UnmodelledLength("a3", "link3")),
    ]
    old = Block(VisitSet(list(short_runs.values()), paper_rig), rv)
    fams = rival_families(paper_rig, old.vs, rv)
    pair = ("fixture_drift", "unmodelled_length")
    now = pair_z([old], rv, fams, 1.0)[pair]
    by_label = {p.label.split(" ")[0] + " " + p.label.split(" ")[1]: p for p in protocols()}
    z = {}
    for key in ("hot-cool 12+12", "room-swing 12+12"):
        p = by_label[key]
        vis, samp = protocol_samples(paper_rig, p, cycle_s=600.0, workdir=tmp_path)
        room = samp["ambient_c"].to_numpy()
        blk = Block(VisitSet(forecast_tables(paper_rig, vis, samp), paper_rig), rv)
        z[key] = pair_z([old, blk], rv, fams, 1.0)[pair]
        if key.startswith("room"):
            assert np.ptp(room) == pytest.approx(2 * ROOM_SWING_C, rel=0.01)
        else:
            assert np.ptp(room) < 1e-9
    assert now <= z["hot-cool 12+12"] <= 1.01 * now
    assert z["room-swing 12+12"] >= Z_TARGET > 3 * now
    # Only a rig that records the room is offered the protocol.
    assert any(p.room for p in protocols())
    assert not any(p.room for p in protocols(room_swing=False))


def test_what_the_robot_alone_can_record_is_proved_before_a_room_swing() -> None:
    """Of two candidates that both reach the target, the one that needs the room's climate
    control off is proved second, even with the better score and the less alike signatures."""
    from thermrs.design.measurements import Candidate
    from thermrs.design.search import conclude

    by = {p.label.split(" ")[0]: p for p in protocols()}
    robot = Candidate(label="robot", kind="protocol", protocol=by["hot-cool"])
    room = Candidate(label="room", kind="protocol", protocol=by["room-swing"])
    pair = ("a", "b")
    scored = [(2 * Z_TARGET, room, {pair: 2 * Z_TARGET}), (Z_TARGET, robot, {pair: Z_TARGET})]
    cosines = {id(room): {pair: 0.1}, id(robot): {pair: 0.5}}
    found = conclude([], scored, cosines, [])
    assert [c.label for c in found.proof_order] == ["robot", "room"]
    assert [r["label"] for r, _ in found.ranked] == ["room", "robot"]  # ranked by score


def test_a_rig_whose_rois_have_no_calibrated_node_is_refused_before_any_work() -> None:
    """The design forecasts the links' temperatures with the simulator's calibrated nodes; a
    rig whose ROIs bear other names (the UR5 fixture's upper_arm and forearm) is refused at
    once, in one error naming them, not deep inside a forecast's temporary scenario."""
    from tests.support.rigs import UR5

    with pytest.raises(thermrs.InputError, match=r"upper_arm, forearm have none") as e:
        design([], [], UR5)
    assert "thermrs-design-" not in str(e.value)


def test_new_chips_go_on_the_side_of_the_base_plane_where_the_rigs_chips_are(
    paper_rig: thermrs.Rig,
) -> None:
    """On the paper rig the chips stand above the base plane, and so does every new one; on a
    random KR 16-like rig whose chips all lie below it (the base frame above the work, as on
    an arm mounted overhead) the new chips go below it too, not nowhere."""
    from tests.support.coverage import random_rig

    rig = random_rig(np.random.default_rng(7))
    assert all(c.centre_mm[2] < 0 for c in rig.cameras)
    for r, sign in ((paper_rig, 1.0), (rig, -1.0)):
        cands = candidates(r, protocol=protocols()[0])
        assert len(cands) > 50
        assert all(sign * c.camera["centre_mm"][2] >= 0 for c in cands if c.camera)
        # The new chip takes the visit times of the camera seen at the pose it turns, named
        # as a camera (the random rig's poses P0, P1 are not its cameras' names A, B).
        seen = {cam.pose: cam.name for cam in r.cameras}
        assert all(c.detail["from_camera"] == seen[c.detail["from_pose"]] for c in cands)
