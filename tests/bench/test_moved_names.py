"""The bench moved from :mod:`thermrs.diagnose` to :mod:`thermrs.bench` (issue #46): the old
names are the new ones, with a ``DeprecationWarning`` that names the new path and the version
they go in, a version after the workspace's own; the README's changes say so."""

from __future__ import annotations

import importlib
import tomllib
from pathlib import Path

import pytest
import thermrs.bench
import thermrs.diagnose.bench as old_bench
from thermrs.moved import MOVED_NAMES_REMOVED_IN

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", ["run_bench", "make_runs"])
def test_the_old_names_are_the_new_ones_with_a_warning(name: str) -> None:
    with pytest.warns(DeprecationWarning) as caught:
        old = getattr(old_bench, name)
    (w,) = caught
    assert old is getattr(thermrs.bench, name)
    assert f"thermrs.diagnose.bench.{name}" in str(w.message)
    assert f"thermrs.bench.{name}" in str(w.message)
    assert f"thermrs {MOVED_NAMES_REMOVED_IN}" in str(w.message)
    assert w.filename == __file__  # the warning points at the caller's line


def test_from_import_warns_and_the_removal_is_after_this_version() -> None:
    with pytest.warns(DeprecationWarning, match=r"thermrs\.bench\.run_bench"):
        from thermrs.diagnose.bench import run_bench
    assert run_bench is thermrs.bench.run_bench
    workspace = tomllib.loads((REPO / "Cargo.toml").read_text())["workspace"]["package"]
    version = tuple(int(x) for x in workspace["version"].split("."))
    assert tuple(int(x) for x in MOVED_NAMES_REMOVED_IN.split(".")) > version
    with pytest.raises(AttributeError):
        old_bench.no_such_name  # noqa: B018


def test_the_world_is_only_under_its_new_name_and_the_readme_says_so() -> None:
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("thermrs.diagnose.bench_world")
    assert importlib.import_module("thermrs.bench.world").EFFECTS
    readme = (REPO / "README.md").read_text()
    changes = readme[readme.index("## Changes") :].split("\n## ", 1)[0]
    assert "`thermrs.diagnose.bench` is `thermrs.bench`" in changes
    assert "`thermrs.diagnose.bench_world` is `thermrs.bench.world`" in changes
