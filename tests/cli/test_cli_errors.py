"""A new user's mistakes through the CLI (issue #13): every wrong invocation exits 2 with exactly
one line on stderr and no traceback, writes nothing; an output the system will not take exits 1
with one line naming the file; losses stay visible; Ctrl-C stops a long
command at once with exit 130 and one line. (Tables never cut: tests/cli/test_tables.py; the
recording these tests share, ``data``: tests/cli/conftest.py.) The table of wrong invocations
goes through the CLI's entry point in this process (``cli_in_process``); the other tests run
``python -m thermrs`` in a child."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import thermrs

from tests.support.cli import cli, cli_in_process, interruptible
from tests.support.rigs import REPO, UR5

PAPER_RUNS = REPO / "fixtures" / "scenarios" / "paper-runs.toml"


# (arguments with {placeholders}, a piece of the one line on stderr)
WRONG: list[tuple[str, str]] = [
    # missing / unreadable / wrong-kind inputs
    ("simulate --rig {rig} --scenario {dir}/missing.toml -o {dir}/o.mcap", "does not exist"),
    ("simulate --rig {rig} --scenario {folder} -o {dir}/o.mcap", "is a directory"),
    ("simulate --rig {dir}/missing.toml --scenario {sc} -o {dir}/o.mcap", "--rig"),
    ("simulate --rig {rec} --scenario {sc} -o {dir}/o.mcap", "rig"),
    ("simulate --rig {rig} --scenario {bad_sc} -o {dir}/o.mcap", "run[0].speed_pct"),
    ("simulate --rig {rig} --scenario {rec} -o {dir}/o.mcap", "scenario"),
    ("extract {dir}/missing.mcap --rig {rig} -o {dir}/o.parquet", "does not exist"),
    ("extract {folder} --rig {rig} -o {dir}/o.parquet", "is a directory"),
    ("extract {rec} --rig {folder} -o {dir}/o.parquet", "is a directory"),
    ("extract {sc} --rig {rig} -o {dir}/o.parquet", "MCAP"),
    ("extract {rec} --rig {rec} -o {dir}/o.parquet", "rig"),
    ("fit --rig {rig} --train {folder}", "is a directory"),
    ("fit --rig {rig} --train {dir}/missing.mcap", "does not exist"),
    ("fit --rig {rig} --train {sc}", "MCAP"),
    ("fit --rig {rig} --train {tables} {tables}", "given twice"),
    ("predict --rig {rig} --fit {dir}/missing.json --run {tables}", "does not exist"),
    ("predict --rig {rig} --fit {bad_json} --run {tables}", "thermrs fit --json"),
    ("drift --rig {rig} --run {dir}/missing.parquet", "does not exist"),
    ("rig {dir}/missing.toml", "does not exist"),
    ("rig {folder}", "is a directory"),
    # mismatched rig: the recording has none of the UR5 rig's camera topics
    ("extract {rec} --rig {ur5} -o {dir}/o.parquet", "/near/image_raw"),
    ("fit --rig {ur5} --train {rec}", "/near/image_raw"),
    # unwritable outputs
    ("extract {rec} --rig {rig} -o {dir}/no/such/folder/o.parquet", "does not exist"),
    ("extract {rec} --rig {rig} -o {folder}", "is a directory"),
    ("extract {rec} --rig {rig} -o {dir}/o.csv", ".parquet"),
    ("simulate --rig {rig} --scenario {sc} -o {dir}/nowhere/o.mcap", "does not exist"),
    ("simulate --rig {rig} --scenario {sc} -o {dir}/o.parquet", ".mcap"),
    ("fit --rig {rig} --train {tables} --json {dir}/nowhere/fit.json", "does not exist"),
    ("predict --rig {rig} --alpha 2e-5 --run {tables} --series {dir}/s.txt", ".csv"),
    ("drift --rig {rig} --run {tables} --json {folder}", "is a directory"),
    # bad numbers
    ("simulate --rig {rig} --scenario {sc} -o {dir}/o.mcap --seed -5", "--seed"),
    ("simulate --rig {rig} --scenario {sc} -o {dir}/o.mcap --seed 1.5", "--seed"),
    ("predict --rig {rig} --alpha 23.2 --run {tables}", "23.2e-6"),
    ("predict --rig {rig} --alpha -1 --run {tables}", "> 0"),
    ("predict --rig {rig} --alpha 0 --run {tables}", "> 0"),
    ("predict --rig {rig} --alpha nan --run {tables}", "finite"),
    ("predict --rig {rig} --alpha lots --run {tables}", "not a number"),
    ("predict --rig {rig} --alpha 2e-5 --run {tables} --end-visits 0", "--end-visits"),
    ("drift --rig {rig} --run {tables} --window 2", "--window"),
    ("drift --rig {rig} --run {tables} --tolerance-um 0", "--tolerance-um"),
    ("extract {rec} --rig {rig} -o {dir}/o.parquet --visit-tolerance-deg -1", "tolerance"),
    # usage
    ("predict --rig {rig} --run {tables}", "exactly one of --alpha, --fit, --diagnosis or --train"),
    ("fit --rig {rig}", "--train"),
    ("frobnicate", "frobnicate"),
]


@pytest.mark.parametrize(("args", "message"), WRONG, ids=[a for a, _ in WRONG])
def test_wrong_invocation_exits_2_with_one_line(
    data: dict[str, Path], args: str, message: str
) -> None:
    before = set(data["dir"].rglob("*"))
    argv = [a.format(**data, ur5=UR5) for a in args.split()]
    p = cli_in_process(*argv)
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert p.returncode == 2, p.stderr
    assert len(lines) == 1, p.stderr
    assert "Traceback" not in p.stderr and lines[0].startswith("thermrs: error: "), p.stderr
    assert message in lines[0], lines[0]
    assert set(data["dir"].rglob("*")) == before  # nothing written, no temporary left


def test_a_campaign_names_a_file_it_cannot_read_once(tmp_path: Path) -> None:
    """A six-byte file among a campaign's recordings: one line, its path said once."""
    (tmp_path / "recs").mkdir()
    notes = tmp_path / "recs" / "notes.mcap"
    notes.write_text("notes\n")
    p = cli("extract", str(tmp_path / "recs"), "--rig", str(thermrs.default_rig_path()),
            "-o", str(tmp_path / "ds"))  # fmt: skip
    assert p.returncode == 2, p.stderr
    (line,) = [ln for ln in p.stderr.splitlines() if "notes.mcap" in ln]
    assert line.count("notes.mcap") == 1 and "not an MCAP file" in line, line


