"""Rig files built from the paper rig, for the rig tests (tests/model/test_rig_*.py): the paper
rig as data, a small TOML writer, mutations addressed by the key paths the validator reports,
and assertions on rig error messages and on ``thermrs rig``.

Every bad rig is built from the paper rig: its TOML is parsed with :mod:`tomllib`, one thing is
changed in the resulting dict by a mutation (:func:`put`, :func:`drop`, :func:`rename` …) and
the dict is written back with the writer below (:func:`mutated_text`)."""

from __future__ import annotations

import copy
import json
import math
import os
import re
import subprocess
import sys
import tomllib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pytest
import thermrs

from tests.support.cli import cli_in_process

# --------------------------------------------------------------------------------------------
# Paths and the good rig
# --------------------------------------------------------------------------------------------

SHARED = Path(__file__).resolve().parents[3] / "shared"
SHARED_RIG = SHARED / "rigs" / "kr15-paper.toml"
requires_shared = pytest.mark.skipif(
    not SHARED_RIG.is_file(),
    reason=f"the shared folder's paper rig is absent ({SHARED_RIG})",
)

GOOD_TEXT = thermrs.default_rig_path().read_text(encoding="utf-8")
GOOD: dict[str, Any] = tomllib.loads(GOOD_TEXT)
SOURCE = "rig.toml"  # source_name given to Rig.from_toml; appears in every message


def good_doc() -> dict[str, Any]:
    """A fresh, mutable copy of the paper rig as plain data."""
    return copy.deepcopy(GOOD)


# --------------------------------------------------------------------------------------------
# A small TOML writer (tomli_w is not installed): enough for rig files and their mutations
# --------------------------------------------------------------------------------------------

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _toml_string(s: str) -> str:
    # JSON string escapes are valid TOML basic-string escapes; TOML also wants DEL escaped.
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007f")


def _toml_key(k: str) -> str:
    return k if _BARE_KEY.fullmatch(k) else _toml_string(k)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)  # always has '.' or an exponent, both valid TOML floats
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _emit_table(lines: list[str], path: list[str], table: dict[str, Any]) -> None:
    for k, v in table.items():  # plain key/values first: they belong to this table's header
        if not isinstance(v, dict) and not _is_table_array(v):
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    for k, v in table.items():
        sub = [*path, _toml_key(k)]
        if isinstance(v, dict):
            lines += ["", f"[{'.'.join(sub)}]"]
            _emit_table(lines, sub, v)
        elif _is_table_array(v):
            for item in v:
                lines += ["", f"[[{'.'.join(sub)}]]"]
                _emit_table(lines, sub, item)


def dumps_toml(doc: dict[str, Any]) -> str:
    """TOML text for ``doc`` (tables as ``[a.b]``, lists of tables as ``[[a.b]]``)."""
    lines: list[str] = []
    _emit_table(lines, [], doc)
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# Mutations addressed by the same key paths the validator reports, e.g. "camera[1].x_axis"
# --------------------------------------------------------------------------------------------

Doc = dict[str, Any]
Mutation = Callable[[Doc], None]
_PATH_TOKEN = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


def _parent(doc: Doc, path: str) -> tuple[Any, str | int]:
    tokens: list[str | int] = [
        int(index) if index else name for name, index in _PATH_TOKEN.findall(path)
    ]
    *head, last = tokens
    node: Any = doc
    for t in head:
        node = node[t]
    return node, last


def put(path: str, value: Any) -> Mutation:
    """Set (or add) the value at ``path``."""

    def mutate(doc: Doc) -> None:
        parent, last = _parent(doc, path)
        parent[last] = copy.deepcopy(value)

    return mutate


def drop(path: str) -> Mutation:
    """Remove the key (or list item) at ``path``."""

    def mutate(doc: Doc) -> None:
        parent, last = _parent(doc, path)
        del parent[last]

    return mutate


def rename(path: str, new_key: str) -> Mutation:
    """Misspell the key at ``path`` as ``new_key``, keeping its value and position."""

    def mutate(doc: Doc) -> None:
        parent, last = _parent(doc, path)
        items = list(parent.items())
        assert last in parent, path
        parent.clear()
        parent.update((new_key if k == last else k, v) for k, v in items)

    return mutate


