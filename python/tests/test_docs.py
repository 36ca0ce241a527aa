"""Every public name has a docstring and a stub; help() reads like numpy's."""

import ast
import inspect
import pydoc
from pathlib import Path

import isoc


def test_public_names_are_documented_and_stubbed():
    stub = Path(isoc.__file__).with_name("__init__.pyi")
    tree = ast.parse(stub.read_text())
    stubbed = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            stubbed.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            stubbed.add(node.target.id)
    assert set(isoc.__all__) <= stubbed, set(isoc.__all__) - stubbed
    assert Path(isoc.__file__).with_name("py.typed").exists()
    for name in isoc.__all__:
        obj = getattr(isoc, name)
        if isinstance(obj, isoc.Expr):
            continue
        assert inspect.getdoc(obj), name
    for cls in (isoc.Surface, isoc.Mesh):
        for name, member in vars(cls).items():
            if not name.startswith("_") and callable(member):
                assert inspect.getdoc(member), f"{cls.__name__}.{name}"


def test_help_of_mesh_reads_like_numpy_docs():
    text = pydoc.render_doc(isoc.Surface.mesh, renderer=pydoc.plaintext)
    for heading in ("Parameters", "Returns", "Raises", "Examples"):
        assert f"{heading}\n" in text and "-" * len(heading) in text
    assert "level : int, optional" in text and "tolerance : float, optional" in text
