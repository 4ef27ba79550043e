"""The reference body's certificate carried through calibration into the tensor's stds.

    python -m benchmarks.certificate [--seeds N] [--rel-std R] [--jobs N] [--out DIR]

The demo's rig (rsp_inertia.scenarios.create_rig_experiment: the paper's body, torque gain,
lossy drive, unbalanced fixture, eccentric encoder, friction 2% stronger backward, its
reference mounted turned; closed-loop reverse passes). Per seed (the virtual device's noise
seed, the same in the three folders) the reference body's certificate states the nominal
values with a relative std R on each moment and on the mass, R times the mean moment on
each product and :data:`COM_STD` on each coordinate of the centre of mass; the reference
the virtual device carries (its virtual.toml ``[body]``, the truth) is one draw from that
certificate (seeded by the seed). calibrate, then identify; the tensor against
the body's truth.

Targets (issue 36): over 20 seeds every entry within 3 stds, mean (err/std)^2 in [0.5, 2],
and the "reference certificate" budget line the largest. Reported besides: the warnings of
calibrate and identify (the certificate's own error must not read as a fault of the rig),
and the same seed with the certificate stated without stds ('no stds': its error then
reaches the tensor unbudgeted).

Writes DIR/certificate.md and DIR/certificate.json (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np
import tomlkit

from benchmarks import RESULTS
from benchmarks.tables import command_line

COM_STD = 1e-5
"""m: the certificate's std of each coordinate of the reference's centre of mass."""


def certificate_cov(mass: float, inertia: np.ndarray, rel: float) -> np.ndarray:
    """(10, 10) the certificate's covariance over [mass, Jx..Jxz, x, y, z]: ``rel`` of the
    mass and of each moment, ``rel`` times the mean moment for each product, COM_STD m."""
    moments = np.asarray(inertia[:3], dtype=float)
    std = np.concatenate(
        [[rel * mass], rel * moments, [rel * moments.mean()] * 3, [COM_STD] * 3]
    )
    return np.diag(std**2)


def run_case(seed: int, work: str, rel: float, stated: bool = True, draw: bool = True) -> dict:
    """One seed end to end in ``work``; the tensor against the truth, the budget, warnings.
    ``stated``: the certificate states its stds; ``draw``: the true reference is a draw from
    the certificate (else the certified values themselves)."""
    from rsp_inertia import api
    from rsp_inertia.estimation.known_terms import CERTIFICATE_SOURCE
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.plant.config import load_reference, write_reference
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.plant.geometry import relative_errors
    from rsp_inertia.scenarios import create_rig_experiment
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    name = f"seed{seed}" + ("" if stated else "-nostd") + ("" if draw else "-exact")
    root, empty, reference = create_rig_experiment(Path(work) / name)
    nominal = load_reference(reference / "reference.toml")
    cov = certificate_cov(nominal.body.mass, nominal.body.inertia, rel)
    drawn = np.random.default_rng(10_000 + seed).multivariate_normal(nominal.values, cov)
    if not draw:
        drawn = nominal.values
    write_reference(reference / "reference.toml", replace(nominal, cov=cov if stated else 0 * cov))
    for folder in (root, empty, reference):
        path = folder / "virtual.toml"
        doc = tomlkit.parse(path.read_text())
        doc["run"]["seed"] = seed
        if folder == reference:
            doc["body"]["mass"] = float(drawn[0])
            doc["body"]["inertia"] = [float(v) for v in drawn[1:7]]
            doc["body"]["com"] = [float(v) for v in drawn[7:10]]
        path.write_text(tomlkit.dumps(doc))
    start = time.perf_counter()
    with lines_to(drop):
        for folder in (empty, reference, root):
            api.simulate(folder, part="braking")
            api.program(folder)
            api.simulate(folder, part="reverse")
        calibration = api.calibrate(root, empty, reference)
        result = api.identify(root)
    exp = open_experiment(root)
    truth = placed_body(exp.device, experiment_virtual(exp))
    err = np.asarray(result.entries) - truth.inertia
    budget = {
        line: float(np.max(parts["tensor"])) for line, parts in result.identification.std_budget.items()
    }
    return {
        "seed": seed,
        "stated": stated,
        "certificate_error": ((drawn - nominal.values) / np.sqrt(np.diag(cov))).tolist(),
        "rel_err": relative_errors(result.entries, truth.inertia).tolist(),
        "err_std": (err / np.asarray(result.entries_std)).tolist(),
        "budget": budget,
        "certificate_line": budget.get(CERTIFICATE_SOURCE, 0.0),
        "calibrate_warnings": list(calibration.warnings),
        "identify_warnings": list(result.warnings),
        "seconds": time.perf_counter() - start,
    }


def _warnings(warnings: list[str]) -> str:
    """A row's warnings in a table cell: how many, and each one's opening words."""
    if not warnings:
        return "none"
    heads = "; ".join(w[:90] + ("..." if len(w) > 90 else "") for w in warnings[:3])
    more = f"; {len(warnings) - 3} more" if len(warnings) > 3 else ""
    return f"{len(warnings)}: {heads}{more}"


def report(rows: list[dict], command: str, rel: float) -> str:
    """certificate.md."""
    lines = [
        "# The reference certificate's uncertainty through calibration",
        "",
        (f"Made by `{command}` (benchmarks/certificate.py; its docstring says what a seed "
         f"is). The reference's certificate states a relative std of {rel:g} on each moment; "
         "the reference the virtual device carries is one draw from it. Targets: every "
         "entry within 3 stds, mean (err/std)^2 in [0.5, 2], the 'reference certificate' "
         "budget line the largest."),
        "",
        ("| seed | certificate | certificate's draw, largest /std | max rel. err | "
         "max err/std | largest budget line | warnings (calibrate + identify) | s |"),
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        largest = max(row["budget"], key=row["budget"].get)
        warned = _warnings(row["calibrate_warnings"] + row["identify_warnings"])
        lines.append(
            f"| {row['seed']} | {'stds' if row['stated'] else 'no stds'} | "
            f"{max(row['certificate_error'], key=abs):+.2f} | "
            f"{max(abs(e) for e in row['rel_err']):.1e} | "
            f"{max(abs(e) for e in row['err_std']):.2f} | {largest} | {warned} | "
            f"{row['seconds']:.0f} |"
        )
    stated = [row for row in rows if row["stated"]]
    if stated:
        ratios = np.array([row["err_std"] for row in stated])
        inside = int(np.sum(np.all(np.abs(ratios) <= 3.0, axis=1)))
        mean_sq = float(np.mean(ratios**2))
        dominant = sum(
            max(row["budget"], key=row["budget"].get) == "reference certificate"
            for row in stated
        )
        warned = sum(bool(row["calibrate_warnings"] or row["identify_warnings"]) for row in stated)
        verdicts = [
            ("every entry within 3 stds", inside == len(stated), f"{inside} of {len(stated)}"),
            ("mean (err/std)^2 in [0.5, 2]", 0.5 <= mean_sq <= 2.0, f"{mean_sq:.2f}"),
            ("'reference certificate' the largest line", dominant == len(stated),
             f"{dominant} of {len(stated)}"),
        ]
        lines += ["", "| target | result | verdict |", "|---|---|---|"]
        lines += [f"| {t} | {r} | {'PASS' if ok else 'FAIL'} |" for t, ok, r in verdicts]
        lines += ["", f"Seeds with a warning (calibrate or identify): {warned} of {len(stated)}."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.certificate", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--seeds", type=int, default=20, help="seeds (20)")
    parser.add_argument("--rel-std", type=float, default=2e-4, help="relative std (2e-4)")
    parser.add_argument("--unstated", type=int, default=3, help="seeds also run without stds (3)")
    parser.add_argument("--jobs", type=int, default=2, help="processes (2)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder (benchmarks/results)")
    args = parser.parse_args(argv)
    jobs = [(seed, True) for seed in range(args.seeds)]
    jobs += [(seed, False) for seed in range(args.unstated)]
    with tempfile.TemporaryDirectory() as work, ProcessPoolExecutor(args.jobs) as pool:
        futures = [pool.submit(run_case, seed, work, args.rel_std, stated) for seed, stated in jobs]
        rows = []
        for future in futures:
            text = json.dumps(future.result()).replace(str(Path(work)) + "/", "WORK/")
            rows.append(json.loads(text))
            row = rows[-1]
            print(
                f"seed {row['seed']} {'stds' if row['stated'] else 'no stds'}: max err/std "
                f"{max(abs(e) for e in row['err_std']):.2f}",
                file=sys.stderr,
            )
    args.out.mkdir(parents=True, exist_ok=True)
    command = command_line("certificate", argv if argv is not None else sys.argv[1:])
    (args.out / "certificate.md").write_text(report(rows, command, args.rel_std))
    (args.out / "certificate.json").write_text(json.dumps(rows, indent=1) + "\n")
    print(f"-> {args.out / 'certificate.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
