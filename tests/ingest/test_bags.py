"""A ROS lab's recordings besides one MCAP file: rosbag2 bag folders split into parts, and
rosbag2's SQLite storage (``.db3``, single and split, compressed per file or per message).

The same messages (two runs of the paper rig, three hours apart) are written by writers
thermrs does not use: one MCAP file by the ``mcap`` package, and bags by ``rosbags``
(:mod:`tests.support.bags`). Every form must give the tables of the MCAP file, identical:
frames, visits, temperatures, joints and runs. The parts of a split bag are cut inside a
run (the first cut between the two spot frames of one visit): the run stays one run, its drift
anchored at its first visit (the truth: the runs' spans and visits as the messages were made).
A missing or damaged part is a stated loss (exit 3), the other parts read.
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import polars as pl
import pytest
import thermrs
from blake3 import blake3
from polars.testing import assert_frame_equal
from thermrs.campaigns.sources import content_hash, expand

from tests.ingest.test_extract import scenario
from tests.support.bags import (
    LOG_DELAY_NS,
    Message,
    shifted,
    write_bag,
    write_mcap,
    write_ros1,
)

#: The second run starts this long after the first (far beyond any idle gap within a run).
APART_NS = 3 * 3600 * 10**9
TABLES = ("frames", "visits", "temperatures", "joints", "runs")


def _messages(rig: thermrs.Rig) -> tuple[list[Message], int, int]:
    """Two runs of four cycles, and where the parts are cut: inside run 1 between the two
    spot frames of camera A's visit of its third cycle, and inside run 2 at its middle."""
    run1 = scenario(rig, cycles=4, seed=1).rec.messages
    run2 = shifted(scenario(rig, cycles=4, seed=2).rec.messages, APART_NS)
    # In time order, as a recorder receives them.
    run1 = sorted(run1, key=lambda m: m[2])
    run2 = sorted(run2, key=lambda m: m[2])
    a_topic = rig.camera("A").topic
    a_frames = [i for i, m in enumerate(run1) if m[0] == a_topic]
    cut1 = a_frames[6] + 1  # cycle 2 (3 frames of A a cycle): after its first spot frame
    cut2 = len(run1) + len(run2) // 2
    return run1 + run2, cut1, cut2


@dataclass(frozen=True)
class World:
    """The messages, where the split bags are cut, the folder the forms go in, the MCAP."""

    messages: list[Message]
    cuts: tuple[int, int]
    dir: Path
    mcap: Path


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    rig = thermrs.load_rig()
    msgs, cut1, cut2 = _messages(rig)
    d = tmp_path_factory.mktemp("bags")
    return World(msgs, (cut1, cut2), d, write_mcap(msgs, d / "one.mcap"))


def _reference(world: World, rig: thermrs.Rig) -> thermrs.Extraction:
    return thermrs.extract(world.mcap, rig)


FORMS = {
    # name: (storage, compression, split, metadata.yaml)
    "mcap-bag-3-parts": ("mcap", "none", True, True),
    "mcap-bag-3-parts-file-zstd": ("mcap", "file", True, True),
    "db3-bag": ("sqlite3", "none", False, True),
    "db3-bag-3-parts": ("sqlite3", "none", True, True),
    "db3-bag-file-zstd": ("sqlite3", "file", False, True),
    "db3-bag-message-zstd": ("sqlite3", "message", True, True),
    "db3-3-parts-no-metadata": ("sqlite3", "none", True, False),
}


def _form(world: World, name: str) -> Path:
    storage, compression, split, meta = FORMS[name]
    folder = world.dir / name
    if not folder.exists():
        msgs = world.messages
        cuts = world.cuts if split else ()
        write_bag(msgs, folder, storage=storage, compression=compression, cuts=cuts, metadata=meta)
    return folder


@pytest.mark.parametrize("name", list(FORMS))
def test_every_form_gives_the_tables_of_one_mcap(
    world: World, paper_rig: thermrs.Rig, name: str
) -> None:
    ref = _reference(world, paper_rig)
    bag = _form(world, name)
    ex = thermrs.extract(bag, paper_rig)
    for t in TABLES:
        assert_frame_equal(getattr(ex, t), getattr(ref, t), check_exact=True)
    assert ex.report.messages == ref.report.messages
    assert ex.report.losses == []
    assert [p["file"] for p in ex.report.parts] == sorted(
        p.name for p in bag.iterdir() if p.name != "metadata.yaml"
    )
    if not FORMS[name][3]:
        assert any("no metadata.yaml" in n for n in ex.report.notes)


