"""A motor that warms between the passes: compensated, named, or budgeted.

    python -m benchmarks.warming [--seeds N] [--clean-seeds N] [--jobs N] [--calibrated]
                                 [--out DIR]

Issue 37's targets on an uncalibrated rig. The default experiment in closed loop (braking,
``program``, reverse) on the virtual device with the warming motor of
:func:`benchmarks.experiments.warming_motor` (NdFeB, alpha = -0.0011/K, the magnets 5 s
behind the winding, its resistance set for a mean drift of 2e-4 or 1e-3 between the braking
and the reverse pass of stage 2), the winding's temperature logged (device.toml ``[log]
temperature_column``). Per drift and seed (the virtual device's noise seed), the motor's true
tempco is one draw from what device.toml states (-0.0011 +- 5e-5 /K), and identify runs
three times on the same logs:

- ``compensated``: device.toml states the tempco (its std, the 5 s lag, the ambient as the
  reference temperature);
- ``uncompensated``: it states nothing of the motor's temperature (as a rig without a
  temperature channel): does a warning name the cause (the model tests' ``warming motor``
  probe, or ``drive loss or warming motor``)?
- ``drift std``: nothing of the temperature either, but ``[motor] torque_constant_drift_std``
  set to the drift the rig may have (the case's drift): are the stds honest?
- ``modelled``: nothing of the temperature, but the motor's thermal time constants
  (``[motor] winding_time_constant`` = the virtual winding's 60 s, ``temperature_lag`` = the
  magnets' 5 s): identify fits the warming's coefficient c from the logged torque's heat;
- ``modelled, tau off``: the same with the time constants stated 25 % and 20 % off (45 s,
  6 s), as a datasheet may be.

And ``--clean-seeds`` experiments without the warming motor (device.toml as the default):
no false alarm of the warming and drive probes, the tensor within 3 stds; and the same logs
identified again with the warming modelled (``clean modelled``): c within 3 stds of 0, the
tensor within 3 stds.

The tensor against the truth: the largest |error| / std, the largest |error| / largest
moment, the warnings. The rig is not calibrated here (device.toml's tares and torque gain,
with their stated stds). With ``--calibrated`` the same three readings on the demo's rig
(rsp_inertia.scenarios.create_rig_experiment: torque gain, lossy drive, unbalanced fixture,
eccentric encoder, friction by direction, every stage both ways), its empty, reference and
body folders all with the warming motor (the same resistance, so the drift differs from the
default experiment's), calibrate run for each reading before identify; its clean seeds
are the demo's rig without the warming motor, calibrated (a false alarm: a warming or drive
warning of calibrate or identify), then calibrated and identified again with the warming
modelled.

Writes DIR/warming.md and DIR/warming.json (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks import RESULTS
from benchmarks.tables import command_line
from rsp_inertia.estimation.model_tests import DRIVE_PROBE, SCALE_PROBES, WARMING_PROBE

DRIFTS = (2e-4, 1e-3)
CASES = ("compensated", "uncompensated", "drift std", "modelled", "modelled, tau off")
"""identify's three readings of each case's logs (module docstring)."""
STATED_TEMPCO = -0.0011
"""1/K, the tempco device.toml states (NdFeB)."""
WARMING_TAUS = (60.0, 5.0)
"""s, the warming motor's winding time constant and magnets' lag
(benchmarks.experiments.warming_motor): what the clean runs' ``clean modelled`` states."""
TEMPCO_STD = 5e-5
"""1/K, its std: the motor's true tempco is drawn from it, per seed."""


