"""The package's architecture, read from the installed package's sources (docs/api.md, "Layers").

Every module of ``rsp_inertia`` is found by walking the installed package (pkgutil), its source
parsed (ast, nothing imported), and its imports of ``rsp_inertia`` modules collected: at module
level and inside functions, but not under ``if TYPE_CHECKING:`` (annotations only, never run).
On that graph:

- no import cycle, of any length;
- each layer imports only the layers below it (``LAYERS``);
- imports inside functions only at the lazy boundary (``rsp_inertia.api``, and the packages'
  ``__init__``, which load their names on first use), each with its reason in a comment;
- each command's result that holds a library record is a view of it (no field copied from
  it, no array field), and the results import nothing heavy.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
import sys
from pathlib import Path

import pytest

LAYERS = {
    "infra": {"infra"},
    "plant": {"infra", "plant"},
    "virtual": {"infra", "plant", "virtual"},
    "estimation": {"infra", "plant", "estimation"},
    "ocp": {"infra", "plant", "ocp", "estimation.smoothing", "estimation.modulated"},
    "design": {"infra", "plant", "virtual", "estimation", "ocp", "design"},
    "commands": {"infra", "plant", "virtual", "estimation", "ocp", "design", "commands"},
}
"""What each layer may import. Infrastructure (errors, files, lazy names, TOML schema, progress)
imports nothing of the package; the plant (model, geometry, transducers, file contracts) only
it. The virtual device and the estimation both stand on the plant and know nothing of each
other: a real rig's identification never loads the simulator. The torque program (ocp) uses
the identification's smoother and its modulating-function fit of Lagrange's equation (its
nominal model), nothing else of estimation; experiment design sits above them (its rehearsal
runs the virtual device); the command layer (the modules of rsp_inertia/ itself) above
everything."""

LAZY_BOUNDARY = {
    "rsp_inertia",
    "rsp_inertia.api",
    "rsp_inertia.plant.log_files",
    "rsp_inertia.plant.log_checks",
}
"""The modules whose functions may import: ``rsp_inertia.__getattr__`` loads the API on first use,
and each API function loads its command's modules, so that ``rsp-inertia --help`` and the light
commands do not pay for casadi, matplotlib and the estimation stack; the loggers' files load
nptdms only to read or write a TDMS log, and pyarrow only to read a log (a CSV's fast path,
a Parquet file) or write a Parquet one, so that importing the package does not pay for them."""


def _modules() -> dict[str, Path]:
    """Every module of the installed package, with its source file: the walk starts at the
    package and its command line, follows every import of an rsp_inertia module, and lists
    every package it reaches (an editable install keeps the layers' folders apart, so the
    packages are found through the imports, not by their place on disk)."""
    found: dict[str, Path] = {}
    queue = ["rsp_inertia", "rsp_inertia.cli"]
    while queue:
        name = queue.pop()
        if name in found:
            continue
        spec = importlib.util.find_spec(name)
        assert spec is not None and spec.origin is not None, name
        found[name] = Path(spec.origin)
        parts = name.split(".")
        queue += [".".join(parts[:k]) for k in range(1, len(parts))]  # its packages
        if spec.submodule_search_locations is not None:  # a package: all its modules
            queue += [
                info.name
                for info in pkgutil.iter_modules(spec.submodule_search_locations, name + ".")
                if info.ispkg or importlib.util.find_spec(info.name).origin.endswith(".py")
            ]
        queue += _imported_names(name, found[name])
    return found


def _imported_names(name: str, path: Path) -> list[str]:
    """The rsp_inertia modules (or their packages) that module ``name`` names in an import."""
    names = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            names.append(node.module)
            names += [f"{node.module}.{alias.name}" for alias in node.names]
    return [n for n in names if n.startswith("rsp_inertia") and _is_module(n)]


def _is_module(name: str) -> bool:
    """Whether ``name`` is a module (not a name inside one), found without importing it: only
    its packages' ``__init__`` run."""
    parent = name.rpartition(".")[0]
    if parent and not (_is_module(parent) and _spec(parent).submodule_search_locations):
        return False
    return _spec(name) is not None


def _spec(name: str):
    try:
        return importlib.util.find_spec(name)
    except ModuleNotFoundError:
        return None


