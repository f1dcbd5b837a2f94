"""ARCHITECTURE.md against the code (issue #46): its file lists are the files there are (the
Python package room by room, the Rust core's table, the bindings), in the floors it gives
them; every file it names exists; the sizes it states are the ones measured (lines of the
package's files, functions over 100 lines with :mod:`ast`)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from tests.test_layers import _imports

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "python" / "thermrs"
CORE = REPO / "rust" / "thermrs-core" / "src"
BINDINGS = REPO / "rust" / "thermrs-py" / "src"
TEXT = (REPO / "ARCHITECTURE.md").read_text()

#: A file or folder named in backticks: ``fit.py``, ``cdr/``, ``report/data.py``.
FILE = re.compile(r"`([\w./-]+(?:\.py|\.pyi|\.rs|/))`")


def _section(title: str) -> str:
    start = TEXT.index(f"## {title}")
    end = TEXT.find("\n## ", start + 1)
    return TEXT[start : end if end >= 0 else None]


def _rows(section: str) -> list[tuple[str, str]]:
    """A Markdown table's rows as (first cell, the rest), header and rule left out."""
    rows = []
    for line in section.splitlines():
        if line.startswith("| ") and not line.startswith(("| ---", "| room", "| file")):
            first, rest = line[2:].split(" | ", 1)
            rows.append((first.strip(), rest))
    return rows


def _entries(folder: Path) -> set[str]:
    """What a folder holds as this page names it: Python and Rust files, and folders (with a
    slash), ``__init__.py``, ``lib.rs`` and caches left out."""
    return {
        p.name + "/" if p.is_dir() else p.name
        for p in folder.iterdir()
        if p.name not in ("__init__.py", "lib.rs", "__pycache__")
        and (p.is_dir() or p.suffix in (".py", ".pyi", ".rs"))
    }


def _python_rooms() -> list[tuple[str, list[str]]]:
    return [(room, FILE.findall(files)) for room, files in _rows(_section("The Python package"))]


def test_the_python_package_room_by_room_is_its_files() -> None:
    rooms = _python_rooms()
    assert [r for r, _ in rooms][-1] == "top level"
    named = {r.strip("`") for r, _ in rooms if r != "top level"}
    assert named | {"data/"} == {e for e in _entries(PACKAGE) if e.endswith("/")}
    for room, files in rooms:
        if room == "top level":
            there = _entries(PACKAGE) - named
        else:
            there = _entries(PACKAGE / room.strip("`"))
        listed = set(files) - {"__init__.py"}
        assert len(files) == len(set(files)), room
        assert listed == there, (room, listed ^ there)


def test_the_python_rooms_stand_in_the_floors_the_page_gives() -> None:
    """Rows from the top floor down, the top-level modules each a floor of its own: nothing
    imports what stands above it, but the face."""
    order: list[str] = []
    for room, files in _python_rooms():
        if room == "top level":
            order += [f"thermrs.{f.removesuffix('.py')}" for f in files if f.endswith(".py")]
        else:
            order.append(f"thermrs.{room.strip('`/')}")

    def floor(module: str) -> int:
        hits = [i for i, r in enumerate(order) if module == r or module.startswith(r + ".")]
        return hits[-1] if hits else len(order)  # thermrs._native: below every room

    up = sorted(
        (a, b)
        for a, targets in _imports().items()
        if a != "thermrs" and a != "thermrs.__main__"
        for b in targets
        if floor(b) < floor(a)
    )
    assert up == []


def test_the_rust_core_table_is_its_files() -> None:
    rows = _rows(_section("Rust core"))
    first = {f for cell, _ in rows for f in FILE.findall(cell)}
    assert first == _entries(CORE)
    for cell, rest in rows:
        for folder in [f for f in FILE.findall(cell) if f.endswith("/")]:
            for name in FILE.findall(rest):
                if not name.endswith("/"):  # in the folder, or the row's file beside it
                    assert (CORE / folder / name).is_file() or name in first, (folder, name)


def test_the_bindings_named_are_the_bindings() -> None:
    start = TEXT.index("Bindings (`rust/thermrs-py/src`)")
    text = TEXT[start : TEXT.index("`python/thermrs/_native.pyi`", start)]
    assert set(FILE.findall(text)) == _entries(BINDINGS) | {"lib.rs"}


def test_every_file_the_page_names_exists() -> None:
    tree = {
        p.relative_to(REPO).as_posix() + ("/" if p.is_dir() else "")
        for p in REPO.rglob("*")
        if not ({".git", "target", ".venv", "__pycache__"} & set(p.relative_to(REPO).parts))
    }
    # The page writes `core/` for the Rust core's sources.
    names = {re.sub(r"^core/", "rust/thermrs-core/src/", n) for n in FILE.findall(TEXT)}
    missing = [
        name for name in sorted(names) if not any(t == name or t.endswith("/" + name) for t in tree)
    ]
    assert missing == []


def _long_functions() -> dict[tuple[str, str], int]:
    found = {}
    for f in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                assert node.end_lineno is not None
                n = node.end_lineno - node.lineno + 1
                if n > 100:
                    found[(f.relative_to(PACKAGE).as_posix(), node.name)] = n
    return found


def test_the_sizes_stated_are_the_code_s() -> None:
    text = " ".join(_section("Sizes").split())
    limit = int(re.search(r"No file of `python/thermrs` is over (\d+) lines", text)[1])  # type: ignore[index]
    longest = max(len(f.read_text().splitlines()) for f in PACKAGE.rglob("*.py"))
    assert longest <= limit
    stated = {
        (path, name): int(n)
        for path, name, n in re.findall(r"`([\w/]+\.py)` `(\w+)` \((\d+)\)", text)
    }
    assert stated == _long_functions()


@pytest.mark.parametrize("claim", ["`tests/test_layers.py`", "`tests/test_architecture.py`"])
def test_the_checks_the_page_cites_exist(claim: str) -> None:
    assert claim in TEXT and (REPO / claim.strip("`")).is_file()
