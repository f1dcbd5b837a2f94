"""The names that moved from :mod:`thermrs.campaigns` to :mod:`thermrs.analyses` (issue #46):
each old name is the new one, with a ``DeprecationWarning`` that names the new path and the
version it goes in, a version after the workspace's own; the package's ``__all__`` holds only
what it holds; the modules that only handed names on are gone, and the README says so."""

from __future__ import annotations

import importlib
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import pytest
import thermrs.analyses
import thermrs.campaigns
from thermrs.campaigns import MOVED_TO_ANALYSES
from thermrs.moved import MOVED_NAMES_REMOVED_IN

REPO = Path(__file__).resolve().parents[2]

#: The names ``thermrs.campaigns`` handed on before they moved (its ``__all__`` at the commit
#: before the move, less what it defines itself).
OLD_NAMES = ("DesignFold", "DiagnosisFold", "DriftResult", "Prediction", "Split", "design",
             "diagnose", "drift", "fit", "open_dataset", "predict", "report", "select_runs",
             "selected", "splits")  # fmt: skip


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in text.split("."))


def test_every_old_name_is_the_new_one_with_a_warning_naming_path_and_version() -> None:
    assert sorted(MOVED_TO_ANALYSES) == sorted(OLD_NAMES)
    for name in OLD_NAMES:
        with pytest.warns(DeprecationWarning) as caught:
            old = getattr(thermrs.campaigns, name)
        (w,) = caught
        home = MOVED_TO_ANALYSES[name]
        assert old is getattr(importlib.import_module(home), name)
        assert f"thermrs.campaigns.{name}" in str(w.message)
        assert f"{home}.{name}" in str(w.message)
        assert f"thermrs {MOVED_NAMES_REMOVED_IN}" in str(w.message)
        assert w.filename == __file__  # the warning points at the caller's line


def test_from_import_warns_too_and_the_removal_is_after_this_version() -> None:
    with pytest.warns(DeprecationWarning, match=r"thermrs\.analyses\.inputs\.open_dataset"):
        from thermrs.campaigns import open_dataset
    assert open_dataset is thermrs.analyses.inputs.open_dataset
    workspace = tomllib.loads((REPO / "Cargo.toml").read_text())["workspace"]["package"]
    assert _version(MOVED_NAMES_REMOVED_IN) > _version(workspace["version"])


def test_the_package_face_lists_what_it_holds_and_star_import_is_quiet() -> None:
    code = (
        "import warnings\n"
        "warnings.simplefilter('error')\n"
        "from thermrs.campaigns import *\n"
        "import thermrs.campaigns as c\n"
        "print(' '.join(sorted(n for n in dir() if not n.startswith('_') and n != 'warnings'"
        " and n != 'c')))\n"
        "print(' '.join(sorted(c.__all__)))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    got, listed = (line.split() for line in p.stdout.splitlines())
    assert got == listed
    assert not set(listed) & set(OLD_NAMES)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in thermrs.campaigns.__all__:
            getattr(thermrs.campaigns, name)


@pytest.mark.parametrize(
    "module", ["thermrs.workflows", "thermrs.campaigns.analyses", "thermrs.campaigns.inputs"]
)
def test_the_modules_that_only_handed_names_on_are_gone_and_the_readme_says_so(
    module: str,
) -> None:
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(module)
    readme = (REPO / "README.md").read_text()
    changes = readme[readme.index("## Changes") :].split("\n## ", 1)[0]
    assert f"`{module}`" in changes
    parent, _, leaf = module.rpartition(".")
    face = importlib.import_module(parent)
    assert leaf not in face.__all__
    with pytest.raises(AttributeError):
        getattr(face, leaf)


def test_the_fold_syntheses_moved_from_the_summary_are_handed_on_with_a_warning() -> None:
    import thermrs.campaigns.summary as summary

    for name, home in (
        ("fold_synthesis", "thermrs.analyses.diagnose"),
        ("predict_synthesis", "thermrs.analyses.predict"),
    ):
        assert name not in summary.__all__
        with pytest.warns(DeprecationWarning) as caught:
            old = getattr(summary, name)
        (w,) = caught
        assert old is getattr(importlib.import_module(home), name)
        assert old is getattr(thermrs.analyses, name)
        assert f"thermrs.campaigns.summary.{name}" in str(w.message)
        assert f"{home}.{name}" in str(w.message)
        assert f"thermrs {MOVED_NAMES_REMOVED_IN}" in str(w.message)
        assert w.filename == __file__
    readme = (REPO / "README.md").read_text()
    changes = readme[readme.index("## Changes") :].split("\n## ", 1)[0]
    assert "`thermrs.campaigns.summary.fold_synthesis`" in changes
    with pytest.raises(AttributeError):
        summary.no_such_name  # noqa: B018
