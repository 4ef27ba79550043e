"""One case of the sweep: a virtual experiment end to end, its errors and timings as one row.

A :class:`Case` is the default experiment with the bearing friction scaled, the encoder's
resolution set, the body's centre of mass moved and the noise seeded (:func:`configure`).
:func:`run_case` runs it through the pipeline (braking, program, closed-loop reverse,
torsion-pendulum runs, identification) and returns its errors against the virtual device's
truth (:mod:`benchmarks.truth`) and its timings as one flat, JSON-ready row.
"""

from __future__ import annotations

import hashlib
import importlib
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from benchmarks.experiments import (
    scale_friction,
    seeded,
    vary,
    with_com,
    with_encoder_bits,
)
from benchmarks.protocol import fit_protocol
from benchmarks.scratch import scratch_folder
from benchmarks.truth import (
    best_axes_count,
    identification_errors,
    method_errors,
    pendulum_estimates,
)
from rsp_inertia.estimation.identify import pendulum_baseline
from rsp_inertia.estimation.pendulum import estimate_pendulum
from rsp_inertia.estimation.reading import known_terms, read_calibration
from rsp_inertia.estimation.runs import ExperimentLogs, Sources
from rsp_inertia.identifying import identify
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.progress import lines_to
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import Log, read_log
from rsp_inertia.programming import program
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import experiment_virtual, placed_body