def append(path: str, value: Any) -> Mutation:
    """Append ``value`` to the list at ``path``."""

    def mutate(doc: Doc) -> None:
        parent, last = _parent(doc, path)
        parent[last].append(copy.deepcopy(value))

    return mutate


def both(*mutations: Mutation) -> Mutation:
    def mutate(doc: Doc) -> None:
        for m in mutations:
            m(doc)

    return mutate


def scale_vec(path: str, factor: float) -> Mutation:
    def mutate(doc: Doc) -> None:
        parent, last = _parent(doc, path)
        parent[last] = [x * factor for x in parent[last]]

    return mutate


def _cross(a: Sequence[float], b: Sequence[float]) -> list[float]:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _unit(a: Sequence[float]) -> list[float]:
    norm = math.hypot(*a)
    return [x / norm for x in a]


def _rotated(v: Sequence[float], degrees: float) -> list[float]:
    """Unit vector ``v`` turned by ``degrees`` about an axis perpendicular to it (and to z)."""
    k = _unit(_cross(v, (0.0, 0.0, 1.0)))
    t = math.radians(degrees)
    # k is perpendicular to v, so Rodrigues' formula reduces to v cos t + (k x v) sin t.
    kv = _cross(k, v)
    return _unit([a * math.cos(t) + b * math.sin(t) for a, b in zip(v, kv, strict=True)])


def rotate_laser(degrees: float) -> Mutation:
    def mutate(doc: Doc) -> None:
        doc["laser"]["direction"] = _rotated(doc["laser"]["direction"], degrees)

    return mutate


def mutated_text(mutate: Mutation) -> str:
    doc = good_doc()
    mutate(doc)
    text = dumps_toml(doc)
    assert text != dumps_toml(GOOD), "the mutation changed nothing"
    return text


# --------------------------------------------------------------------------------------------
# Assertions on messages and on the CLI
# --------------------------------------------------------------------------------------------

_AFTER_SOURCE = re.compile(r"(?: line (?P<line>\d+))?: (?P<detail>.+)")


def message_detail(message: str, source: str) -> tuple[int | None, str]:
    """Split ``rig SOURCE[ line N]: DETAIL`` into (N, DETAIL), checking it is one line."""
    assert "\n" not in message and "\r" not in message, f"message is not one line: {message!r}"
    prefix = f"rig {source}"
    assert message.startswith(prefix), f"message does not name the source: {message!r}"
    m = _AFTER_SOURCE.fullmatch(message[len(prefix) :])
    assert m, f"message is not 'rig SOURCE[ line N]: ...': {message!r}"
    return (int(m["line"]) if m["line"] else None), m["detail"]


def assert_names_key(message: str, source: str, key: str, says: Sequence[str]) -> None:
    """The message is one line, names ``key`` first (when given) and contains ``says``."""
    _, detail = message_detail(message, source)
    if key:
        assert detail.startswith(f"{key}: "), f"expected key {key!r} to be named: {message!r}"
    for text in says:
        assert text in detail, f"expected {text!r} in: {message!r}"


def run_rig_cli(*args: str, in_process: bool = False) -> subprocess.CompletedProcess[str]:
    """``thermrs rig ARGS…`` in a child process, or (``in_process``: for the tables of bad
    rigs, whose subject is the message) through the same entry point in this one."""
    if in_process:
        return cli_in_process("rig", *args)
    env = {k: v for k, v in os.environ.items() if k != "THERMRS_DEBUG"}
    return subprocess.run(
        [sys.executable, "-m", "thermrs", "rig", *args],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        check=False,
    )


def assert_cli_rejects(result: subprocess.CompletedProcess[str]) -> str:
    """Exit 2, one ``thermrs: error:`` line on stderr, no traceback; returns the message."""
    assert "Traceback" not in result.stderr, result.stderr
    assert result.returncode == 2, (result.returncode, result.stderr)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, f"expected one line on stderr, got: {result.stderr!r}"
    assert lines[0].startswith("thermrs: error: "), lines[0]
    assert result.stdout == "", result.stdout
    return lines[0].removeprefix("thermrs: error: ")


#: The laser turned by 3°: a valid file whose laser misses pose A's camera.
MISSES = rotate_laser(3.0)
