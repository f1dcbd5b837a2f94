"""Backs BENCHMARKS.md "CLI start-up < 0.2 s" and "Ctrl-C stops within a fraction of a second".

Start-up of the CLI and how fast Ctrl-C stops it (issue #13).

- ``thermrs --help``: wall time of the whole process, repeated (hyperfine-style: warm-up runs,
  then min / median / max of N runs), and the modules that cost most to import
  (``python -X importtime``), optionally beside another checkout's package for comparison
  (``--baseline DIR``: a folder holding a ``thermrs`` package; its ``_native`` extension is
  copied from the installed one if absent).
- Ctrl-C: SIGINT sent to ``thermrs simulate`` (the paper's three runs) once it is writing its
  recording, and to ``thermrs extract`` of the recording that simulation would write (here a
  short one); the time from the signal to the process's exit, its exit code and stderr.

Run:  python benchmarks/bench_cli_latency.py [--runs 30] [--baseline OLD/python]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import thermrs

REPO = Path(__file__).resolve().parents[1]


def _env(pythonpath: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    return env


def _timed(cmd: list[str], runs: int, env: dict[str, str]) -> tuple[list[float], list[float]]:
    """Wall and CPU (user + system) seconds of ``runs`` runs of ``cmd``, after 3 warm-ups.
    CPU time is what the process itself costs; wall time also holds waiting for a core,
    which on a shared machine can be most of it."""
    for _ in range(3):  # warm-up: page cache, bytecode
        subprocess.run(cmd, capture_output=True, env=env, check=False)
    wall, cpu = [], []
    for _ in range(runs):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(cmd, capture_output=True, env=env, check=True)
        wall.append(time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
    return wall, cpu


def help_times(runs: int, pythonpath: Path | None) -> tuple[list[float], list[float]]:
    cmd = [sys.executable, "-c", "from thermrs.cli import main; main(['--help'])"]
    return _timed(cmd, runs, _env(pythonpath))


def python_floor(runs: int) -> tuple[list[float], list[float]]:
    return _timed([sys.executable, "-c", "pass"], runs, _env(None))


def import_top(pythonpath: Path | None, n: int = 8) -> list[tuple[int, str]]:
    p = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import thermrs.cli"],
        capture_output=True,
        text=True,
        env=_env(pythonpath),
        check=True,
    )
    rows = []
    for line in p.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        parts = line.split("|")
        rows.append((int(parts[1]), parts[2].strip()))
    rows.sort(reverse=True)
    return rows[:n]


def _sigint_child() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def interrupt(args: list[str], ready: Callable[[], bool], cwd: Path) -> tuple[float, int, str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "thermrs", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=cwd,
        preexec_fn=_sigint_child,
    )
    while not ready() and proc.poll() is None:
        time.sleep(0.005)
    time.sleep(0.5)
    t0 = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate()
    return time.perf_counter() - t0, proc.returncode, err.strip()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--baseline", type=Path, default=None)
    a = ap.parse_args()

    def stats(wc: tuple[list[float], list[float]]) -> str:
        xs, cpu = wc
        return (
            f"wall min {min(xs) * 1e3:.0f} ms, median {statistics.median(xs) * 1e3:.0f} ms, "
            f"max {max(xs) * 1e3:.0f} ms; CPU median {statistics.median(cpu) * 1e3:.0f} ms "
            f"(n = {len(xs)})"
        )

    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"python -c pass:          {stats(python_floor(a.runs))}")
    print(f"thermrs --help (this):   {stats(help_times(a.runs, None))}")
    if a.baseline is not None:
        native = next(Path(thermrs.__file__).parent.glob("_native*.so"))
        target = a.baseline / "thermrs" / native.name
        if not target.exists():
            shutil.copy(native, target)
        print(f"thermrs --help (baseline): {stats(help_times(a.runs, a.baseline))}")
    print("costliest imports of thermrs.cli (cumulative µs):")
    for us, name in import_top(None):
        print(f"  {us:>8}  {name}")

    rig = str(thermrs.default_rig_path())
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        sc = REPO / "fixtures" / "scenarios" / "paper-runs.toml"
        dt, code, err = interrupt(
            ["simulate", "--rig", rig, "--scenario", str(sc), "-o", str(tmp / "p.mcap")],
            lambda: any(tmp.glob(".p.mcap.*.tmp")),
            tmp,
        )
        print(f"Ctrl-C simulate: exit {code} {err!r} {dt * 1e3:.0f} ms after the signal")
        short = REPO / "fixtures" / "scenarios" / "two-runs-thermal-lag.toml"
        rec = thermrs.simulate.simulate(rig, short, tmp / "r.mcap").recording
        out = tmp / "out"
        out.mkdir()
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "thermrs", "extract", str(rec), "--rig", rig,
                        "--quiet", "-o", str(out / "o.parquet")], check=True)  # fmt: skip
        whole = time.perf_counter() - t0
        shutil.rmtree(out)
        out.mkdir()
        dt, code, err = interrupt(
            ["extract", str(rec), "--rig", rig, "--quiet", "-o", str(out / "o.parquet")],
            lambda: True,
            tmp,
        )
        print(
            f"Ctrl-C extract (whole command {whole * 1e3:.0f} ms): exit {code} {err!r} "
            f"{dt * 1e3:.0f} ms after the signal"
        )


if __name__ == "__main__":
    main()
