"""The rig's conventions verified by calibrate on the virtual device: sign slips refused,
an encoder's zero offset measured, clean rigs left alone.

    python -m benchmarks.conventions [--seeds N] [--clean N] [--jobs N] [--out DIR]

The demo's rig (rsp_inertia.scenarios.create_rig_experiment: the paper's body, torque gain,
lossy drive, unbalanced fixture, eccentric encoder, friction 2% stronger backward, every
stage both ways round, closed-loop reverse passes) with its reference mounted turned (30 deg
about x, then 20 about z, 2 mm above O: its certified tensor has products in rig axes). Per
case and seed (the virtual device's noise seed, the same in the three folders), the rig
built against docs/method.md §1 by one fault of virtual.toml ``[rig]`` in every folder:

- ``gear_reversed``, ``phi_left_handed``, ``encoder_reversed``: the route must stop with exit
  status 2 before anything is written (calibrate, or program on a log an encoder counting
  backwards made), naming the convention;
- ``encoder_zero_deg`` 0.5 and 3: calibrate must measure the offset within 3 stds, and
  identify's tensor must be within 1e-4 of the largest moment and 3 stds;
- clean (no fault): no refusal, and no warning from calibrate or identify.

Writes DIR/conventions.md and DIR/conventions.json (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import tomlkit

from benchmarks import RESULTS
from benchmarks.tables import command_line

FAULTS = {
    "gear reversed": ("gear_reversed", True, "the gear turns the outer frame the other way"),
    "phi left-handed": ("phi_left_handed", True, "phi is read left-handed"),
    "encoder reversed": ("encoder_reversed", True, "the encoder counts backwards"),
    "zero 0.5 deg": ("encoder_zero_deg", 0.5, None),
    "zero 3 deg": ("encoder_zero_deg", 3.0, None),
    "clean": (None, None, None),
}
"""Case -> (virtual.toml [rig] key, value, what the refusal must say; None: no refusal)."""


def run_case(case: str, seed: int, work: str) -> dict:
    """One case and seed end to end in ``work``; what the route did."""
    from rsp_inertia import api
    from rsp_inertia.infra.errors import InputError
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.plant.geometry import relative_errors
    from rsp_inertia.scenarios import create_rig_experiment
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    key, value, expected = FAULTS[case]
    root, empty, reference = create_rig_experiment(Path(work) / f"{case}-{seed}".replace(" ", "_"))
    for folder in (root, empty, reference):
        path = folder / "virtual.toml"
        doc = tomlkit.parse(path.read_text())
        doc["run"]["seed"] = seed
        if key is not None:
            doc["rig"][key] = value
        path.write_text(tomlkit.dumps(doc))
    out = {"case": case, "seed": seed}
    start = time.perf_counter()
    folders = (empty, reference) if expected else (empty, reference, root)
    try:
        with lines_to(drop):
            for folder in folders:
                api.simulate(folder, part="braking")
                api.program(folder)
                api.simulate(folder, part="reverse")
            calibration = api.calibrate(root, empty, reference)
    except InputError as error:
        out.update(refused=str(error), named=bool(expected) and expected in str(error))
        out["written"] = (root / "calibration.toml").exists()
        out["seconds"] = time.perf_counter() - start
        return out
    out["refused"] = None
    out["calibrate_warnings"] = list(calibration.warnings)
    out["conventions"] = calibration.conventions
    out["zero_deg"] = math.degrees(calibration.encoder_zero)
    out["zero_std_deg"] = math.degrees(calibration.encoder_zero_std)
    if expected is None and key == "encoder_zero_deg":
        out["zero_true_deg"] = value
    with lines_to(drop):
        result = api.identify(root)
    exp = open_experiment(root)
    truth = placed_body(exp.device, experiment_virtual(exp))
    err = np.asarray(result.entries) - truth.inertia
    out["rel_err"] = relative_errors(result.entries, truth.inertia).tolist()
    out["err_std"] = (err / np.asarray(result.entries_std)).tolist()
    out["identify_warnings"] = list(result.warnings)
    out["seconds"] = time.perf_counter() - start
    return out


def _verdict(row: dict) -> str:
    """Whether a case met its target."""
    key, value, expected = FAULTS[row["case"]]
    if expected:
        return "pass" if row["refused"] and row["named"] and not row["written"] else "FAIL"
    if row["refused"]:
        return "FAIL"
    ok = max(abs(e) for e in row["rel_err"]) <= 1e-4 and max(
        abs(e) for e in row["err_std"]
    ) <= 3.0
    if key == "encoder_zero_deg":
        ok = ok and abs(row["zero_deg"] - value) <= 3.0 * row["zero_std_deg"]
    else:
        ok = ok and not row["calibrate_warnings"] and not row["identify_warnings"]
    return "pass" if ok else "FAIL"


def report(rows: list[dict], command: str) -> str:
    """conventions.md."""
    lines = [
        "# The rig's conventions verified by calibrate",
        "",
        (f"Made by `{command}` (benchmarks/conventions.py; its docstring says what each case "
         "is). The demo's rig, its reference mounted turned; one fault of virtual.toml `[rig]` "
         "per case in every folder. Targets: a sign slip refused naming the convention, "
         "nothing written; a zero offset measured within 3 stds and the tensor within 1e-4 of "
         "the largest moment and 3 stds; a clean rig neither refused nor warned about."),
        "",
        ("| case | seed | verdict | refused with | zero measured, deg | max rel. err | "
         "max err/std | warnings (calibrate + identify) | s |"),
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        # The refusal's fault and evidence, without its folder and its fix.
        refusal = (row["refused"] or "").split(": ", 1)[-1].split("; ")[0]
        zero = rel = ratio = warned = ""
        if not row["refused"]:
            zero = f"{row['zero_deg']:+.4f} +- {row['zero_std_deg']:.4f}"
            rel = f"{max(abs(e) for e in row['rel_err']):.1e}"
            ratio = f"{max(abs(e) for e in row['err_std']):.2f}"
            warned = "; ".join(row["calibrate_warnings"] + row["identify_warnings"]) or "none"
        lines.append(
            f"| {row['case']} | {row['seed']} | {_verdict(row)} | {refusal} | {zero} | {rel} | "
            f"{ratio} | {warned} | {row['seconds']:.0f} |"
        )
    passed = sum(_verdict(row) == "pass" for row in rows)
    lines += ["", f"{passed} of {len(rows)} cases met their target."]
    clean = [r for r in rows if r["case"] == "clean" and not r["refused"]]
    if clean:
        ratios = np.array([r["err_std"] for r in clean])
        lines.append(
            f"Clean rigs: mean (err/std)^2 over {ratios.size} entries "
            f"{float(np.mean(ratios**2)):.2f}; the conventions line of the first: "
            f"\"{clean[0]['conventions']}\"."
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.conventions", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--seeds", type=int, default=5, help="seeds per fault (5)")
    parser.add_argument("--clean", type=int, default=20, help="seeds of the clean rig (20)")
    parser.add_argument("--jobs", type=int, default=2, help="processes (2)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder (benchmarks/results)")
    args = parser.parse_args(argv)
    jobs = [
        (case, seed)
        for case in FAULTS
        for seed in range(args.clean if case == "clean" else args.seeds)
    ]
    with tempfile.TemporaryDirectory() as work, ProcessPoolExecutor(args.jobs) as pool:
        futures = [pool.submit(run_case, case, seed, work) for case, seed in jobs]
        rows = []
        for future in futures:
            # Messages name the scratch folder: WORK in the files, which do not depend on it.
            text = json.dumps(future.result()).replace(str(Path(work)) + "/", "WORK/")
            rows.append(json.loads(text))
            row = rows[-1]
            print(f"{row['case']} seed {row['seed']}: {_verdict(row)}", file=sys.stderr)
    args.out.mkdir(parents=True, exist_ok=True)
    command = command_line("conventions", argv if argv is not None else sys.argv[1:])
    (args.out / "conventions.md").write_text(report(rows, command))
    (args.out / "conventions.json").write_text(json.dumps(rows, indent=1) + "\n")
    print(f"-> {args.out / 'conventions.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
