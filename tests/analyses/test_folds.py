"""Folds on Dask workers (:mod:`thermrs.analyses.folds`): each fold's result is the one
this process computes, what a fold says comes back with its name, a fold's error arrives as
itself, and the cluster is gone afterwards."""

from __future__ import annotations

import pickle

import polars as pl
import pytest
import thermrs
from thermrs.analyses.diagnose import DiagnosisFold, diagnose_splits
from thermrs.analyses.folds import map_folds, run_folds
from thermrs.analyses.inputs import Split
from thermrs.bench import make_runs
from thermrs.diagnose import diagnose
from thermrs.effects import ThermalLag
from thermrs.errors import InputError

from tests.support.nested import assert_nested_close


@pytest.fixture(scope="module")
def folds() -> list[Split]:
    """Leave-one-run-out over three 2-h runs with a thermal lag."""
    runs = make_runs(thermrs.load_rig(), ThermalLag(tau_min=60.0), seed=5, hours=2)
    return [
        Split(f"without {i}", [r for j, r in enumerate(runs) if j != i], [runs[i]])
        for i in range(len(runs))
    ]


def test_a_rig_pickles_as_itself() -> None:
    rig = thermrs.load_rig()
    back = pickle.loads(pickle.dumps(rig))
    assert back.source == rig.source
    assert back.to_dict() == rig.to_dict() and back.tolerances == rig.tolerances


@pytest.mark.slow
def test_folds_on_workers_are_the_folds_diagnosed_here(folds: list[Split]) -> None:
    rig = thermrs.load_rig()
    said: list[str] = []
    here = diagnose_splits(folds, rig, bootstrap=0, workers=1)
    there = diagnose_splits(folds, rig, bootstrap=0, workers=2, progress=said.append)
    assert [f.split.name for f in there] == [s.name for s in folds]
    for a, b in zip(here, there, strict=True):
        assert_nested_close(b.diagnosis.to_json(), a.diagnosis.to_json(), rel=1e-9)
    # Every fold's own messages came back, its name first, and its end.
    for s in folds:
        mine = [m for m in said if m.startswith(f"{s.name}: ")]
        assert any(m.endswith("verdict") for m in mine), mine
        assert sum(" done (" in m for m in mine) == 1, mine


@pytest.mark.slow
def test_a_fold_that_fails_on_a_worker_raises_its_own_error(folds: list[Split]) -> None:
    import multiprocessing

    before = {p.pid for p in multiprocessing.active_children()}
    with pytest.raises(InputError, match=r"--exclude .*nonsense.*: not effects"):
        run_folds(
            diagnose, DiagnosisFold, folds[:2], thermrs.load_rig(), workers=2, exclude=["nonsense"]
        )
    # The cluster it started is shut down: no worker process is left behind.
    assert {p.pid for p in multiprocessing.active_children()} <= before


def test_one_worker_runs_the_folds_here_in_order(folds: list[Split]) -> None:
    said: list[str] = []

    def task(split: Split, progress: object) -> int:
        assert callable(progress)
        progress("working")
        return int(split.holdout[0].select(pl.len()).item())

    got = map_folds(task, folds, workers=1, progress=said.append)
    assert got == [s.holdout[0].height for s in folds]
    assert said == [f"{s.name}: working" for s in folds]


def test_the_old_module_hands_on_the_runner_with_a_warning_naming_the_new_path() -> None:
    import thermrs.campaigns.fold_map as old

    with pytest.warns(DeprecationWarning, match=r"thermrs\.analyses\.folds\.map_folds") as w:
        moved = old.map_folds
    assert moved is map_folds
    assert "0.2.0" in str(w[0].message)
    with pytest.raises(AttributeError):
        old.run_bench  # noqa: B018