def test_a_db3_file_itself_and_its_compressed_form_give_the_same_tables(
    world: World, paper_rig: thermrs.Rig
) -> None:
    ref = _reference(world, paper_rig)
    for name in ("db3-bag", "db3-bag-file-zstd"):
        (db3,) = (p for p in _form(world, name).iterdir() if p.name != "metadata.yaml")
        ex = thermrs.extract(db3, paper_rig)
        for t in TABLES:
            assert_frame_equal(getattr(ex, t), getattr(ref, t), check_exact=True)


@pytest.mark.parametrize("compression", ["none", "bz2", "lz4"])
def test_a_ros1_bag_gives_the_tables_of_one_mcap(
    world: World, paper_rig: thermrs.Rig, compression: str
) -> None:
    ref = _reference(world, paper_rig)
    bag = world.dir / f"ros1-{compression}.bag"
    if not bag.exists():
        write_ros1(world.messages, bag, compression=compression)
    ex = thermrs.extract(bag, paper_rig)
    for t in TABLES:
        assert_frame_equal(getattr(ex, t), getattr(ref, t), check_exact=True)
    assert ex.report.messages == ref.report.messages
    assert ex.report.losses == []
    assert ex.report.chunks > 1
    inv = thermrs.inventory.inventory(bag, rig=paper_rig)
    assert inv.messages == len(world.messages) and inv.runs.height == 2
    want = Counter(m[0] for m in world.messages)
    assert dict(zip(inv.topics["topic"], inv.topics["messages"], strict=True)) == want


def test_a_run_split_across_parts_is_one_run_anchored_at_its_first_visit(
    world: World, paper_rig: thermrs.Rig
) -> None:
    bag = _form(world, "db3-bag-3-parts")
    ex = thermrs.extract(bag, paper_rig)
    msgs = world.messages
    cut1, _ = world.cuts
    # The truth as the messages were made: two runs, each of 4 cycles × 2 cameras visits;
    # the first cut falls inside a visit of run 1.
    stamps = [m[2] for m in msgs]
    t0, t1 = min(stamps), min(s for s in stamps if s >= stamps[0] + APART_NS)
    assert ex.runs.height == 2
    v = ex.visits
    assert v.filter(pl.col("t_ns") < t1)["run"].unique().to_list() == [ex.runs["run"][0]]
    assert v.filter(pl.col("t_ns") >= t1)["run"].unique().to_list() == [ex.runs["run"][1]]
    assert v.group_by("run").len()["len"].to_list() == [8, 8]
    cut_t = msgs[cut1][2]
    visit = v.filter((pl.col("t_start_ns") < cut_t) & (pl.col("t_end_ns") >= cut_t))
    assert visit.height == 1 and visit["n_ok"].item() == 2, "the visit across the cut is whole"
    # Drift is anchored at each run's first visit of each camera: zero there, and elsewhere
    # the spot's move from that visit (frames' centroids, averaged per visit).
    for run in ex.runs["run"]:
        for cam in ("A", "B"):
            rv = v.filter((pl.col("run") == run) & (pl.col("camera") == cam)).sort("t_ns")
            assert rv["drift_u_um"][0] == 0.0 and rv["drift_v_um"][0] == 0.0
            assert rv["t_ns"][0] >= (t0 if run == ex.runs["run"][0] else t1)
            assert (rv["drift_u_um"] - (rv["u_um"] - rv["u_um"][0])).abs().max() < 1e-9


def test_info_sums_the_parts(world: World, paper_rig: thermrs.Rig) -> None:
    msgs = world.messages
    want = Counter(m[0] for m in msgs)
    for name in ("mcap-bag-3-parts", "db3-bag-3-parts", "db3-bag-file-zstd"):
        inv = thermrs.inventory.inventory(_form(world, name), rig=paper_rig)
        assert inv.messages == len(msgs)
        assert dict(zip(inv.topics["topic"], inv.topics["messages"], strict=True)) == want
        assert inv.start_ns == min(m[2] for m in msgs) + LOG_DELAY_NS
        assert inv.end_ns == max(m[2] for m in msgs) + LOG_DELAY_NS
        assert inv.runs.height == 2
        assert inv.losses == []
        assert inv.storage.startswith("bag of")


