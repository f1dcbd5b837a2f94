"""The names that moved from :mod:`thermrs.report` to :mod:`thermrs.analyses` when the report
stopped reading runs and computing (issue #46): each old name is the new one, with a
``DeprecationWarning`` that names the new path and the version it goes in, a version after the
workspace's own; ``from thermrs.report import *`` gives what the package holds, quietly."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import thermrs.report
from thermrs.moved import MOVED_NAMES_REMOVED_IN
from thermrs.report import MOVED_TO_ANALYSES

REPO = Path(__file__).resolve().parents[2]

#: The names ``thermrs.report`` exported before the move that read runs or computed (its
#: ``__all__`` at the commit before it).
OLD_NAMES = ("load_run", "load_runs", "run_from_extraction", "write_report")


def test_every_old_name_is_the_new_one_with_a_warning_naming_path_and_version() -> None:
    assert sorted(MOVED_TO_ANALYSES) == sorted(OLD_NAMES)
    for name in OLD_NAMES:
        with pytest.warns(DeprecationWarning) as caught:
            old = getattr(thermrs.report, name)
        (w,) = caught
        home = MOVED_TO_ANALYSES[name]
        assert home.startswith("thermrs.analyses.")
        assert old is getattr(importlib.import_module(home), name)
        assert f"thermrs.report.{name}" in str(w.message) and f"{home}.{name}" in str(w.message)
        assert f"thermrs {MOVED_NAMES_REMOVED_IN}" in str(w.message)
        assert w.filename == __file__  # the warning points at the caller's line
    workspace = tomllib.loads((REPO / "Cargo.toml").read_text())["workspace"]["package"]
    version = tuple(int(x) for x in workspace["version"].split("."))
    assert tuple(int(x) for x in MOVED_NAMES_REMOVED_IN.split(".")) > version


def test_star_import_is_quiet_and_gives_what_the_package_holds() -> None:
    code = (
        "import warnings\n"
        "warnings.simplefilter('error')\n"
        "from thermrs.report import *\n"
        "print(sorted(k for k in dir() if not k.startswith('_')))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    names = set(ast.literal_eval(p.stdout))
    assert set(thermrs.report.__all__) <= names
    assert not names & set(OLD_NAMES)
    with pytest.raises(AttributeError, match="no attribute 'gather'"):
        thermrs.report.gather  # noqa: B018
