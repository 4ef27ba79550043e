"""The experiment pipeline behind the commands: files in, files out, no physics here.

Each function takes an experiment folder, calls the library (plant/, estimation/, ocp/) and
writes the outputs atomically. What it did comes back as small summary records that the
command line prints.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rsp_inertia.plant.config import DIRECTIONS
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.experiment import Experiment, open_experiment
from rsp_inertia.plant.logs import (
    align_counter,
    read_log,
    read_program,
    write_atomic,
    write_log,
    write_program,
)

# Each command imports what it uses inside its function: ``program`` must not pay for the
# identification's modules (scipy.stats, the GLS) nor ``identify`` for the OCP's.
if TYPE_CHECKING:
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.results import Identification
    from rsp_inertia.ocp.program import ProgramResult
    from rsp_inertia.plant.virtual import SimulatedPass

__all__ = [
    "DEFAULT_EXPERIMENT",
    "PassSummary",
    "ProgramSummary",
    "calibrate",
    "create_default_experiment",
    "create_rig_experiment",
    "demo",
    "format_identification",
    "identify",
    "program",
    "program_summaries",
    "result_json",
    "simulate",
]

DEFAULT_EXPERIMENT = Path("demo-experiment")
"""Where ``rsp-inertia demo`` builds its experiment when no folder is given."""

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
        read_log(path, exp.device.encoder, "braking", direction),
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
    exp = open_experiment(root)
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
    details: ProgramResult
    """How it was made: the program's arrays, the mirror, the nominal model, the OCP's
    solution, the smoothed braking, the wall time (rsp_inertia.ocp.program.ProgramResult)."""

    def __str__(self) -> str:
        prog = self.details.program
        label = "" if self.direction == "forward" else f" {self.direction}"
        return (
            f"stage {self.stage}{label}: program: {len(prog.t)} rows over {prog.t[-1]:.2f} s, "
            f"peak torque {abs(prog.torque_ff).max():.3f} N m, k_phi "
            f"{prog.k_phi.mean():.3g} N m/rad, k_omega {prog.k_omega.mean():.3g} "
            f"N m s/rad, OCP {self.details.ocp.iterations} iterations; "
            f"{self.details.seconds:.2f} s -> {self.path}"
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
    summaries = []
    for st in exp.stages(stage):
        for direction in exp.device.stages[st - 1].directions:
            path = exp.braking_path(st, direction)
            braking = read_log(path, exp.device.encoder, "braking", direction)
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
) -> list[ProgramResult]:
    """``rsp-inertia program``: :func:`program_summaries`, each run's ProgramResult only."""
    return [summary.details for summary in program_summaries(root, stage, progress)]


