"""Batch benchmarks: accuracy and speed of the whole experiment over a grid of cases.

One :class:`Case` is one virtual experiment end to end through the pipeline (braking,
program, closed-loop reverse, torsion-pendulum runs, identification), with the bearing
friction scaled, the encoder's resolution set and the noise seeded; :func:`run_case` returns
its errors against the virtual device's truth and its timings as one flat row. A sweep
(:func:`run_sweep`) runs many cases on local processes (joblib) or on a Dask cluster, keeps one
JSON file per case so that an interrupted sweep resumes, and :func:`write_report` turns the
rows into the Markdown tables and the chart of ``benchmarks/results/``.

Only the Coulomb (a1) and viscous (a2) friction coefficients are scaled, never the quadratic
one (a3): quadratic drag takes the fraction 1 - exp(-4 pi a3 / M) of the kinetic energy every
turn whatever the speed (25% on stage 1 at the paper's a3, 95% at ten times it), so no
multi-turn braking pass exists at a scaled a3.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import math
import os
import re
import tempfile
import time
import traceback
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import tomlkit
from scipy.optimize import brentq
from threadpoolctl import threadpool_limits

from rsp_inertia.checking import MIN_TURNS_PAST_LAST_NODE
from rsp_inertia.estimation.calibration import known_terms
from rsp_inertia.estimation.identify import identify_pendulum
from rsp_inertia.estimation.pendulum import estimate_pendulum
from rsp_inertia.pipeline import create_default_experiment, identify, program, simulate
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import Log, read_log, write_atomic, write_log
from rsp_inertia.plant.model import ModelParameters, dissipation
from rsp_inertia.plant.virtual import true_parameters
from rsp_inertia.sensitivity import (
    Perturbation,
    default_perturbations,
    run_perturbation,
    sensitivity_figure,
    sensitivity_table,
)

__all__ = [
    "COM_OFFSETS_MM",
    "ENCODER_BITS",
    "FRICTION_FACTORS",
    "METHODS",
    "MIN_TURNS_PAST_LAST_NODE",
    "TORQUE_MARGIN",
    "BenchReport",
    "Case",
    "accuracy_table",
    "bench",
    "code_fingerprint",
    "default_cases",
    "is_timing",
    "run_case",
    "run_sweep",
    "write_report",
]

FRICTION_FACTORS = (0.0, 1.0, 10.0, 100.0)
"""Factors on the paper's Coulomb and viscous friction in the default sweep."""

ENCODER_BITS = (12, 16, 20)
"""Encoder resolutions of the default sweep, bits (counts_per_rev = 2**bits)."""

QUICK_FRICTION_FACTORS = (1.0, 10.0)
"""``--quick``: the paper's friction and ten times it ..."""

QUICK_ENCODER_BITS = (16,)
"""... on the default 16-bit encoder, one seed."""

DEFAULT_COM_MM = 3.0
"""mm, the centre-of-mass offset of most cases (the default body's is 3.9 mm)."""

COM_OFFSETS_MM = (0.0, 3.0, 10.0)
"""Centre-of-mass offsets of the default sweep, mm: a balanced body, a typical one, and one
whose gravity stiffness m g r is 10% of the pendulum's torsion spring (2 kg, 2 N m/rad)."""

COM_FRICTION_FACTORS = (1.0, 10.0)
"""Friction factors at which the offsets other than DEFAULT_COM_MM are run."""

TORQUE_MARGIN = 0.7
"""Fraction of the motor's torque limit the mirror's reverse torque may need; the rest is the
regulator's headroom (gravity, inertia slope, tracking corrections)."""

MAX_PROTOCOL_TRIES = 8
"""Braking torques tried per stage (the default, then halved each time)."""

METHODS = {
    "ls": "RSP least squares",
    "node": "RSP node formula",
    "pendulum": "pendulum classic",
    "pendulum_damped": "pendulum damped fit",
    "pendulum_best": "pendulum best practice",
}
"""Row-key suffixes of the methods (``err_Jk_<key>``, ``std_Jk_<key>``, ``z_Jk_<key>``,
``err_tensor_<key>``) and their names."""

EQUAL_TIME_METHODS = ("pendulum_equal", "pendulum_best_equal")
"""Row-key suffixes of the pendulum reduced from logs cut to the RSP experiment's time."""


@dataclass(frozen=True, order=True)
class Case:
    """One virtual experiment of a sweep; cases sort by friction, bits, seed, then com."""

    friction_factor: float
    """Factor on the paper's Coulomb (a1) and viscous (a2) friction, >= 0; a3 is kept."""
    encoder_bits: int
    """Encoder resolution, bits: counts_per_rev = 2**encoder_bits."""
    seed: int
    """Seed of the virtual device's noise and of the release-angle jitter, >= 0."""
    com_mm: float = DEFAULT_COM_MM
    """Distance of the body's centre of mass from the fixed point O, mm, >= 0, along the
    default body's offset direction."""

    @property
    def name(self) -> str:
        """File-name stem of the case's result, e.g. ``friction10_bits16_com3_seed0``."""
        return (
            f"friction{self.friction_factor:g}_bits{self.encoder_bits}_com{self.com_mm:g}"
            f"_seed{self.seed}"
        )


def default_cases(seeds: int = 2, quick: bool = False) -> list[Case]:
    """The default grid: friction x {0, 1, 10, 100} x bits {12, 16, 20} x ``seeds`` seeds at
    a 3 mm centre-of-mass offset, and the other offsets of COM_OFFSETS_MM at friction x1 and
    x10 for every encoder, on the first seed (a partial factorial: the offset acts through
    gravity, whatever the friction and noise, so its cases need not repeat every cell).

    With ``quick``: friction {1, 10} x 16 bits x one seed, 3 mm.
    """
    if seeds < 1:
        raise InputError(f"--seeds: must be >= 1, got {seeds}")
    if quick:
        return [Case(f, b, 0) for f in QUICK_FRICTION_FACTORS for b in QUICK_ENCODER_BITS]
    cases = [Case(f, b, s) for f in FRICTION_FACTORS for b in ENCODER_BITS for s in range(seeds)]
    cases += [
        Case(f, b, 0, c)
        for f in COM_FRICTION_FACTORS
        for b in ENCODER_BITS
        for c in COM_OFFSETS_MM
        if c != DEFAULT_COM_MM
    ]
    return sorted(cases)


# --- one case ----------------------------------------------------------------------------