MODULES = _modules()


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(name: str) -> list[tuple[str, int, bool]]:
    """(imported rsp_inertia module, line, inside a function) for each import in ``name``."""
    tree = ast.parse(MODULES[name].read_text(), str(MODULES[name]))
    package = name if MODULES[name].name == "__init__.py" else name.rpartition(".")[0]
    found: list[tuple[str, int, bool]] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for sub in child.orelse:
                    visit(sub, in_function)
                continue
            inner = in_function or isinstance(
                child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)
            )
            if isinstance(child, ast.Import):
                for alias in child.names:
                    found.append((alias.name, child.lineno, in_function))
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.rsplit(".", child.level - 1)[0]
                    base = f"{base}.{child.module}" if child.module else base
                else:
                    base = child.module or ""
                for alias in child.names:
                    sub = f"{base}.{alias.name}"
                    found.append((sub if sub in MODULES else base, child.lineno, in_function))
            visit(child, inner)

    visit(tree, False)
    for node in tree.body:  # a package's public names, loaded from their homes on first use
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "_HOMES":
            homes = ast.literal_eval(node.value)
            found += [(f"{name}.{home}", node.lineno, True) for home in set(homes.values())]
    return [(target, line, local) for target, line, local in found if target in MODULES]


IMPORTS = {name: _imports(name) for name in MODULES}


def _layer(name: str) -> str:
    """The layer of a module: its subpackage (``LAYERS``), or commands (rsp_inertia/)."""
    parts = name.split(".")
    if len(parts) > 1 and parts[1] in set(LAYERS) - {"commands"}:
        return parts[1]
    return "commands"


def _allowed(source: str, target: str) -> bool:
    allowed = LAYERS[_layer(source)]
    rest = target.split(".", 1)[1] if "." in target else ""
    return _layer(target) in allowed or any(
        rest == entry or rest.startswith(entry + ".") for entry in allowed if "." in entry
    )


def test_the_walk_finds_every_layer() -> None:
    """The walk sees the installed package whole: every layer, with its known modules."""
    layers = {_layer(name) for name in MODULES}
    assert layers == set(LAYERS)
    for name in ("rsp_inertia.api", "rsp_inertia.plant.model", "rsp_inertia.estimation.tensor_fit",
                 "rsp_inertia.ocp.program", "rsp_inertia.design.plan"):
        assert name in MODULES
    assert any(IMPORTS[name] for name in MODULES)


