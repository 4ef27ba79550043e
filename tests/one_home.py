"""The check both one-home test modules make: a consumer module imports a formula's home
function itself (no copy of its own) and calls it."""

from __future__ import annotations

import ast
import importlib
import inspect


def _module(name: str):
    return importlib.import_module(f"rsp_inertia.{name}")


def _called(module, name: str) -> bool:
    """Whether ``module``'s source calls ``name`` (as a bare name)."""
    tree = ast.parse(inspect.getsource(module))
    return any(
        isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == name
        for node in ast.walk(tree)
    )


def home_cases(homes: list[tuple]) -> list[tuple[str, str, str]]:
    """(home module, function, consumer module) for every consumer of a table of
    (formula, home module, function, consumer modules)."""
    return [(home, name, c) for _, home, name, consumers in homes for c in consumers]


def assert_calls_home(home: str, name: str, consumer: str) -> None:
    """``rsp_inertia.<consumer>`` uses ``rsp_inertia.<home>.<name>`` and calls it."""
    function = getattr(_module(home), name)
    used = _module(consumer)
    assert getattr(used, name, None) is function, f"{consumer} has its own {name}"
    assert _called(used, name), f"{consumer} does not call {name}"
