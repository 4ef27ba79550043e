"""The experiment pipeline behind the commands: files in, files out, no physics here.

Each function takes an experiment folder, calls the library (plant/, estimation/, ocp/) and
writes the outputs atomically. What it did comes back as small summary records that the
command line prints. The demo, which runs these functions on the virtual rig, is
:mod:`rsp_inertia.rig_demo`; the table identify prints is
:func:`rsp_inertia.identify_result.format_identification`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

# The identify table's home is identify_result; tests/plant/test_geometry.py imports it from here.
from rsp_inertia.plant.config import DIRECTIONS
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.experiment import Experiment, open_experiment
from rsp_inertia.plant.files import check_writable, write_atomic
from rsp_inertia.plant.logs import (
    align_counter,
    read_device_log,
    read_program,
    write_log,
    write_program,
)

# Each command imports what it uses inside its function: ``program`` must not pay for the
# identification's modules (scipy.stats, the GLS) nor ``identify`` for the OCP's.
if TYPE_CHECKING:
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.combine import Combination
    from rsp_inertia.estimation.results import Identification
    from rsp_inertia.ocp.program import TorqueProgram
    from rsp_inertia.plant.virtual import SimulatedPass

__all__ = [
    "BODY_FILE",
    "PassSummary",
    "ProgramSummary",
    "calibrate",
    "combine",
    "create_default_experiment",
    "create_rig_experiment",
    "create_second_mounting",
    "identify",
    "program",
    "program_summaries",
    "result_json",
    "simulate",
]

PARTS = ("braking", "reverse", "pendulum", "pilot")


@dataclass(frozen=True)
class PassSummary:
    """What one simulated pass produced."""

    stage: int
    """Stage number, from 1."""
    part: str
    """'braking', 'reverse' or 'ideal reverse'."""
    path: Path
    """The log written."""
    rows: int
    """Rows of the log."""
    duration: float
    """s, the pass's physical duration."""
    turns: float
    """Turns covered by the pass (encoder angle span / 2 pi)."""
    turns_past_last_node: float | None
    """Braking only: turns after the first passage of the stage's last node."""
    direction: str = "forward"
    """Direction of the stage's run, 'forward' or 'backward' (pendulum runs: 'forward')."""

    def __str__(self) -> str:
        part = self.part if self.direction == "forward" else f"{self.part} {self.direction}"
        text = (
            f"stage {self.stage}: {part}: {self.duration:.2f} s, {self.rows} rows, "
            f"{self.turns:.2f} turns"
        )
        if self.turns_past_last_node is not None:
            text += f" ({self.turns_past_last_node:.2f} past the last node)"
        return f"{text} -> {self.path}"


def create_default_experiment(root: str | Path) -> Path:
    """Write the default experiment's device.toml and virtual.toml into ``root``.

    The default is the paper's scenario (plant/defaults/). Files already present are kept
    as they are (an experiment's inputs are never overwritten), so a user can edit them and
    rerun the demo.
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    for name in ("device.toml", "virtual.toml"):
        target = root / name
        if not target.exists():
            text = resources.files("rsp_inertia.plant").joinpath("defaults", name).read_text()
            write_atomic(target, text)
    return root


CALIBRATION_FOLDERS = ("empty", "reference")
"""The demo's calibration experiments, in EXP/calibration/: the empty fixture, the reference."""


def create_rig_experiment(root: str | Path) -> tuple[Path, Path, Path]:
    """Write the demo's rig experiment and its calibration experiments (plant/defaults/rig/).

    The paper's body on a virtual rig with a real one's imperfections (a torque gain, tares
    that device.toml knows only to 1%, an unbalanced fixture, friction 2% larger turning
    backward), every stage run both ways round, and the calibration runs: ``root`` (the
    body), ``root/calibration/empty`` and ``root/calibration/reference`` (with
    reference.toml). Files already present are kept as they are.

    Returns
    -------
    (root, empty, reference) : paths
    """
    root = Path(root)
    folders = [root] + [root / "calibration" / name for name in CALIBRATION_FOLDERS]
    sources = [("rig",)] + [("rig", name) for name in CALIBRATION_FOLDERS]
    for folder, source in zip(folders, sources):
        folder.mkdir(parents=True, exist_ok=True)
        files = resources.files("rsp_inertia.plant").joinpath("defaults", *source)
        for name in ("device.toml", "virtual.toml", "reference.toml"):
            target = folder / name
            if not target.exists() and files.joinpath(name).is_file():
                write_atomic(target, files.joinpath(name).read_text())
    return root, folders[1], folders[2]


