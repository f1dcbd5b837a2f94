"""The report renders and computes nothing (issue #46): read from its source with :mod:`ast`,
no module of :mod:`thermrs.report` imports, at module level or inside a function, a module
that fits, predicts, diagnoses, designs, compensates, simulates or reads recordings into runs;
and importing every one of them loads none of those modules, as the interpreter itself reports
(``sys.modules`` in a fresh process). Imports for type checkers only (``if TYPE_CHECKING:``)
are not run and are not counted."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import thermrs

REPORT = Path(thermrs.__file__).parent / "report"

#: Modules that compute: a report module may import none of them (nor what lies inside them).
COMPUTING = (
    "thermrs.analyses",
    "thermrs.campaigns",
    "thermrs.compensate",
    "thermrs.design",
    "thermrs.diagnose",
    "thermrs.fit",
    "thermrs.heating",
    "thermrs.iso9283",
    "thermrs.predict",
    "thermrs.runs",
    "thermrs.runtable",
    "thermrs.simulate",
    "thermrs.stats",
    "thermrs.visits",
)

#: What a report module may still take from a computing module, and why: formatting and
#: constants, no computation.
ALLOWED = {
    # The regressions' table cells and sentence, written once for the CLI and the report.
    ("thermrs.report.sections.baselines", "thermrs.diagnose.baselines"): {"said", "row_cells"},
}


def _computing(module: str) -> bool:
    return any(module == c or module.startswith(c + ".") for c in COMPUTING)


def _typing_only(tree: ast.Module) -> set[int]:
    """The ids of the import nodes under ``if TYPE_CHECKING:``."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            out |= {id(n) for b in node.body for n in ast.walk(b)}
    return out


def _imports() -> dict[str, list[tuple[str, set[str]]]]:
    """Every report module → the thermrs modules it imports at run time, with the names."""
    graph: dict[str, list[tuple[str, set[str]]]] = {}
    for f in sorted(REPORT.rglob("*.py")):
        parts = f.relative_to(REPORT.parent.parent).with_suffix("").parts
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        tree = ast.parse(f.read_text(), str(f))
        skip = _typing_only(tree)
        got: list[tuple[str, set[str]]] = []
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            if isinstance(node, ast.Import):
                got += [(a.name, set()) for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = {a.name for a in node.names}
                if node.module == "thermrs":
                    got += [(f"thermrs.{n}", set()) for n in names]
                else:
                    got.append((node.module, names))
        graph[module] = got
    return graph


def test_the_reading_sees_the_imports_it_should() -> None:
    """The reader against imports known to be there, and one known to be typing only."""
    graph = _imports()
    assert ("thermrs.report.document", {"compose"}) in graph["thermrs.report"]
    assert ("thermrs.report.figures", {"fig_iso"}) in graph["thermrs.report.sections.iso"]
    # ``report/data.py`` names the diagnosis' type for type checkers only.
    assert not any(m.startswith("thermrs.diagnose") for m, _ in graph["thermrs.report.data"])
    assert "thermrs.diagnose.result" in (REPORT / "data.py").read_text()


def test_no_report_module_imports_what_computes() -> None:
    found = sorted(
        (module, target, sorted(names - ALLOWED.get((module, target), set())))
        for module, imports in _imports().items()
        for target, names in imports
        if _computing(target) and not (names and names <= ALLOWED.get((module, target), set()))
    )
    assert found == [], f"report modules that import what computes: {found}"


def test_importing_the_report_loads_nothing_that_computes() -> None:
    modules = sorted(_imports())
    code = (
        "import sys, importlib\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
        "print(' '.join(sorted(sys.modules)))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    names = set(p.stdout.split())
    assert "thermrs.report.sections.diagnosis" in names  # the reading is the interpreter's
    assert sorted(n for n in names if _computing(n)) == []