def _set_key(text: str, key: str, value: object, where: str) -> str:
    """Replace the value of the one ``key = ...`` line of a TOML text (keeps its comment)."""
    pattern = rf"(?m)^({re.escape(key)}\s*=\s*)[^\s#]+"
    text, n = re.subn(pattern, lambda m: f"{m.group(1)}{value!r}", text)
    if n != 1:
        raise InputError(f"{where}: expected one '{key} =' line, found {n}")
    return text


def _configure(root: Path, case: Case) -> None:
    """Rewrite the default experiment's files for ``case`` (friction, encoder, seed, release)."""
    if case.friction_factor < 0:
        raise InputError(f"case {case.name}: friction_factor must be >= 0")
    if not 1 <= case.encoder_bits <= 31:
        raise InputError(f"case {case.name}: encoder_bits must be in 1..31")
    path = root / "virtual.toml"
    text = path.read_text()
    virtual = open_experiment(root).load_virtual()
    for key in ("coulomb", "viscous"):
        value = getattr(virtual.friction, key) * case.friction_factor
        text = _set_key(text, key, value, str(path))
    text = _set_key(text, "seed", case.seed, str(path))
    # A release angle jittered by the seed changes the encoder's quantization pattern too
    # (the noise seed alone leaves it identical from run to run).
    jitter = np.random.default_rng(case.seed).uniform(-1.0, 1.0)
    release = float(virtual.run.release_angle_deg + jitter)
    text = _set_key(text, "release_angle_deg", release, str(path))
    if case.com_mm < 0:
        raise InputError(f"case {case.name}: com_mm must be >= 0")
    doc = tomlkit.parse(text)
    com = np.asarray(virtual.body.com, dtype=float)
    doc["body"]["com"] = [float(v) for v in com / np.linalg.norm(com) * case.com_mm * 1e-3]
    write_atomic(path, tomlkit.dumps(doc))
    path = root / "device.toml"
    text = _set_key(path.read_text(), "counts_per_rev", 2**case.encoder_bits, str(path))
    write_atomic(path, text)


def _set_protocol(root: Path, stage: int, launch_speed: float, braking_torque: float) -> None:
    """Write one stage's launch speed and braking torque into device.toml."""
    path = root / "device.toml"
    text = path.read_text()
    starts = [m.start() for m in re.finditer(r"(?m)^\[\[stage\]\]", text)] + [len(text)]
    lo, hi = starts[stage - 1], starts[stage]
    block = _set_key(text[lo:hi], "launch_speed", launch_speed, f"{path}: stage[{stage}]")
    block = _set_key(block, "braking_torque", braking_torque, f"{path}: stage[{stage}]")
    write_atomic(path, text[:lo] + block + text[hi:])
    st = load_device(path).stages[stage - 1]
    assert (st.launch_speed, st.braking_torque) == (launch_speed, braking_torque)


def _reverse_torque(params: ModelParameters, speed: float, braking_torque: float) -> float:
    """N m the mirror of a braking pass needs at ``speed``: braking_torque + 2 D(speed).

    The braking obeys M eps = -b - D(Omega); its time reversal runs at -Omega with the same
    acceleration, against the friction, so the motor supplies b + 2 D (METHOD.md §4). The
    benchmark evaluates it with the virtual device's TRUE friction (``params``): it may use the
    truth to choose its protocol, as an operator would from a trial run.
    """
    return braking_torque + 2.0 * float(dissipation(speed, params))


def _fit_protocol(root: Path, stage: int) -> dict:
    """Choose a stage's launch speed and braking torque, and run its braking pass (pipeline).

    Keep the defaults if the mirror's torque (:func:`_reverse_torque`) stays within
    TORQUE_MARGIN of the motor's limit; else lower the launch speed until it does. If the
    braking then covers fewer than MIN_TURNS_PAST_LAST_NODE turns past the last node, halve
    the braking torque (which lets the launch speed rise again, up to its default) and retry.
    When no try gets there (high friction on a light stage: the friction then takes most of
    the energy a launch within the torque margin gives), the try with the most turns is kept
    and ``short_protocol_N`` says so; identification then decides whether it is enough.
    """
    exp = open_experiment(root)
    st = exp.device.stages[stage - 1]
    params = true_parameters(exp.device, stage, exp.load_virtual())
    limit = TORQUE_MARGIN * exp.device.motor.torque_limit
    if _reverse_torque(params, 1e-9, 0.0) >= limit:
        raise InputError(
            f"stage {stage}: the friction alone needs more than {TORQUE_MARGIN:g} of the "
            "motor's torque limit for the reverse pass"
        )
    braking_torque = st.braking_torque
    tries = []
    for _ in range(MAX_PROTOCOL_TRIES):
        speed = st.launch_speed
        if _reverse_torque(params, speed, braking_torque) > limit:
            speed = brentq(
                lambda w, b=braking_torque: _reverse_torque(params, w, b) - limit,
                1e-9,
                st.launch_speed,
                xtol=1e-9,
            )
            speed = math.floor(speed * 1e6) / 1e6  # a value a person would type, still within
        _set_protocol(root, stage, speed, braking_torque)
        braking = simulate(root, stage, "braking")[0]
        tries.append((braking.turns_past_last_node, speed, braking_torque, braking))
        if braking.turns_past_last_node >= MIN_TURNS_PAST_LAST_NODE:
            break
        braking_torque /= 2.0
    turns, speed, braking_torque, braking = max(tries, key=lambda t: t[0])
    if braking is not tries[-1][3]:  # leave the chosen protocol's braking log in place
        _set_protocol(root, stage, speed, braking_torque)
        braking = simulate(root, stage, "braking")[0]
    return {
        f"launch_speed_{stage}": speed,
        f"braking_torque_{stage}": braking_torque,
        f"turns_past_last_node_{stage}": turns,
        f"short_protocol_{stage}": turns < MIN_TURNS_PAST_LAST_NODE,
        f"braking_duration_{stage}": braking.duration,
    }


