"""The documentation (README.md and docs/) checked against the code.

A command, option, file key or result.json key that the docs name and the code no longer has
fails here, and so does one the code has and the docs leave out; so does a Markdown link that
leaves the repository or points at nothing, and a module reference that does not resolve.

What is parsed, so that a doc edit keeps it parseable:

- commands: every ``rsp-inertia ...`` inside code (inline spans and fenced blocks) of
  README.md and docs/*.md; docs/commands.md has one ``## <command>`` section per command
  naming each of its options;
- docs/files.md: the tables under ``## device.toml``, ``## virtual.toml``,
  ``## reference.toml``, ``## calibration.toml`` and ``## result.json``, one key per row
  (first cell, dotted, in backticks); the device/virtual/reference tables' second cell is
  ``required``, a TOML default in backticks, or ``not set``; fenced ``toml`` blocks whose
  first line is ``# device.toml``, ``# virtual.toml`` or ``# reference.toml`` (a folder may
  come first: ``# bench-A/device.toml``) are loaded by rsp_inertia.plant.config (fragments
  on top of the default experiment's files).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomlkit

import rsp_inertia.plant
from rsp_inertia.cli import _parser, main
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.toml_schema import (
    REQUIRED,
    Key,
    accepted_keys,
    is_table,
    layout,
    read_file,
    read_table,
)
from rsp_inertia.plant import config, reference_config
from rsp_inertia.virtual import config as virtual_config

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FILES = DOCS / "files.md"
COMMANDS = DOCS / "commands.md"
PAGES = [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]
OWN_PAGES = [ROOT / "README.md"] + [
    DOCS / name for name in ("index.md", "method.md", "files.md", "commands.md", "real-rig.md")
]
"""The pages whose module references are checked (docs/api.md documents the API itself)."""

DEFAULTS = Path(rsp_inertia.plant.__file__).parent / "defaults"
ENTRIES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")

# --- parsing the pages --------------------------------------------------------------------

FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _fences(text: str) -> list[tuple[str, str]]:
    """(info string, body) of every fenced code block."""
    return [(m.group(1).strip(), m.group(2)) for m in FENCE.finditer(text)]


def _prose(text: str) -> str:
    """The text outside fenced code blocks."""
    return FENCE.sub("", text)


def _code_lines(text: str) -> list[str]:
    """Every line of fenced code and every inline code span."""
    lines = [line for _, body in _fences(text) for line in body.splitlines()]
    lines += re.findall(r"`([^`\n]+)`", _prose(text))
    return lines


def _section(text: str, heading: str, level: int = 2) -> str:
    """The text under the heading ``#``*level ``heading`` up to the next heading of that
    level or above; '' when there is none."""
    marks = "#" * level
    masked = FENCE.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)
    pattern = re.compile(rf"^{marks} {re.escape(heading)}[ \t]*$", re.MULTILINE)
    found = pattern.search(masked)
    if not found:
        return ""
    end = re.compile(rf"^#{{1,{level}}} ", re.MULTILINE).search(masked, found.end())
    return text[found.end() : end.start() if end else len(text)]


def _table_rows(text: str) -> list[list[str]]:
    """Cells of every Markdown table row whose first cell is one backticked key."""
    rows = []
    for line in text.splitlines():
        if re.match(r"^\|\s*`[^`]+`\s*\|", line):
            rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    return rows


def _key(cell: str) -> str:
    return cell.strip().strip("`")


# --- commands and options -----------------------------------------------------------------

MENTION = re.compile(r"(?<![\w.-])rsp-inertia[ \t]+(.*)")


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = _parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {s: a for a in parser._actions for s in a.option_strings}


def _mentions() -> list[tuple[str, list[str]]]:
    """(page, tokens after ``rsp-inertia``) of every command line in the docs' code.

    Left out: a ``$`` command of a fenced block whose output is argparse's usage error (a
    deliberate bad example), and argparse's own ``rsp-inertia COMMAND: error:`` prefix (only
    its command is kept).
    """
    found = []
    for page in PAGES:
        text = _text(page)
        lines = re.findall(r"`([^`\n]+)`", _prose(text))
        for _, body in _fences(text):
            block = []
            for line in body.splitlines():  # a command's options continued on the next line
                if block and line[:1] == " " and line.strip()[:1] in ("[", "-"):
                    block[-1] += " " + line.strip()
                else:
                    block.append(line)
            for k, line in enumerate(block):
                if line.startswith("$ "):
                    output = []
                    for after in block[k + 1 :]:
                        if after.startswith("$ "):
                            break
                        output.append(after)
                    if any(re.search(r"error: (argument|unrecognized)", o) for o in output):
                        continue
                lines.append(line)
        for line in lines:
            for match in MENTION.finditer(line):
                rest = match.group(1)
                if re.match(r"[a-z-]+: ", rest):
                    found.append((page.name, [rest.split(":")[0]]))
                    continue
                rest = re.split(r"\s#|;|&&|\s\|\s|>", rest)[0]
                tokens = [t.strip("[](){},.:") for t in rest.split()]
                found.append((page.name, [t for t in tokens if t]))
    return found


def test_every_documented_command_and_option_exists():
    commands = _subcommands()
    global_options = _options(_parser())
    mentions = _mentions()
    assert len(mentions) > 30, "the docs' command lines were not found: has the format changed?"
    faults = []
    seen = set()
    for page, tokens in mentions:
        if not tokens:
            continue
        head = tokens[0]
        if head.startswith("-"):
            if head not in global_options:
                faults.append(f"{page}: rsp-inertia {head}: no such global option")
            continue
        if not re.fullmatch(r"[a-z][a-z-]*", head):
            continue  # not a command line (e.g. the version that --version prints)
        if head not in commands:
            faults.append(f"{page}: rsp-inertia {head}: no such command")
            continue
        seen.add(head)
        options = _options(commands[head])
        for k, token in enumerate(tokens[1:], 1):
            if not token.startswith("-"):
                continue
            name = token.split("=")[0]
            if name not in options:
                faults.append(f"{page}: rsp-inertia {head} {name}: no such option")
                continue
            choices = options[name].choices
            value = tokens[k + 1] if k + 1 < len(tokens) else ""
            if choices and re.fullmatch(r"[a-z|]+", value):
                bad = [v for v in value.split("|") if v not in choices]
                if bad:
                    faults.append(f"{page}: rsp-inertia {head} {name} {value}: not a choice {bad}")
    assert not faults, "\n".join(faults)
    assert seen == set(commands), f"commands never shown in a command line: {set(commands) - seen}"


def test_commands_md_documents_every_command_and_option():
    text = _text(COMMANDS)
    faults = []
    for name, parser in _subcommands().items():
        section = _section(text, name)
        if not section:
            faults.append(f"commands.md: no section '## {name}'")
            continue
        rows = [row[0] for row in _table_rows(section)]
        for option in _options(parser):
            documented = any(re.match(rf"`{re.escape(option)}\b", cell) for cell in rows)
            if option.startswith("--") and option != "--help" and not documented:
                faults.append(f"commands.md ## {name}: option {option} has no row in its table")
    for option in _options(_parser()):
        if option.startswith("--") and option != "--help" and f"`rsp-inertia {option}`" not in text:
            faults.append(f"commands.md: global option {option} not documented")
    assert not faults, "\n".join(faults)


# --- device.toml, virtual.toml, reference.toml ---------------------------------------------

def _load_reference_tables(path):
    """reference.toml read by its loader (its rules across keys) and returned as its tables,
    whose keys the docs name (the loader's Reference holds the stds as a covariance)."""
    config.load_reference(path)
    return read_table(reference_config._ReferenceFile, read_file(path))


LOADERS = {
    "device.toml": config.load_device,
    "virtual.toml": virtual_config.load_virtual,
    "reference.toml": _load_reference_tables,
}
BASES = {
    "device.toml": DEFAULTS / "device.toml",
    "virtual.toml": DEFAULTS / "virtual.toml",
    "reference.toml": DEFAULTS / "rig" / "reference" / "reference.toml",
}


FILE_CLASSES = {
    "device.toml": config.Device,
    "virtual.toml": virtual_config.Virtual,
    "reference.toml": reference_config._ReferenceFile,
}
"""The config class each loader reads a whole file into (reference.toml: its [body] holder)."""


@functools.cache
def _accepted() -> dict[str, dict[str, set[str]]]:
    """Per file, per table ("" for the top level), the keys rsp_inertia.plant.config accepts.

    Read off the config classes' fields: the key sets its reader checks unknown keys against
    (rsp_inertia.infra.toml_schema.layout, through accepted_keys).
    """
    return {file: accepted_keys(cls) for file, cls in FILE_CLASSES.items()}


def _documented(file: str) -> dict[str, list[str]]:
    """Documented key -> its table row's cells, from docs/files.md's section on ``file``."""
    section = _section(_text(FILES), file)
    return {_key(row[0]): row for row in _table_rows(section)}


@pytest.mark.parametrize("file", list(LOADERS))
def test_documented_toml_keys_are_the_ones_config_accepts(file):
    accepted = _accepted()[file]
    assert accepted.get(""), f"no top-level tables of {file} found in config.py"
    known = {
        f"{table}.{key}" for table, keys in accepted.items() if table for key in keys
    }
    documented = set(_documented(file))
    assert documented, f"docs/files.md has no key table under '## {file}'"
    assert documented <= known, (
        f"{file}: documented but not accepted by rsp_inertia.plant.config: "
        f"{sorted(documented - known)}"
    )
    assert known <= documented, (
        f"{file}: accepted by rsp_inertia.plant.config but not documented in docs/files.md: "
        f"{sorted(known - documented)}"
    )
    tables = {k.split(".")[0] for k in documented}
    assert tables <= accepted[""], f"{file}: unknown tables {sorted(tables - accepted[''])}"


def _fields(file: str) -> dict[str, Key]:
    """Dotted key -> the config field that declares it, for every key of ``file``."""
    out = {}
    for name, entry in layout(FILE_CLASSES[file]).items():
        if isinstance(entry, tuple):
            out |= {f"{name}.{member.name}": member for member in entry}
        elif is_table(entry.kind):
            members = layout(entry.kind, entry.meta["without"])
            out |= {f"{name}.{key}": member for key, member in members.items()}
    return out


@pytest.mark.parametrize("file", list(LOADERS))
def test_documented_units_are_the_fields_units(file):
    """The unit column starts with the unit the field declares (and the writer comments)."""
    fields = _fields(file)
    assert set(fields) == {f"{t}.{k}" for t, keys in _accepted()[file].items() if t for k in keys}
    faults = []
    for dotted, row in _documented(file).items():
        unit = fields[dotted].meta["unit"] if dotted in fields else ""
        if unit and not (row[2] == unit or row[2].startswith(unit + ",")):
            faults.append(f"{dotted}: documented unit {row[2]!r}, the field's is {unit!r}")
    assert not faults, "\n".join(faults)


def _examples(file: str) -> list[dict]:
    """Every fenced toml block of the docs that says it is ``file`` (first line ``# file``,
    or ``# FOLDER/file``: a file real-rig.md tells the reader to write)."""
    blocks = []
    for page in PAGES:
        for info, body in _fences(_text(page)):
            first = body.lstrip().splitlines()[0] if body.strip() else ""
            if info == "toml" and re.fullmatch(rf"#\s*(?:\S+/)?{re.escape(file)}\b.*", first):
                blocks.append(tomllib.loads(body))
    return blocks


def _merged(file: str, block: dict, tmp_path: Path, name: str = "x") -> Path:
    """``block``'s tables on top of the default experiment's ``file``, written to a file."""
    doc = tomllib.loads(BASES[file].read_text(encoding="utf-8"))
    doc.update(block)
    path = tmp_path / f"{name}-{file}"
    path.write_text(tomlkit.dumps(doc), encoding="utf-8")
    return path


@pytest.mark.parametrize("file", list(LOADERS))
def test_documented_examples_load(file, tmp_path):
    blocks = _examples(file)
    assert blocks, f"no '# {file}' toml example in the docs"
    for k, block in enumerate(blocks):
        LOADERS[file](_merged(file, block, tmp_path, str(k)))


def _attribute(loaded, file: str, dotted: str):
    """The loaded value of ``table.key`` (stage: the first stage)."""
    table, key = dotted.split(".", 1)
    if file == "device.toml":
        holder = loaded.stages[0] if table == "stage" else (
            loaded if table == "device" else getattr(loaded, table)
        )
    else:
        holder = getattr(loaded, table)
    return getattr(holder, key)


def _plain(value):
    if isinstance(value, (tuple, list, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    return value


TOGETHER = (
    {"encoder.error_cos", "encoder.error_sin", "encoder.error_std"},
    {"rig.encoder_error_amplitude", "rig.encoder_error_phase_deg"},
    {"motor.torque_constant", "motor.torque_constant_std", "log.torque_unit"},
    {"log.delimiter", "log.decimal"},
    {"stage.braking_torque_2", "stage.braking_switch_turns"},
    {
        "motor.torque_constant_tempco", "motor.torque_constant_tempco_std",
        "motor.temperature_lag", "motor.reference_temperature", "log.temperature_column",
    },
    {"motor.winding_time_constant", "motor.temperature_lag", "motor.reverse_delay"},
)
"""Optional keys (dotted) that a file gives together or not at all: an encoder's error series,
a torque constant and logs of the current, a decimal comma and its delimiter, a tempco and
the logged temperature it compensates, a two-level braking's second torque and its switch,
a warming motor's modelled time constants and pause."""


def _together(table: str, key: str) -> set[str]:
    """The dotted keys left out with ``table.key``: itself, and the keys it only comes with."""
    for keys in TOGETHER:
        if f"{table}.{key}" in keys:
            return keys
    return {f"{table}.{key}"}


@pytest.mark.parametrize("file", list(LOADERS))
def test_documented_requirements_and_defaults_hold(file, tmp_path):
    """Each key left out of the example that shows it: a required key is missed, an optional
    one takes its documented default (or stays unset)."""
    blocks = _examples(file)
    faults = []
    for dotted, row in _documented(file).items():
        table, key = dotted.split(".", 1)
        holders = [b for b in blocks if key in _entries(b.get(table))]
        if not holders:
            faults.append(f"{dotted}: in no '# {file}' example of the docs")
            continue
        block = json.loads(json.dumps(holders[0]))
        for other in _together(table, key):
            other_table, other_key = other.split(".", 1)
            holder = block.get(other_table, {})
            entry = holder[0] if isinstance(holder, list) else holder
            entry.pop(other_key, None)
        path = _merged(file, block, tmp_path, dotted)
        spec = row[1].strip()
        if spec == "required":
            with pytest.raises(InputError) as error:
                LOADERS[file](path)
            if "missing required key" not in str(error.value):
                faults.append(f"{dotted}: left out, {error.value}")
            continue
        try:
            loaded = LOADERS[file](path)
        except InputError as error:
            faults.append(f"{dotted}: documented as optional, but left out: {error}")
            continue
        value = _plain(_attribute(loaded, file, dotted))
        if spec == "not set":
            expected = None
        elif re.fullmatch(r"`[^`]+`", spec):
            expected = _plain(tomllib.loads(f"v = {spec.strip('`')}")["v"])
        else:
            faults.append(f"{dotted}: second cell {spec!r} is not required, `default` or not set")
            continue
        if value != expected:
            faults.append(f"{dotted}: documented default {spec}, config gives {value!r}")
    assert not faults, "\n".join(faults)


def _entries(table) -> dict:
    if isinstance(table, list):
        return table[0] if table else {}
    return table if isinstance(table, dict) else {}


# --- result.json ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def result(tmp_path_factory) -> dict:
    """result.json of a small experiment with every section filled: the default gimbal with
    short passes, stage 2 run both ways, stated tare and gain stds, pendulum runs (~8 s).

    BLAS on one thread: the smoother's and the GLS's many small factorisations run several
    times slower when the machine's cores are shared with other work."""
    from threadpoolctl import threadpool_limits

    from rsp_inertia.scenarios import create_default_experiment
    from rsp_inertia.simulating import simulate

    root = create_default_experiment(tmp_path_factory.mktemp("docs") / "exp")
    text = (root / "device.toml").read_text()
    edits = [
        (r"braking_torque = 0\.005\b.*", "braking_torque = 0.05"),
        (r"braking_torque = 0\.12\b.*", 'braking_torque = 0.3\ndirections = ["forward", "backward"]'),
        (r"tare_inertia_std = 0\.0\b.*", "tare_inertia_std = 1e-5"),
        (r"tare_inertia_std = 0\.0\b.*", "tare_inertia_std = 1e-4"),
        (r"duration = 30\.0\b.*", "duration = 20.0"),
    ]
    for old, new in edits:
        text, found = re.subn(old, new, text, count=1)
        assert found, f"the default device.toml changed: no line {old!r}"
    (root / "device.toml").write_text(text)
    # A specification, so that result.json's decision is filled (record.toml's keys are
    # always there, null where not stated).
    (root / "spec.toml").write_text(
        '[decision]\nrule = "guarded"\n[tensor]\nJx = [0.0, 1.0]\n[com]\nx = [-0.1, 0.1]\n'
    )
    with threadpool_limits(limits=1):
        simulate(root, part="braking")
        simulate(root, part="reverse", ideal=True)
        simulate(root, part="pendulum")
        assert main(["identify", str(root)]) == 0
    return json.loads((root / "result.json").read_text())


def _paths(value, path: str = "") -> set[str]:
    """Every key path of a JSON document (result.json, body.json) in the notation of
    docs/files.md."""
    out = {path} if path else set()
    if isinstance(value, dict):
        names = set(value)
        for name, child in value.items():
            if path.endswith("std_budget"):
                name = "<source>"
            elif path.endswith("best_budget"):
                name = "<part>"
            elif path == "provenance.inputs":
                name = "<file>"
            elif path == "provenance.software":
                name = "<package>"
            elif path.endswith("residuals") or path in (
                "decision.quantities", "decision.limits", "decision.values"
            ):
                name = "<quantity>"
            elif path in ("com", "com_std") and names == {"x", "y", "z"}:
                name = "<coordinate>"
            elif names == set(ENTRIES):
                name = "<entry>"
            out |= _paths(child, f"{path}.{name}" if path else name)
    elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        for child in value:
            out |= {p for p in _paths(child, f"{path}[]") if p != f"{path}[]"}
    return out


def test_result_json_keys_are_documented_and_exist(result):
    real = _paths(result)
    documented = set(_documented("result.json"))
    assert documented, "docs/files.md has no key table under '## result.json'"
    assert not documented - real, (
        f"documented in docs/files.md but not in identify's result.json: {sorted(documented - real)}"
    )
    assert not real - documented, (
        f"in identify's result.json but not documented in docs/files.md: {sorted(real - documented)}"
    )


def test_result_json_placeholders_name_the_real_keys(result):
    section = _section(_text(FILES), "result.json")
    names = set(result["least_squares"]["std_budget"])
    names |= {k for a in result["pendulum"]["axes"] for k in (a["best_budget"] or {})}
    missing = [name for name in sorted(names) if f"`{name}`" not in section]
    assert not missing, f"docs/files.md ## result.json does not name {missing}"


# --- calibration.toml -----------------------------------------------------------------------

def _calibration_keys() -> dict[str, Key]:
    """Dotted key (docs notation: ``stage.gear_ratio``, ``inputs.<file>``) -> the field of
    rsp_inertia.estimation.calibration_file that declares it, for every key its reader accepts
    (rsp_inertia.infra.toml_schema.accepted_keys)."""
    from rsp_inertia.estimation.calibration_file import CalibrationFile

    out = {}
    for name, entry in layout(CalibrationFile).items():
        if entry.free:
            out[f"{name}.<{entry.meta['free_key']}>"] = entry
        else:
            members = layout(entry.kind, entry.meta["without"])
            out |= {f"{name}.{key}": member for key, member in members.items()}
    accepted = accepted_keys(CalibrationFile)
    assert set(out) == {f"{t}.{k}" for t, keys in accepted.items() if t for k in keys}
    return out


CALIBRATION_OLDER_KEYS = {"calibration.torque_gain", "calibration.torque_gain_std"}
"""The keys only a calibration.toml of an older rsp-inertia has (read, never written)."""


def test_calibration_toml_keys_are_documented_and_exist():
    """docs/files.md documents the keys calibration.toml's reader accepts, with their units
    and whether they are required; calibrate writes every one but the older files' keys."""
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.known_terms import KnownTerms
    from rsp_inertia.estimation.stiffness import StiffnessCalibration
    from rsp_inertia.estimation.tempco import TempcoFit

    fields = _calibration_keys()
    documented = _documented("calibration.toml")
    assert set(documented) == set(fields), (
        f"calibration.toml: documented only {sorted(set(documented) - set(fields))}, "
        f"accepted only {sorted(set(fields) - set(documented))}"
    )
    faults = []
    for dotted, row in documented.items():
        unit = fields[dotted].meta["unit"]
        if unit and not (row[2] == unit or row[2].startswith(unit + ",")):
            faults.append(f"{dotted}: documented unit {row[2]!r}, the field's is {unit!r}")
        required = fields[dotted].default is REQUIRED
        if (row[1] == "required") != required:
            faults.append(f"{dotted}: documented as {row[1]!r}, the reader's required={required}")
    assert not faults, "\n".join(faults)

    tares = KnownTerms.from_tares([0.0037, 0.084])
    share = np.eye(tares.cov.shape[0]) * 1e-14  # a reference certificate's whole covariance
    known = tares.with_theta(tares.theta, share, certificate_cov=share)
    calibration = Calibration(
        device_name="bench-A",
        counts_per_rev=65536,
        gear_ratios=(0.7639320225, 5.2360679775),
        nodes_deg=((0.0, 120.0, 240.0), (60.0, 180.0, 300.0)),
        known=known,
        reference=True,
        inputs={"bench-A/calibration/empty/device.toml": "0" * 64},
        chi2_dof=1.0,
        date="2026-11-18",
        certificate=config.Certificate(id="RB-1", issuer="Lab", date="2026-03-02"),
        stiffness=StiffnessCalibration(2.0, 1e-3, [(1, 0.0, 2.0, 1e-3)], math.nan, []),
        # A tempco the runs measured (its std a fifth of the stated one): calibration.toml [motor].
        tempco_fit=TempcoFit(
            stated=-0.0011, stated_std=1e-4, estimate=-0.0009, std=2e-5,
            covariance=(0.0,) * tares.cov.shape[0], reference_temperature=25.0,
        ),
    )
    doc = tomllib.loads(calibration.to_toml())
    written = set()
    for table, value in doc.items():
        if table == "inputs":
            written.add("inputs.<file>")
        else:
            written |= {f"{table}.{key}" for entry in _all(value) for key in entry}
    assert written == set(fields) - CALIBRATION_OLDER_KEYS


def _all(table) -> list[dict]:
    """The tables of a table or of an array of tables."""
    return table if isinstance(table, list) else [table]


# --- links and references -------------------------------------------------------------------

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)|<(https?://[^>]+)>|(?<![(<\w])(https?://\S+)")


def _anchors(text: str) -> set[str]:
    """GitHub's anchors of a page's headings."""
    out = set()
    for heading in re.findall(r"^#{1,6} (.+)$", _prose(text), re.MULTILINE):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        out.add(slug)
    return out


def test_links_stay_inside_the_repository_and_resolve():
    faults = []
    for page in PAGES:
        text = _prose(_text(page))
        for match in LINK.finditer(text):
            target = next(g for g in match.groups() if g)
            where = f"{page.relative_to(ROOT)}: ({target})"
            if re.match(r"[a-z][a-z0-9+.-]*:", target, re.IGNORECASE) or target.startswith("//"):
                faults.append(f"{where}: leaves the repository")
                continue
            path, _, anchor = target.partition("#")
            if path.startswith("/") or ".." in Path(path).parts:
                faults.append(f"{where}: leaves the folder tree (absolute or ../)")
                continue
            resolved = (page.parent / path).resolve() if path else page
            if not resolved.exists():
                faults.append(f"{where}: no such file")
                continue
            if anchor and resolved.suffix == ".md" and anchor not in _anchors(_text(resolved)):
                faults.append(f"{where}: no heading with anchor #{anchor}")
    assert not faults, "\n".join(faults)


def test_nothing_outside_the_repository_is_mentioned():
    faults = []
    for page in PAGES:
        for bad in (r"(?<!\.)\.\./", r"\bMETHOD\.md", r"\bINTERFACES\.md", r"\bshared/"):
            if re.search(bad, _text(page)):
                faults.append(f"{page.relative_to(ROOT)}: mentions {bad!r}")
    assert not faults, "\n".join(faults)


def _resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            fields = getattr(obj, "__dataclass_fields__", {})
            if hasattr(obj, name):
                obj = getattr(obj, name)
            elif name in fields:
                obj = None
            else:
                return False
        return True
    return False


def test_module_references_resolve():
    refs = set()
    for page in OWN_PAGES:
        refs |= {
            (page.name, ref.rstrip("."))
            for ref in re.findall(r"\brsp_inertia(?:\.\w+)+", _text(page))
        }
    assert len(refs) > 20, "no module references found in the docs"
    bad = sorted(f"{page}: {ref}" for page, ref in refs if not _resolves(ref))
    assert not bad, "references that do not resolve:\n" + "\n".join(bad)