def test_a_campaign_warns_of_one_recording_under_two_names(
    two_runs: dict[str, Path], tmp_path: Path
) -> None:
    """Byte-identical copies are catalogued (they are two files) and said to be one
    recording, so that no rule's folds compare a run with itself unawares (L12)."""
    (tmp_path / "recs").mkdir()
    for name in ("day1.mcap", "day1-copy.mcap"):
        (tmp_path / "recs" / name).write_bytes((two_runs["root"] / "rec.mcap").read_bytes())
    p = cli("extract", str(tmp_path / "recs"), "--rig", str(two_runs["rig"]),
            "-o", str(tmp_path / "ds"), "--workers", "1")  # fmt: skip
    assert p.returncode == 0, p.stderr
    (line,) = [ln for ln in p.stderr.splitlines() if ln.startswith("thermrs: warning")]
    assert "day1-copy.mcap and " in line and "day1.mcap are the same recording" in line, line


def test_at_least_thirty_wrong_invocations() -> None:
    assert len(WRONG) >= 30


@pytest.mark.slow
def test_data_loss_survives_quiet_and_stays_with_the_tables(
    data: dict[str, Path], tmp_path: Path
) -> None:
    p = cli("extract", str(data["cut"]), "--rig", str(data["rig"]), "--quiet", "-o",
            str(tmp_path / "c.parquet"))  # fmt: skip
    assert p.returncode == 3, p.stderr
    assert "data loss" in p.stderr and "Traceback" not in p.stderr
    # Every table remembers the loss; a clean extraction records none.
    for name in ("c.parquet", "c.visits.parquet", "c.temperatures.parquet", "c.joints.parquet"):
        assert thermrs.ingest.data_loss(tmp_path / name), name
    assert thermrs.ingest.data_loss(data["tables"]) == []
    # Every later command on the cut tables exits 3 and says why; on clean tables 0.
    rig = str(data["rig"])
    for clean, code in ((data["tables"], 0), (tmp_path / "c.parquet", 3)):
        for args in (
            ["fit", "--rig", rig, "--train", str(clean)],
            ["predict", "--rig", rig, "--alpha", "2.2e-5", "--run", str(clean)],
            ["drift", "--rig", rig, "--run", str(clean)],
        ):
            r = cli(*args)
            assert r.returncode == code, (args, r.stderr)
            assert ("data loss" in r.stderr) == (code == 3), r.stderr
    table, lost = thermrs.fit.load_run_table(tmp_path / "c.visits.parquet", data["rig"])
    assert lost and table.height > 0