def calibrate(
    root: str | Path,
    empty: str | Path,
    reference: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """``rsp-inertia calibrate``: EMPTY's and REF's logs -> EXP/calibration.toml (atomically).

    Nothing is written when an input is bad (stages that differ from EXP's, a missing or
    unphysical reference.toml, bad logs).
    """
    from rsp_inertia.estimation.reading import CALIBRATION_FILE, calibrate_experiment

    exp = open_experiment(root)
    result = calibrate_experiment(
        exp,
        open_experiment(empty),
        None if reference is None else open_experiment(reference),
        progress,
    )
    write_atomic(exp.root / CALIBRATION_FILE, result.to_toml())
    return result


def identify(
    root: str | Path, progress: Callable[[str], None] | None = None
) -> Identification:
    """``rsp-inertia identify``: all stages' logs -> EXP/result.json (written atomically)."""
    from rsp_inertia.estimation.reading import identify_experiment

    exp = open_experiment(root)
    result = identify_experiment(exp, progress)
    write_atomic(exp.result_path, result_json(result))
    return result


def result_json(result: Identification) -> str:
    """The text of EXP/result.json: ``result.to_json()`` indented, with a final newline."""
    return json.dumps(result.to_json(), indent=2) + "\n"


def format_identification(result: Identification, truth: np.ndarray | None = None) -> str:
    """A short human table of an identification (optionally against a known tensor)."""
    from rsp_inertia.estimation.tensor import ENTRY_KEYS
    from rsp_inertia.plant.geometry import relative_errors

    lines = []
    head = f"{'':5} {'RSP least squares':>26} {'RSP node formula':>26}"
    if truth is not None:
        head += f" {'truth':>12} {'LS error':>10} {'node error':>10}"
        ls_error = relative_errors(result.entries, truth)
        node_error = relative_errors(result.node_entries, truth)
    lines.append(head)
    node_std = np.sqrt(np.diag(result.node_entries_cov))
    for k, name in enumerate(ENTRY_KEYS):
        row = (
            f"{name:5} {result.entries[k]:14.8f} +- {result.entries_std[k]:8.1e}"
            f" {result.node_entries[k]:14.8f} +- {node_std[k]:8.1e}"
        )
        if truth is not None:
            row += f" {truth[k]:12.8f} {ls_error[k]:+10.1e} {node_error[k]:+10.1e}"
        lines.append(row)
    if truth is not None:
        lines.append("(errors relative to the largest principal moment)")
    lines.append(f"axes (cond(V) = {result.condition_number:.4f}):")
    for a in result.axes:
        lines.append(
            f"  stage {a.stage} node {a.phi_deg:6.1f} deg: J = {a.J:.8f} +- {a.J_std:.1e}"
            f"  node formula {a.J_node:.8f} +- {a.J_node_std:.1e}  plain {a.J_plain:.8f}"
        )
    if result.std_budget:
        worst = int(np.argmax([a.J_std / a.J for a in result.axes]))
        a = result.axes[worst]
        shares = ", ".join(
            f"{source} {part['axes'][worst] / a.J:.1e}" for source, part in result.std_budget.items()
        )
        lines.append(
            f"uncertainty budget of the least sure axis (stage {a.stage} node {a.phi_deg:g} deg, "
            f"relative std {a.J_std / a.J:.1e}): {shares}"
        )
    if result.friction_asymmetry is not None:
        for k, (e, std) in enumerate(
            zip(result.friction_asymmetry, result.friction_asymmetry_std), 1
        ):
            if np.all(np.isfinite(e)):
                lines.append(
                    f"stage {k}: friction asymmetry D_backward - D_forward = "
                    f"{e[0]:+.2e} +- {std[0]:.0e} N m {e[1]:+.2e} +- {std[1]:.0e} |W| "
                    f"{e[2]:+.2e} +- {std[2]:.0e} W^2"
                )
    if result.calibration is not None:
        cal = result.calibration
        lines.append(
            f"calibration applied: torque gain {cal['torque_gain']:.6f} +- "
            f"{cal['torque_gain_std']:.1e}, empty-system M0 per stage "
            + ", ".join(f"{row[0]:.6f}" for row in cal["empty_inertia"])
            + " kg m^2"
        )
    if result.pendulum is not None:
        pend = result.pendulum
        lines.append(
            "torsion-pendulum baseline (classic / damped fit; best practice +- std, about the "
            "axis at the oscillation's equilibrium):"
        )
        for i, r in enumerate(pend.runs):
            best = ""
            if pend.J_best is not None and np.isfinite(pend.J_best[i]):
                best = (
                    f"; {pend.J_best[i]:.8f} +- {pend.J_best_std[i]:.1e} at "
                    f"{np.degrees(pend.phi_best[i]):.2f} deg"
                )
            lines.append(
                f"  stage {r.stage} node {r.node_deg:6.1f} deg: tau = {r.period:.5f} s,"
                f" J = {pend.J_classic[i]:.8f} / {pend.J_damped[i]:.8f}{best}"
            )
        if truth is not None and pend.entries_classic is not None:
            err_c = np.abs(relative_errors(pend.entries_classic, truth)).max()
            err_d = np.abs(relative_errors(pend.entries_damped, truth)).max()
            err_ls = np.abs(ls_error).max()
            best = ""
            if pend.entries_best is not None:
                err_b = np.abs(relative_errors(pend.entries_best, truth)).max()
                best = f", pendulum best practice {err_b:.1e}"
            lines.append(
                f"worst tensor error / largest moment: RSP {err_ls:.1e}, pendulum classic "
                f"{err_c:.1e}, pendulum damped fit {err_d:.1e}{best}"
            )
    if result.com is not None:
        lines.append(
            f"centre of mass: x = {result.com[0] * 1e3:.4f} +- {result.com_std[0] * 1e3:.4f} mm,"
            f" y = {result.com[1] * 1e3:.4f} +- {result.com_std[1] * 1e3:.4f} mm"
        )
    lines += [f"warning: {w}" for w in result.warnings]
    return "\n".join(lines)


def demo_figures(
    exp: Experiment, result: Identification, folder: str | Path | None = None
) -> list[Path]:
    """The demo's PNG figures: Fig. 1, and per stage Fig. 3 and Fig. 4; error chart.

    Fig. 4 shows what a rig sees: the program's reference speed against the smoothed speed
    of the reverse log (forward runs). Fig. 3 (the free motions) and the error chart need
    the virtual device's truth, so they are drawn only for a virtual experiment (with
    virtual.toml; the error chart with its [body]); Fig. 4 only for a stage with a
    stageN/program.csv (a closed-loop reverse). The demo has all of them and gets every
    figure. Written into ``folder`` (created if needed; default: the experiment folder);
    returns the paths written, in that order.
    """
    # Imported here: only the demo draws, and matplotlib costs the other commands a second.
    from rsp_inertia.design import plot_cone_conditioning
    from rsp_inertia.estimation.smoothing import smooth_log
    from rsp_inertia.plant.geometry import design_matrix
    from rsp_inertia.plant.virtual import free_motion
    from rsp_inertia.plots import plot_errors, plot_motion, plot_tracking

    out = exp.root if folder is None else Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    device = exp.device
    virtual = exp.load_virtual() if exp.virtual_path.is_file() else None
    paths = [out / "design.png"]
    plot_cone_conditioning(paths[0])
    for st in exp.stages():
        has_program = exp.program_path(st).is_file()
        if virtual is None and not has_program:
            continue
        braking = read_log(exp.braking_path(st), device.encoder, "braking")
        reverse = read_log(exp.reverse_path(st), device.encoder, "reverse")
        sb = smooth_log(braking, device.encoder.quantum)
        sr = smooth_log(reverse, device.encoder.quantum)
        if virtual is not None:
            duration = float(braking.t[-1] + reverse.t[-1])
            paths.append(out / f"motion_stage{st}.png")
            plot_motion(
                paths[-1],
                (sb.t, sb.omega),
                (sr.t, sr.omega),
                free_motion(device, st, virtual, duration, damped=False)[::2],
                free_motion(device, st, virtual, duration, damped=True)[::2],
                f"Stage {st}: RSP motion and free motions (paper Fig. 3)",
            )
        if has_program:
            prog = read_program(exp.program_path(st), device.encoder)
            n = min(len(prog.t), len(sr.t))
            paths.append(out / f"tracking_stage{st}.png")
            plot_tracking(
                paths[-1],
                prog.t[:n],
                prog.omega_ref[:n],
                sr.omega[:n],
                f"Stage {st}: reverse pass, reference and smoothed output (paper Fig. 4)",
            )
    if virtual is None or virtual.body is None:  # no truth to compare with
        return paths
    # The true moments about the axes: J_k = V_k . J (docs/method.md §5).
    J_true = design_matrix(np.array([a.direction for a in result.axes])) @ virtual.body.inertia
    errors = {
        "RSP least squares": np.array([a.J for a in result.axes]) / J_true - 1,
        "RSP node formula": np.array([a.J_node for a in result.axes]) / J_true - 1,
    }
    if result.pendulum is not None and len(result.pendulum.runs) == len(result.axes):
        errors["pendulum classic"] = result.pendulum.J_classic / J_true - 1
        errors["pendulum damped fit"] = result.pendulum.J_damped / J_true - 1
        pend = result.pendulum
        if pend.J_best is not None:
            # About the axis at each run's equilibrium, where the best practice measures.
            J_best_true = design_matrix(pend.best_axes(exp.device)) @ virtual.body.inertia
            errors["pendulum best practice"] = pend.J_best / J_best_true - 1
    labels = [f"s{a.stage} {a.phi_deg:g} deg" for a in result.axes]
    paths.append(out / "errors.png")
    plot_errors(paths[-1], labels, errors, "Relative error of each axial moment, per method")
    return paths


def demo(
    root: str | Path = DEFAULT_EXPERIMENT, progress: Callable[[str], None] | None = None
) -> Identification:
    """``rsp-inertia demo``: the whole real-rig workflow on the virtual device.

    The rig of :func:`create_rig_experiment`: for the body and for both calibration
    experiments, every stage's braking passes in both directions, their torque programs and
    the closed-loop reverse passes; the torsion-pendulum runs (in the calibration folders
    too: they give the torsion element's stiffness); an identification without calibration
    (its warnings and error shown); ``calibrate``; the identification, printed
    against the virtual device's true tensor, with figures.
    """
    from rsp_inertia.estimation.reading import CALIBRATION_FILE
    from rsp_inertia.plant.geometry import relative_errors

    say = progress or (lambda _text: None)
    root, empty, reference = create_rig_experiment(root)
    say(f"experiment folder: {root}; calibration runs: {empty}, {reference}")
    for folder in (empty, reference, root):
        simulate(folder, part="braking", progress=lambda s: say(str(s)))
        program(folder, progress=say)
        simulate(folder, part="reverse", progress=lambda s: say(str(s)))
    for folder in (empty, reference, root):  # calibration folders: the torsion element's runs
        if open_experiment(folder).device.pendulum is not None:
            simulate(folder, part="pendulum", progress=lambda s: say(str(s)))
    exp = open_experiment(root)
    truth = exp.load_virtual()
    (root / CALIBRATION_FILE).unlink(missing_ok=True)
    raw = identify(root)
    say(
        "without calibration: worst tensor error / largest moment "
        f"{np.abs(relative_errors(raw.entries, truth.body.inertia)).max():.1e}, warnings:"
    )
    for warning in raw.warnings:
        say(f"  {warning}")
    say(f"rsp-inertia calibrate {root} --empty {empty} --reference {reference}")
    say(str(calibrate(root, empty, reference)))
    result = identify(root, progress=say)
    say(format_identification(result, truth.body.inertia))
    say(f"figures -> {', '.join(str(p) for p in demo_figures(exp, result))}")
    if result.com is not None:
        say(f"true centre of mass: x = {truth.body.com[0] * 1e3:.4f} mm, "
            f"y = {truth.body.com[1] * 1e3:.4f} mm")
    say(f"result -> {root / 'result.json'}")
    return result
