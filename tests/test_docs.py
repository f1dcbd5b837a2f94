"""The examples in the library's docstrings run and print what they say."""

from __future__ import annotations

import doctest
import inspect

import pytest
import thermrs
import thermrs.atomic
import thermrs.diagnose.sequential
import thermrs.heating
import thermrs.ingest
import thermrs.iso9283
import thermrs.model
import thermrs.paper
import thermrs.predict
import thermrs.rig


@pytest.mark.parametrize(
    "module",
    [
        thermrs,
        thermrs.rig,
        thermrs.model,
        thermrs.paper,
        thermrs.heating,
        thermrs.iso9283,
        thermrs.predict,
        thermrs.ingest,
        thermrs.atomic,
        thermrs.diagnose.sequential,
    ],
)
def test_docstring_examples(module: object) -> None:
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)  # type: ignore[arg-type]
    assert result.attempted > 0
    assert result.failed == 0


@pytest.mark.parametrize(
    "module",
    ["fit", "predict", "heating", "iso9283", "ingest", "simulate", "rig", "campaigns", "analyses"],
)
def test_public_functions_have_numpy_docstrings(module: str) -> None:
    """Issue #13: every public function documents its parameters, what it returns, what it
    raises and shows an example (numpy docstring sections)."""
    mod = getattr(thermrs, module)
    for name in mod.__all__:
        obj = getattr(mod, name)
        if not inspect.isfunction(obj):
            continue
        doc = inspect.getdoc(obj) or ""
        sig = inspect.signature(obj)
        need = ["Examples"]
        if sig.parameters:  # what it takes, and how bad input fails
            need += ["Parameters", "Raises"]
        if sig.return_annotation not in ("None", None):
            # A generator says what it yields (numpy docstring standard).
            need += ["Yields" if inspect.isgeneratorfunction(obj) else "Returns"]
        missing = [s for s in need if f"{s}\n---" not in doc]
        assert not missing, f"{module}.{name}: no {missing}"