def _start(args: list[str], cwd: Path) -> subprocess.Popen[str]:
    """The CLI in a child that takes SIGINT as a terminal's Ctrl-C would."""
    return interruptible(*args, cwd=cwd)


def test_ctrl_c_stops_simulate_at_once(tmp_path: Path) -> None:
    # The paper's three 15-hour runs: minutes of work, far longer than the test waits.
    rig = thermrs.default_rig_path()
    out = tmp_path / "long.mcap"
    proc = _start(["simulate", "--rig", str(rig), "--scenario", str(PAPER_RUNS), "-o", str(out)],
                  tmp_path)  # fmt: skip
    deadline = time.monotonic() + 60
    # At work: the simulator has opened its temporary recording.
    while not any(tmp_path.glob(".long.mcap.*.tmp")) and time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.01)
    time.sleep(0.5)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    dt = time.monotonic() - t0
    assert proc.returncode == 130, err
    assert err.splitlines() == ["thermrs: interrupted"], err
    assert dt < 5.0, dt  # a functional bound; the latency itself: BENCHMARKS.md
    assert list(tmp_path.iterdir()) == []  # no recording, no temporary file left


def _mapped(pid: int, needle: str) -> bool:
    """Whether process ``pid`` has a file whose path contains ``needle`` mapped or open."""
    try:
        if needle in Path(f"/proc/{pid}/maps").read_text():
            return True
        return any(needle in os.readlink(fd) for fd in Path(f"/proc/{pid}/fd").iterdir())
    except OSError:  # it has exited, or closed the file while we looked
        return False


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("phase", ["started", "extracting", "writing"])
def test_ctrl_c_stops_extract_cleanly_wherever_it_lands(
    data: dict[str, Path], tmp_path: Path, phase: str
) -> None:
    """Ctrl-C at a point of the run this test observes, not after a guessed delay (which a
    loaded machine turns into a different point): ``started`` once the command has loaded the
    Rust extension (its work all ahead: it must be interrupted), ``extracting`` once the
    recording is mapped, ``writing`` once a temporary output exists. A phase the command has
    already left when the signal lands may finish instead (exit 0, complete output); either
    way: exit 130 with one line and nothing left behind, or exit 0."""
    out = tmp_path / "out"
    out.mkdir()
    args = ["extract", str(data["rec"]), "--rig", str(data["rig"]), "-o",
            str(out / "o.parquet")]  # fmt: skip
    proc = _start(args, tmp_path)
    rec = str(data["rec"].resolve())
    seen = {
        "started": lambda: _mapped(proc.pid, "_native"),
        "extracting": lambda: _mapped(proc.pid, rec),
        "writing": lambda: any(out.iterdir()),  # the first table's temporary file
    }[phase]
    landed = False
    while proc.poll() is None:
        if seen():
            proc.send_signal(signal.SIGINT)
            landed = True
            break
        time.sleep(0.001)
    _, err = proc.communicate(timeout=60)
    if phase == "started":
        assert landed
    if proc.returncode == 0:  # finished before the signal mattered: complete output
        assert phase != "started", err
        assert (out / "o.parquet").exists()
        return
    assert proc.returncode == 130, err
    assert err.splitlines() == ["thermrs: interrupted"], err
    assert list(out.iterdir()) == []  # no table, no temporary file


def _file_size_limit(limit: int) -> Callable[[], None]:
    """A child's set-up: files may not grow past ``limit`` bytes (a write beyond fails with
    EFBIG, as a full disk fails with ENOSPC), and Ctrl-C as a terminal's."""

    def setup() -> None:
        import resource

        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG, not death by the signal
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return setup