def _relative_errors(result, virtual, device) -> dict:
    """Per method of METHODS: ``err_Jk_<key>``, the worst relative J_k error over the axes;
    ``std_Jk_<key>``, the worst relative std it reports; ``z_Jk_<key>``, the worst |J_k error|
    / its std; ``err_tensor_<key>``, the worst tensor entry error over the largest principal
    moment. Also ``com_error_mm`` and ``pendulum_axes``.

    The pendulum's J_k are over the axes whose run could be reduced (``pendulum_axes``), its
    tensor needs all of them; the best practice measures about each run's equilibrium axis.
    """
    body = virtual.body
    axes = np.array([a.direction for a in result.axes])
    J_true = np.einsum("ij,jk,ik->i", axes, body.tensor, axes)
    scale = np.linalg.eigvalsh(body.tensor).max()
    estimates = {
        "ls": (np.array([a.J for a in result.axes]), np.array([a.J_std for a in result.axes]),
               J_true, result.entries),
        "node": (np.array([a.J_node for a in result.axes]),
                 np.array([a.J_node_std for a in result.axes]), J_true, result.node_entries),
    }
    pend = result.pendulum
    row: dict = {"pendulum_axes": 0 if pend is None else len(pend.runs)}
    row["pendulum_best_axes"] = _best_axes_count(pend)
    if pend is not None:
        estimates.update(_pendulum_estimates(pend, result, body, device, ""))
    for key in METHODS:
        row.update(_method_errors(estimates.get(key), key, body, scale))
    row["com_error_mm"] = (
        None if result.com is None else float(np.hypot(*(result.com - body.com[:2])) * 1e3)
    )
    return row


def _best_axes_count(pend) -> int:
    """Axes the best-practice pendulum reduced (its runs with enough half cycles)."""
    if pend is None or pend.J_best is None:
        return 0
    return int(np.sum(np.isfinite(pend.J_best)))


def _pendulum_estimates(pend, result, body, device, suffix: str) -> dict:
    """The pendulum methods' (J, J_std, J_true, entries), keyed ``pendulum<...>`` + suffix."""
    where = [(a.stage, a.phi_deg) for a in result.axes]
    index = [where.index((r.stage, r.node_deg)) for r in pend.runs]
    axes = np.array([result.axes[i].direction for i in index])
    J_true = np.einsum("ij,jk,ik->i", axes, body.tensor, axes)
    out = {
        "pendulum" + suffix: (pend.J_classic, pend.J_classic_std, J_true, pend.entries_classic),
        "pendulum_damped" + suffix: (pend.J_damped, pend.J_damped_std, J_true,
                                     pend.entries_damped),
    }
    if pend.J_best is not None and np.any(np.isfinite(pend.J_best)):
        best_axes = pend.best_axes(device)
        J_true_best = np.einsum("ij,jk,ik->i", best_axes, body.tensor, best_axes)
        out["pendulum_best" + suffix] = (pend.J_best, pend.J_best_std, J_true_best,
                                         pend.entries_best)
    return out


def _method_errors(estimate, key: str, body, scale: float) -> dict:
    """``err_Jk_``, ``std_Jk_``, ``z_Jk_`` and ``err_tensor_`` + key of one method's
    (J, J_std, J_true, entries); None where it has nothing (NaN J: a failed run)."""
    names = [f"{name}_{key}" for name in ("err_Jk", "std_Jk", "z_Jk", "err_tensor")]
    if estimate is None:
        return dict.fromkeys(names)
    J, J_std, J_true, entries = estimate
    J, J_std = np.asarray(J, dtype=float), np.asarray(J_std, dtype=float)

    def worst(values):
        return float(np.nanmax(values)) if np.any(np.isfinite(values)) else None

    return dict(zip(names, (
        worst(np.abs(J / J_true - 1.0)),
        worst(J_std / J_true),
        worst(np.abs(J - J_true) / J_std),
        None if entries is None else float(np.max(np.abs(entries - body.inertia)) / scale),
    )))


def _equal_time_pendulum(root: Path, result, row: dict) -> dict:
    """The pendulum at the RSP experiment's time: the RSP passes' total duration shared by
    the pendulum's runs in proportion to their periods (every run gets the same number of
    oscillations, as a user with that time would plan; a run friction stopped early counts
    with the mean period), each log cut to its share (at most its logged duration) and
    reduced again (classic and best practice, with the same gravity terms). Runs the cut
    leaves too short are left out and said."""
    exp = open_experiment(root)
    device = exp.device
    pend = result.pendulum
    if pend is None or not pend.runs:
        return {}
    runs = sum(len(st.nodes_deg) for st in device.stages)  # the method's runs, failed or not
    periods = np.array([r.period for r in pend.runs])
    total_periods = periods.sum() + (runs - periods.size) * periods.mean()
    shares = np.minimum(
        row["experiment_time_rsp"] * periods / total_periods, device.pendulum.duration
    )
    used = float(shares.sum() + (runs - periods.size) * min(
        row["experiment_time_rsp"] * periods.mean() / total_periods, device.pendulum.duration
    ))
    cut_root = root.parent / f"{root.name}-equal-time"
    cut_root.mkdir()
    (cut_root / "device.toml").write_text((root / "device.toml").read_text())
    cut = open_experiment(cut_root)
    left_out = []
    for r, duration in zip(pend.runs, shares):
        k = device.stages[r.stage - 1].nodes_deg.index(r.node_deg) + 1
        log = read_log(exp.pendulum_path(r.stage, k), device.encoder, "pendulum")
        keep = log.t <= log.t[0] + duration
        short = Log(t=log.t[keep], phi=log.phi[keep], torque=log.torque[keep])
        path = cut.pendulum_path(r.stage, k)
        try:
            estimate_pendulum(short, device.pendulum.stiffness, r.stage, r.node_deg, str(path))
        except InputError as error:
            left_out.append(str(error))
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        write_log(path, short)
    warnings: list[str] = []
    known = known_terms(exp)[0]
    short_pend = identify_pendulum(
        cut, None, known, result.gravity, result.gravity_cov, warnings
    )
    out: dict = {
        "experiment_time_pendulum_equal": used,
        "pendulum_failures_equal": "; ".join(
            w.replace(str(cut_root), "EXP") for w in left_out + warnings
        ) or None,
        "pendulum_axes_equal": 0 if short_pend is None else len(short_pend.runs),
        "pendulum_best_axes_equal": _best_axes_count(short_pend),
    }
    estimates = (
        {} if short_pend is None
        else _pendulum_estimates(short_pend, result, exp.load_virtual().body, device, "_equal")
    )
    body = exp.load_virtual().body
    scale = np.linalg.eigvalsh(body.tensor).max()
    for key in EQUAL_TIME_METHODS:
        out.update(_method_errors(estimates.get(key), key, body, scale))
    return out


