"""The type stubs and docstrings ship with the wheel and describe what the module has."""

import ast
import types
from pathlib import Path

import rigfit


def stub_tree():
    path = Path(rigfit.__file__).with_name("__init__.pyi")
    assert path.exists(), "the stubs are installed with the package"
    assert path.with_name("py.typed").exists(), "py.typed marks the package as typed"
    return ast.parse(path.read_text())


def test_the_stubs_cover_every_public_name_and_member():
    tree = stub_tree()
    stubbed = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            stubbed[node.name] = {
                n.name if isinstance(n, ast.FunctionDef) else n.target.id
                for n in node.body
                if isinstance(n, ast.FunctionDef) or (isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name))
            }
        elif isinstance(node, ast.FunctionDef):
            stubbed[node.name] = set()
    # Submodules (rigfit.cluster, once imported) have stubs of their own: their source.
    public = {n for n in dir(rigfit) if not n.startswith("_") and not isinstance(getattr(rigfit, n), types.ModuleType)}
    assert public - {"rigfit"} <= set(stubbed) | {"RigfitError"}, public - set(stubbed)
    for name, members in stubbed.items():
        obj = getattr(rigfit, name)
        assert obj.__doc__, f"{name} has a docstring"
        if isinstance(obj, type) and not issubclass(obj, Exception):
            actual = {m for m in dir(obj) if not m.startswith("_")}
            assert actual == members - {"__init__", "__len__"}, (name, actual ^ (members - {"__init__", "__len__"}))
