"""A torque scale that differs between the braking and the reverse pass: is it identifiable?

    python -m benchmarks.pass_gain [--seeds N] [--drift D] [--protocol A,B,TURNS ...]
        [--protocol-seeds N] [--out DIR]

Issue 37, item 2. A motor that warms up between the passes scales the reverse pass's torque
by 1 + d against the braking's (NdFeB: about -0.1% per kelvin of magnet temperature). In a
run's balance the reverse pass's work is its driving work W_d (the motor drives the body all
through the reverse), so a constant d per run adds the column d W_d(phi): the same column as
a change of the drive's gain h_d, the model tests' drive-loss probe, run by run. The
question is whether the balance's design, with that column per run as an unknown, still
determines the tensor: its rank, its condition, and what freeing d costs in the stds.

The default experiment (both stages, forward; braking and the ideal reverse on the virtual
device, seeded), device.toml's terms exact. Per seed:

- the design with and without one unknown d per run (the tensor fit's own pass gain,
  rsp_inertia.estimation.tensor_fit.pass_gain_unknown): rank, and the condition number of the
  whitened design with unit columns (the weights the least squares uses,
  rsp_inertia.estimation.gls);
- the stds of the entries and of each d with d free, against those without;
- the reverse log's torque scaled by 1 / (1 + D) (so that the body received 1 + D times the
  logged torque in the reverse pass alone): the tensor's error, in stds, fitted without d
  and with d free.

The protocols that make d identifiable: a two-level braking (device.toml ``braking_torque_2``,
``braking_switch_turns``), the braking torque A x the stage's ``braking_torque`` from the
release for TURNS turns, then B x it to the stop (``--protocol A,B,TURNS``, several; by
default :data:`PROTOCOLS`). Per seed of ``--protocol-seeds``: the same designs, each run's d
and its std, the entries' stds with d free over today's protocol's without d (what the
two-level protocol costs or buys against today's), and the largest error in stds with the
drift, d free.

Writes DIR/pass_gain.md and DIR/pass_gain.json (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from benchmarks import RESULTS
from benchmarks.tables import command_line

STAGES = (1, 2)

PROTOCOLS = (
    (0.0, 1.0, 1.0),
    (0.0, 2.0, 2.0),
    (2.0, 0.5, 1.0),
    ((1.0, 10.0, 1.5), (0.0, 1.5, 7.0)),
    ((1.0, 20.0, 2.0), (0.0, 2.0, 9.0)),
)
"""The two-level brakings studied by default: (A, B, TURNS) for every stage, or one per stage
(module docstring)."""


def two_level(device, protocol):
    """``device`` with every stage's braking two-level: ``protocol`` = (A, B, TURNS) for
    every stage, or one such triple per stage."""
    per_stage = protocol if isinstance(protocol[0], (tuple, list)) else [protocol] * len(
        device.stages
    )
    stages = tuple(
        dataclasses.replace(
            st, braking_torque=a * st.braking_torque, braking_torque_2=b * st.braking_torque,
            braking_switch_turns=turns,
        )
        for st, (a, b, turns) in zip(device.stages, per_stage)
    )
    return dataclasses.replace(device, stages=stages)


BRAKINGS: list[tuple[float, float]] = []
"""The last :func:`_balances`' brakings, per stage: (turns, s)."""


def _balances(device, virtual, drift: float):
    """The default stages' balances, the reverse logs' torque divided by 1 + drift."""
    from rsp_inertia.estimation.balance import stage_balance
    from rsp_inertia.estimation.passes import estimate_pass
    from rsp_inertia.virtual import device as vd

    q = device.encoder.quantum
    out = []
    BRAKINGS.clear()
    for stage in STAGES:
        braking = vd.simulate_braking(device, stage, virtual)
        truth = braking.truth
        BRAKINGS.append(
            (abs(truth.end_phi - truth.phi[0]) / (2 * np.pi), float(truth.end_time))
        )
        reverse = vd.simulate_ideal_reverse(device, stage, virtual, braking)
        log = dataclasses.replace(reverse.log, torque=reverse.log.torque / (1.0 + drift))
        two = device.stages[stage - 1].braking_torque_2 is not None
        b = estimate_pass(braking.log, q, "braking", constant_torque=True, two_levels=two)
        r = estimate_pass(log, q, "reverse", sigma_torque=b.sigma_torque)
        out.append(stage_balance(device, stage, b, r))
    return out