def _drop_failing_pendulum_runs(root: Path) -> str:
    """Remove the pendulum logs that the baseline cannot reduce; return their reasons.

    Heavy Coulomb friction stops a torsion pendulum within a few periods, and identify reduces
    the pendulum logs in the same step as the RSP ones (one failing run would fail both): the
    benchmark leaves such runs out, says why, and compares the pendulum on the axes left.
    """
    exp = open_experiment(root)
    device = exp.device
    if device.pendulum is None:
        return ""
    reasons = []
    for stage in exp.stages():
        st = device.stages[stage - 1]
        for k, node_deg in enumerate(st.nodes_deg, 1):
            path = exp.pendulum_path(stage, k)
            if not path.is_file():
                continue
            try:
                log = read_log(path, device.encoder, "pendulum")
                estimate_pendulum(log, device.pendulum.stiffness, stage, node_deg, str(path))
            except InputError as error:
                reasons.append(str(error).replace(str(root), "EXP"))
                path.unlink()
    return "; ".join(reasons)


def run_case(case: Case) -> dict:
    """One virtual experiment end to end; its errors and timings as one flat, JSON-ready row.

    The default experiment (plant/defaults/) in a temporary folder, with the Coulomb and
    viscous friction times ``case.friction_factor``, counts_per_rev = 2**encoder_bits, the
    virtual seed, and the release angle moved by U(-1, 1) deg drawn from the seed. The
    protocol is the default one unless its reverse pass would need more than TORQUE_MARGIN of
    the motor's limit (see :func:`_fit_protocol`). Then, through the pipeline: braking,
    program, closed-loop reverse (per stage), the torsion-pendulum runs, identification.

    Parameters
    ----------
    case : Case
        What to run.

    Returns
    -------
    dict
        ``case`` (its name), the inputs, ``code`` (:func:`code_fingerprint`),
        ``release_angle_deg``; per stage N the protocol used (``launch_speed_N``,
        ``braking_torque_N``, ``turns_past_last_node_N``, ``short_protocol_N``); relative
        errors against the truth, ``err_Jk_<method>`` (worst over the axes of J_k / J_k true
        - 1) and ``err_tensor_<method>`` (worst tensor entry over the largest principal
        moment) for the methods of :data:`METHODS`, ``com_error_mm``, ``axes``,
        ``pendulum_axes`` and ``pendulum_failures`` (the runs left out and why);
        ``physical_duration`` (s, braking and reverse passes); wall-clock times in s
        (``time_*``: smoothing, program and closed loop per stage, pendulum runs,
        identification, processing = programs + identification, the whole case) and their
        ratios to the physical duration (``ratio_*``); ``warnings`` of the identification;
        ``error``: None, or the one-line reason an InputError stopped the case (the row then
        holds only the inputs and ``time_case``).
    """
    start = time.perf_counter()
    row: dict = {"case": case.name, **asdict(case), "code": code_fingerprint()}
    # One BLAS thread: a multithreaded BLAS sums in an order that depends on its thread count,
    # which would change the last digits from one scheduler to another (a sweep runs one case
    # per core anyway).
    with threadpool_limits(limits=1), tempfile.TemporaryDirectory(prefix="rsp-bench-") as tmp:
        root = Path(tmp) / case.name
        try:
            row.update(_run_experiment(root, case))
            row["error"] = None
        except InputError as error:
            row["error"] = str(error).replace(str(root), "EXP")
    row["time_case"] = time.perf_counter() - start
    if row["error"] is None:
        row["ratio_processing"] = row["time_processing"] / row["physical_duration"]
        row["ratio_case"] = row["time_case"] / row["physical_duration"]
    return row


def _run_experiment(root: Path, case: Case) -> dict:
    """:func:`run_case` in the experiment folder ``root``: the row without its bookkeeping."""
    create_default_experiment(root)
    _configure(root, case)
    exp = open_experiment(root)
    row: dict = {"release_angle_deg": exp.load_virtual().run.release_angle_deg}
    stages = exp.stages()
    for stage in stages:
        row.update(_fit_protocol(root, stage))
    physical = 0.0
    for stage in stages:
        t0 = time.perf_counter()
        program(root, stage)
        row[f"time_program_{stage}"] = time.perf_counter() - t0
    for stage in stages:
        t0 = time.perf_counter()
        reverse = simulate(root, stage, "reverse")[0]
        row[f"time_closed_loop_{stage}"] = time.perf_counter() - t0
        physical += row[f"braking_duration_{stage}"] + reverse.duration
    row["physical_duration"] = physical
    t0 = time.perf_counter()
    if open_experiment(root).device.pendulum is not None:
        simulate(root, part="pendulum")
    row["time_pendulum_runs"] = time.perf_counter() - t0
    row["pendulum_failures"] = _drop_failing_pendulum_runs(root) or None
    # identify reports each stage as soon as its two logs are smoothed and balanced: the
    # time between reports is that stage's smoothing (the rest is the fits).
    marks: list[float] = []
    t0 = time.perf_counter()
    result = identify(root, progress=lambda _text: marks.append(time.perf_counter()))
    row["time_identify"] = time.perf_counter() - t0
    previous = t0
    for stage, mark in zip(stages, marks, strict=False):  # then comes the pendulum's report
        row[f"time_smoothing_{stage}"] = mark - previous
        previous = mark
    row["time_processing"] = row["time_identify"] + sum(
        row[f"time_program_{stage}"] for stage in stages
    )
    row["axes"] = len(result.axes)
    row.update(_relative_errors(result, exp.load_virtual(), exp.device))
    row["warnings"] = "; ".join(result.warnings).replace(str(root), "EXP")
    # Experiment time (physical): RSP's braking and reverse passes; the pendulum's logged
    # runs, one per node. Neither calibrates here (device.toml's tares and stiffness are
    # exact on this virtual device), and neither counts setting up, spin-up or deflection.
    row["experiment_time_rsp"] = physical
    pendulum = exp.device.pendulum
    nodes = sum(len(st.nodes_deg) for st in exp.device.stages)
    row["experiment_time_pendulum"] = None if pendulum is None else nodes * pendulum.duration
    if pendulum is not None:
        row.update(_equal_time_pendulum(root, result, row))
    return row


def is_timing(key: str) -> bool:
    """Whether a row key is a wall-clock measurement (differs run to run; all else is exact)."""
    return key.startswith(("time_", "ratio_"))


# --- the sweep ---------------------------------------------------------------------------

PACKAGES = ("plant", "ocp", "estimation", "rsp_inertia")  # folder names
"""The project's packages: where a crash's innermost frame of interest lies."""


