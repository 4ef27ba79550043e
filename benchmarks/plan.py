"""Experiment planning end to end on the virtual device -> benchmarks/results/plan.md.

For each scenario: a pilot run per stage (``simulate --part pilot``), ``plan`` (which reads
only device.toml and the pilots), the braking, ``program``, the closed-loop reverse and
``identify``; then against the virtual device's truth: every stage feasible, the share of
reverse samples where the drive saturates (torque limit or torque-rate limit), every J_k's
error, and the std identify reports against the one plan predicted. Also, on the paper's
scenario, the plan's predicted worst std against the default protocol's at the same
duration, and how the predicted std falls with the top speed (why the default is near the
best this motor allows).

    python -m benchmarks.plan [--scenarios paper spring ...]
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks import RESULTS
from benchmarks.experiments import default_experiment, scale_friction, with_stage
from benchmarks.tables import command_line, markdown_table
from benchmarks.truth import true_moments
from rsp_inertia.identifying import identify
from rsp_inertia.infra.files import write_atomic
from rsp_inertia.planning import plan
from rsp_inertia.plant.config import Device, load_device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.geometry import axis_direction
from rsp_inertia.plant.logs import read_log
from rsp_inertia.programming import program
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import Virtual, load_virtual, placed_body

SCENARIOS = ("paper", "spring", "heavy-friction", "com-offset", "cone-z")
CONE_OPENING = 140.0
"""deg, the one-cone-plus-z design's opening (docs/method.md §5: cond(V) least near 140 deg)."""


def _tare(lam: float) -> float:
    """The default fixture's reduced tare (1 + lam^2) I1 + lam^2 I, I1 = 0.002, I = 0.001."""
    return (1 + lam * lam) * 0.002 + lam * lam * 0.001


def build(root: Path, scenario: str) -> None:
    """A scenario's experiment in ``root``: the default one with the scenario's changes."""
    default_experiment(
        root,
        device=lambda d: _scenario_device(d, scenario),
        virtual=lambda v: _scenario_virtual(v, scenario),
    )


def _scenario_device(device: Device, scenario: str) -> Device:
    if scenario == "spring":
        return replace(device, spring=replace(device.spring, stiffness=0.02))
    if scenario == "cone-z":
        lam = math.tan(math.radians(CONE_OPENING) / 2)
        device = with_stage(
            device, 1, gear_ratio=round(lam, 10), tare_inertia=round(_tare(lam), 10),
            nodes_deg=(0.0, 72.0, 144.0, 216.0, 288.0),
        )
        return with_stage(device, 2, gear_ratio=0.0, tare_inertia=_tare(0.0), nodes_deg=(0.0,))
    return device


def _scenario_virtual(virtual: Virtual, scenario: str) -> Virtual:
    if scenario == "heavy-friction":
        return scale_friction(virtual, 30.0)
    if scenario == "com-offset":
        return replace(virtual, body=replace(virtual.body, com=(0.010, -0.004, 0.002)))
    return virtual


def truth_axes(root: Path) -> np.ndarray:
    """True J_k at every node, in identify's order (stages, nodes)."""
    device = load_device(root / "device.toml")
    body = placed_body(device, load_virtual(root / "virtual.toml"))
    dirs = []
    for st in device.stages:
        nodes = [0.0] if st.gear_ratio == 0.0 else st.nodes_deg
        dirs += [axis_direction(math.radians(n), st.gear_ratio) for n in nodes]
    return true_moments(dirs, body.tensor)