def _fit(balances, free: bool):
    """The tensor fit's solution (rsp_inertia.estimation.gls), with one pass-gain unknown d
    per run when ``free``; and the whitened design's rank and condition."""
    from rsp_inertia.estimation.calibration import device_known_terms
    from rsp_inertia.estimation.columns import both_directions
    from rsp_inertia.estimation.gls import (
        _joint_fit,
        assemble_blocks,
        solve_blocks,
        speed_noise_scales,
    )
    from rsp_inertia.estimation.tensor_fit import tensor_block

    known = dataclasses.replace(device_known_terms(DEVICE)[0], calibrated=False)
    both = both_directions(balances)
    # The product's pass gain (rsp_inertia.estimation.tensor_fit.pass_gain_unknown: the body
    # received (1 + d) times the reverse's logged work), in every run when ``free``, in none
    # otherwise, whatever the braking.
    blocks = [
        tensor_block(dataclasses.replace(bal, pass_gain=free), str(k), known, bal.stage in both)
        for k, bal in enumerate(balances)
    ]
    eq = assemble_blocks(blocks)
    scales = speed_noise_scales(eq)
    fit = solve_blocks(eq, scales)
    Aw = _joint_fit(eq, scales, eq.priors).Aw
    Aw = Aw[:, np.linalg.norm(Aw, axis=0) > 0]
    unit = Aw / np.linalg.norm(Aw, axis=0)
    sv = np.linalg.svd(unit, compute_uv=False)
    return fit, int(np.sum(sv > sv[0] * 1e-12)), unit.shape[1], float(sv[0] / sv[-1])


def run_seed(seed: int, drift: float, protocol=None) -> dict:
    """One seed: the designs' rank and condition, the stds, the errors with a drift; with
    today's protocol, or the two-level ``protocol`` (A, B, TURNS)."""
    from rsp_inertia.estimation.tensor_fit import pass_gain_unknown
    from rsp_inertia.plant.geometry import ENTRY_KEYS
    from rsp_inertia.virtual.config import placed_body

    virtual = dataclasses.replace(
        VIRTUAL, run=dataclasses.replace(VIRTUAL.run, seed=seed)
    )
    truth = placed_body(DEVICE, virtual).inertia
    device = DEVICE if protocol is None else two_level(DEVICE, protocol)
    out = {"seed": seed, "drift": drift, "protocol": protocol}
    for label, d in (("clean", 0.0), ("drift", drift)):
        balances = _balances(device, virtual, d)
        out["brakings"] = list(BRAKINGS)
        for free in (False, True):
            fit, rank, columns, cond = _fit(balances, free)
            idx = [fit.index(k) for k in ENTRY_KEYS]
            x, std = fit.x[idx], np.sqrt(np.diag(fit.cov)[idx])
            key = f"{label}_{'free' if free else 'fixed'}"
            out[key] = {
                "rank": rank, "columns": columns, "cond": cond,
                "std": std.tolist(), "err_std": ((x - truth) / std).tolist(),
                "d": [fit.value(pass_gain_unknown(str(k))) for k in range(len(balances))]
                if free
                else [],
            }
    return out


def report(rows: list[dict], command: str, studies: list[dict] = ()) -> str:
    """pass_gain.md: today's protocol's ``rows``, the two-level protocols' ``studies``."""
    drift = rows[0]["drift"]
    first = rows[0]
    lines = [
        "# A torque scale that differs between the passes: identifiability",
        "",
        f"Made by `{command}` (benchmarks/pass_gain.py; its docstring says what is fitted).",
        "",
        "## The design",
        "",
        "| design | unknowns | rank | condition (whitened, unit columns) |",
        "|---|---|---|---|",
        (f"| tensor, gravity, each run's constant and friction slopes | "
        f"{first['clean_fixed']['columns']} | {first['clean_fixed']['rank']} | "
        f"{first['clean_fixed']['cond']:.3g} |"),
        (f"| the same and one pass gain d per run | {first['clean_free']['columns']} | "
        f"{first['clean_free']['rank']} | {first['clean_free']['cond']:.3g} |"),
        "",
        "## What freeing d costs, and what it buys",
        "",
        (f"Per seed: the entries' stds with d free over those without (clean logs); each run's "
         f"d with its std on clean logs; with the reverse torque scaled by 1 + {drift:g}, the "
         "largest |error| / std of the entries without d and with d free, and d found."),
        "",
        ("| seed | std ratio (Jx..Jxz) | d clean, 1e-4 | largest err/std, d fixed | "
        "largest err/std, d free | d found, 1e-4 |"),
        "|---|---|---|---|---|---|",
    ]
    for row in rows:
        ratio = np.array(row["clean_free"]["std"]) / np.array(row["clean_fixed"]["std"])
        dc = ", ".join(f"{v * 1e4:+.2f} +- {s * 1e4:.2f}" for v, s in row["clean_free"]["d"])
        dd = ", ".join(f"{v * 1e4:+.2f} +- {s * 1e4:.2f}" for v, s in row["drift_free"]["d"])
        lines.append(
            f"| {row['seed']} | {' '.join(f'{r:.1f}' for r in ratio)} | {dc} | "
            f"{max(abs(e) for e in row['drift_fixed']['err_std']):.1f} | "
            f"{max(abs(e) for e in row['drift_free']['err_std']):.1f} | {dd} |"
        )
    if studies:
        lines += _study_lines(rows, studies)
    return "\n".join(lines) + "\n"