def code_fingerprint() -> str:
    """A hash of the source that computes a case (plant, ocp, estimation, the pipeline, this
    module, the default experiment): a cached result is reused only under the same code."""
    digest = hashlib.sha256()
    files = []
    for package in ("rsp_inertia.plant", "rsp_inertia.ocp", "rsp_inertia.estimation"):
        folder = Path(importlib.import_module(package).__file__).parent
        files += sorted(folder.rglob("*.py")) + sorted(folder.rglob("*.toml"))
    files += [Path(importlib.import_module(m).__file__) for m in ("rsp_inertia.pipeline", __name__)]
    for path in files:
        digest.update(f"{path.parent.name}/{path.name}\n".encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _run_guarded(case: Case | Perturbation) -> dict:
    """:func:`run_case` (or the sensitivity study's run_perturbation), with a crash (a bug, not bad input) turned into a row flagged ``bug``.

    One crashing case must not lose a sweep's other results or its report; the row says what
    crashed and where, and is never cached, so the case runs again once the bug is fixed.
    """
    try:
        return run_perturbation(case) if isinstance(case, Perturbation) else run_case(case)
    except Exception as error:  # noqa: BLE001 - reported in its row, never cached
        frames = [
            f
            for f in traceback.extract_tb(error.__traceback__)
            if Path(f.filename).parent.name in PACKAGES
        ]
        where = ""
        if frames:
            path = Path(frames[-1].filename)
            where = f" at {path.parent.name}/{path.name}:{frames[-1].lineno} ({frames[-1].name})"
        return {
            "case": case.name,
            **asdict(case),
            "error": f"bug: {type(error).__name__}: {' '.join(str(error).split())}{where}",
            "bug": True,
        }


def run_sweep(
    cases: Iterable[Case],
    out_dir: str | os.PathLike,
    scheduler: str | None = None,
    jobs: int = -1,
    progress: bool = True,
) -> list[dict]:
    """Run every case not yet in ``out_dir/cases/``; return all rows, sorted by case.

    Parameters
    ----------
    cases : iterable of Case
        The grid; duplicates are run once.
    out_dir : path
        Results folder; one JSON file per case goes to ``out_dir/cases/<case.name>.json``,
        written atomically as soon as the case finishes. A case whose file exists, made by
        the same code (:func:`code_fingerprint`), is not run again, so an interrupted sweep
        resumes where it stopped; a change of the code runs it again. A case that crashes (a
        bug, not an InputError) gets a row flagged ``bug`` and no file.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``): the cases run on its workers
        through ``client.map`` (needs the ``cluster`` extra, and rsp-inertia installed on
        the workers). By default they run on local processes (joblib, loky).
    jobs : int
        Local processes (joblib's n_jobs: -1 = one per core, 1 = in this process).
    progress : bool
        Show a progress bar over the completed cases (on stderr).

    Returns
    -------
    list of dict
        One :func:`run_case` row per case, in the order of the sorted cases: the same inputs
        give the same rows (timings aside) whatever the scheduler.
    """
    from tqdm import tqdm

    cases = sorted(set(cases), key=lambda c: (isinstance(c, Perturbation), c))
    case_dir = Path(out_dir) / "cases"
    case_dir.mkdir(parents=True, exist_ok=True)
    code = code_fingerprint()
    rows: dict[str, dict] = {}
    todo = []
    for case in cases:
        path = case_dir / f"{case.name}.json"
        cached = json.loads(path.read_text()) if path.is_file() else None
        if cached is not None and cached.get("code") == code:
            rows[case.name] = cached
        else:
            todo.append(case)
    run = _on_cluster(todo, scheduler) if scheduler else _on_processes(todo, jobs)
    with tqdm(
        total=len(cases), initial=len(cases) - len(todo), disable=not progress,
        desc="bench", unit="case",
    ) as bar:
        for row in run:
            if not row.get("bug"):
                write_atomic(case_dir / f"{row['case']}.json", json.dumps(row, indent=2) + "\n")
            rows[row["case"]] = row
            bar.set_postfix_str(row["case"] + (" (failed)" if row["error"] else ""))
            bar.update()
    return [rows[case.name] for case in cases]


def _on_processes(cases: Sequence[Case], jobs: int) -> Iterator[dict]:
    """Rows of ``cases`` as they complete, on local processes (checked before any runs)."""
    from joblib import Parallel, delayed

    if jobs == 0:
        raise InputError("--jobs: must not be 0 (-1 = one process per core)")
    if not cases:
        return iter(())
    parallel = Parallel(n_jobs=jobs, return_as="generator_unordered")
    return parallel(delayed(_run_guarded)(case) for case in cases)


def _on_cluster(cases: Sequence[Case], address: str) -> Iterator[dict]:
    """Rows of ``cases`` as they complete, on the Dask cluster at ``address``.

    Importing dask and connecting happen here, before any case runs, so that a missing extra
    or a wrong address is one line of error.
    """
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise InputError(
            "--scheduler: dask.distributed is not installed: pip install 'rsp-inertia[cluster]'"
        ) from None
    if not cases:
        return iter(())
    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as error:
        reason = " ".join(str(error).split()) or type(error).__name__
        raise InputError(f"--scheduler {address}: cannot connect: {reason}") from None

    def rows() -> Iterator[dict]:
        with client:
            futures = client.map(_run_guarded, cases, key=[f"rsp-bench-{c.name}" for c in cases])
            for future in as_completed(futures):
                yield future.result()

    return rows()


# --- the report --------------------------------------------------------------------------


@dataclass(frozen=True)
class BenchReport:
    """What a benchmark run wrote."""

    rows: list[dict]
    """One :func:`run_case` row per case, sorted by case."""
    table: str
    """The accuracy table (Markdown), as in accuracy.md."""
    paths: tuple[Path, ...]
    """accuracy.md, accuracy.png, speed.md."""

    @property
    def crashed(self) -> list[str]:
        """Names of the cases that crashed (bugs; their rows are flagged ``bug``)."""
        return [row["case"] for row in self.rows if row.get("bug")]


def _fmt(value: float | None, spec: str = ".1e") -> str:
    return "-" if value is None else format(value, spec)


def _fmt_z(value: float | None) -> str:
    """|err|/std: one decimal up to 1000, then a power of ten."""
    if value is None:
        return "-"
    return format(value, ".1f") if value < 1000 else format(value, ".0e")


def _groups(rows: list[dict]) -> dict[tuple[float, int, float], list[dict]]:
    """Rows by (friction, bits, com mm), in case order."""
    groups: dict[tuple[float, int, float], list[dict]] = {}
    for row in sorted(rows, key=lambda r: (r["friction_factor"], r["encoder_bits"],
                                           r.get("com_mm", DEFAULT_COM_MM), r["seed"])):
        key = (row["friction_factor"], row["encoder_bits"], row.get("com_mm", DEFAULT_COM_MM))
        groups.setdefault(key, []).append(row)
    return groups


def _stat(rows: list[dict], key: str) -> tuple[float | None, float | None]:
    """Mean and worst of ``key`` over the rows that have it."""
    values = [row[key] for row in rows if row.get(key) is not None]
    if not values:
        return None, None
    return float(np.mean(values)), float(np.max(values))


def _partial_pendulum(row: dict, suffix: str = "", best: bool = False) -> bool:
    """Whether the row's pendulum errors (``best``: the best practice's) cover fewer axes
    than the RSP ones."""
    key = f"pendulum_best_axes{suffix}" if best else f"pendulum_axes{suffix}"
    return row["error"] is None and row.get(key, 0) < row["axes"]


COMPARED = {
    "pendulum": "naive pendulum",
    "pendulum_best": "best-practice pendulum",
    "pendulum_best_equal": "best-practice pendulum at RSP's time",
    "node": "RSP node formula",
    "ls": "RSP least squares",
}
"""The comparison table's methods, in its column order."""


def accuracy_table(rows: list[dict]) -> str:
    """Markdown: the comparison, one row per friction x bits x com offset.

    Per method, worst over the seeds of: the worst relative J_k error over the axes, the
    worst relative std the method reports, and the worst |error| / std. A pendulum cell
    marked * is over fewer axes than six (runs friction stopped too early, said in the
    per-case notes).
    """
    head = ["friction x", "bits", "com mm", "cases ok", "experiment s RSP / pendulum"]
    head += [f"{name}: J_k err (std) worst err/std" for name in COMPARED.values()]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (factor, bits, com), group in _groups(rows).items():
        ok = [row for row in group if row["error"] is None]
        rsp_time = _stat(ok, "experiment_time_rsp")[0]
        pend_time = _stat(ok, "experiment_time_pendulum")[0]
        cells = [f"{factor:g}", f"{bits}", f"{com:g}", f"{len(ok)}/{len(group)}",
                 f"{_fmt(rsp_time, '.0f')} / {_fmt(pend_time, '.0f')}"]
        for key in COMPARED:
            err, std, z = (_stat(ok, f"{kind}_Jk_{key}")[1] for kind in ("err", "std", "z"))
            suffix = "_equal" if key.endswith("_equal") else ""
            mark = "*" if key.startswith("pendulum") and any(
                _partial_pendulum(row, suffix, best="best" in key) for row in ok) else ""
            cells.append(f"{_fmt(err)} ({_fmt(std)}) {_fmt_z(z)}{mark}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def tensor_table(rows: list[dict]) -> str:
    """Markdown: worst over the seeds of each method's worst tensor-entry error over the
    largest principal moment, and the centre of mass's error."""
    head = ["friction x", "bits", "com mm"] + [f"{name} tensor" for name in COMPARED.values()]
    head += ["RSP com mm"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (factor, bits, com), group in _groups(rows).items():
        ok = [row for row in group if row["error"] is None]
        cells = [f"{factor:g}", f"{bits}", f"{com:g}"]
        cells += [_fmt(_stat(ok, f"err_tensor_{key}")[1]) for key in COMPARED]
        cells.append(_fmt(_stat(ok, "com_error_mm")[1]))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def headline(rows: list[dict]) -> str:
    """One paragraph: RSP least squares' worst J_k error against the best-practice pendulum's,
    at the default protocols and at equal time, over the cases where both have all six axes;
    and where the pendulum is as good or better."""
    ok = [r for r in rows if r["error"] is None and r.get("err_Jk_pendulum_best") is not None
          and not _partial_pendulum(r, best=True)]
    if not ok:
        return "No case has both methods on all six axes."
    ratio = np.array([r["err_Jk_pendulum_best"] / r["err_Jk_ls"] for r in ok])
    both = [r for r in ok if r.get("err_Jk_pendulum_best_equal") is not None
            and not _partial_pendulum(r, "_equal", best=True)]
    equal = np.array([r["err_Jk_pendulum_best_equal"] / r["err_Jk_ls"] for r in both])
    at_least = [r["case"] for r in ok if r["err_Jk_pendulum_best"] <= r["err_Jk_ls"]]
    at_least += [f"{r['case']} (at RSP's time)" for r in both
                 if r["err_Jk_pendulum_best_equal"] <= r["err_Jk_ls"]]
    text = (
        f"Over the {len(ok)} cases where both have all six axes, the best-practice pendulum's "
        f"worst J_k error is {np.median(ratio):.0f}x RSP least squares' (median; "
        f"{ratio.min():.1f}x to {ratio.max():.0f}x) with each method's default protocol "
    )
    rsp_time = np.median([r["experiment_time_rsp"] for r in ok])
    pend_time = np.median([r["experiment_time_pendulum"] for r in ok])
    text += f"(RSP {rsp_time:.0f} s of runs, the pendulum {pend_time:.0f} s)"
    if equal.size:
        text += (
            f", and {np.median(equal):.0f}x ({equal.min():.1f}x to {equal.max():.0f}x) with the "
            f"pendulum's runs cut to RSP's time ({equal.size} cases with all six axes)"
        )
    text += ". "
    if at_least:
        text += "The pendulum is as good or better in: " + ", ".join(at_least) + "."
    else:
        text += "In no case is the pendulum as good as RSP's least squares."
    return text


def _case_table(rows: list[dict]) -> str:
    """Markdown: every case, its protocol and errors; then the notes (failures, short runs)."""
    head = ["case", "launch speeds rad/s", "braking torques N m", "turns past last node"]
    head += [f"{name} J_k" for name in METHODS.values()]
    head += [f"{name} tensor" for name in METHODS.values()]
    head += ["best practice at RSP's time J_k", "experiment s RSP / pendulum / cut"]
    head += ["com mm", "pendulum axes", "RSP LS worst |err|/std", "pendulum best worst |err|/std",
             "warnings"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    notes = []
    for row in rows:
        if row["error"] is not None:
            lines.append(f"| {row['case']} | failed |" + " |" * (len(head) - 2))
            notes.append(f"- {row['case']}: failed: {row['error']}")
            continue
        stages = sorted(int(k.rsplit("_", 1)[1]) for k in row if k.startswith("launch_speed_"))
        cells = [
            row["case"],
            ", ".join(f"{row[f'launch_speed_{s}']:g}" for s in stages),
            ", ".join(f"{row[f'braking_torque_{s}']:g}" for s in stages),
            ", ".join(f"{row[f'turns_past_last_node_{s}']:.2f}" for s in stages),
        ]
        cells += [_fmt(row[f"err_Jk_{k}"]) for k in METHODS]
        cells += [_fmt(row[f"err_tensor_{k}"]) for k in METHODS]
        cells.append(_fmt(row.get("err_Jk_pendulum_best_equal")))
        cells.append(" / ".join(
            _fmt(row.get(f"experiment_time_{k}"), ".0f")
            for k in ("rsp", "pendulum", "pendulum_equal")
        ))
        cells += [_fmt(row["com_error_mm"]), f"{row['pendulum_axes']}/{row['axes']}"]
        z = row.get("z_Jk_ls")  # absent from the rows of older sweeps
        warned = len(row["warnings"].split("; ")) if row["warnings"] else 0
        zb = row.get("z_Jk_pendulum_best")
        cells += ["" if z is None else f"{z:.1f}", "" if zb is None else f"{zb:.1f}", str(warned)]
        lines.append("| " + " | ".join(cells) + " |")
        short = [s for s in stages if row[f"short_protocol_{s}"]]
        if short:
            notes.append(
                f"- {row['case']}: stage(s) {', '.join(map(str, short))}: fewer than "
                f"{MIN_TURNS_PAST_LAST_NODE:g} braking turns past the last node within the "
                "torque margin; the longest braking found was used"
            )
        if row["pendulum_failures"]:
            notes.append(f"- {row['case']}: pendulum runs left out: {row['pendulum_failures']}")
        if row.get("pendulum_failures_equal"):
            notes.append(
                f"- {row['case']}: at RSP's time, pendulum runs left out or not reduced by the "
                f"best practice: {row['pendulum_failures_equal'][:400]}"
            )
        if row["warnings"]:
            notes.append(f"- {row['case']}: warnings: {row['warnings'][:300]}")
    if notes:
        lines += ["", "Notes:", "", *notes]
    return "\n".join(lines)


def _speed_table(rows: list[dict]) -> str:
    ok = [row for row in rows if row["error"] is None]
    if not ok:
        return "(no successful case)"
    stages = sorted(int(k.rsplit("_", 1)[1]) for k in ok[0] if k.startswith("time_program_"))
    columns = [("physical s", "physical_duration", ".1f")]
    for label, key in (("smoothing", "smoothing"), ("program", "program"),
                       ("closed loop", "closed_loop")):
        columns += [(f"{label} {s} s", f"time_{key}_{s}", ".2f") for s in stages]
    columns += [
        ("pendulum runs s", "time_pendulum_runs", ".2f"),
        ("identification s", "time_identify", ".2f"),
        ("processing s", "time_processing", ".2f"),
        ("whole case s", "time_case", ".1f"),
        ("processing / physical", "ratio_processing", ".3f"),
        ("case / physical", "ratio_case", ".3f"),
    ]
    lines = [
        "| case | " + " | ".join(c[0] for c in columns) + " |",
        "|" + "---|" * (len(columns) + 1),
    ]
    for row in ok:
        lines.append(
            f"| {row['case']} | " + " | ".join(format(row[k], f) for _, k, f in columns) + " |"
        )
    means = [format(float(np.mean([row[k] for row in ok])), f) for _, k, f in columns]
    lines.append("| **mean** | " + " | ".join(means) + " |")
    return "\n".join(lines)


def _accuracy_figure(rows: list[dict], path: Path, command: str) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from rsp_inertia.plots import save_figure

    # Over friction x bits at the default offset (the other offsets: the tables).
    groups = {(f, b): g for (f, b, c), g in _groups(rows).items() if c == DEFAULT_COM_MM}
    factors = sorted({f for f, _ in groups})
    bits_all = sorted({b for _, b in groups})
    fig = Figure(figsize=(4.2 * len(bits_all) + 1.0, 4.4), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(bits_all), sharey=True, squeeze=False)[0]
    x = np.arange(len(factors))  # friction 0 has no place on a log axis: categories
    for ax, bits in zip(axes, bits_all, strict=True):
        for i, (key, name) in enumerate(METHODS.items()):
            mean, worst = [], []
            for factor in factors:
                ok = [r for r in groups.get((factor, bits), []) if r["error"] is None]
                m, w = _stat(ok, f"err_Jk_{key}")
                mean.append(np.nan if m is None else m)
                worst.append(np.nan if w is None else w)
            color = f"C{i}"
            ax.plot(x, mean, "o-", color=color, label=name)
            ax.plot(x, worst, "v--", color=color, alpha=0.6, lw=1)
        if not any(r["error"] is None for f in factors for r in groups.get((f, bits), [])):
            ax.text(0.5, 0.5, "no case succeeded\n(see accuracy.md)", ha="center",
                    va="center", transform=ax.transAxes, color="grey")
        ax.axhline(1e-4, color="k", lw=0.8, ls=":", label="target 1e-4")
        ax.set_yscale("log")
        ax.set_xticks(x, [f"x{f:g}" for f in factors])
        ax.set_xlabel("bearing friction (Coulomb and viscous) / paper's")
        ax.set_title(f"{bits}-bit encoder")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("worst relative error of J_k over the 6 axes")
    handles, _ = axes[-1].get_legend_handles_labels()
    handles += [
        Line2D([], [], color="grey", marker="o", ls="-", label="mean over seeds"),
        Line2D([], [], color="grey", marker="v", ls="--", alpha=0.6, label="worst over seeds"),
    ]
    axes[-1].legend(handles=handles, fontsize=7, loc="best")
    fig.suptitle(
        f"RSP and torsion-pendulum accuracy over seeds (com {DEFAULT_COM_MM:g} mm)\n$ {command}",
        fontsize=9,
    )
    save_figure(fig, path)


def write_report(rows: list[dict], out_dir: str | os.PathLike, command: str) -> BenchReport:
    """Write accuracy.md, accuracy.png and speed.md into ``out_dir`` (atomically).

    Parameters
    ----------
    rows : list of dict
        :func:`run_sweep`'s rows.
    out_dir : path
        The results folder (it must exist).
    command : str
        The command line that produced the rows, written into each file.
    """
    out = Path(out_dir)
    sensitivity = [row for row in rows if "source" in row]
    rows = [row for row in rows if "source" not in row]
    table = accuracy_table(rows)
    failed = [row for row in rows if row["error"] is not None]
    seeds = sorted({row["seed"] for row in rows})
    accuracy = [
        "# Accuracy: RSP against the torsion pendulum",
        "",
        f"Command: `{command}`",
        "",
        (
            "Each case is the default experiment (paper scenario, icosahedron stages) on the "
            "virtual device, end to end: braking, torque program, closed-loop reverse, "
            "torsion-pendulum runs at every node, identification. 'friction x' scales the "
            "Coulomb (a1) and viscous (a2) coefficients of the paper's a = [1e-4, 1e-4, 1e-3]; "
            "the quadratic a3 keeps the paper's value (at 10x it would take 95% of stage 1's "
            "energy every turn). counts_per_rev = 2^bits. 'com mm': the body's centre of mass "
            "this far from the fixed point, along the default body's offset direction "
            f"({', '.join(f'{c:g}' for c in COM_OFFSETS_MM)} mm; the offsets other than "
            f"{DEFAULT_COM_MM:g} mm at friction x"
            f"{' and x'.join(f'{f:g}' for f in COM_FRICTION_FACTORS)}, first seed). Seeds "
            f"{', '.join(map(str, seeds))} set the noise and move the release angle by "
            "U(-1, 1) deg. Protocol: where the default launch speed would make the reverse "
            f"pass need more than {TORQUE_MARGIN:g} of the motor's torque limit "
            "(b + 2 D(Omega), with the virtual device's true friction), the launch speed is "
            "lowered to fit; where the braking then covers fewer than "
            f"{MIN_TURNS_PAST_LAST_NODE:g} turns past the last node, the braking torque is "
            "halved (up to 7 times) and the longest braking kept (per-case table)."
        ),
        "",
        (
            "Methods: the naive pendulum (period from the zero crossings, M = c tau^2 / 4 pi^2, "
            "the spring's stiffness and the tare as stated); the best-practice pendulum "
            "(estimation/pendulum.py: every half cycle fitted on the encoder's edges, Coulomb "
            "and viscous damping, amplitude extrapolation, the gravity stiffness from the RSP "
            "least squares' Gs, Gc; its std from its own budget); the same at RSP's time; "
            "RSP's node formula and its least squares. At RSP's time, the RSP passes' total duration is "
            "shared by the six pendulum runs in proportion to their periods (each log cut to "
            "its share). Experiment time: the physical duration of the runs "
            "each method needs, RSP's braking and reverse passes, the pendulum's six logged "
            "runs of [pendulum] duration; neither counts setting up, spin-up or deflection, and "
            "neither calibrates here: the virtual device's tares and stiffness are exactly "
            "device.toml's (errors in them: sensitivity.md)."
        ),
        "",
        (
            "Cells: worst over the seeds of the worst relative J_k error over the axes, "
            "(the worst relative std the method reports), and the worst |error| / std. "
            "Pendulum cells marked * are over fewer axes: the runs friction stops within 3 "
            "oscillations (or, cut to RSP's time, with too few half cycles) are left out and "
            "named in the per-case notes."
        ),
        "",
        table,
        "",
        (
            "Tensor: worst entry error over the largest principal moment (worst over the "
            "seeds); a pendulum tensor needs all six runs."
        ),
        "",
        tensor_table(rows),
        "",
        "**Headline.** " + headline(rows),
        "",
        "Chart: accuracy.png. Timings: speed.md.",
        "",
        "## Per case",
        "",
        _case_table(rows),
    ]
    if failed:
        accuracy += ["", f"{len(failed)} of {len(rows)} case(s) failed; the notes say why."]
    speed = [
        "# Speed: processing time against the experiment's physical duration",
        "",
        f"Command: `{command}`",
        "",
        (
            f"Wall-clock seconds on this machine ({os.cpu_count()} cores, shared by the cases "
            "that run in parallel and by whatever else runs). Per stage: smoothing "
            "(identification's UKF + RTS of the braking and reverse logs, and their balances), "
            "program generation (smoothing, mirror, nominal fit, OCP, LQR), closed loop (the "
            "virtual device running the program sample by sample, after regenerating the "
            "braking's end state). Identification: the whole identify step (smoothing "
            "included, then least squares, node formula and pendulum reduction). Processing = "
            "programs + identification: what a rig's computer does. Physical: the braking and "
            "reverse passes of all stages (pendulum runs not counted). Whole case: everything, "
            "the virtual device's simulation included (the demo's work)."
        ),
        "",
        _speed_table(rows),
    ]
    paths = (out / "accuracy.md", out / "accuracy.png", out / "speed.md")
    if sensitivity:
        accuracy += [
            "",
            "## Sensitivity to calibration errors",
            "",
            (
                "The default case (friction x1, 16 bits, 3 mm, seed 0) with one constant off "
                "at a time (rsp_inertia/sensitivity.py): the pendulum's torsion stiffness in "
                "device.toml, the rig's torque gain (the logged torque over the applied one, "
                "device.toml says 1), the tares in device.toml; each identified with the "
                "constants stated exact (std 0) and with the error's size stated as their "
                "std. Chart: sensitivity.png."
            ),
            "",
            sensitivity_table(sensitivity),
        ]
        paths += (out / "sensitivity.png",)
        sensitivity_figure(sensitivity, paths[-1], command)
    write_atomic(paths[0], "\n".join(accuracy) + "\n")
    _accuracy_figure(rows, paths[1], command)
    write_atomic(paths[2], "\n".join(speed) + "\n")
    return BenchReport(rows=rows, table=table, paths=paths)


def bench(
    seeds: int = 2,
    quick: bool = False,
    scheduler: str | None = None,
    jobs: int = -1,
    out: str | os.PathLike = Path("benchmarks/results"),
    command: str = "rsp-inertia bench",
    progress: bool = True,
) -> BenchReport:
    """``rsp-inertia bench``: the default sweep (or the quick one) and its report in ``out``.

    Parameters
    ----------
    seeds : int
        Seeds per friction x bits (ignored with ``quick``, which runs one).
    quick : bool
        Friction {1, 10} x 16 bits x 1 seed instead of the default grid.
    scheduler, jobs, progress
        As for :func:`run_sweep`.
    out : path
        Results folder: cases/ (one JSON per case, reused), accuracy.md, accuracy.png,
        speed.md.
    command : str
        The command line to record in the report.
    """
    cases: list = default_cases(seeds, quick)
    if not quick:
        cases += default_perturbations()
    rows = run_sweep(cases, out, scheduler=scheduler, jobs=jobs, progress=progress)
    return write_report(rows, out, command)