def run_case(drift: float, seed: int, work: str) -> dict:
    """One drift and seed: simulate once, identify with and without the compensation."""
    from benchmarks.experiments import (
        closed_loop,
        default_experiment,
        load,
        seeded,
        warming_motor,
        write,
    )
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    root = Path(work) / f"{drift:g}-{seed}"

    def device(d):
        return dataclasses.replace(d, log=dataclasses.replace(d.log, temperature_column="T"))

    # The motor's true tempco is one draw from what device.toml states of it (its std).
    alpha = STATED_TEMPCO + TEMPCO_STD * float(np.random.default_rng(3700 + seed).standard_normal())

    def virtual(v):
        warm = warming_motor(seeded(v, seed), drift)
        return dataclasses.replace(
            warm, rig=dataclasses.replace(warm.rig, torque_constant_tempco=alpha)
        )

    default_experiment(root, device, virtual)
    with lines_to(drop):
        closed_loop(root)
    stated, virtual = load(root)
    truth = placed_body(open_experiment(root).device, experiment_virtual(open_experiment(root)))
    out = {"drift": drift, "seed": seed, "tempco": alpha}
    for label in CASES:
        write(root, _stated(stated, virtual, label, drift))
        out[label] = _identified(root, truth)
    return out


def _stated(device, virtual, label: str, drift: float):
    """device.toml for one reading of :data:`CASES`: the tempco stated (its std, the virtual
    magnets' lag, the ambient as the reference temperature), nothing of the temperature, or
    the drift's std stated as ``drift``."""
    motor = device.motor
    if label == "compensated":
        motor = dataclasses.replace(
            motor, torque_constant_tempco=STATED_TEMPCO, torque_constant_tempco_std=TEMPCO_STD,
            temperature_lag=virtual.rig.magnet_lag,
            reference_temperature=virtual.rig.ambient_temperature,
        )
    elif label == "drift std":
        motor = dataclasses.replace(motor, torque_constant_drift_std=drift)
    elif label.startswith("modelled"):
        off = label.endswith("tau off")
        taus = (virtual.rig.winding_time_constant * (0.75 if off else 1.0),
                virtual.rig.magnet_lag * (1.2 if off else 1.0))
        return _modelled(device, taus)
    return dataclasses.replace(device, motor=motor)


def _modelled(device, taus: tuple[float, float] = WARMING_TAUS):
    """device.toml with the warming modelled: ``[motor] winding_time_constant`` and
    ``temperature_lag`` = ``taus`` (s)."""
    motor = dataclasses.replace(
        device.motor, winding_time_constant=taus[0], temperature_lag=taus[1]
    )
    return dataclasses.replace(device, motor=motor)


def run_calibrated_case(drift: float, seed: int, work: str) -> dict:
    """One drift and seed on the demo's calibrated rig: its three folders simulated once with
    the warming motor, then calibrate and identify for each reading of :data:`CASES`."""
    from benchmarks.experiments import (
        closed_loop,
        drawn_reference,
        load,
        seeded,
        warming_motor,
        write,
    )
    from rsp_inertia import api
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.scenarios import create_rig_experiment
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    folders = create_rig_experiment(Path(work) / f"rig-{drift:g}-{seed}")
    alpha = STATED_TEMPCO + TEMPCO_STD * float(np.random.default_rng(3700 + seed).standard_normal())
    stated = {}
    for folder in folders:
        device, virtual = load(folder)
        warm = warming_motor(seeded(virtual, seed), drift)
        warm = dataclasses.replace(
            warm, rig=dataclasses.replace(warm.rig, torque_constant_tempco=alpha)
        )
        log = dataclasses.replace(device.log, temperature_column="T")
        write(folder, dataclasses.replace(device, log=log), warm)
        stated[folder] = (dataclasses.replace(device, log=log), warm)
    drawn_reference(folders[2], seed)  # the reference's truth: one draw from its certificate
    with lines_to(drop):
        for folder in folders:
            closed_loop(folder)
    root = folders[0]
    truth = placed_body(open_experiment(root).device, experiment_virtual(open_experiment(root)))
    out = {"drift": drift, "seed": seed, "tempco": alpha}
    for label in CASES:
        for folder in folders:
            write(folder, _stated(*stated[folder], label, drift))
        with lines_to(drop):
            calibration = api.calibrate(*folders)
        out[label] = _identified(root, truth)
        out[label]["calibrate_warnings"] = list(calibration.warnings)
    return out


