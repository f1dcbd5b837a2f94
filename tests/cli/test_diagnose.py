"""`thermrs diagnose` and `thermrs diagnose-bench` on the command line (issue #17): runs too
short are bad input, not a crash (the library refuses them too); a share of the gap closed
beyond the gap is capped and implausible candidates are marked; the bench says which effects
it could not test. The diagnoser itself: tests/diagnose/."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import thermrs

from tests.support.cli import bad, cli, ok


@pytest.mark.slow
def test_diagnosing_runs_too_short_is_bad_input_not_a_crash(tmp_path: Path) -> None:
    rig = str(thermrs.default_rig_path())
    sc = tmp_path / "short.toml"
    sc.write_text(
        'format = "thermrs-scenario/1"\nseed = 3\n'
        '[[run]]\nname = "a"\nspeed_pct = 30\nduration_min = 1\ncycle_s = 60\n'
        'start = "ambient"\n'
        '[[run]]\nname = "b"\nspeed_pct = 75\nduration_min = 1\ncycle_s = 60\n'
        'start = "continue"\n'
    )
    rec = tmp_path / "short.mcap"
    ok(cli("simulate", "--rig", rig, "--scenario", str(sc), "-o", str(rec)))
    bad(cli("diagnose", "--rig", rig, "--train", f"{rec}#a", "--holdout", f"{rec}#b"),
        "visit(s); a diagnosis needs at least 3")  # fmt: skip
    # The library refuses what the command refuses.
    from thermrs.diagnose import diagnose
    from thermrs.runs import load_runs

    r = thermrs.load_rig(rig)
    with pytest.raises(thermrs.InputError, match=r"visit\(s\); a diagnosis needs at least 3"):
        diagnose(load_runs(f"{rec}#a", r).tables, load_runs(f"{rec}#b", r).tables, r)


@pytest.mark.slow
def test_a_gap_closed_beyond_the_gap_is_capped_and_implausible_candidates_marked(
    d: dict[str, Path],
) -> None:
    doc = json.loads(d["diag"].read_text())
    hf = doc["how_far"]
    # The JSON's share is capped at 1; the raw share beside it says by how much it overran.
    assert hf["gap_closed"] is None or hf["gap_closed"] <= 1.0
    if hf["gap_closed_raw"] is not None and hf["gap_closed_raw"] > 1.0:
        assert hf["gap_closed"] == 1.0 and hf["gap_closed_note"]
    p = ok(cli("diagnose", "--rig", str(d["rig"]), "--train", f"{d['rec']}#s30",
               "--holdout", f"{d['rec']}#s75"))  # fmt: skip
    for r in doc["ranking"]:
        if r["effect"] == "laser_tilt" and abs(r["params"]["tilt_deg"]) > 10:
            (row,) = [ln for ln in p.stdout.splitlines() if "tilt_deg = " in ln]
            assert "implausible" in row
    # A share beyond the gap is shown capped, with why (the floor read high).
    from thermrs.numbers import gap_closed

    shown = gap_closed(1.24, 1.73, 3.39)
    assert (
        shown.startswith("100 % (the effect removed 124 %")
        and "floor is estimated too high" in shown
    )


def test_the_bench_says_which_effects_it_could_not_test() -> None:
    # A tilted laser moves a drift-anchored spot by far less than the noise: the bench says it
    # did not run those cases and why, instead of scoring them.
    p = ok(cli("diagnose-bench", "--seeds", "1", "--hours", "4", "--effect", "laser_tilt",
               "--world", "white", "--snr", "1", "--nulls", "0"))  # fmt: skip
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("not run: white laser_tilt")]
    assert lines and all("reaches SNR" in ln for ln in lines)


@pytest.mark.slow
def test_a_diagnosis_is_made_once_for_diagnose_design_and_a_second_diagnose(
    d: dict[str, Path], tmp_path: Path
) -> None:
    """The on-disk cache (thermrs.memo.DiskCache): the runs the session's diagnosis read,
    diagnosed once in three commands; other runs are diagnosed anew."""
    env = {"THERMRS_CACHE_DIR": str(tmp_path / "cache")}
    rig, rec = str(d["rig"]), d["rec"]
    runs = ["--train", f"{rec}#s30", "--holdout", f"{rec}#s75"]
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    first = ok(cli("diagnose", "--rig", rig, *runs, "--json", str(a), env=env))
    assert "reused from the cache" not in first.stderr
    again = ok(cli("diagnose", "--rig", rig, *runs, "--json", str(b), env=env))
    assert "reused from the cache" in again.stderr
    # The same document as the diagnosis made without a cache, at the session's start.
    truth = json.loads(d["diag"].read_text())
    assert json.loads(a.read_text()) == truth and json.loads(b.read_text()) == truth
    out = tmp_path / "design"
    design = ok(cli("design", "--rig", rig, *runs, "--no-proof", "-o", str(out), env=env))
    assert "reused from the cache" in design.stderr
    other = ["--train", f"{rec}#s30", "--holdout", f"{d['rep']}#s75"]
    fresh = ok(cli("diagnose", "--rig", rig, *other, env=env))
    assert "reused from the cache" not in fresh.stderr
    assert len(list((tmp_path / "cache" / "diagnoses").glob("*.pickle"))) == 2