@pytest.mark.skipif(not hasattr(signal, "SIGXFSZ"), reason="needs RLIMIT_FSIZE")
@pytest.mark.parametrize("command", ["simulate", "extract"])
def test_a_failed_write_exits_1_with_one_line_naming_the_file(
    data: dict[str, Path], tmp_path: Path, command: str
) -> None:
    """Writing fails part way (the operating system refuses to let the file grow): not bad
    input but a failure, exit 1, one line naming the file, nothing left behind."""
    out = tmp_path / ("o.mcap" if command == "simulate" else "o.parquet")
    args = {
        "simulate": ["--rig", str(data["rig"]), "--scenario", str(data["sc"]), "-o", str(out)],
        "extract": [str(data["rec"]), "--rig", str(data["rig"]), "-o", str(out)],
    }[command]
    assert data["rec"].stat().st_size > 1_000  # the recording is larger than the limit
    p = subprocess.run(
        [sys.executable, "-m", "thermrs", command, *args],
        capture_output=True,
        text=True,
        env={**os.environ, "THERMRS_DEBUG": ""},
        preexec_fn=_file_size_limit(1_000),
    )
    assert p.returncode == 1, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert lines[0].startswith(f"thermrs: error: cannot write {out}: "), lines
    if command == "simulate":  # (polars' parquet writer does not pass the errno on)
        assert "File too large" in lines[0], lines
    assert list(tmp_path.iterdir()) == []


def _unwritable_folder(tmp_path: Path) -> Path:
    """A folder that takes no new file: read-only for a user; for root (whom permissions do not
    stop) /proc, which takes no file whatever the user."""
    if os.geteuid() == 0:
        return Path("/proc")
    ro = tmp_path / "read-only"
    ro.mkdir()
    ro.chmod(0o555)
    return ro


def _assert_cannot_write(line: str, path: Path) -> None:
    """`error: cannot write PATH: reason`, the reason the operating system's: permission
    denied in a read-only folder; in /proc whatever this kernel says (here ENOENT)."""
    head = f"thermrs: error: cannot write {path}: "
    assert line.startswith(head), line
    if path.parent != Path("/proc"):
        assert line == head + os.strerror(errno.EACCES), line
    else:
        assert len(line) > len(head), line


#: Commands writing an output into a folder that takes no file, and that output's name.
UNWRITABLE = [
    ("extract {rec} --rig {rig} -o {out}/x.parquet", "x.parquet"),
    ("simulate --rig {rig} --scenario {sc} -o {out}/x.mcap", "x.mcap"),
    ("fit --rig {rig} --train {tables} --json {out}/fit.json", "fit.json"),
    ("predict --rig {rig} --alpha 2e-5 --run {tables} --json {out}/p.json", "p.json"),
    ("drift --rig {rig} --run {tables} --json {out}/d.json", "d.json"),
]


@pytest.mark.parametrize(("args", "name"), UNWRITABLE, ids=[a for a, _ in UNWRITABLE])
def test_an_unwritable_output_exits_1_with_one_line_naming_the_file(
    data: dict[str, Path], tmp_path: Path, args: str, name: str
) -> None:
    """Not bad input (exit 2) nor an internal error: `error: cannot write PATH: reason`, exit 1,
    the operating system's reason, nothing written."""
    out = _unwritable_folder(tmp_path)
    before = set(data["dir"].rglob("*"))
    p = cli(*[a.format(**data, out=out) for a in args.split()])
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert p.returncode == 1, p.stderr
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    _assert_cannot_write(lines[0], out / name)
    assert set(data["dir"].rglob("*")) == before
    assert not out.exists() or out == Path("/proc") or list(out.iterdir()) == []


def test_an_unwritable_report_exits_1_naming_the_file(tmp_path: Path) -> None:
    """The report's output is checked before the (minute-long) demo starts."""
    out = _unwritable_folder(tmp_path) / "r.html"
    p = cli("report", "--demo", "-o", str(out))
    assert p.returncode == 1, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    _assert_cannot_write(lines[0], out)


def test_a_failed_write_in_the_library_is_an_oserror_naming_the_file(
    data: dict[str, Path], tmp_path: Path
) -> None:
    """The library raises the operating system's error with the file asked for (not the
    temporary one), in a child process so that the file size limit stays there."""
    out = tmp_path / "o.mcap"
    code = (
        "import sys, thermrs\n"
        "try:\n"
        f"    thermrs.simulate.simulate({str(data['rig'])!r}, {str(data['sc'])!r}, {str(out)!r})\n"
        "except OSError as e:\n"
        "    print(type(e).__name__, e.errno, e.filename, str(e).startswith('cannot write'))\n"
    )
    p = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        preexec_fn=_file_size_limit(1_000),
    )
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["OutputError", str(errno.EFBIG), str(out), "True"], p.stdout
    assert list(tmp_path.iterdir()) == []


def test_cli_defaults_written_out_for_a_fast_start_match_the_library() -> None:
    from thermrs import cli, visits

    assert cli.VISIT_TOLERANCE_DEG == visits.DEFAULT_TOLERANCE_DEG
