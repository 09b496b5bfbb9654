# The typed stub (python/tritrace.pyi) describes the module as built: the same public names, the
# same members of each class, the same parameters in the same order with the same defaults; and
# every public function and class has a docstring.
import ast
import pathlib
import re

import pytest

import tritrace

STUB = pathlib.Path(__file__).resolve().parents[2] / "python" / "tritrace.pyi"
TREE = ast.parse(STUB.read_text())


def public(names):
    return {n for n in names if not n.startswith("_")}


def stub_top_level():
    names = {}
    for node in TREE.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names[node.name] = node
        elif isinstance(node, ast.AnnAssign):
            names[node.target.id] = node
    return names


# Helper types that exist only in the stub.
STUB_ONLY = {"CameraInfo", "LightInfo", "SpotLightInfo", "DirectionalLightInfo", "FirstHits",
             "Intersections", "ClosestPoints"}


def test_stub_and_module_have_the_same_public_names():
    module_names = public(n for n in dir(tritrace) if not isinstance(getattr(tritrace, n),
                                                                      type(tritrace)))
    assert public(stub_top_level()) - STUB_ONLY == module_names


def runtime_parameters(function):
    """Parameter names and defaults from pybind11's signature line, e.g.
    'render(scene: tritrace.Scene, *, spp: object = None) -> tritrace.Frame'."""
    line = function.__doc__.splitlines()[0]
    inside = line[line.index("(") + 1:line.rindex(")", 0, line.index("->") if "->" in line
                                                   else len(line))]
    params = []
    for part in re.split(r",\s*(?![^()\[\]]*[)\]])", inside):
        part = part.strip()
        if not part:
            continue
        if part == "*":
            params.append(("*", None))
            continue
        name = part.split(":")[0].strip()
        if name == "self":
            continue
        default = part.split("=", 1)[1].strip() if "=" in part else None
        params.append((name, default))
    return params


def stub_parameters(node):
    args = node.args
    params = [(a.arg, None) for a in args.args]
    for i, d in enumerate(args.defaults):
        index = len(params) - len(args.defaults) + i
        params[index] = (params[index][0], ast.unparse(d))
    if args.kwonlyargs:
        params.append(("*", None))
        for a, d in zip(args.kwonlyargs, args.kw_defaults):
            params.append((a.arg, None if d is None else ast.unparse(d)))
    return [p for p in params if p[0] != "self"]


def same_default(runtime, stub):
    if runtime is None or stub is None:
        return runtime == stub
    normalise = {"inf": "float('inf')", "()": "()"}
    return normalise.get(runtime, runtime).replace('"', "'") == stub.replace('"', "'")


def check_signature(function, node):
    runtime = runtime_parameters(function)
    stub = stub_parameters(node)
    assert [n for n, _ in runtime] == [n for n, _ in stub], node.name
    for (name, a), (_, b) in zip(runtime, stub):
        assert same_default(a, b), f"{node.name}({name}): {a} vs {b}"


@pytest.mark.parametrize("name", ["load", "render", "denoise"])
def test_functions_have_the_stubs_parameters(name):
    check_signature(getattr(tritrace, name), stub_top_level()[name])


@pytest.mark.parametrize("name", ["Scene", "Accel", "Hits", "Frame", "QueryScene"])
def test_classes_have_the_stubs_members(name):
    node = stub_top_level()[name]
    cls = getattr(tritrace, name)
    members = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
    assert public(members) == public(vars(cls)) - {"__init__"} or \
        public(members) == public(vars(cls))
    for member_name, member in members.items():
        if member_name.startswith("_") and member_name != "__init__":
            continue
        if any(isinstance(d, ast.Name) and d.id == "property" for d in member.decorator_list):
            assert isinstance(vars(cls)[member_name], property), member_name
        else:
            check_signature(getattr(cls, member_name), member)


def test_everything_public_has_a_docstring():
    for name in public(dir(tritrace)):
        value = getattr(tritrace, name)
        if callable(value):
            assert value.__doc__ and len(value.__doc__) > 40, name
    for cls in (tritrace.Scene, tritrace.Accel, tritrace.Frame, tritrace.Hits,
                tritrace.QueryScene):
        assert len(cls.__doc__) > 40
        for name, value in vars(cls).items():
            if not name.startswith("_") and isinstance(value, property) and cls in (
                    tritrace.Scene, ):
                assert value.__doc__, f"{cls.__name__}.{name}"