def run_calibrated_clean(seed: int, work: str) -> dict:
    """One seed of the demo's calibrated rig without the warming motor: calibrate, identify."""
    from benchmarks.experiments import closed_loop, drawn_reference, load, seeded, write
    from rsp_inertia import api
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.scenarios import create_rig_experiment
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    folders = create_rig_experiment(Path(work) / f"rig-clean-{seed}")
    for folder in folders:
        write(folder, None, seeded(load(folder)[1], seed))
    drawn_reference(folders[2], seed)  # the reference's truth: one draw from its certificate
    with lines_to(drop):
        for folder in folders:
            closed_loop(folder)
        calibration = api.calibrate(*folders)
    root = folders[0]
    truth = placed_body(open_experiment(root).device, experiment_virtual(open_experiment(root)))
    clean = _identified(root, truth)
    clean["calibrate_warnings"] = list(calibration.warnings)
    clean["named"] = clean["named"] or _named(calibration.warnings)
    for folder in folders:  # the same logs, the warming modelled in every folder
        write(folder, _modelled(load(folder)[0]))
    with lines_to(drop):
        calibration = api.calibrate(*folders)
    modelled = _identified(root, truth)
    modelled["calibrate_warnings"] = list(calibration.warnings)
    return {"seed": seed, "clean": clean, "clean modelled": modelled}


def run_clean(seed: int, work: str) -> dict:
    """One seed without the warming motor: identify once."""
    from benchmarks.experiments import closed_loop, default_experiment, load, seeded, write
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    root = Path(work) / f"clean-{seed}"
    default_experiment(root, None, lambda v: seeded(v, seed))
    with lines_to(drop):
        closed_loop(root)
    truth = placed_body(open_experiment(root).device, experiment_virtual(open_experiment(root)))
    out = {"seed": seed, "clean": _identified(root, truth)}
    write(root, _modelled(load(root)[0]))
    out["clean modelled"] = _identified(root, truth)
    return out


def _identified(root: Path, truth) -> dict:
    """identify on ``root``: the errors in stds and of the largest moment, the warnings."""
    from rsp_inertia import api
    from rsp_inertia.infra.progress import drop, lines_to

    with lines_to(drop):
        result = api.identify(root)
    err = np.asarray(result.entries) - truth.inertia
    return {
        "err_std": (err / np.asarray(result.entries_std)).tolist(),
        "rel_err": (err / truth.inertia[:3].max()).tolist(),
        "warnings": list(result.warnings),
        "named": _named(result.warnings),
        "warming": None if result.identification.warming is None else list(
            result.identification.warming
        ),
    }


def _named(warnings: list[str]) -> str:
    """Which of the pass-scale causes the warnings name: "warming", "either", "drive" or ""."""
    for prefix, name in (
        (f"{WARMING_PROBE}:", "warming"), (f"{SCALE_PROBES}:", "either"),
        (f"{DRIVE_PROBE}:", "drive"),
    ):
        if any(w.startswith(prefix) for w in warnings):
            return name
    return ""


def _largest(case: dict) -> tuple[float, float]:
    return max(map(abs, case["err_std"])), max(map(abs, case["rel_err"]))


