"""A motor that warms through the passes: the torque scale's drift between braking and reverse.

On the default experiment, closed loop (braking, ``program``, reverse), with the warming motor
of :func:`benchmarks.experiments.warming_motor` (NdFeB, alpha = -0.0011/K): for each stage and
direction the mean of the torque constant's factor 1 + alpha (T_magnet - ambient) over the
rows of each pass, and over the pass's motor work (sum of |torque dphi|), and their
difference reverse - braking; the logged (winding) temperature's rise. This is what fixes
:data:`benchmarks.experiments.WARMING_MOTORS`: the drift is linear in the winding's resistance
(the rises are linear in P = I^2 R).

    python -m benchmarks.thermal [--out DIR]

Writes DIR/thermal.md (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.experiments import WARMING_MOTORS, default_experiment, warming_motor
from benchmarks.tables import command_line
from rsp_inertia import api
from rsp_inertia.infra.progress import lines_to
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import read_program
from rsp_inertia.virtual.config import experiment_virtual
from rsp_inertia.virtual.device import run_program, simulate_braking


def _means(sim, tempco: float) -> tuple[float, float]:
    """The factor's mean over the rows and over the motor work of a pass."""
    factor = 1.0 + tempco * sim.truth.magnet
    work = np.abs(sim.truth.torque[:-1] * np.diff(sim.truth.phi))
    return float(np.mean(factor)), float(np.sum(factor[:-1] * work) / np.sum(work))


def drifts(root: Path) -> list[dict]:
    """Per stage and direction: the passes' mean factors and the winding's end rise."""
    with lines_to(None):
        api.simulate(root, part="braking")
        api.program(root)
    exp = open_experiment(root)
    virtual = experiment_virtual(exp)
    tempco = virtual.rig.torque_constant_tempco
    rows = []
    for st in exp.stages(None):
        for d in exp.device.stages[st - 1].directions:
            braking = simulate_braking(exp.device, st, virtual, d)
            program = read_program(exp.program_path(st, d), exp.device.encoder)
            start = (braking.truth.end_phi, 0.0)
            reverse = run_program(
                exp.device, st, virtual, program, start, direction=d,
                motor=braking.truth.end_motor,
            )
            (b_rows, b_work), (r_rows, r_work) = _means(braking, tempco), _means(reverse, tempco)
            rows.append({
                "stage": st, "direction": str(d), "rows": r_rows - b_rows, "work": r_work - b_work,
                "braking_end": braking.truth.end_motor.magnet,
                "reverse_end": reverse.truth.end_motor.magnet,
                "logged_rise": float(reverse.log.temperature[-1] - braking.log.temperature[0]),
            })
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="benchmarks/results")
    args = parser.parse_args(argv)
    lines = [
        "# A warming motor: the torque scale between the passes",
        "",
        f"`{command_line('thermal', argv)}`",
        "",
        ("Default experiment, closed loop; benchmarks.experiments.warming_motor (alpha = "
        "-0.0011/K, 0.5 N m/A at phi, R_th = 4 K/W, tau_w = 60 s, magnets 5 s behind)."),
        "Drift = mean of 1 + alpha (T_magnet - ambient) in the reverse less in the braking.",
        "",
        ("| target | R (ohm) | stage | direction | drift over rows | drift over work "
        "| magnets at braking's end (K) | at reverse's end (K) | logged rise (K) |"),
        "|---|---|---|---|---|---|---|---|---|",
    ]
    start = time.perf_counter()
    for target, resistance in WARMING_MOTORS.items():
        with tempfile.TemporaryDirectory() as tmp:
            root = default_experiment(
                Path(tmp) / "exp", virtual=lambda v, t=target: warming_motor(v, t)
            )
            for r in drifts(root):
                lines.append(
                    f"| {target:g} | {resistance:g} | {r['stage']} | {r['direction']} "
                    f"| {r['rows']:.3e} | {r['work']:.3e} | {r['braking_end']:.3f} "
                    f"| {r['reverse_end']:.3f} | {r['logged_rise']:.1f} |"
                )
    lines += ["", f"{time.perf_counter() - start:.0f} s."]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "thermal.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
