"""The package's layers, read from its source with :mod:`ast` (issue #46): counting every import
(at module level, inside functions and under ``TYPE_CHECKING``), its subpackages and top-level
modules import one another without a loop, none imports the package's face
(``thermrs/__init__.py``, which names them all for type checkers), the CLI is imported by none,
and :mod:`thermrs.campaigns` imports nothing of :mod:`thermrs.analyses`, which stands above it.

What ``importlib.import_module`` loads by a computed name is not read: the names that moved from
:mod:`thermrs.campaigns` to :mod:`thermrs.analyses` are handed on that way until 0.2.0
(``tests/campaigns/test_moved_names.py``)."""

from __future__ import annotations

import ast
import graphlib
from collections import defaultdict
from pathlib import Path

import thermrs

PACKAGE = Path(thermrs.__file__).parent


def _room(module: str) -> str:
    """A module's room: its subpackage (``diagnose``), a top-level module (``fit``), or the
    face (``thermrs``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "thermrs"


def _imports() -> dict[str, set[str]]:
    """Every module of the package → the thermrs modules it imports."""
    graph: dict[str, set[str]] = defaultdict(set)
    for f in sorted(PACKAGE.rglob("*.py")):
        parts = f.relative_to(PACKAGE.parent).with_suffix("").parts
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.walk(ast.parse(f.read_text(), str(f))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                # ``from thermrs import fit`` imports the module thermrs.fit.
                names = (
                    [f"thermrs.{a.name}" for a in node.names]
                    if node.module == "thermrs"
                    else [node.module]
                )
            else:
                continue
            graph[module] |= {n for n in names if n == "thermrs" or n.startswith("thermrs.")}
    return graph


def _rooms(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    rooms: dict[str, set[str]] = defaultdict(set)
    for a, targets in graph.items():
        rooms[_room(a)] |= {_room(b) for b in targets if _room(b) != _room(a)}
    return rooms


def test_the_reading_sees_the_imports_it_should() -> None:
    """The reader against imports known to be there: deferred, typing-only and at module
    level."""
    graph = _imports()
    assert "thermrs.report" in graph["thermrs.analyses.report"]  # inside a function
    assert "thermrs.rig" in graph["thermrs.cli.common"]  # under TYPE_CHECKING
    assert "thermrs._native" in graph["thermrs.signatures"]  # at module level
    assert {"diagnose", "design", "report", "campaigns"} <= _rooms(graph)["thermrs"]


def test_the_rooms_import_one_another_without_a_loop() -> None:
    rooms = _rooms(_imports())
    order = list(graphlib.TopologicalSorter(rooms).static_order())  # raises CycleError
    assert order.index("campaigns") < order.index("analyses") < order.index("cli")


def test_no_module_imports_the_face_or_the_cli_from_below() -> None:
    graph = _imports()
    face = sorted(a for a, targets in graph.items() if "thermrs" in targets)
    assert face == [], f"import the package's face: {face}"
    cli = sorted(
        a
        for a, targets in graph.items()
        if _room(a) not in ("cli", "__main__") and any(_room(b) == "cli" for b in targets)
    )
    assert cli == [], f"import the CLI: {cli}"


def test_campaigns_import_nothing_of_the_analyses() -> None:
    graph = _imports()
    up = sorted(
        (a, b)
        for a, targets in graph.items()
        if _room(a) == "campaigns"
        for b in targets
        if _room(b) == "analyses"
    )
    assert up == []