def _study_lines(rows: list[dict], studies: list[dict]) -> list[str]:
    """The two-level protocols' table: per protocol and seed, against today's."""
    base = {row["seed"]: np.array(row["clean_fixed"]["std"]) for row in rows}
    lines = [
        "",
        "## A two-level braking: the protocol that identifies d",
        "",
        ("Each stage's braking at A x its braking_torque from the release for TURNS turns, "
         "then B x it to the stop (device.toml braking_torque_2, braking_switch_turns; one "
         "triple for every stage, or stage 1 / stage 2). "
         "The brakings' turns and durations per stage; rank and condition of the design "
         "with one d per run; each run's d with its std (clean logs); the entries' stds over "
         "today's protocol's without d (same seed), with d fixed (what the protocol itself "
         "costs) and with d free; with the reverse scaled by 1 + drift, the largest "
         "|error| / std of the entries, d free, and d found."),
        "",
        ("| A, B, TURNS | seed | brakings, turns in s | rank | condition, d fixed / free | "
         "d clean, 1e-4 | std ratio to today's, d fixed (Jx..Jxz) | std ratio to today's, "
         "d free (Jx..Jxz) | largest err/std, d free | d found, 1e-4 |"),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in studies:
        protocol = row["protocol"]
        per_stage = protocol if isinstance(protocol[0], (tuple, list)) else [protocol]
        label = " / ".join(f"{a:g}, {b:g}, {turns:g}" for a, b, turns in per_stage)
        free = row["clean_free"]
        ratio = np.array(free["std"]) / base[row["seed"]]
        fixed = np.array(row["clean_fixed"]["std"]) / base[row["seed"]]
        brakings = ", ".join(f"{turns:.1f} in {time:.1f}" for turns, time in row["brakings"])
        dc = ", ".join(f"{v * 1e4:+.2f} +- {s * 1e4:.2f}" for v, s in free["d"])
        dd = ", ".join(f"{v * 1e4:+.2f} +- {s * 1e4:.2f}" for v, s in row["drift_free"]["d"])
        lines.append(
            f"| {label} | {row['seed']} | {brakings} | {free['rank']} of {free['columns']} | "
            f"{row['clean_fixed']['cond']:.3g} / {free['cond']:.3g} | {dc} | "
            f"{' '.join(f'{r:.2f}' for r in fixed)} | {' '.join(f'{r:.2f}' for r in ratio)} | "
            f"{max(abs(e) for e in row['drift_free']['err_std']):.1f} | {dd} |"
        )
    return lines


def _protocol(text: str):
    """``A,B,TURNS`` of --protocol (every stage), or ``A,B,TURNS/A,B,TURNS`` (per stage)."""
    stages = []
    for part in text.split("/"):
        values = tuple(float(v) for v in part.split(","))
        if len(values) != 3:
            raise argparse.ArgumentTypeError(f"expected A,B,TURNS[/A,B,TURNS], got {text!r}")
        stages.append(values)
    return stages[0] if len(stages) == 1 else tuple(stages)


DEVICE = None
VIRTUAL = None


def main(argv: list[str] | None = None) -> int:
    global DEVICE, VIRTUAL
    import rsp_inertia.plant
    from rsp_inertia.plant.config import load_device
    from rsp_inertia.virtual.config import load_virtual

    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.pass_gain", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--seeds", type=int, default=5, help="seeds (5)")
    parser.add_argument("--drift", type=float, default=2e-4, help="reverse pass's scale (2e-4)")
    parser.add_argument(
        "--protocol", type=_protocol, action="append",
        help="a two-level braking A,B,TURNS, or A,B,TURNS/A,B,TURNS per stage (several; "
        "default: PROTOCOLS)",
    )
    parser.add_argument(
        "--protocol-seeds", type=int, default=2, help="seeds per two-level protocol (2)"
    )
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder (benchmarks/results)")
    args = parser.parse_args(argv)
    defaults = Path(rsp_inertia.plant.__file__).parent / "defaults"
    DEVICE = load_device(defaults / "device.toml")
    VIRTUAL = load_virtual(defaults / "virtual.toml")
    rows = []
    for seed in range(args.seeds):
        rows.append(run_seed(seed, args.drift))
        row = rows[-1]
        print(
            f"seed {seed}: fixed {max(abs(e) for e in row['drift_fixed']['err_std']):.1f} std, "
            f"free {max(abs(e) for e in row['drift_free']['err_std']):.1f} std",
            file=sys.stderr,
        )
    studies = []
    for protocol in args.protocol or PROTOCOLS:
        for seed in range(min(args.protocol_seeds, args.seeds)):
            studies.append(run_seed(seed, args.drift, protocol))
            free = studies[-1]["clean_free"]
            print(
                f"protocol {protocol} seed {seed}: condition {free['cond']:.3g}, d std "
                + ", ".join(f"{s:.2g}" for _, s in free["d"]),
                file=sys.stderr,
            )
    args.out.mkdir(parents=True, exist_ok=True)
    command = command_line("pass_gain", argv if argv is not None else sys.argv[1:])
    (args.out / "pass_gain.md").write_text(report(rows, command, studies))
    (args.out / "pass_gain.json").write_text(json.dumps(rows + studies, indent=1) + "\n")
    print(f"-> {args.out / 'pass_gain.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