def saturation(root: Path, noise: float) -> tuple[float, float]:
    """Largest shares over the stages of reverse samples at the torque limit and at the
    torque-rate limit.

    Read off the reverse log (command + white noise of std ``noise``): at the torque limit
    the logged value lies within 5 noise stds of it; at the rate limit the logged change
    (noise std sqrt 2 sigma) within 3 of its stds of torque_rate_limit dt. The regulator's
    own steps, k_phi q per encoder count, are kept at or below torque_rate_limit dt by its
    bandwidth rule (rsp_inertia.ocp.regulator); on a heavy stage they sit just under it (0.0186 against
    0.02 N m), 9 stds of the logged change away.
    """
    exp = open_experiment(root)
    motor, dt = exp.device.motor, exp.device.encoder.dt
    torque, rate = 0.0, 0.0
    for st in exp.stages(None):
        u = read_log(exp.reverse_path(st), exp.device.encoder, "reverse").torque
        torque = max(torque, float(np.mean(np.abs(u) >= motor.torque_limit - 5 * noise)))
        du = np.abs(np.diff(u))
        rate = max(
            rate, float(np.mean(du >= motor.torque_rate_limit * dt - 3 * math.sqrt(2) * noise))
        )
    return torque, rate


def run(scenario: str, tmp: Path) -> dict:
    root = tmp / scenario
    build(root, scenario)
    simulate(root, part="pilot")
    start = time.perf_counter()
    report = plan(root)
    plan_seconds = time.perf_counter() - start
    p = report.plan
    simulate(root, part="braking")
    prog_times = []
    for st in open_experiment(root).stages(None):
        t0 = time.perf_counter()
        result = program(root, st)[0]
        prog_times.append((time.perf_counter() - t0, float(result.mirror.rest_time)))
    simulate(root, part="reverse")
    identify(root)
    res = json.loads((root / "result.json").read_text())
    J = np.array([a["J"] for a in res["axes"]])
    J_std = np.array([a["J_std"] for a in res["axes"]])
    truth = truth_axes(root)
    err = np.abs(J - truth) / truth
    ratio = J_std / report.predicted_std
    ideal_ratio = J_std / p.axis_std
    noise = load_virtual(root / "virtual.toml").run.torque_noise
    sat = saturation(root, noise)
    front = p.front
    row = {
        "scenario": scenario,
        "protocol": "; ".join(
            f"{c.launch_speed:g} rad/s, {c.braking_torque:.3g} N m, {c.braking_time:.1f} s"
            for c in p.chosen
        ),
        "motion s": p.duration,
        "plan s": plan_seconds,
        "program s / pass s": ", ".join(f"{a:.1f}/{b:.1f}" for a, b in prog_times),
        "torque-limited": sat[0],
        "rate-limited": sat[1],
        "worst J_k err": float(err.max()),
        "worst err/std": float((np.abs(J - truth) / J_std).max()),
        "predicted worst std": float(report.predicted_std.max() / truth.max()),
        "ideal worst std": float(p.worst / truth.max()),
        "std ratio": f"{ratio.min():.2f}-{ratio.max():.2f}",
        "ideal std ratio": f"{ideal_ratio.min():.2f}-{ideal_ratio.max():.2f}",
        "warnings": len(res.get("warnings", [])),
        "current std": (p.current_std / truth.max()) if p.current_std else math.nan,
        "current s": sum(c.run_time for c in p.current) if p.current else math.nan,
        "front": front.tolist(),
        "tradeoff": [
            (stage, speed, None if c is None else c.braking_torque, own, overall)
            for stage, speed, c, own, overall in p.tradeoff
        ],
        "J_ref": float(truth.max()),
    }
    return row


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.plan", description=__doc__.splitlines()[0]
    )
    parser.add_argument(
        "--scenarios", nargs="+", default=list(SCENARIOS), choices=SCENARIOS,
        help="the scenarios to run (default: all)",
    )
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, scenario in enumerate(args.scenarios, 1):
            print(f"[{k}/{len(args.scenarios)}] {scenario} ...", flush=True)
            row = run(scenario, Path(tmp))
            print({key: v for key, v in row.items() if key != "front"}, flush=True)
            rows.append(row)
    keys = [
        "scenario", "protocol", "motion s", "plan s", "program s / pass s", "torque-limited",
        "rate-limited",
        "worst J_k err", "worst err/std", "predicted worst std", "std ratio",
        "ideal std ratio", "warnings",
    ]

    def spec(key: str) -> str:
        return {
            "motion s": ".0f", "plan s": ".1f", "torque-limited": ".2%", "rate-limited": ".1%",
            "worst J_k err": ".2e",
            "worst err/std": ".2f", "predicted worst std": ".2e", "warnings": "d",
        }.get(key, "")

    lines = [
        "# Experiment planning, end to end",
        "",
        f"Command: `{command_line('plan', argv)}`",
        "",
        ("Per scenario: `simulate --part pilot`, `plan` (budget 120 s of motion), braking, "
        "`program`, closed-loop reverse, `identify`, on the virtual device (16-bit encoder, "
        "torque-log noise 1e-4 N m). 'protocol': per stage, launch speed, braking torque and "
        "braking duration chosen; 'torque-limited', 'rate-limited': the largest share of a "
        "stage's reverse samples at the drive's torque limit, and at its torque-rate limit; errors and stds of J_k relative to the largest "
        "true J_k; 'predicted worst std': plan's, from its closed-loop rehearsal on the "
        "nominal model (relative); 'std ratio': identify's J_std over that prediction, range "
        "over axes; 'ideal std ratio': over the ideal reverse's prediction that ranks the "
        "protocols; 'plan s': the whole plan in process, rehearsal included."),
        "",
        *markdown_table(rows, keys, spec),
        "",
    ]
    paper = next((r for r in rows if r["scenario"] == "paper"), None)
    if paper is not None and math.isfinite(paper["current s"]):
        front = np.array(paper["front"])
        within = front[front[:, 0] <= paper["current s"]]
        same = within[-1, 1] / paper["J_ref"] if within.size else math.nan
        lines += [
            "## Against the default protocol (paper scenario)",
            "",
            "Ideal-reverse stds (relative), the planner's ranking, on both sides:",
            "",
            (f"- Default protocol (12 rad/s, 0.005 N m; 3.5 rad/s, 0.12 N m): predicted worst "
            f"std {paper['current std']:.3e} in {paper['current s']:.0f} s of motion."),
            (f"- Best plan within the same {paper['current s']:.0f} s: {same:.3e} "
            f"({paper['current std'] / same:.2f}x smaller)."),
            (f"- Plan within 120 s: {paper['ideal worst std']:.3e} "
            f"({paper['current std'] / paper['ideal worst std']:.2f}x smaller; its closed-loop "
            f"rehearsal {paper['predicted worst std']:.3e})."),
            "",
            "Front (motion time s, best predicted worst std relative):",
            "",
            *[f"- {d:.0f} s: {s / paper['J_ref']:.3e}" for d, s in front],
            "",
            ("Per launch speed (best braking torque, other stage as planned; predicted worst std"
            " of the stage's own J_k, relative):"),
            "",
            *[
                f"- stage {st}, {sp:.3g} rad/s: "
                + ("infeasible" if tq is None else f"{tq:.3g} N m, {own / paper['J_ref']:.3e}")
                for st, sp, tq, own, _ in paper["tradeoff"]
            ],
            "",
            ("Why the default is near the best this rig allows: the worst axes are stage 1's, "
            "and their std falls with the launch speed (the balances' kinetic-energy terms grow "
            "as W^2 while the torque logs' noise grows with the angle covered). The launch "
            "speed is capped by the mirror: the reverse needs u_b + 2 D(W) = u_b + 2 (a1 + a2 W "
            "+ a3 W^2), and with the paper's a3 = 1e-3 N m s^2 that reaches 0.8 x 0.5 N m at "
            "14 rad/s whatever the braking torque. The default's 12 rad/s is already 86% of "
            "that cap; the longer passes a smaller braking torque gives add turns at falling "
            "speed, which the front shows are worth little. Beating the default by 1.5x at "
            "the same time would take a stronger motor (the cap grows as its square root), "
            "less quadratic friction, or less torque-log noise (the reverse's torque log "
            "dominates the budget)."),
            "",
        ]
    RESULTS.mkdir(exist_ok=True)
    write_atomic(RESULTS / "plan.md", "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