__all__ = [
    "COM_FRICTION_FACTORS",
    "COM_OFFSETS_MM",
    "DEFAULT_COM_MM",
    "ENCODER_BITS",
    "EQUAL_TIME_METHODS",
    "FRICTION_FACTORS",
    "Case",
    "code_fingerprint",
    "configure",
    "default_cases",
    "is_timing",
    "run_case",
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

EQUAL_TIME_METHODS = ("pendulum_equal", "pendulum_best_equal")
"""Row-key suffixes of the pendulum reduced from logs cut to the RSP experiment's time."""

FINGERPRINT_MODULES = (
    "rsp_inertia.scenarios",
    "rsp_inertia.simulating",
    "rsp_inertia.programming",
    "rsp_inertia.identifying",
    "rsp_inertia.calibrating",
    "rsp_inertia.results.common",
    "rsp_inertia.results.identify",
    "rsp_inertia.checking",
    "benchmarks.experiments",
    "benchmarks.protocol",
    "benchmarks.truth",
    "benchmarks.cases",
    "benchmarks.sensitivity",
)
"""Modules outside infra, plant, virtual, ocp, estimation and design whose source computes a
row."""


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


def configure(root: Path, case: Case) -> None:
    """The experiment in ``root`` made ``case``'s: friction, encoder, seed and release, com."""
    if case.friction_factor < 0:
        raise InputError(f"case {case.name}: friction_factor must be >= 0")
    if not 1 <= case.encoder_bits <= 31:
        raise InputError(f"case {case.name}: encoder_bits must be in 1..31")
    if case.com_mm < 0:
        raise InputError(f"case {case.name}: com_mm must be >= 0")
    vary(
        root,
        device=lambda d: with_encoder_bits(d, case.encoder_bits),
        virtual=lambda v: with_com(
            seeded(scale_friction(v, case.friction_factor), case.seed), case.com_mm
        ),
    )


def code_fingerprint() -> str:
    """A hash of the source that computes a case (infra, plant, the virtual device, ocp,
    estimation and design with the default experiment's files, FINGERPRINT_MODULES): a cached row is reused only under the same
    code."""
    digest = hashlib.sha256()
    files = []
    for package in (
        "rsp_inertia.infra", "rsp_inertia.plant", "rsp_inertia.virtual", "rsp_inertia.ocp",
        "rsp_inertia.estimation", "rsp_inertia.design",
    ):
        folder = Path(importlib.import_module(package).__file__).parent
        files += sorted(folder.rglob("*.py")) + sorted(folder.rglob("*.toml"))
    files += [Path(importlib.import_module(m).__file__) for m in FINGERPRINT_MODULES]
    for path in files:
        digest.update(f"{path.parent.name}/{path.name}\n".encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def is_timing(key: str) -> bool:
    """Whether a row key is a wall-clock measurement (differs run to run; all else is exact)."""
    return key.startswith(("time_", "ratio_"))


def run_case(case: Case) -> dict:
    """One virtual experiment end to end; its errors and timings as one flat, JSON-ready row.

    The default experiment (plant/defaults/) in a scratch folder (removed at the end, or
    by the next case or sweep on the machine if the process is killed:
    :mod:`benchmarks.scratch`), configured for ``case`` (:func:`configure`; the release
    angle moved by U(-1, 1) deg drawn from the seed). The protocol is the default one
    unless its reverse pass would need more than TORQUE_MARGIN of the motor's limit
    (:func:`benchmarks.protocol.fit_protocol`). Then, through the pipeline: braking,
    program, closed-loop reverse (per stage), the torsion-pendulum runs, identification.

    Returns
    -------
    dict
        ``case`` (its name), the inputs, ``code`` (:func:`code_fingerprint`),
        ``release_angle_deg``; per stage N the protocol used (``launch_speed_N``,
        ``braking_torque_N``, ``turns_past_last_node_N``, ``short_protocol_N``); the errors
        of :func:`benchmarks.truth.identification_errors` per method of METHODS, ``axes``,
        ``pendulum_failures`` (the runs left out and why), the same for the pendulum at RSP's
        time (``*_equal``); ``physical_duration`` (s, braking and reverse passes); wall-clock
        times in s (``time_*``: smoothing, program and closed loop per stage, pendulum runs,
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
    with threadpool_limits(limits=1), scratch_folder() as tmp:
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
    configure(root, case)
    exp = open_experiment(root)
    row: dict = {"release_angle_deg": experiment_virtual(exp).run.release_angle_deg}
    stages = exp.stages()
    for stage in stages:
        row.update(fit_protocol(root, stage))
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
    with lines_to(lambda _text: marks.append(time.perf_counter())):
        result = identify(root)
    row["time_identify"] = time.perf_counter() - t0
    previous = t0
    for stage, mark in zip(stages, marks, strict=False):  # then comes the pendulum's report
        row[f"time_smoothing_{stage}"] = mark - previous
        previous = mark
    row["time_processing"] = row["time_identify"] + sum(
        row[f"time_program_{stage}"] for stage in stages
    )
    row["axes"] = len(result.axes)
    body = placed_body(exp.device, experiment_virtual(exp))
    row.update(identification_errors(result, body, exp.device))
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
    left_out = []
    cut: dict[tuple[int, int], Log] = {}
    names: dict[tuple[int, int], str] = {}
    for r, duration in zip(pend.runs, shares):
        k = device.stages[r.stage - 1].nodes_deg.index(r.node_deg) + 1
        path = exp.pendulum_path(r.stage, k)
        log = read_log(path, device.encoder, "pendulum")
        keep = log.t <= log.t[0] + duration
        short = Log(t=log.t[keep], phi=log.phi[keep], torque=log.torque[keep])
        name = str(path).replace(str(root), "EXP")
        try:
            estimate_pendulum(short, device.pendulum.stiffness, r.stage, r.node_deg, name)
        except InputError as error:
            left_out.append(str(error))
            continue
        cut[r.stage, k], names[r.stage, k] = short, name
    warnings: list[str] = []
    short_pend = pendulum_baseline(
        ExperimentLogs(
            device, runs={}, pendulum=cut,
            sources=Sources(device="EXP/device.toml", pendulum=names),
        ),
        known_terms(exp, read_calibration(exp))[0], result.gravity, result.gravity_cov,
        warnings=warnings,
    )
    body = placed_body(exp.device, experiment_virtual(exp))
    out: dict = {
        "experiment_time_pendulum_equal": used,
        "pendulum_failures_equal": "; ".join(left_out + warnings) or None,
        "pendulum_axes_equal": 0 if short_pend is None else len(short_pend.runs),
        "pendulum_best_axes_equal": best_axes_count(short_pend),
    }
    estimates = (
        {} if short_pend is None
        else pendulum_estimates(short_pend, result, body, device, "_equal")
    )
    for key in EQUAL_TIME_METHODS:
        out.update(method_errors(estimates.get(key), key, body))
    return out
