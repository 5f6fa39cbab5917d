"""Every public name is typed: each function of `gweave.__all__` is annotated in
`gweave/__init__.py` itself (the package ships `py.typed`, so the source is its own stub: no
`__init__.pyi` to keep in step), and `gweave/_gweave.pyi` has each function of the compiled
module with the parameters the function has (names, kinds, which have defaults)."""

import ast
import inspect
from pathlib import Path
from typing import Dict, List, Tuple

import pytest

import gweave
from gweave import _gweave

PACKAGE = Path(gweave.__file__).parent


def stub(name: str) -> Dict[str, ast.AST]:
    tree = ast.parse((PACKAGE / name).read_text(encoding="utf-8"))
    names: Dict[str, ast.AST] = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names[node.name] = node
        elif isinstance(node, ast.ImportFrom):
            for alias in node.names:
                names[alias.asname or alias.name] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names[node.target.id] = node
    return names


def stub_params(node: ast.FunctionDef) -> List[Tuple[str, str, bool]]:
    a = node.args
    out = []
    positional = a.posonlyargs + a.args
    first_default = len(positional) - len(a.defaults)
    for i, p in enumerate(positional):
        kind = "POSITIONAL_ONLY" if p in a.posonlyargs else "POSITIONAL_OR_KEYWORD"
        out.append((p.arg, kind, i >= first_default))
    for p, d in zip(a.kwonlyargs, a.kw_defaults):
        out.append((p.arg, "KEYWORD_ONLY", d is not None))
    if a.kwarg is not None:
        out.append((a.kwarg.arg, "VAR_KEYWORD", False))
    return out


def runtime_params(f: object) -> List[Tuple[str, str, bool]]:
    sig = inspect.signature(f)  # type: ignore[arg-type]
    return [(p.name, p.kind.name, p.default is not inspect.Parameter.empty) for p in sig.parameters.values()]


def test_every_public_function_is_typed_in_its_source() -> None:
    source = stub("__init__.py")
    assert not (PACKAGE / "__init__.pyi").exists(), "a stub beside the typed source would shadow it"
    for name in gweave.__all__:
        assert name in source, f"gweave.{name} is not defined or imported in __init__.py"
        value = getattr(gweave, name)
        if inspect.isfunction(value):
            node = source[name]
            assert isinstance(node, ast.FunctionDef), name
            assert node.returns is not None, f"gweave.{name}: no return type"
            a = node.args
            for arg in a.posonlyargs + a.args + a.kwonlyargs:
                assert arg.annotation is not None, f"gweave.{name}({arg.arg}): no type"


def test_every_compiled_function_has_a_stub_with_the_same_parameters() -> None:
    stubs = stub("_gweave.pyi")
    for name, value in vars(_gweave).items():
        if name.startswith("_") or not callable(value) or inspect.isclass(value):
            continue
        assert name in stubs, f"_gweave.{name} has no stub in _gweave.pyi"
        node = stubs[name]
        assert isinstance(node, ast.FunctionDef), name
        assert stub_params(node) == runtime_params(value), f"_gweave.{name}: the stub's parameters differ"


@pytest.mark.parametrize("cls", ["Line", "Reader", "Machine", "HelicalPath"])
def test_classes_are_in_the_compiled_stub(cls: str) -> None:
    assert isinstance(stub("_gweave.pyi").get(cls), ast.ClassDef)
