"""Backs BENCHMARKS.md "report of three 15-h runs < 30 s" and "thermrs report --demo < 60 s".

Benchmark of `thermrs report` (issue #11).

1. The report of three 15-hour runs once they are extracted (must reach: under 30 s): the
   paper's three runs are simulated from the packaged demo scenario and extracted (not timed),
   then :func:`thermrs.analyses.report.write_report` is timed end to end (fit, start/end,
   prediction tables, heating curves, ISO 9283, the diagnosis where the diagnoser exists,
   figures, HTML, Markdown and SVG files), best of ``--repeat``.
2. ``thermrs report --demo`` end to end as a user runs it (must reach: under a minute), with
   the size of the HTML it writes (must be small enough to mail).

Writes ``bench-out/report/bench_report.json`` (or ``--dir``) and prints it.

    python benchmarks/bench_report.py [--repeat 3] [--dir bench-out/report]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

# Timed from scratch: no diagnosis is read from the on-disk cache (thermrs.memo).
os.environ["THERMRS_CACHE_DIR"] = "off"  # thermrs.memo.CACHE_ENV


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/report"))
    ap.add_argument(
        "--scenario",
        type=Path,
        default=None,
        help="Simulate this scenario instead of the packaged demo's (e.g. "
        "fixtures/scenarios/paper-runs.toml: the paper's one-minute cycles).",
    )
    ap.add_argument(
        "--reuse", action="store_true", help="Reuse the recording simulated before in --dir."
    )
    ap.add_argument("--no-demo", action="store_true", help="Skip `thermrs report --demo`.")
    ap.add_argument(
        "--screenshot",
        type=Path,
        default=None,
        help="Also save the top of the demo report as a small PNG here (the README's "
        "docs/report-top.png; needs chromium and playwright).",
    )
    args = ap.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)

    import thermrs
    from thermrs.analyses.demo import simulate_demo
    from thermrs.analyses.report import write_report

    rig = thermrs.load_rig()
    d = simulate_demo(args.dir / "work", scenario=args.scenario, reuse=args.reuse)
    visits = sum(r.table.height for r in d.runs)
    hours = [
        float(r.table["t_ns"].max() - r.table["t_ns"].min()) / 3.6e12  # type: ignore[operator]
        for r in d.runs
    ]
    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        w = write_report(args.dir / "three-runs.html", runs=d.runs, rig=rig, paper_reference=True)
        times.append(time.perf_counter() - t0)

    doc: dict[str, object] = {
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs, "
        f"Python {platform.python_version()}",
        "scenario": str(args.scenario or "packaged demo-scenario.toml"),
        "runs": len(d.runs),
        "run_hours": [round(h, 2) for h in hours],
        "visits": visits,
        "simulate_s": round(d.timings["simulate"], 2),
        "extract_and_cut_s": round(d.timings["extract"], 2),
        "report_s_best": round(min(times), 2),
        "report_s_all": [round(t, 2) for t in times],
        "html_bytes": w.html_bytes,
        "figures": len(w.figures),
    }
    if not args.no_demo:
        doc |= demo(args.dir)
        if args.screenshot is not None:
            screenshot(args.dir / "demo.html", args.screenshot)
    (args.dir / "bench_report.json").write_text(json.dumps(doc, indent=2))
    print(json.dumps(doc))


def demo(out_dir: Path) -> dict[str, object]:
    """`thermrs report --demo` end to end, as a user runs it."""
    t0 = time.perf_counter()
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "thermrs",
            "report",
            "--demo",
            "--quiet",
            "-o",
            str(out_dir / "demo.html"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    demo_s = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"thermrs report --demo failed: {p.stderr}")
    return {
        "demo_end_to_end_s": round(demo_s, 2),
        "demo_html_bytes": (out_dir / "demo.html").stat().st_size,
    }


def screenshot(html: Path, png: Path) -> None:
    """The report's top as a person sees it (headless Chromium), reduced to 64 colours."""
    from PIL import Image
    from playwright.sync_api import sync_playwright
    from thermrs.report import find_chromium

    exe = find_chromium()
    if exe is None:
        sys.exit("--screenshot needs chromium")
    raw = png.with_suffix(".raw.png")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1100, "height": 900})
        page.goto(html.resolve().as_uri())
        page.screenshot(path=str(raw))
        browser.close()
    png.parent.mkdir(parents=True, exist_ok=True)
    Image.open(raw).convert("RGB").quantize(colors=64).save(png, optimize=True)
    raw.unlink()


if __name__ == "__main__":
    main()
