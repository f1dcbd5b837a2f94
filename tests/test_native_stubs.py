"""``python/thermrs/_native.pyi`` describes the compiled module as it is: the same names,
classes with the same methods, functions with the same parameters (names, kinds, defaults).
mypy trusts the stub; this checks the stub against the truth, the extension itself."""

from __future__ import annotations

import ast
import builtins
import inspect
from pathlib import Path
from typing import Any

import pytest
import thermrs
from thermrs import _native

STUB = Path(thermrs.__file__).with_name("_native.pyi")
#: Type aliases the stub defines for itself (not in the module).
ALIASES = {"Progress"}


def _stub() -> ast.Module:
    return ast.parse(STUB.read_text())


def _params(fn: ast.FunctionDef) -> list[tuple[str, str, str | None]]:
    """(name, kind, default as source) of a stub function, `self` dropped."""
    a = fn.args
    out: list[tuple[str, str, str | None]] = []
    pos = a.posonlyargs + a.args
    defaults: list[ast.expr | None] = [None] * (len(pos) - len(a.defaults)) + list(a.defaults)
    for p, d in zip(pos, defaults, strict=True):
        kind = "POSITIONAL_ONLY" if p in a.posonlyargs else "POSITIONAL_OR_KEYWORD"
        out.append((p.arg, kind, None if d is None else ast.unparse(d)))
    for p, kd in zip(a.kwonlyargs, a.kw_defaults, strict=True):
        out.append((p.arg, "KEYWORD_ONLY", None if kd is None else ast.unparse(kd)))
    return [p for p in out if p[0] not in ("self", "cls")]


def _actual(obj: Any) -> list[tuple[str, str, str | None]] | None:
    """The same for a compiled function, from its text signature (None where it has none)."""
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return None
    return [
        (
            p.name,
            p.kind.name,
            None if p.default is inspect.Parameter.empty else repr(p.default),
        )
        for p in sig.parameters.values()
        if p.name not in ("self", "cls", "$self", "$cls")
    ]


def test_the_stub_and_the_module_have_the_same_names() -> None:
    stub = set()
    for node in _stub().body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            stub.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            stub.add(node.target.id)
        elif isinstance(node, ast.Assign):
            stub.update(t.id for t in node.targets if isinstance(t, ast.Name))
    stub -= ALIASES
    actual = {n for n in dir(_native) if not (n.startswith("__") and n != "__version__")}
    assert stub == actual, {"stub only": stub - actual, "module only": actual - stub}


def test_classes_have_the_stubs_methods_and_bases() -> None:
    for node in _stub().body:
        if not isinstance(node, ast.ClassDef):
            continue
        cls = getattr(_native, node.name)
        for base in node.bases:
            want = getattr(_native, ast.unparse(base), None) or getattr(builtins, ast.unparse(base))
            assert issubclass(cls, want), (node.name, ast.unparse(base))
        stub_methods = {f.name for f in node.body if isinstance(f, ast.FunctionDef)}
        stub_methods.discard("__init__")
        public = {n for n in vars(cls) if not n.startswith("_")}
        assert stub_methods == public, (node.name, stub_methods ^ public)


def _functions() -> list[tuple[str, ast.FunctionDef, Any]]:
    out = []
    for node in _stub().body:
        if isinstance(node, ast.FunctionDef):
            out.append((node.name, node, getattr(_native, node.name)))
        elif isinstance(node, ast.ClassDef):
            cls = getattr(_native, node.name)
            for f in node.body:
                if isinstance(f, ast.FunctionDef):
                    target = cls if f.name == "__init__" else getattr(cls, f.name)
                    out.append((f"{node.name}.{f.name}", f, target))
    return out


@pytest.mark.parametrize(("name", "fn", "obj"), _functions(), ids=[n for n, _, _ in _functions()])
def test_parameters_match(name: str, fn: ast.FunctionDef, obj: Any) -> None:
    actual = _actual(obj)
    if actual is None:
        pytest.skip(f"{name}: the extension gives no signature")
    assert _params(fn) == actual, name
