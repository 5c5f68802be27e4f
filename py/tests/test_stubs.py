"""The .pyi stubs match the extension: every public function, class,
method and property of each submodule is in its stub with the same
parameters, and the stub names nothing the module lacks (the CI drift check)."""

import ast
import inspect
from pathlib import Path

import pytest

import vpctl

MODULES = ["scene", "forest", "labelgen", "planner", "mission", "sim", "mvs"]
DUNDERS = {"__init__", "__new__", "__len__", "__getitem__", "__enter__", "__exit__"}
# Constructors: an extension class is built by __new__ (pyo3's #[new]), so
# its stub says __new__ (stubtest checks that too); its signature is the class's.
CONSTRUCTORS = ("__init__", "__new__")


def stub_tree(name):
    path = Path(vpctl.__file__).parent / f"{name}.pyi"
    return ast.parse(path.read_text())


def params(fn: ast.FunctionDef):
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
    return [n for n in names if n not in ("self", "cls")]


def runtime_params(obj):
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return None
    return [p.name for p in sig.parameters.values()
            if p.name not in ("self", "cls") and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)]


def stub_params(fn):
    names = params(fn)
    return [n for n in names]


@pytest.mark.parametrize("name", MODULES)
def test_stub_matches_module(name):
    mod = getattr(vpctl, name)
    tree = stub_tree(name)
    funcs = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
    public = {n for n in dir(mod) if not n.startswith("_")}
    assert public == set(funcs) | set(classes), f"{name}: module vs stub"
    for fname, node in funcs.items():
        got = runtime_params(getattr(mod, fname))
        if got is not None:
            assert got == stub_params(node), f"{name}.{fname}"
    for cname, node in classes.items():
        cls = getattr(mod, cname)
        members = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
        runtime = {n for n in dir(cls) if not n.startswith("_")}
        stubbed = {n for n in members if not n.startswith("_")}
        assert runtime == stubbed, f"{name}.{cname}: class vs stub"
        for dunder in set(members) & DUNDERS:
            assert hasattr(cls, dunder), f"{name}.{cname}.{dunder}"
        for mname, m in members.items():
            if any(isinstance(d, ast.Name) and d.id == "property" for d in m.decorator_list):
                assert isinstance(inspect.getattr_static(cls, mname), (property, type(vpctl.scene.Mesh.n_faces))), mname
                continue
            target = cls if mname in CONSTRUCTORS else getattr(cls, mname)
            got = runtime_params(target)
            if got is not None:
                assert got == stub_params(m), f"{name}.{cname}.{mname}"


@pytest.mark.parametrize("name", MODULES)
def test_runtime_signatures_show_real_defaults(name):
    """help() showed `x=Ellipsis` where a default was meant (issue 18)."""
    mod = getattr(vpctl, name)
    for fname in (n for n in dir(mod) if not n.startswith("_")):
        obj = getattr(mod, fname)
        targets = [(fname, obj)]
        if inspect.isclass(obj):
            targets += [(f"{fname}.{m}", getattr(obj, m)) for m in dir(obj)
                        if not m.startswith("_") and callable(getattr(obj, m))]
        for label, t in targets:
            try:
                sig = inspect.signature(t)
            except (TypeError, ValueError):
                continue
            bad = [p.name for p in sig.parameters.values() if p.default is Ellipsis]
            assert not bad, f"{name}.{label}: {bad} default to Ellipsis"
