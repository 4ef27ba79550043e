"""The docstring standard (numpydoc), checked on every public function of the package.

Like python-control's docstring test: a public function or method (no leading underscore, in a
public module and, for a method, a public class) with three or more parameters (``self`` and
``cls`` aside; ``*args`` and ``**kwargs`` count) documents them in numpydoc form:

- a ``Parameters`` section (the word, then a line of dashes) that names every parameter in an
  entry ``name : type`` (several names may share an entry: ``a, b : float``; star parameters as
  ``*args``, ``**kwargs``);
- a ``Returns`` (or ``Yields``) section, unless the function is annotated ``-> None``.

A command's function documented in the API (its docstring says it is "the command behind
:func:`rsp_inertia.api.NAME`, documented there": one home per public docstring) instead has
every parameter documented by that API function's Parameters section, whatever their number.

The sources are read with ast from the installed package's modules (tests/test_architecture.py
finds them), so no module is imported but the packages' light ``__init__``.
"""

from __future__ import annotations

import ast
import re

import pytest

from tests.test_architecture import MODULES

MIN_PARAMETERS = 3

HOME = re.compile(r"command behind :func:`rsp_inertia\.api\.(\w+)`, documented there")
"""How a command's function names the API function that documents it."""


def _sections(doc: str) -> dict[str, list[str]]:
    """The numpydoc sections of ``doc``: title -> its lines."""
    lines = doc.splitlines()
    sections: dict[str, list[str]] = {}
    current = None
    for k, line in enumerate(lines):
        following = lines[k + 1].strip() if k + 1 < len(lines) else ""
        if line.strip() and following and set(following) == {"-"} and len(following) >= 3:
            current = line.strip()
            sections[current] = []
        elif current is not None and not (line.strip() and set(line.strip()) == {"-"}):
            sections[current].append(line)
    return sections


def _documented(lines: list[str]) -> set[str]:
    """The parameter names of a Parameters section's entries (``name : type`` lines at the
    section's own indentation; a bare ``name`` line counts too)."""
    indent = min((len(s) - len(s.lstrip()) for s in lines if s.strip()), default=0)
    names: set[str] = set()
    for line in lines:
        if not line.strip() or len(line) - len(line.lstrip()) != indent:
            continue
        head = line.strip().split(" : ")[0].rstrip(":").strip()
        names |= {name.strip() for name in head.split(",")}
    return names


def _parameters(node: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    a = node.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
    if a.vararg:
        names.append("*" + a.vararg.arg)
    if a.kwarg:
        names.append("**" + a.kwarg.arg)
    return [n for n in names if n not in ("self", "cls")]


def _returns_none(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    r = node.returns
    return r is not None and (
        (isinstance(r, ast.Constant) and r.value is None) or ast.unparse(r) == "None"
    )


def _api_parameters() -> dict[str, set[str]]:
    """The parameters each public function of rsp_inertia.api documents."""
    tree = ast.parse(MODULES["rsp_inertia.api"].read_text())
    return {
        node.name: _documented(_sections(ast.get_docstring(node) or "").get("Parameters", []))
        for node in tree.body
        if isinstance(node, ast.FunctionDef) and _public(node.name)
    }


def _home_faults(names: list[str], home: str, qualname: str) -> list[str]:
    """The faults of a function documented at rsp_inertia.api.``home``: its parameters that
    the home does not document."""
    documented = _api_parameters().get(home)
    if documented is None:
        return [f"{qualname}: its home rsp_inertia.api.{home} is no public API function"]
    missing = [n for n in names if n.lstrip("*") not in documented]
    return [f"{qualname}: rsp_inertia.api.{home} does not document {missing}"] if missing else []


def _faults(node, qualname: str) -> list[str]:
    names = _parameters(node)
    doc = ast.get_docstring(node) or ""
    home = HOME.search(" ".join(doc.split()))
    if home:
        return _home_faults(names, home.group(1), qualname)
    if len(names) < MIN_PARAMETERS:
        return []
    sections = _sections(doc)
    faults = []
    if "Parameters" not in sections:
        faults.append(f"{qualname}: no Parameters section")
    else:
        documented = _documented(sections["Parameters"])
        missing = [n for n in names if n not in documented and n.lstrip("*") not in documented]
        if missing:
            faults.append(f"{qualname}: Parameters lacks {missing}")
    if not _returns_none(node) and not ({"Returns", "Yields"} & set(sections)):
        faults.append(f"{qualname}: no Returns section")
    return faults


def _public(name: str) -> bool:
    return not name.startswith("_")


def module_faults(name: str) -> list[str]:
    """Every fault of the standard in module ``name`` (empty for a private module)."""
    if not all(_public(part) for part in name.split(".")):
        return []
    tree = ast.parse(MODULES[name].read_text())
    faults = []
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _public(node.name):
            faults += _faults(node, node.name)
        elif isinstance(node, ast.ClassDef) and _public(node.name):
            for item in node.body:
                is_property = any(
                    ast.unparse(d).endswith(("property", "setter")) for d in item.decorator_list
                ) if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) else True
                if not is_property and _public(item.name):
                    faults += _faults(item, f"{node.name}.{item.name}")
    return faults


@pytest.mark.parametrize("name", sorted(MODULES))
def test_public_functions_document_their_parameters(name: str) -> None:
    assert module_faults(name) == []


def _function(source: str) -> ast.FunctionDef:
    return ast.parse(source).body[0]


def test_the_standard_can_fail() -> None:
    """A prose docstring, a section that forgets a parameter, a missing Returns: each found;
    a complete numpydoc docstring passes, and so does a function of two parameters."""
    prose = _function('def f(a, b, c):\n    """Adds a to b and c."""\n    return a\n')
    assert _faults(prose, "f") == ["f: no Parameters section", "f: no Returns section"]
    partial = _function(
        'def f(a, b, *rest, **options) -> None:\n    """Do.\n\n    Parameters\n    ----------\n'
        '    a, b : float\n        Two.\n    *rest : float\n        More.\n    """\n'
    )
    assert _faults(partial, "f") == ["f: Parameters lacks ['**options']"]
    full = _function(
        'def f(self, a, b, c):\n    """Do.\n\n    Parameters\n    ----------\n    a : int\n'
        '        One.\n    b, c : float\n        Two (N m: ``x : y`` inside prose is no entry).\n\n'
        '    Returns\n    -------\n    float\n        The sum.\n    """\n'
    )
    assert _faults(full, "f") == []
    assert _faults(_function("def f(a, b):\n    pass\n"), "f") == []


def test_a_command_documented_in_the_api_is_checked_there() -> None:
    """A command's function whose docstring points to its API function passes when that
    function documents each of its parameters, and fails on one it does not."""
    pointer = '"""The command behind :func:`rsp_inertia.api.{}`, documented there."""'
    calibrate = _function(
        f"def calibrate(path, empty, reference, progress):\n    {pointer.format('calibrate')}\n"
    )
    assert _faults(calibrate, "calibrate") == []
    wrong = _function(f"def identify(path, stage):\n    {pointer.format('identify')}\n")
    assert _faults(wrong, "identify") == [
        "identify: rsp_inertia.api.identify does not document ['stage']"
    ]
    nowhere = _function(f"def f(path):\n    {pointer.format('nowhere')}\n")
    assert _faults(nowhere, "f") == [
        "f: its home rsp_inertia.api.nowhere is no public API function"
    ]