def _run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "thermrs", *args], capture_output=True, text=True, check=False
    )


@pytest.mark.parametrize("damage", ["missing", "garbage", "cut"])
def test_a_missing_or_damaged_part_is_a_stated_loss(
    world: World, paper_rig: thermrs.Rig, tmp_path: Path, damage: str
) -> None:
    src = _form(world, "db3-bag-3-parts")
    bag = tmp_path / "bag"
    shutil_copy(src, bag)
    part = bag / f"{src.name}_1.db3"
    if damage == "missing":
        part.unlink()
    elif damage == "garbage":
        part.write_bytes(b"not a database" * 100)
    else:
        data = part.read_bytes()
        part.write_bytes(data[: len(data) // 2])
    ex = thermrs.extract(bag, paper_rig)
    assert ex.report.data_loss
    assert any(part.name in x["detail"] for x in ex.report.losses)
    # The other parts are read whole: every frame outside part 1's span is there.
    msgs = world.messages
    cut1, cut2 = world.cuts
    ref = _reference(world, paper_rig).frames
    cameras = {c.topic for c in paper_rig.cameras}
    lost = [m[2] for m in msgs[cut1:cut2] if m[0] in cameras]
    kept = ref.filter(~pl.col("t_ns").is_in(lost))
    assert_frame_equal(ex.frames.filter(~pl.col("t_ns").is_in(lost)), kept, check_exact=True)
    if damage != "cut":  # a database cut short may keep the messages before the cut
        assert ex.frames.height == kept.height
    r = _run_cli(
        "extract", str(bag), "--rig", str(paper_rig.source), "-o", str(tmp_path / "o.parquet")
    )
    assert r.returncode == 3, r.stderr
    assert "data loss" in r.stderr and part.name in r.stderr and "Traceback" not in r.stderr
    r = _run_cli("info", str(bag))
    assert r.returncode == 3 and part.name in r.stderr, r.stderr


def shutil_copy(src: Path, dst: Path) -> None:
    import shutil

    shutil.copytree(src, dst)


def test_a_folder_of_bags_is_a_campaign_of_bags(world: World, tmp_path: Path) -> None:
    root = tmp_path / "recs"
    root.mkdir()
    shutil_copy(_form(world, "db3-bag-3-parts"), root / "day1")
    shutil_copy(_form(world, "mcap-bag-3-parts"), root / "day2")
    (root / "loose.mcap").write_bytes(world.mcap.read_bytes())
    write_ros1(world.messages, root / "old.bag", compression="lz4")
    found = expand([str(root)])
    assert [s.path.name for s in found] == ["day1", "day2", "loose.mcap", "old.bag"]
    day1 = found[0]
    files = sorted(p for p in day1.path.iterdir() if p.name != "metadata.yaml")
    assert day1.size_bytes == sum(p.stat().st_size for p in files)
    # The bag's hash is that of its files' hashes in order (each BLAKE3 of the file's bytes),
    # the same as the extraction's own pass.
    want = blake3(
        b"thermrs-bag\n"
        + b"".join(f"{p.name}\t{blake3(p.read_bytes()).hexdigest()}\n".encode() for p in files)
    ).hexdigest()
    assert content_hash(day1.path) == want
    ex = thermrs.extract(day1.path, thermrs.load_rig(), content_hash=True)
    assert ex.report.content_hash == want
    assert [p["content_hash"] for p in ex.report.parts] == [
        blake3(p.read_bytes()).hexdigest() for p in files
    ]
    # A bag folder named on its own is one recording.
    assert [s.path.name for s in expand([str(root / "day2")])] == ["day2"]
    # Numbered files without metadata.yaml that do not follow each other in time (the same
    # recording twice) are two recordings, not one bag.
    twice = tmp_path / "twice"
    twice.mkdir()
    for i in range(2):
        (twice / f"rec_{i}.mcap").write_bytes(world.mcap.read_bytes())
    assert [s.path.name for s in expand([str(twice)])] == ["rec_0.mcap", "rec_1.mcap"]


@pytest.mark.slow
def test_a_campaign_catalogs_a_bag_as_one_row_beside_mcap_and_ros1(
    world: World, tmp_path: Path
) -> None:
    from distributed import Client
    from thermrs.campaigns.engine import local_cluster

    root = tmp_path / "recs"
    root.mkdir()
    shutil_copy(_form(world, "db3-bag-3-parts"), root / "day1")
    (root / "loose.mcap").write_bytes(world.mcap.read_bytes())
    write_ros1(world.messages, root / "old.bag", compression="bz2")
    names = (root / "day1", root / "loose.mcap", root / "old.bag")
    with local_cluster(1) as cluster, Client(cluster) as c:  # type: ignore[no-untyped-call]
        res = thermrs.campaign([str(root)], tmp_path / "ds", client=c)
        cat = res.dataset.catalog().sort("path")
        assert cat["path"].to_list() == [str(p) for p in names]
        assert cat["content_hash"][0] == content_hash(root / "day1")
        assert cat["runs"].to_list() == [2, 2, 2]
        assert cat["frames"].n_unique() == 1 and cat["losses"].to_list() == [0, 0, 0]
        again = thermrs.campaign([str(root)], tmp_path / "ds", client=c)
        assert sorted(again.unchanged) == sorted(str(p) for p in names)


def test_refused_and_wrong_folders_say_what_to_do(paper_rig: thermrs.Rig, tmp_path: Path) -> None:
    old = tmp_path / "old.bag"
    old.write_bytes(b"#ROSBAG V1.2\n" + bytes(100))
    out = str(tmp_path / "o.parquet")
    r = _run_cli("extract", str(old), "--rig", str(paper_rig.source), "-o", out)
    assert r.returncode == 2 and "before 2.0" in r.stderr and "rosbag filter" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    empty = tmp_path / "notabag"
    empty.mkdir()
    (empty / "a.mcap").write_bytes(b"")
    (empty / "b.mcap").write_bytes(b"")
    r = _run_cli("extract", str(empty), "--rig", str(paper_rig.source), "-o", out)
    assert r.returncode == 2 and "not a rosbag2 bag" in r.stderr, r.stderr


def test_the_diagnosis_of_a_bag_is_that_of_the_mcap(
    world: World, paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    """`thermrs diagnose` on run 1 against run 2 of each form: the same JSON once the runs'
    names (the recording's stem) are the same."""
    ros1 = world.dir / "ros1-lz4.bag"
    if not ros1.exists():
        write_ros1(world.messages, ros1, compression="lz4")
    texts = []
    for rec, stem in [
        (world.mcap, "one"),
        (_form(world, "db3-bag-3-parts"), "db3-bag-3-parts"),
        (ros1, "ros1-lz4"),
    ]:
        out = tmp_path / f"{stem}.json"
        r = _run_cli(
            "diagnose", "--rig", str(paper_rig.source), "--train", f"{rec}#run1",
            "--holdout", f"{rec}#run2", "--json", str(out),
        )  # fmt: skip
        assert r.returncode == 0, r.stderr
        texts.append(out.read_text().replace(f"{stem}#", "REC#"))
    assert texts[1] == texts[0]
    assert texts[2] == texts[0]


def test_a_report_of_a_bag_is_that_of_the_mcap(
    world: World, paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    """`thermrs report` takes a bag folder as a RUN: its Markdown twin is the MCAP's, once the
    recording's name is the same."""
    texts = []
    for rec, stem in [(world.mcap, "one"), (_form(world, "db3-bag-3-parts"), "db3-bag-3-parts")]:
        (tmp_path / stem).mkdir()
        out = tmp_path / stem / "r.html"
        r = _run_cli(
            "report", "--rig", str(paper_rig.source), "--run", str(rec), "-o", str(out), "--quiet",
        )  # fmt: skip
        assert r.returncode == 0, r.stderr
        md = out.with_suffix(".md").read_text()
        for name in (str(rec), f"{stem}#", f"-{stem}-"):
            md = md.replace(name, name.replace(stem, "REC") if name != str(rec) else "REC")
        # How the bytes were read (chunks, a summary) is the storage's own; the rest is the same.
        texts.append("\n".join(x for x in md.splitlines() if not x.startswith("Read ")))
    assert texts[1] == texts[0]
