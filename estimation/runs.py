"""The runs of an experiment: which (stage, direction) pairs it has, and their passes read.

A run is one stage in one direction of rotation (device.toml ``[[stage]] directions``): its
braking log and its reverse log. A backward run is mirrored into the forward coordinate
(rsp_inertia.estimation.balance mirror_log), so everything downstream treats it as a forward run.
"""

from __future__ import annotations

from rsp_inertia.estimation.balance import StageBalance, mirror_log, stage_balance
from rsp_inertia.estimation.passes import PassEstimate, check_braking_monotone, estimate_pass
from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.experiment import Experiment
from rsp_inertia.plant.logs import Log, align_counter, read_log

__all__ = ["estimate_run", "read_run", "run_balances", "runs"]


def runs(device: Device) -> list[tuple[int, str]]:
    """(stage, direction) of every run of the device, stage by stage."""
    return [
        (stage, direction)
        for stage, st in enumerate(device.stages, 1)
        for direction in st.directions
    ]


def read_run(
    exp: Experiment, stage: int, direction: str, warnings: list[str]
) -> tuple[PassEstimate, PassEstimate]:
    """Both passes of one run, read, checked and estimated (a backward run mirrored)."""
    device = exp.device
    b_path = exp.braking_path(stage, direction)
    r_path = exp.reverse_path(stage, direction)
    braking = read_log(b_path, device.encoder, "braking", direction)
    # The reverse starts where the braking stopped: one counter, one angle.
    reverse = align_counter(
        read_log(r_path, device.encoder, "reverse", direction), float(braking.phi[-1]),
        device.encoder,
    )
    return estimate_run(device, braking, reverse, direction, warnings, str(b_path), str(r_path))


def estimate_run(
    device: Device,
    braking: Log,
    reverse: Log,
    direction: str,
    warnings: list[str],
    braking_source: str = "braking",
    reverse_source: str = "reverse",
    braking_smoothed: Smoothed | None = None,
) -> tuple[PassEstimate, PassEstimate]:
    """Both passes of one run from their logs in memory, checked and estimated (a backward
    run mirrored); the sources name the logs in messages. ``braking_smoothed``: the
    (mirrored) braking log's smoothed states when already computed (rsp_inertia.ocp.program's)."""
    q = device.encoder.quantum
    if direction == "backward":
        braking, reverse = mirror_log(braking, q), mirror_log(reverse, q)
    check_braking_monotone(braking, braking_source)
    rate = device.encoder.sample_rate
    b_est = estimate_pass(
        braking, q, braking_source, constant_torque=True, smoothed=braking_smoothed,
        sample_rate=rate,
    )
    if b_est.torque_mean is None:
        warnings.append(
            f"{braking_source}: the braking torque is not constant within the log's noise "
            f"(p = {b_est.constancy_p:.2g}); its work is summed row by row, with a larger "
            "uncertainty"
        )
    # The torque channel's logging noise shows cleanly only in the braking log (constant
    # applied torque); the reverse's own changes are largely real regulator torque.
    r_est = estimate_pass(
        reverse, q, reverse_source, sigma_torque=b_est.sigma_torque, sample_rate=rate
    )
    return b_est, r_est


def run_balances(
    exp: Experiment, warnings: list[str], progress=None
) -> tuple[list[StageBalance], list[tuple[int, int, PassEstimate, PassEstimate]]]:
    """Every run's balance equations (rsp_inertia.estimation.balance), and its passes for the node formula
    as (stage, sign, braking, reverse), sign +1 forward and -1 backward."""
    balances, passes = [], []
    for stage, direction in runs(exp.device):
        b_est, r_est = read_run(exp, stage, direction, warnings)
        sign = 1 if direction == "forward" else -1
        balances.append(stage_balance(exp.device, stage, b_est, r_est, sign))
        passes.append((stage, sign, b_est, r_est))
        if progress is not None:
            progress(
                f"{exp.root}: stage {stage} {direction}: {len(b_est.log)} + {len(r_est.log)} "
                "rows smoothed and balanced"
            )
    return balances, passes