SECOND_MOUNTING = "mounting-x90"
"""The demo's second mounting of its body, a subfolder of its experiment."""

TURNED_X90 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""A quarter turn about the rig's x axis: takes the body direction on the shaft across it."""


def create_second_mounting(root: str | Path) -> Path:
    """``root/mounting-x90``: the experiment ``root``'s body mounted again, turned 90 deg
    about the rig's x axis (device.toml ``[mounting] rotation`` = TURNED_X90 times root's),
    on the same rig (root's device.toml and virtual.toml otherwise). Files already present
    are kept as they are; returns the folder."""
    import tomlkit

    root = Path(root)
    folder = root / SECOND_MOUNTING
    folder.mkdir(exist_ok=True)
    device = folder / "device.toml"
    if not device.exists():
        first = open_experiment(root, protocol=False).device.mounting
        rotation = TURNED_X90 @ (np.eye(3) if first is None else first.rotation)
        table = tomlkit.table()
        table["rotation"] = [[float(c) + 0.0 for c in row] for row in rotation]
        table["origin"] = [0.0, 0.0, 0.0] if first is None else [float(c) for c in first.origin]
        doc = tomlkit.parse((root / "device.toml").read_text())
        doc["mounting"] = table
        write_atomic(device, tomlkit.dumps(doc))
    virtual = folder / "virtual.toml"
    if not virtual.exists():
        write_atomic(virtual, (root / "virtual.toml").read_text())
    return folder


def _summary(
    exp: Experiment,
    stage: int,
    part: str,
    path: Path,
    sim: SimulatedPass,
    direction: str = "forward",
) -> PassSummary:
    log = sim.log
    past = None
    if part == "braking":
        from rsp_inertia.plant.geometry import turns_past_last_node

        past = turns_past_last_node(log.phi, exp.device.stages[stage - 1].nodes)
    return PassSummary(
        stage=stage,
        part=part,
        path=path,
        rows=len(log),
        duration=sim.truth.end_time,
        turns=float(abs(log.phi[-1] - log.phi[0]) / (2 * math.pi)),
        turns_past_last_node=past,
        direction=direction,
    )


def _check_simulate_outputs(
    exp: Experiment, stages: list[int], part: str, direction: str | None
) -> None:
    """Refuse, before any run is simulated, a log that :func:`simulate` could not write
    (rsp_inertia.plant.files.check_writable): in a stage folder that exists, each log; else
    the experiment folder, where the stage folder is to be made."""
    for st in stages:
        if part == "pendulum":
            nodes = len(exp.device.stages[st - 1].nodes)
            paths = [exp.pendulum_path(st, k + 1) for k in range(nodes)]
        elif part == "pilot":
            paths = [exp.pilot_path(st)]
        else:
            directions = exp.device.stages[st - 1].directions if direction is None else (direction,)
            where = exp.braking_path if part == "braking" else exp.reverse_path
            paths = [where(st, d) for d in directions]
        folder = exp.stage_dir(st)
        for path in paths if folder.is_dir() else [folder]:
            check_writable(path)


def _write_log(exp: Experiment, virtual, path: Path, log) -> None:
    """A simulated log as the virtual rig's logger writes it: ``t,counts,torque`` with
    virtual.toml ``[logger] counts`` (device.toml's ``[encoder] counter_bits`` wide), else
    ``t,phi,torque``."""
    if not virtual.logger.counts:
        write_log(path, log)
        return
    if exp.device.encoder.counter_bits is None:
        raise InputError(
            f"{exp.root / 'virtual.toml'}: logger.counts: the logger writes a counter's counts, "
            "but device.toml's [encoder] has no counter_bits (the counter's width)"
        )
    write_log(path, log, counter=exp.device.encoder)