def _cycles(imports: dict[str, list[tuple[str, int, bool]]]) -> list[list[str]]:
    """The strongly connected components of more than one module of ``imports`` (Tarjan)."""
    graph = {name: sorted({t for t, _, _ in edges if t != name}) for name, edges in imports.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            connect(v)
    return found


def test_no_import_cycle() -> None:
    assert _cycles(IMPORTS) == []


def test_the_cycle_finder_finds_a_cycle() -> None:
    """The check can fail: an edge back from infra.errors to plant.logs closes a cycle of three
    (logs -> files -> errors -> logs)."""
    edges = dict(IMPORTS)
    edges["rsp_inertia.infra.errors"] = [("rsp_inertia.plant.logs", 1, True)]
    closed = [cycle for cycle in _cycles(edges) if "rsp_inertia.infra.errors" in cycle]
    assert len(closed) == 1 and "rsp_inertia.plant.logs" in closed[0]


@pytest.mark.parametrize("name", sorted(MODULES))
def test_layers_import_only_below(name: str) -> None:
    wrong = [f"line {line}: {target}" for target, line, _ in IMPORTS[name]
             if not _allowed(name, target)]
    assert wrong == [], f"{name} ({_layer(name)}) imports above its layer: {wrong}"


def test_the_layer_rule_can_fail() -> None:
    assert not _allowed("rsp_inertia.plant.model", "rsp_inertia.estimation.smoothing")
    assert not _allowed("rsp_inertia.infra.files", "rsp_inertia.plant.logs")
    assert not _allowed("rsp_inertia.plant.experiment", "rsp_inertia.virtual.config")
    assert not _allowed("rsp_inertia.estimation.balance", "rsp_inertia.virtual.device")
    assert not _allowed("rsp_inertia.virtual.device", "rsp_inertia.estimation.smoothing")
    assert not _allowed("rsp_inertia.ocp.program", "rsp_inertia.estimation.balance")
    assert not _allowed("rsp_inertia.estimation.tensor_fit", "rsp_inertia.design.plan")
    assert _allowed("rsp_inertia.ocp.program", "rsp_inertia.estimation.smoothing")
    assert _allowed("rsp_inertia.design.plan", "rsp_inertia.estimation.predict")


@pytest.mark.parametrize("name", sorted(MODULES))
def test_function_local_imports_only_at_the_lazy_boundary(name: str) -> None:
    tree = ast.parse(MODULES[name].read_text())
    local = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            local += [
                sub.lineno for sub in ast.walk(node) if isinstance(sub, (ast.Import, ast.ImportFrom))
            ]
    if name in LAZY_BOUNDARY:
        lines = MODULES[name].read_text().splitlines()
        unexplained = [n for n in sorted(set(local)) if not _has_reason(lines, n)]
        assert unexplained == [], f"{name}: lazy imports without a reason at lines {unexplained}"
    else:
        assert local == [], f"{name}: imports inside functions at lines {sorted(set(local))}"


def _has_reason(lines: list[str], lineno: int) -> bool:
    """A comment on the import's line or in the comment block right above it (through other
    imports of the same group)."""
    k = lineno - 1
    if "#" in lines[k]:
        return True
    k -= 1
    while k >= 0:
        text = lines[k].strip()
        if text.startswith("#"):
            return True
        if not (text.startswith(("from ", "import ")) or text.endswith(",") or text in ("", ")")):
            return False
        k -= 1
    return False


SUBPACKAGES = ("infra", "plant", "virtual", "estimation", "ocp", "design")


@pytest.mark.parametrize("sub", (*SUBPACKAGES, "results"))
def test_each_subpackage_exports_its_public_api_from_the_homes(sub: str) -> None:
    """Every name of a subpackage's ``__all__`` comes from the module its ``__init__`` names,
    whose own ``__all__`` holds it (plant.config is the public home of device_config's and
    reference_config's classes, its docstring says)."""
    package = importlib.import_module(f"rsp_inertia.{sub}")
    assert package.__all__, f"rsp_inertia.{sub} exports nothing"
    for name in package.__all__:
        home = importlib.import_module(f"rsp_inertia.{sub}.{package._HOMES[name]}")
        assert name in home.__all__, f"{name} is not in {home.__name__}.__all__"
        assert getattr(package, name) is getattr(home, name)


# --- the commands' results: views of the library's records, light --------------------------

RESULT_RECORDS = {
    "rsp_inertia.results.identify.IdentifyResult": (
        "identification", "rsp_inertia.estimation.results.Identification"
    ),  # and truth, demo's array of the virtual body's entries, which no record holds
    "rsp_inertia.results.calibrate.CalibrateResult": (
        "calibration", "rsp_inertia.estimation.calibration.Calibration"
    ),
    "rsp_inertia.results.plan.PlanResult": ("plan", "rsp_inertia.design.plan.Plan"),
    "rsp_inertia.results.combine.CombineResult": (
        "combination", "rsp_inertia.estimation.combine.Combination"
    ),
    "rsp_inertia.results.export.ExportResult": ("exported", "rsp_inertia.exporting.Exported"),
    "rsp_inertia.results.program.ProgramSummary": (
        "details", "rsp_inertia.ocp.program.TorqueProgram"
    ),
}
"""Each command's result that holds a library record: (its field, the record's class)."""

OWN_ARRAYS = {"rsp_inertia.results.identify.IdentifyResult": {"truth"}}
"""Array fields of a result that are the command's own (no record holds them)."""

LIGHT_PACKAGES = {"numpy"}
"""What the results may import beyond the standard library and the package (check and combine
load every result's module; neither may pay for scipy, CasADi or matplotlib)."""


def _class_fields(qualname: str) -> dict[str, str]:
    """The dataclass fields of class ``module.Class``, read from its source: name ->
    annotation (ClassVar aside)."""
    module, _, name = qualname.rpartition(".")
    tree = ast.parse(MODULES[module].read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == name)
    return {
        item.target.id: ast.unparse(item.annotation)
        for item in cls.body
        if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name)
        and not ast.unparse(item.annotation).startswith("ClassVar")
    }


def _copies(
    view: dict[str, str], record: dict[str, str], holder: str, kind: str, own: set[str]
) -> list[str]:
    """What keeps a result from being a view of its record: no field ``holder`` of the record's
    class ``kind``, a field of the record's name (a copy), an array field but the command's
    ``own`` (a copy, or a value computed from the record: a property's)."""
    faults = [] if view.get(holder) == kind else [f"no field {holder}: {kind}"]
    faults += [f"{name} copies the record's field" for name in sorted(view.keys() & record)]
    faults += [
        f"{name} is an array field"
        for name, annotation in view.items()
        if "ndarray" in annotation and name not in own
    ]
    return faults


@pytest.mark.parametrize("view", sorted(RESULT_RECORDS))
def test_each_result_is_a_view_of_its_record(view: str) -> None:
    holder, record = RESULT_RECORDS[view]
    own = OWN_ARRAYS.get(view, set())
    faults = _copies(
        _class_fields(view), _class_fields(record), holder, record.rpartition(".")[2], own
    )
    assert faults == [], f"{view}: {faults}"


