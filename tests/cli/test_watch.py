"""``thermrs watch`` as a user meets it: a closed recording watched leaves ``extract -o``'s
tables; Ctrl-C on a recording still being written exits 130 and leaves the tables so far,
which a second watch goes on from to the same end; ``--until`` on a recording never closed;
bad input as one line; the page opened in Chromium (Debian's, driven by Playwright)."""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path

import polars as pl
import pytest
from polars.testing import assert_frame_equal
from thermrs.follow import STATE_KEY
from thermrs.identity import RIG_KEY
from thermrs.ingest import LOSS_KEY

from tests.support.cli import bad, cli, interruptible, ok

TABLES = ("visits", "temperatures", "joints", "runs")


def _siblings(out: Path) -> list[Path]:
    stem = out.name.removesuffix(".parquet")
    return [out] + [out.with_name(f"{stem}.{t}.parquet") for t in TABLES]


def _same_as_extract(out: Path, ref: Path) -> None:
    for a, b in zip(_siblings(out), _siblings(ref), strict=True):
        assert_frame_equal(pl.read_parquet(a), pl.read_parquet(b), check_exact=True)
        ma, mb = pl.read_parquet_metadata(a), pl.read_parquet_metadata(b)
        assert STATE_KEY not in ma
        assert ma[LOSS_KEY] == mb[LOSS_KEY] and ma[RIG_KEY] == mb[RIG_KEY]


def test_a_closed_recording(data: dict[str, Path], tmp_path: Path) -> None:
    rec, rig = data["rec"], data["rig"]
    out, page, js = tmp_path / "w.parquet", tmp_path / "w.html", tmp_path / "w.json"
    r = ok(cli("watch", str(rec), "--rig", str(rig), "-o", str(out), "--html", str(page),
               "--json", str(js), "--tolerance-um", "20"))  # fmt: skip
    assert "closed" in r.stdout
    ok(cli("extract", str(rec), "--rig", str(rig), "-o", str(tmp_path / "ref.parquet"),
           "--quiet"))  # fmt: skip
    _same_as_extract(out, tmp_path / "ref.parquet")
    doc = json.loads(js.read_text())
    assert doc["closed"] is True and doc["visits"] > 0
    assert 'http-equiv="refresh"' not in page.read_text()  # closed: the page stays


def _watch(*args: str) -> subprocess.Popen[str]:
    return interruptible("watch", *args)


def test_ctrl_c_then_resumed(data: dict[str, Path], tmp_path: Path) -> None:
    rec, rig = data["rec"], data["rig"]
    whole = rec.read_bytes()
    live = tmp_path / "live.mcap"
    live.write_bytes(whole[: len(whole) // 2])
    out, js = tmp_path / "w.parquet", tmp_path / "w.json"
    p = _watch(str(live), "--rig", str(rig), "-o", str(out), "--json", str(js), "--every", "0.2")
    deadline = time.monotonic() + 120
    while not js.exists() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.1)
    assert js.exists(), p.communicate()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "Traceback" not in err
    meta = pl.read_parquet_metadata(out)
    state = json.loads(meta[STATE_KEY])
    assert 0 < state["bytes"] < len(whole)
    with live.open("ab") as fh:
        fh.write(whole[len(whole) // 2 :])
    ok(cli("watch", str(live), "--rig", str(rig), "-o", str(out)))
    ok(cli("extract", str(rec), "--rig", str(rig), "-o", str(tmp_path / "ref.parquet"),
           "--quiet"))  # fmt: skip
    _same_as_extract(out, tmp_path / "ref.parquet")


def test_until_on_a_recording_never_closed(data: dict[str, Path], tmp_path: Path) -> None:
    whole = data["rec"].read_bytes()
    live = tmp_path / "killed.mcap"
    live.write_bytes(whole[: len(whole) * 3 // 5 + 3])
    out = tmp_path / "w.parquet"
    r = ok(cli("watch", str(live), "--rig", str(data["rig"]), "-o", str(out), "--until", "1s",
               "--every", "0.2"))  # fmt: skip
    assert "recording" in r.stdout and "data loss" not in r.stderr
    assert STATE_KEY in pl.read_parquet_metadata(out)


def test_bad_input(data: dict[str, Path], tmp_path: Path) -> None:
    rig = str(data["rig"])
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "bag_0.bag").write_bytes(b"#ROSBAG V2.0\n")
    bad(cli("watch", str(bag), "--rig", rig, "--until", "1s"), "only MCAP and SQLite")
    bad(cli("watch", str(data["rec"]), "--rig", rig, "-o", str(tmp_path / "x.csv")), "-o")
    bad(cli("watch", str(data["rec"]), "--rig", rig, "--until", "soon"), "--until")
    other = tmp_path / "other.parquet"
    whole = data["rec"].read_bytes()
    (tmp_path / "other.mcap").write_bytes(whole[: len(whole) * 3 // 5])
    ok(cli("watch", str(tmp_path / "other.mcap"), "--rig", rig, "-o", str(other), "--until",
           "0.3s", "--every", "0.1"))  # fmt: skip
    bad(cli("watch", str(data["rec"]), "--rig", rig, "-o", str(other)), "other.mcap")


def test_the_page_in_chromium(data: dict[str, Path], tmp_path: Path) -> None:
    from tests.report.test_report import browse

    rec = data["rec"]
    whole = rec.read_bytes()
    live = tmp_path / "live.mcap"
    live.write_bytes(whole[: len(whole) * 4 // 5])
    page = tmp_path / "w.html"
    ok(cli("watch", str(live), "--rig", str(data["rig"]), "--html", str(page), "--until", "1s",
           "--every", "0.2", "--tolerance-um", "20", "--hours", "1"))  # fmt: skip
    if "α not determined" in page.read_text():
        pytest.skip("the short run does not determine α by itself")
    seen = browse(page, tmp_path / "w.png")
    assert seen["errors"] == [] and seen["console"] == []
    assert seen["requests"] == [page.resolve().as_uri()]  # self-contained
    assert "drift" in seen["sections"]
    fig = seen["figures"][0]
    assert fig["name"] == "watch-drift" and fig["w"] > 300 and fig["paths"] > 4
    assert 'http-equiv="refresh"' in page.read_text()  # live: it reloads itself