def _braking_truth(
    exp: Experiment, stage: int, virtual, direction: str = "forward"
) -> SimulatedPass:
    """Re-run the (deterministic) braking pass of ``direction`` and check it is the one on disk.

    The reverse pass starts where the braking stopped; the simulator regenerates that state
    rather than storing truth next to the logs, and refuses a braking log it did not write
    with these settings.
    """
    from rsp_inertia.plant.virtual import simulate_braking

    braking = simulate_braking(exp.device, stage, virtual, direction)
    path = exp.braking_path(stage, direction)
    if not path.is_file():
        raise InputError(f"{path}: not found: simulate the braking first (--part braking)")
    on_disk = align_counter(  # a counts log is known up to whole ranges of the counter
        read_device_log(path, exp.device, "braking", direction),
        float(braking.log.phi[0]),
        exp.device.encoder,
    )
    q = exp.device.encoder.quantum
    same = (
        len(on_disk) == len(braking.log)
        and np.array_equal(on_disk.t, braking.log.t)
        and np.array_equal(on_disk.torque, braking.log.torque)
        # in counts: a counts log's angle is rebuilt from the counter, not bit for bit
        and np.array_equal(np.rint(on_disk.phi / q), np.rint(braking.log.phi / q))
    )
    if not same:
        raise InputError(
            f"{path}: not the virtual device's braking pass for the current device.toml and "
            "virtual.toml; simulate it again (--part braking)"
        )
    return braking


def simulate(
    root: str | Path,
    stage: int | None = None,
    part: str = "braking",
    *,
    ideal: bool = False,
    direction: str | None = None,
    progress: Callable[[PassSummary], None] | None = None,
) -> list[PassSummary]:
    """``rsp-inertia simulate``: the virtual device writes the logs of one part.

    Parameters
    ----------
    root : path
        Experiment folder with device.toml and virtual.toml.
    stage : int, optional
        One stage (from 1); all stages by default.
    part : {'braking', 'reverse', 'pendulum', 'pilot'}
        The braking pass writes stageN/braking.csv. The reverse pass runs stageN/program.csv
        in closed loop and writes stageN/reverse.csv; with ``ideal`` it runs the exact mirror
        of the braking on an ideal drive instead (no program needed). The pendulum part
        writes stageN/pendulum_kK.csv, one torsion-pendulum run per node K; the pilot part
        stageN/pilot.csv (spin-up at a known torque, then a coast; for ``plan``). A backward run
        uses stageN/braking_backward.csv, program_backward.csv and reverse_backward.csv.
        Braking and reverse need every stage's protocol in device.toml
        (rsp_inertia.plant.config.require_protocol); pendulum and pilot runs do not.
    direction : {'forward', 'backward'}, optional
        Braking and reverse: only this direction, on the stages whose ``directions`` in
        device.toml include it; every direction of each stage by default. Pendulum and pilot
        runs ignore it.
    progress : callable, optional
        Called with each pass's summary as soon as it is written.

    Raises
    ------
    InputError
        Bad ``part`` or ``direction``, ``ideal`` with a part other than 'reverse', or no
        selected stage runs ``direction``; and whatever the files' readers and the simulator
        raise.
    """
    from rsp_inertia.plant.virtual import (
        run_program,
        simulate_braking,
        simulate_ideal_reverse,
        simulate_pendulum,
        simulate_pilot,
    )

    if part not in PARTS:
        raise InputError(f"--part: must be one of {', '.join(PARTS)}, got {part!r}")
    if ideal and part != "reverse":
        raise InputError("--ideal goes with --part reverse")
    if direction is not None and direction not in DIRECTIONS:
        raise InputError(
            f"--direction: must be one of {', '.join(DIRECTIONS)}, got {direction!r}"
        )
    exp = open_experiment(root, protocol=part in ("braking", "reverse"))
    virtual = exp.load_virtual()
    stages = exp.stages(stage)
    if direction is not None and part not in ("pendulum", "pilot"):
        runs = [st for st in stages if direction in exp.device.stages[st - 1].directions]
        if not runs:
            fault = (
                f"stage: no stage's directions include {direction!r}"
                if stage is None
                else f"stage[{stage}].directions: does not include {direction!r}"
            )
            raise InputError(f"{exp.root / 'device.toml'}: {fault}")
        stages = runs
    _check_simulate_outputs(exp, stages, part, direction)
    summaries = []
    for st in stages:
        exp.stage_dir(st).mkdir(exist_ok=True)
        if part == "pendulum":
            for k in range(len(exp.device.stages[st - 1].nodes)):
                sim = simulate_pendulum(exp.device, st, virtual, k)
                path = exp.pendulum_path(st, k + 1)
                _write_log(exp, virtual, path, sim.log)
                summary = _summary(exp, st, f"pendulum at node {k + 1}", path, sim)
                if progress is not None:
                    progress(summary)
                summaries.append(summary)
            continue
        if part == "pilot":
            sim = simulate_pilot(exp.device, st, virtual)
            path = exp.pilot_path(st)
            _write_log(exp, virtual, path, sim.log)
            summary = _summary(exp, st, "pilot", path, sim)
            if progress is not None:
                progress(summary)
            summaries.append(summary)
            continue
        directions = exp.device.stages[st - 1].directions if direction is None else (direction,)
        for d in directions:
            if part == "braking":
                sim = simulate_braking(exp.device, st, virtual, d)
                path = exp.braking_path(st, d)
                label = "braking"
            else:
                braking = _braking_truth(exp, st, virtual, d)
                if ideal:
                    sim = simulate_ideal_reverse(exp.device, st, virtual, braking, d)
                    label = "ideal reverse"
                else:
                    program = read_program(exp.program_path(st, d), exp.device.encoder)
                    start = (braking.truth.end_phi, 0.0)
                    sim = run_program(exp.device, st, virtual, program, start, direction=d)
                    label = "reverse"
                path = exp.reverse_path(st, d)
            _write_log(exp, virtual, path, sim.log)
            summary = _summary(exp, st, label, path, sim, d)
            if progress is not None:
                progress(summary)
            summaries.append(summary)
    return summaries