def test_a_result_that_copies_its_record_is_found() -> None:
    """The identify result of before (a copy of Identification's arrays) fails."""
    before = {
        "entries": "np.ndarray", "tensor": "np.ndarray", "warnings": "tuple[str, ...]",
        "identification": "Identification", "path": "Path",
    }
    record = _class_fields("rsp_inertia.estimation.results.Identification")
    assert _copies(before, record, "identification", "Identification", set()) == [
        "entries copies the record's field", "warnings copies the record's field",
        "entries is an array field", "tensor is an array field",
    ]
    assert _copies({"path": "Path"}, record, "identification", "Identification", set()) == [
        "no field identification: Identification"
    ]


def _third_party(source: str) -> set[str]:
    """The packages outside the standard library and rsp_inertia that ``source`` imports when
    it runs (not under ``if TYPE_CHECKING:``)."""
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for sub in child.orelse:
                    visit(sub)
                continue
            if isinstance(child, ast.Import):
                found.update(alias.name.split(".")[0] for alias in child.names)
            elif isinstance(child, ast.ImportFrom) and not child.level and child.module:
                found.add(child.module.split(".")[0])
            visit(child)

    visit(ast.parse(source))
    return found - set(sys.stdlib_module_names) - {"rsp_inertia"}


RESULT_MODULES = sorted(name for name in MODULES if name.startswith("rsp_inertia.results"))
"""The package of results and its modules, one per command and the shared one."""


@pytest.mark.parametrize("name", RESULT_MODULES)
def test_the_results_import_nothing_heavy(name: str) -> None:
    """Of the package, a result imports only the light modules the results share (the
    device's files, geometry and run directions, the figure writer, the result files' seal
    (provenance: the standard library's hashlib and json), other results), never a layer's
    computation; of the rest, numpy."""
    light = ("rsp_inertia.results", "rsp_inertia.figure_files", "rsp_inertia.plant.experiment",
             "rsp_inertia.plant.geometry", "rsp_inertia.plant.direction",
             "rsp_inertia.infra.toml_writer", "rsp_inertia.infra.lazy",
             "rsp_inertia.provenance", "rsp_inertia.infra.frozen")
    heavy = [target for target, _, _ in IMPORTS[name] if not target.startswith(light)]
    assert heavy == [], f"{name} imports {heavy}"
    assert _third_party(MODULES[name].read_text()) <= LIGHT_PACKAGES


def test_a_heavy_import_in_a_result_is_found() -> None:
    source = (
        "from typing import TYPE_CHECKING\nimport json\nimport numpy as np\n"
        "import matplotlib.pyplot as plt\nif TYPE_CHECKING:\n    import casadi\n"
    )
    assert _third_party(source) - LIGHT_PACKAGES == {"matplotlib"}
    assert len(RESULT_MODULES) == 11  # the package, the shared module, nine commands


# --- one representation each: the direction of a run, the progress of the work --------------

ROOT = Path(__file__).resolve().parent.parent

WORDS = {"forward", "backward"}
"""The direction's words: only rsp_inertia.plant.direction turns them into meaning."""


def _direction_restatements(source: str) -> list[int]:
    """Lines of ``source`` that restate the direction's conversion instead of using
    :class:`rsp_inertia.plant.direction.Direction`: a comparison with one of its words
    (``direction == "forward"``, the first step of ``1 if direction == "forward" else -1``),
    a choice between its words (``"forward" if s > 0 else "backward"``), or its words listed
    (``("forward", "backward")``)."""

    def word(node: ast.AST) -> bool:
        return isinstance(node, ast.Constant) and node.value in WORDS

    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare) and any(map(word, [node.left, *node.comparators])) or isinstance(node, ast.IfExp) and (word(node.body) or word(node.orelse)) or isinstance(node, (ast.Tuple, ast.List, ast.Set)) and {
            element.value for element in node.elts if word(element)
        } == WORDS:
            lines.append(node.lineno)
    return sorted(set(lines))


def _sources() -> dict[str, Path]:
    """The installed package's modules, the tests and the benchmarks."""
    files = dict(MODULES)
    for folder in ("tests", "benchmarks"):
        files |= {str(path.relative_to(ROOT)): path for path in (ROOT / folder).rglob("*.py")}
    return files


def test_the_direction_is_converted_in_one_place() -> None:
    """The direction of a run is a Direction everywhere: its words are parsed once where they
    enter (device.toml, --direction, the API's direction=) and its sign is Direction.sign."""
    # The type itself, its test, and this check name the words.
    homes = {
        MODULES["rsp_inertia.plant.direction"],
        ROOT / "tests" / "plant" / "test_direction.py",
        Path(__file__).resolve(),
    }
    found = {
        name: lines
        for name, path in _sources().items()
        if path.resolve() not in homes and (lines := _direction_restatements(path.read_text()))
    }
    assert found == {}, f"the direction restated (use rsp_inertia.plant.direction): {found}"


