"""What the analyses load: ``thermrs fit`` and the other commands that write no report import no
module of :mod:`thermrs.report` (issue #46), as the interpreter itself reports its imports
(``python -X importtime``), in a fresh process."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


def _imported(stderr: str) -> set[str]:
    """The modules ``-X importtime`` says were imported (its lines end ``| <module>``)."""
    return {
        ln.rsplit("|", 1)[1].strip()
        for ln in stderr.splitlines()
        if ln.startswith("import time:") and ln.count("|") == 2
    }


def _report_modules(names: set[str]) -> list[str]:
    return sorted(m for m in names if m == "thermrs.report" or m.startswith("thermrs.report."))


def test_fit_and_drift_on_a_recording_import_no_report_module(data: dict[str, Path]) -> None:
    rig, rec = str(data["rig"]), str(data["rec"])
    for args in (("fit", "--rig", rig, "--train", rec), ("drift", "--rig", rig, "--run", rec)):
        p = subprocess.run(
            [sys.executable, "-X", "importtime", "-m", "thermrs", *args],
            capture_output=True,
            text=True,
            env={**os.environ, "THERMRS_DEBUG": ""},
        )
        assert p.returncode == 0, p.stderr[-2000:]
        names = _imported(p.stderr)
        # The reading is the interpreter's: the command's own modules are among them.
        assert {"thermrs.cli.app", f"thermrs.analyses.{args[0]}"} <= names, args
        assert _report_modules(names) == [], args


def test_every_analysis_but_the_report_loads_no_report_module() -> None:
    code = (
        "import sys, thermrs.cli, thermrs.analyses, thermrs.campaigns, thermrs.diagnose\n"
        "import thermrs.design, thermrs.compensate\n"
        "for m in ('fit', 'predict', 'drift', 'diagnose', 'design', 'inputs'):\n"
        "    __import__(f'thermrs.analyses.{m}')\n"
        "print(' '.join(sorted(sys.modules)))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    names = set(p.stdout.split())
    assert "thermrs.analyses.diagnose" in names
    assert _report_modules(names) == []
    # The report itself still loads it, when a report is asked for.
    code = "import sys, thermrs.analyses; thermrs.analyses.report; import thermrs.report\n"
    subprocess.run([sys.executable, "-c", code], check=True)
