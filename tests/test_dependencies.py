"""Each part declares what it imports (pyproject.toml): the installed package its run-time
dependencies, tests/ and benchmarks/ their extras.

The third-party imports of each part are read from its sources (ast, nothing imported; a
``pytest.importorskip`` counts as an import), mapped to their distributions, and checked
against the declarations:

- the installed package (the walk of tests/test_architecture.py) imports only its
  ``dependencies``, and imports every one of them: nothing is installed for another part;
- tests/ imports only those and the ``test`` extra, and uses all of the extra;
- benchmarks/ imports only the package's and the ``benchmarks`` and ``cluster`` extras, and
  uses all of them;
- an extra does not restate a run-time dependency;
- ``make`` installs the extras the test suite needs: tests/test_bench.py runs the benchmarks.
"""

from __future__ import annotations

import ast
import functools
import re
import sys
import tomllib
from importlib import metadata
from pathlib import Path

from tests.test_architecture import MODULES

ROOT = Path(__file__).resolve().parent.parent

FIRST_PARTY = {"rsp_inertia", "tests", "benchmarks"}

PARTS = {
    "runtime": ("runtime",),
    "tests": ("runtime", "test"),
    "benchmarks": ("runtime", "benchmarks", "cluster"),
}
"""Each part and the groups of pyproject.toml whose distributions it may import."""

USERS = {"runtime": "runtime", "test": "tests", "benchmarks": "benchmarks", "cluster": "benchmarks"}
"""Each group and the part that must import every one of its distributions."""


def _name(requirement: str) -> str:
    """A distribution's normalised name (PEP 503) from a requirement or a distribution name."""
    match = re.match(r"[A-Za-z0-9._-]+", requirement)
    assert match is not None, requirement
    return re.sub(r"[-_.]+", "-", match.group()).lower()


def _declared() -> dict[str, set[str]]:
    """pyproject.toml's groups: 'runtime' (``dependencies``) and each extra."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    groups = {"runtime": {_name(r) for r in project["dependencies"]}}
    for extra, requirements in project["optional-dependencies"].items():
        groups[extra] = {_name(r) for r in requirements}
    return groups


def _top_modules(path: Path) -> set[str]:
    """The top-level names of the modules ``path`` imports, anywhere in it."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            found.add(node.module.split(".")[0])
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", "") == "importorskip"
            and node.args
            and isinstance(node.args[0], ast.Constant)
        ):
            found.add(node.args[0].value.split(".")[0])
    return found


def _requirements(distribution: str) -> set[str]:
    """The normalised names of the distributions ``distribution`` requires (extras' too)."""
    return {_name(r) for r in metadata.requires(distribution) or ()}


def _top_owners(owners: list[str]) -> set[str]:
    """Of the distributions that provide one module, those no other of them requires: a
    package split over several distributions (mujoco 4: mujoco requires mujoco-core and
    mujoco-studio, all three install ``mujoco``) is declared by its top one."""
    names = {_name(owner) for owner in owners}
    required = set().union(*(_requirements(owner) for owner in owners)) & names
    return names - required or names


def _distributions(paths) -> set[str]:
    """The distributions of the third-party modules that ``paths`` import."""
    owners = metadata.packages_distributions()
    found = set()
    for path in paths:
        for module in _top_modules(path) - FIRST_PARTY - set(sys.stdlib_module_names):
            if module == "__future__":
                continue
            assert module in owners, f"{path}: imports {module}, which no distribution provides"
            found |= _top_owners(owners[module])
    return found


@functools.cache
def imported() -> dict[str, set[str]]:
    """The distributions each part imports (scanned once for the tests of this module; callers
    do not change it)."""
    return {
        "runtime": _distributions(MODULES.values()),
        "tests": _distributions(sorted((ROOT / "tests").rglob("*.py"))),
        "benchmarks": _distributions(sorted((ROOT / "benchmarks").rglob("*.py"))),
    }


def faults(imports: dict[str, set[str]], declared: dict[str, set[str]]) -> list[str]:
    """What is wrong with ``declared`` (group -> distributions) for ``imports`` (part ->
    distributions it imports): one line per fault; none when each part declares exactly
    what it imports."""
    found = []
    for part, groups in PARTS.items():
        allowed = set().union(*(declared.get(group, set()) for group in groups))
        for name in sorted(imports[part] - allowed):
            found.append(f"{part} imports {name}, not in {' or '.join(groups)}")
    for group, names in declared.items():
        user = USERS.get(group)
        if user is None:
            found.append(f"the extra {group!r} has no part that uses it")
            continue
        for name in sorted(names - imports[user]):
            found.append(f"{group} declares {name}, which {user} does not import")
        if group != "runtime":
            for name in sorted(names & declared["runtime"]):
                found.append(f"{group} restates the run-time dependency {name}")
    return found


def test_each_part_declares_what_it_imports():
    assert faults(imported(), _declared()) == []


def test_the_scan_sees_each_part():
    parts = imported()
    assert {"numpy", "casadi", "tomlkit"} <= parts["runtime"]
    assert {"pytest", "hypothesis", "control", "filterpy", "dask"} <= parts["tests"]
    assert {"tqdm", "joblib", "dask"} <= parts["benchmarks"]


def test_misdeclared_dependencies_are_found():
    """The check can fail: a run-time import left undeclared, a run-time dependency that only
    the tests import, a benchmark's extra nothing imports, a test extra that restates one."""
    imports = {"runtime": {"numpy", "tqdm"}, "tests": {"pytest", "control"}, "benchmarks": set()}
    declared = {
        "runtime": {"numpy", "control"},
        "test": {"pytest", "numpy"},
        "benchmarks": {"joblib"},
        "cluster": set(),
        "docs": set(),
    }
    assert faults(imports, declared) == [
        "runtime imports tqdm, not in runtime",
        "runtime declares control, which runtime does not import",
        "test declares numpy, which tests does not import",
        "test restates the run-time dependency numpy",
        "benchmarks declares joblib, which benchmarks does not import",
        "the extra 'docs' has no part that uses it",
    ]


def test_make_installs_what_the_tests_import():
    """The test suite imports the benchmarks (tests/test_bench.py), so ``make test``'s install
    takes their extra with its own."""
    assert any("benchmarks" in _top_modules(path) for path in (ROOT / "tests").rglob("*.py"))
    assert "pip install --quiet -e '.[test,benchmarks]'" in (ROOT / "Makefile").read_text()