def test_a_restated_direction_is_found() -> None:
    source = (
        'sign = 1 if direction == "forward" else -1\n'
        'name = "forward" if bal.direction > 0 else "backward"\n'
        'DIRECTIONS = ("forward", "backward")\n'
        "sign = direction.sign\n"
        'path = exp.braking_path(1, Direction.BACKWARD)\n'
    )
    assert _direction_restatements(source) == [1, 2, 3]


def _progress_channels(name: str, source: str) -> list[str]:
    """What in module ``name`` makes a second way for progress: a function that takes a
    ``progress`` callable (only the API's functions do, and hand it to
    rsp_inertia.infra.progress.lines_to), or a context variable of its own."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            arguments = node.args.posonlyargs + node.args.args + node.args.kwonlyargs
            if name != "rsp_inertia.api" and any(a.arg == "progress" for a in arguments):
                found.append(f"line {node.lineno}: {node.name}(progress)")
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            modules = [a.name for a in node.names] if isinstance(node, ast.Import) else [
                node.module or ""
            ]
            if "contextvars" in modules and name != "rsp_inertia.infra.progress":
                found.append(f"line {node.lineno}: imports contextvars")
    return found


@pytest.mark.parametrize("name", sorted(MODULES))
def test_progress_travels_through_one_channel(name: str) -> None:
    """Lines and fractions alike go through rsp_inertia.infra.progress (say, report) to the
    one Progress installed; no function passes a progress callable along."""
    assert _progress_channels(name, MODULES[name].read_text()) == []


def test_a_second_progress_channel_is_found() -> None:
    source = (
        "import contextvars\n"
        "def balance_runs(logs, warnings, progress=None):\n"
        "    say(str(logs))\n"
        "def identify(path, *, progress=None):\n"
        "    pass\n"
    )
    assert _progress_channels("rsp_inertia.estimation.runs", source) == [
        "line 1: imports contextvars",
        "line 2: balance_runs(progress)",
        "line 4: identify(progress)",
    ]
    assert _progress_channels("rsp_inertia.api", "def identify(path, *, progress=None): ...\n") == []


def _forwarders(tree: ast.Module) -> list[str]:
    """The functions of a module whose whole body (after the docstring) returns a call of a
    function of the same name with the same arguments in the same order: a second name for
    one home, not a function of its own."""
    found = []
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef):
            continue
        body = node.body
        if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            body = body[1:]
        if len(body) != 1 or not isinstance(body[0], ast.Return):
            continue
        call = body[0].value
        if not isinstance(call, ast.Call):
            continue
        called = call.func.attr if isinstance(call.func, ast.Attribute) else getattr(
            call.func, "id", ""
        )
        params = [a.arg for a in node.args.posonlyargs + node.args.args]
        passed = [a.id for a in call.args if isinstance(a, ast.Name)]
        if called == node.name and passed == params and len(call.args) == len(params):
            found.append(node.name)
    return found


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_function_only_forwards_to_its_namesake(name: str) -> None:
    """A function lives in one module: no module wraps another's function under the same
    name (as virtual.drive.encoder_reading once forwarded to plant.transducers')."""
    tree = ast.parse(MODULES[name].read_text(), str(MODULES[name]))
    assert _forwarders(tree) == [], f"{name}: forwards to another home"


def test_the_forwarder_check_can_fail() -> None:
    source = '''
def encoder_reading(phi, quantum, error=()):
    """Forwards."""
    return transducers.encoder_reading(phi, quantum, error)


def reading(phi, quantum):
    return transducers.encoder_reading(phi, quantum, ())
'''
    assert _forwarders(ast.parse(source)) == ["encoder_reading"]


INFRASTRUCTURE = {"scipy", "casadi", "matplotlib"}
"""What the infrastructure (rsp_inertia.infra) never imports: it holds no physics (numpy only
for the arrays a TOML file's keys hold), so that every layer stands on it at no cost."""


@pytest.mark.parametrize("name", sorted(n for n in MODULES if _layer(n) == "infra"))
def test_infrastructure_holds_no_physics(name: str) -> None:
    tree = ast.parse(MODULES[name].read_text(), str(MODULES[name]))
    imported = {
        alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
        for alias in node.names
    } | {
        node.module.split(".")[0] for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and node.module and not node.level
    }
    assert imported & INFRASTRUCTURE == set(), f"{name} imports {imported & INFRASTRUCTURE}"