def report(rows: list[dict], clean: list[dict], command: str, calibrated: bool = False) -> str:
    """warming.md (warming_calibrated.md)."""
    rig = (
        "The demo's rig (rsp_inertia.scenarios.create_rig_experiment), calibrated by its empty "
        "and reference runs, every folder with the same warming motor. The reference's truth "
        "is one draw from its certificate (reference.toml's values and covariance, seeded by "
        "the seed, as benchmarks.certificate draws it)."
        if calibrated
        else "The default experiment, uncalibrated (device.toml's tares and gain)."
    )
    lines = [
        "# A motor that warms between the passes: compensated, named, or budgeted",
        "",
        rig,
        "",
        f"Made by `{command}` (benchmarks/warming.py; its docstring says what a case is).",
        "",
        ("Per case: the largest |error| / std, the largest |error| / largest moment, and the "
        "warnings (their number, and which pass-scale cause they name: warming, either = "
        "'drive loss or warming motor', drive)."),
        "",
        ("| drift | seed | compensated | warnings | uncompensated | named | "
         "drift std stated | warnings | modelled | warnings | modelled, tau off |"),
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        c, u, d = (row[label] for label in CASES[:3])
        m, o = (row.get(label) for label in CASES[3:])
        lines.append(
            f"| {row['drift']:g} | {row['seed']} | {_largest(c)[0]:.2f}, {_largest(c)[1]:.1e} "
            f"| {len(c['warnings'])} | {_largest(u)[0]:.1f}, {_largest(u)[1]:.1e} | "
            f"{u['named'] or '-'} | {_largest(d)[0]:.2f}, {_largest(d)[1]:.1e} | "
            f"{len(d['warnings'])} ({d['named'] or '-'}) | "
            + (
                f"{_largest(m)[0]:.2f}, {_largest(m)[1]:.1e} | {len(m['warnings'])} | "
                f"{_largest(o)[0]:.2f}, {_largest(o)[1]:.1e} |"
                if m is not None
                else "- | - | - |"
            )
        )
    lines += ["", "| drift | target | result | verdict |", "|---|---|---|---|"]
    for drift in sorted({row["drift"] for row in rows}):
        mine = [row for row in rows if row["drift"] == drift]
        comp = [row["compensated"] for row in mine]
        ratios = np.array([c["err_std"] for c in comp])
        rel = np.array([c["rel_err"] for c in comp])
        inside = int(np.sum(np.all((np.abs(ratios) <= 3.0) & (np.abs(rel) <= 1e-4), axis=1)))
        mean_sq = float(np.mean(ratios**2))
        warned = sum(bool(c["warnings"]) for c in comp)
        named = sum(row["uncompensated"]["named"] in ("warming", "either") for row in mine)
        honest = [row["drift std"] for row in mine]
        within = sum(_largest(c)[0] <= 3.0 for c in honest)
        n = len(mine)
        lines += [
            (f"| {drift:g} | compensated: every entry within 1e-4 and 3 stds | {inside} of {n} "
             f"| {'PASS' if inside == n else 'FAIL'} |"),
            (f"| {drift:g} | compensated: mean (err/std)^2 in [0.5, 2] | {mean_sq:.2f} | "
             f"{'PASS' if 0.5 <= mean_sq <= 2.0 else 'FAIL'} |"),
            f"| {drift:g} | compensated: seeds with a warning | {warned} of {n} | |",
            (f"| {drift:g} | no temperature: a warning naming the warming motor | {named} of "
             f"{n} | {'PASS' if named >= 0.95 * n else 'FAIL'} |"),
            (f"| {drift:g} | no temperature, the drift's std stated: every entry within 3 stds "
             f"| {within} of {n} | {'PASS' if within == n else 'FAIL'} |"),
        ]
        for label in CASES[3:]:
            cases = [row[label] for row in mine if label in row]
            if not cases:
                continue
            ratios = np.array([c["err_std"] for c in cases])
            rel = np.array([c["rel_err"] for c in cases])
            inside = int(np.sum(np.all((np.abs(ratios) <= 3.0) & (np.abs(rel) <= 1e-4), axis=1)))
            mean_sq = float(np.mean(ratios**2))
            warned = sum(bool(c["warnings"]) for c in cases)
            lines += [
                (f"| {drift:g} | no temperature, {label}: every entry within 1e-4 and 3 stds | "
                 f"{inside} of {len(cases)} | {'PASS' if inside == len(cases) else 'FAIL'} |"),
                (f"| {drift:g} | no temperature, {label}: mean (err/std)^2 in [0.5, 2] | "
                 f"{mean_sq:.2f} | {'PASS' if 0.5 <= mean_sq <= 2.0 else 'FAIL'} |"),
                (f"| {drift:g} | no temperature, {label}: seeds with a warning | {warned} of "
                 f"{len(cases)} | |"),
            ]
    if calibrated:
        lines += ["", "calibrate's and identify's warnings per case (seed: count):", ""]
        lines += [
            f"- {row['drift']:g} {row['seed']} {label}: calibrate "
            f"{len(row[label]['calibrate_warnings'])}, identify {len(row[label]['warnings'])}"
            + "".join(f"; {w[:110]}" for w in row[label]["warnings"])
            for row in rows
            for label in CASES
        ]
    if clean:
        cases = [row["clean"] for row in clean]
        alarms = sum(bool(c["named"]) for c in cases)
        within = sum(_largest(c)[0] <= 3.0 for c in cases)
        mean_sq = float(np.mean(np.square([c["err_std"] for c in cases])))
        n = len(cases)
        lines += [
            (f"| clean | no warming or drive warning | {n - alarms} of {n} | "
             f"{'PASS' if alarms == 0 else 'FAIL'} |"),
            f"| clean | every entry within 3 stds | {within} of {n} | |",
            f"| clean | mean (err/std)^2 | {mean_sq:.2f} | |",
        ]
        modelled = [row["clean modelled"] for row in clean if "clean modelled" in row]
        if modelled:
            n = len(modelled)
            within = sum(_largest(c)[0] <= 3.0 for c in modelled)
            zero = sum(abs(c["warming"][0]) <= 3.0 * c["warming"][1] for c in modelled)
            alarms = sum(bool(c["warnings"]) for c in modelled)
            mean_sq = float(np.mean(np.square([c["err_std"] for c in modelled])))
            lines += [
                (f"| clean, warming modelled | c within 3 stds of 0 | {zero} of {n} | "
                 f"{'PASS' if zero == n else 'FAIL'} |"),
                (f"| clean, warming modelled | every entry within 3 stds | {within} of {n} | "
                 f"{'PASS' if within == n else 'FAIL'} |"),
                f"| clean, warming modelled | mean (err/std)^2 | {mean_sq:.2f} | |",
                f"| clean, warming modelled | seeds with a warning | {alarms} of {n} | |",
            ]
        lines += ["", "Clean runs' warnings (seed: count):", ""]
        lines += [
            f"- {row['seed']}: {len(row['clean']['warnings'])}"
            + "".join(f"; {w[:110]}" for w in row["clean"]["warnings"])
            for row in clean
        ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.warming", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--seeds", type=int, default=10, help="seeds per drift (10)")
    parser.add_argument(
        "--clean-seeds", type=int, default=20, help="experiments without the warming motor (20)"
    )
    parser.add_argument("--jobs", type=int, default=2, help="processes (2)")
    parser.add_argument(
        "--calibrated", action="store_true",
        help="the demo's calibrated rig instead (writes warming_calibrated.md/.json)",
    )
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder (benchmarks/results)")
    args = parser.parse_args(argv)
    jobs = [(drift, seed) for drift in DRIFTS for seed in range(args.seeds)]
    with tempfile.TemporaryDirectory() as work, ProcessPoolExecutor(args.jobs) as pool:
        case = run_calibrated_case if args.calibrated else run_case
        futures = [pool.submit(case, drift, seed, work) for drift, seed in jobs]
        clean_case = run_calibrated_clean if args.calibrated else run_clean
        clean_futures = [pool.submit(clean_case, seed, work) for seed in range(args.clean_seeds)]
        rows, clean = [], []
        for future in futures:
            rows.append(json.loads(json.dumps(future.result()).replace(work + "/", "WORK/")))
            row = rows[-1]
            print(
                f"drift {row['drift']:g} seed {row['seed']}: compensated "
                f"{_largest(row['compensated'])[0]:.2f} std, uncompensated "
                f"{_largest(row['uncompensated'])[0]:.1f} std "
                f"({row['uncompensated']['named'] or 'not named'}), drift std stated "
                f"{_largest(row['drift std'])[0]:.2f} std",
                file=sys.stderr,
            )
        for future in clean_futures:
            clean.append(json.loads(json.dumps(future.result()).replace(work + "/", "WORK/")))
            print(
                f"clean seed {clean[-1]['seed']}: {_largest(clean[-1]['clean'])[0]:.2f} std, "
                f"{clean[-1]['clean']['named'] or 'no pass-scale warning'}",
                file=sys.stderr,
            )
    args.out.mkdir(parents=True, exist_ok=True)
    command = command_line("warming", argv if argv is not None else sys.argv[1:])
    name = "warming_calibrated" if args.calibrated else "warming"
    (args.out / f"{name}.md").write_text(report(rows, clean, command, args.calibrated))
    (args.out / f"{name}.json").write_text(
        json.dumps({"cases": rows, "clean": clean}, indent=1) + "\n"
    )
    print(f"-> {args.out / f'{name}.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
