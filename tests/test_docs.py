"""The examples in the library's docstrings run and print what they say."""

from __future__ import annotations

import doctest

import pytest
import thermrs.model
import thermrs.paper
import thermrs.rig


@pytest.mark.parametrize("module", [thermrs.rig, thermrs.model, thermrs.paper])
def test_docstring_examples(module: object) -> None:
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)  # type: ignore[arg-type]
    assert result.attempted > 0
    assert result.failed == 0