@dataclass(frozen=True)
class ProgramSummary:
    """What ``program`` wrote for one run: a stage in one direction."""

    stage: int
    """Stage number, from 1."""
    direction: str
    """'forward' or 'backward'."""
    path: Path
    """The program.csv written."""
    details: TorqueProgram
    """How it was made: the program's arrays, the mirror, the nominal model, the OCP's
    solution, the smoothed braking, the wall time (rsp_inertia.ocp.program.TorqueProgram)."""

    def __str__(self) -> str:
        prog = self.details.program
        label = "" if self.direction == "forward" else f" {self.direction}"
        return (
            f"stage {self.stage}{label}: program: {len(prog.t)} rows over {prog.t[-1]:.2f} s, "
            f"peak torque {abs(prog.torque_ff).max():.3f} N m, k_phi "
            f"{prog.k_phi.mean():.3g} N m/rad, k_omega {prog.k_omega.mean():.3g} "
            f"N m s/rad, OCP {self.details.ocp.iterations} iterations; "
            f"{self.details.seconds:.2f} s -> {self.path}"
            + "".join(f"\nwarning: {w}" for w in self.details.warnings)
        )


def program_summaries(
    root: str | Path,
    stage: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[ProgramSummary]:
    """``rsp-inertia program``: stageN/braking.csv -> stageN/program.csv (written atomically).

    Reads only device.toml and the braking log. Nothing is written for a stage whose mirror
    the motor cannot drive (the error says what torque it needs). ``progress`` gets each
    run's summary line as soon as its program is written.
    """
    from rsp_inertia.ocp.program import make_program

    exp = open_experiment(root)
    # Every program's file found writable before any is made (a run without its braking log
    # is refused, in order, by the reader below).
    for st in exp.stages(stage):
        for direction in exp.device.stages[st - 1].directions:
            if exp.braking_path(st, direction).is_file():
                check_writable(exp.program_path(st, direction))
    summaries = []
    for st in exp.stages(stage):
        for direction in exp.device.stages[st - 1].directions:
            path = exp.braking_path(st, direction)
            braking = read_device_log(path, exp.device, "braking", direction)
            result = make_program(exp.device, st, braking, str(path), direction=direction)
            out = exp.program_path(st, direction)
            write_program(out, result.program)
            summary = ProgramSummary(st, direction, out, result)
            if progress is not None:
                progress(str(summary))
            summaries.append(summary)
    return summaries


def program(
    root: str | Path,
    stage: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[TorqueProgram]:
    """``rsp-inertia program``: :func:`program_summaries`, each run's TorqueProgram only."""
    return [summary.details for summary in program_summaries(root, stage, progress)]


ENCODER_FIGURE = "encoder_error.png"
"""The encoder's error curve that ``calibrate`` draws into EXP when it measured one."""


def calibrate(
    root: str | Path,
    empty: str | Path,
    reference: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """``rsp-inertia calibrate``: EMPTY's and REF's logs -> EXP/calibration.toml (atomically),
    and the encoder's error curve EXP/encoder_error.png when the calibration has one.

    Nothing is written when an input is bad (stages that differ from EXP's, a missing or
    unphysical reference.toml, bad logs).
    """
    from rsp_inertia.estimation.calibration_file import write_calibration_file
    from rsp_inertia.estimation.reading import calibrate_experiment
    from rsp_inertia.plots import encoder_error_figure

    exp = open_experiment(root)
    check_writable(exp.calibration_path)
    result = calibrate_experiment(
        exp,
        open_experiment(empty),
        None if reference is None else open_experiment(reference),
        progress,
    )
    write_calibration_file(exp.calibration_path, result.to_file())
    if result.known.orders:
        encoder_error_figure(
            result.known,
            exp.root / ENCODER_FIGURE,
            f"{exp.device.name}: encoder reading error from the calibration",
        )
    return result


def identify(
    root: str | Path, progress: Callable[[str], None] | None = None
) -> Identification:
    """``rsp-inertia identify``: all stages' logs -> EXP/result.json (written atomically),
    with its provenance: the time, the software and every input's sha256 as identify read
    them (rsp_inertia.provenance)."""
    from rsp_inertia.estimation.reading import identify_experiment
    from rsp_inertia.provenance import make_provenance

    exp = open_experiment(root)
    check_writable(exp.result_path)
    provenance = make_provenance("identify", exp.root, exp.identify_inputs())
    result = identify_experiment(exp, progress)
    result = replace(result, provenance=provenance)
    write_atomic(exp.result_path, result_json(result))
    return result


def result_json(result: Identification) -> str:
    """The text of EXP/result.json: ``result.to_json()`` indented, with a final newline."""
    return json.dumps(result.to_json(), indent=2) + "\n"


BODY_FILE = "body.json"
"""What ``combine`` writes into its output folder."""


def combine(roots: list[str | Path], out: str | Path) -> tuple[Combination, Path]:
    """``rsp-inertia combine``: several identified mountings of one body -> OUT/body.json
    (atomically), the tensor and the whole centre of mass in body axes
    (rsp_inertia.estimation.combine.combine_mountings); returns it with the path written.

    Each folder is an experiment identified as usual, its device.toml's ``[mounting]`` saying
    how the body sat on the rig. A mounting whose inputs changed since identify (its
    result.json's provenance against the folder) gives a warning.

    Raises
    ------
    InputError
        No folder, a folder given twice, folders of different devices (``[device] name``)
        or masses, a folder without result.json or ``[body] mass``, mountings that cannot
        give z_c (rsp_inertia.estimation.combine), an output that cannot be written (found
        before anything is read).
    """
    from rsp_inertia.estimation.combine import combine_mountings, read_mounting
    from rsp_inertia.provenance import input_changes, input_status

    if not roots:
        raise InputError("combine: no experiment folder given: name every mounting's folder")
    exps = [open_experiment(root, protocol=False) for root in roots]
    seen: dict[Path, Path] = {}
    for exp in exps:
        same = seen.setdefault(exp.root.resolve(), exp.root)
        if same is not exp.root:
            raise InputError(f"{exp.root}: given twice (as {same}): each mounting once")
    first = exps[0]
    for exp in exps[1:]:
        if exp.device.name != first.device.name:
            raise InputError(
                f"{exp.root / 'device.toml'}: device.name = {exp.device.name!r} differs from "
                f"{first.root / 'device.toml'}'s {first.device.name!r}: the mountings must be "
                "measured on one device"
            )
    folder = Path(out)
    target = folder / BODY_FILE
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{folder}: --out: is a file, not a folder; nothing was computed")
    check_writable(target if folder.is_dir() else folder)
    mountings = [read_mounting(exp) for exp in exps]
    for exp, mounting in zip(exps[1:], mountings[1:]):
        if mounting.mass != mountings[0].mass:
            raise InputError(
                f"{exp.root / 'device.toml'}: body.mass = {mounting.mass!r} differs from "
                f"{first.root / 'device.toml'}'s {mountings[0].mass!r}: the mountings must be "
                "of one body"
            )
    warnings = []
    for exp in exps:
        recorded = (json.loads(exp.result_path.read_text()).get("provenance") or {}).get("inputs")
        if recorded is None:
            warnings.append(f"{exp.result_path}: records no inputs: whether it still "
                            "describes the folder's logs cannot be checked")
            continue
        changes = input_changes(input_status(exp.root, recorded, exp.identify_inputs()))
        if changes:
            warnings.append(f"{exp.root}: identify again: {'; '.join(changes)}")
    combination = combine_mountings(mountings)
    if warnings:
        combination = replace(combination, warnings=warnings + list(combination.warnings))
    folder.mkdir(parents=True, exist_ok=True)
    write_atomic(target, body_json(combination))
    return combination, target


def body_json(combination: Combination) -> str:
    """The text of OUT/body.json: ``combination.to_json()`` indented, with a final newline."""
    return json.dumps(combination.to_json(), indent=2) + "\n"
